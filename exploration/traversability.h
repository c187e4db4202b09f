#pragma once
/// @file
/// Traversability at the 3D map's own resolution (docs/exploration.md, section
/// "Traversability"), the volumetric mode's replacement for the paper's coarse collision map C
/// (eqs. 11-13), whose k_C x k_C lattice closes every passage not aligned with it.
///
///  1. Band: a 2D grid of the 3D map's cells (edge alpha, aligned to its lower corner) at the
///     exploration height h. A cell is BLOCKED when any 3D cell of its column whose z extent
///     overlaps the vehicle's band (h - band_below, h + band_above) has P > free_threshold
///     (C_thresh of eq. 13). Unknown space (P_init = 0.1 > C_thresh) is blocked, so the vehicle
///     only ever flies through space the map knows to be free. Cells outside the map are blocked.
///  2. Clearance: an exact Euclidean distance transform (Felzenszwalb and Huttenlocher 2012) gives
///     every cell the distance from its centre to the nearest blocked cell's centre; clearance =
///     that distance - alpha/2, the distance to the blocked cell's near face (exact for a face
///     straight ahead, within alpha (sqrt(2) - 1)/2 = 0.016 m for the paper's cells otherwise).
///  3. Traversable: clearance >= vehicle radius + margin. A gap whose mapped free width is w is
///     passable where w/2 >= radius + margin, wherever it lies: no lattice.
///  3b. Passages: centre clearance samples a gap on the lattice, and the jamb cells of a door at
///     an angle to the map's axes (any overlap blocks a cell) reach up to alpha sqrt(2) into it,
///     so a door of 1.12 m can map to 0.91 m between blocked surfaces. A free cell that is not
///     traversable but holds a point on a gap's middle line (its nearest blocked surfaces on
///     two opposite sides, more than 110 deg apart, at distances within 2 alpha/10 of each
///     other) whose clearance to the blocked cells' surfaces (the squares, exactly) is
///     >= radius + passage_margin is a passage cell: paths may cross it and pass it through its
///     best such point (passage_points; found on a 10 x 10 grid in the cell, then refined), never
///     farther across the passage from it than min(alpha/2, its clearance - radius)
///     (passage_across); goals may not use it. Any angle, any offset (docs/exploration.md,
///     "Traversability").
///  4. Preferred clearance (ClearanceStepWeights): paths are searched with steps weighted up
///     where the clearance is below radius + margin + preferred_extra, so they keep that much
///     more room where the space allows (round a shelf's end wide, not at the margin) and pass
///     narrow places through their middle. The map's surfaces can be a cell off where grazing
///     rays read a partly filled cell free; the margin alone leaves no room for that.
///
/// Two exceptions, both for the explorer's view only (the 3D map is never changed):
///  - the start-up zone (docs/algorithms.md §8.1): band cells with no evidence of occupancy
///    (P <= P_init) within a radius of the take-off point count as free, since a level camera
///    with a minimum range cannot see the band next to itself;
///  - the flown corridor: cells within 1.5 cells of the polyline the vehicle's centre has flown
///    along are traversable where the known occupied cells alone (band P > 0.5) leave the
///    vehicle's radius (no margin): the vehicle has been there, so the flight itself has shown
///    that it fits, whatever uncertain cells sensor noise has added since. Occupied cells whose
///    whole square lay inside the vehicle's disc somewhere along the path (centre within
///    radius - alpha/sqrt(2) - 0.02 m of it) are carved: the body has been where they are, so
///    they are noise (e.g. depth speckle at a door jamb). Static worlds only: an obstacle moved
///    into the flown path since is seen only by the trajectory checks against the latest map.
/// Pure functions; no LCM, no clock.

#include <Eigen/Core>
#include <optional>
#include <unordered_map>
#include <vector>

#include "exploration/grid_map_2d.h"
#include "exploration/projected_maps.h"

namespace kestrel {

/// Parameters of the fine traversability.
struct TraversabilityConfig {
  double height_m{0.75};            ///< exploration height h, m, W
  double band_below_m{0.2};         ///< vehicle band below h, m (> 0)
  double band_above_m{0.2};         ///< vehicle band above h, m (> 0)
  double vehicle_radius_m{0.44};    ///< disc radius, m (> 0)
  double margin_m{0.10};            ///< clearance beyond the radius, m (>= 0)
  double free_threshold{0.05};      ///< a band cell blocks when P > this (C_thresh), in (0, 1)
  double p_init{0.1};               ///< P_init of the 3D map (the start-up zone's rule), in (0, 1)
  double preferred_extra_m{0.0};    ///< clearance paths prefer beyond radius + margin, m (>= 0)
  double clearance_weight{0.0};     ///< step weight at the required clearance, minus 1 (>= 0)
  double passage_margin_m{0.0125};  ///< clearance beyond the radius at a passage point, m (>= 0)

  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
  /// Radius + margin: the clearance a traversable cell needs, m.
  [[nodiscard]] double required_clearance_m() const { return vehicle_radius_m + margin_m; }
  /// Radius + passage margin: the clearance a passage point needs, m.
  [[nodiscard]] double passage_clearance_m() const { return vehicle_radius_m + passage_margin_m; }
};

/// How a path crosses a passage cell (file comment, step 3b).
struct PassageAcross {
  /// Unit vector across the passage, from the passage point to its nearest blocked surface.
  Eigen::Vector2d normal{1.0, 0.0};
  /// How far across the passage (along normal) from its point the vehicle's centre may be, m.
  double tolerance_m{0.0};
};

/// The fine traversability of one map.
struct Traversability {
  /// Per 2D cell, the largest P over the band (1 where the band leaves the map): what blocks.
  GridMap2D band;
  /// Per 2D cell, clearance to the nearest blocked cell (file comment, step 2), m, at the cell's
  /// centre or, for a passage cell, at its passage point (to the blocked squares' surfaces); 0 on
  /// blocked cells, large where nothing is blocked.
  GridMap2D clearance;
  /// clearance >= radius + margin, x fastest.
  std::vector<bool> traversable;
  /// Per cell: blocked by unknown space only (band max in [P_init/2, 0.5], not known free, not
  /// known occupied): what the frontier baseline looks for.
  std::vector<bool> unknown;
  /// Passage cells (file comment, step 3b) by index, each with the point paths pass it through
  /// (on the gap's middle line, m). Not in `traversable`: AllowPassages adds them for paths.
  std::unordered_map<int, Eigen::Vector2d> passage_points;
  /// Per passage cell, the direction across the passage and how far from the point a path may
  /// stray across it.
  std::unordered_map<int, PassageAcross> passage_across;
};

/// Computes the fine traversability (file comment).
/// @param startup  optional start-up zone (cells with band P <= P_init inside it count as free)
/// @param flown    optional points (x, y) the vehicle has flown through (flown corridor)
/// @throws std::invalid_argument if the view or config is invalid.
[[nodiscard]] Traversability ComputeTraversability(
    const OccupancyGridView& map, const TraversabilityConfig& config,
    const std::optional<StartupFreeZone>& startup = std::nullopt,
    const std::vector<Eigen::Vector2d>* flown = nullptr);

/// Squared Euclidean distance transform on a width x height grid: for every cell, the squared
/// distance in cells from its centre to the nearest cell with site[i] (+inf if there is none).
/// Exact (Felzenszwalb and Huttenlocher 2012, two separable passes).
/// @throws std::invalid_argument on inconsistent sizes.
[[nodiscard]] std::vector<double> SquaredDistanceTransform(int width, int height,
                                                           const std::vector<bool>& site);

/// The step weights of step 4 (file comment) for ComputeDistanceField: per cell
/// 1 + clearance_weight s^2 with s = (c_pref - c) / preferred_extra_m clamped to [0, 1], c the
/// cell's clearance, c_pref = radius + margin + preferred_extra_m (cells below the required
/// clearance, which only the start, the escape and the flown corridor make usable, weigh the
/// most). Empty (unweighted Euclidean steps) when preferred_extra_m or clearance_weight is 0.
[[nodiscard]] std::vector<double> ClearanceStepWeights(const Traversability& map,
                                                       const TraversabilityConfig& config);

/// Marks the passage cells (file comment, step 3b) traversable, for paths (not for goals).
/// Returns how many cells it added.
int AllowPassages(const Traversability& map, std::vector<bool>* traversable);

/// Escape from a place short of clearance (new map data can leave the vehicle there, e.g. a table
/// top or sensor noise that blurs into the band): marks traversable the free cells within
/// escape_radius_m of p whose clearance is at least the clearance at p's own cell or the required
/// clearance, whichever is smaller, so the vehicle can move along space no
/// tighter than where it is until it reaches fully traversable space. Nothing when p's cell is
/// traversable. Returns how many cells it added.
int AllowEscape(const Traversability& map, const TraversabilityConfig& config,
                const Eigen::Vector2d& p_m, double escape_radius_m, std::vector<bool>* traversable);

}  // namespace kestrel
