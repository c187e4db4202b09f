#pragma once
/// @file
/// Projected 2D maps of section III-B of Kaufman et al. 2018 (docs/algorithms.md §7): the
/// collision map C (eqs. 11-13), the entropy map E (eqs. 14-15) and the combined map B (eq. 16),
/// all in the plane of the exploration height h, aligned to the 3D map's lower limit.
///
/// Choices the paper leaves open (tested in tests/exploration/projected_maps_test.cc):
///  - A 3D cell belongs to the vertical band of C / B when its z extent [z, z + alpha) overlaps
///    the open interval (h - alpha_C/2, h + alpha_C/2) by more than 1e-9 m (rounding).
///  - A collision cell that sticks out of the 3D map (docs/algorithms.md §1.1) counts its
///    missing part as unknown (P_init), so it is never traversable: the vehicle must not leave
///    the map. A band that leaves the map vertically counts the same way.
///  - A 3D cell lies below the floor (ignored by E) when its top z + alpha <= floor height, above
///    the ceiling (ignored too) when its bottom z >= ceiling_height_m.
///  - E's maximum-entropy cell: ties go to the lowest cell. The column mean of eq. (15) is over
///    the same cells (those not below the floor).

#include <Eigen/Core>
#include <limits>
#include <optional>

#include "exploration/grid_map_2d.h"
#include "exploration/occupancy_grid_view.h"

namespace kestrel {

/// Parameters of the projections (defaults: docs/algorithms.md §7, §8.1).
struct ProjectionConfig {
  double height_m{0.75};             ///< exploration height h, m, W
  int collision_factor{0};           ///< k_C (>= 1); 0: the smallest k with k*alpha >= diameter
  double vehicle_diameter_m{0.88};   ///< for the default k_C, m
  double collision_threshold{0.05};  ///< C_thresh: traversable iff P(C_k) <= C_thresh, eq. (13)
  double floor_height_m{0.0};        ///< E ignores 3D cells wholly below this height, m
  /// E also ignores 3D cells wholly above this height, m (+inf: the paper, whose map top is below
  /// the ceiling; set it below a ceiling inside the map, or every E column takes the ceiling's
  /// uncertain-occupied cells and blocks every predicted ray).
  double ceiling_height_m{std::numeric_limits<double>::infinity()};
  /// P_min_E of eq. (15), in (0, 0.5): the map's clamp, so that H(P_min_E) ~ 0 as eq. (15) needs
  /// (with 0.01 a ray over known free cells still predicts about 0.65 nats).
  double p_min_entropy{1e-4};
  double p_thresh{0.3};  ///< P_thresh of eq. (16), in (P_init, 1)
  double p_init{0.1};    ///< P_init of the 3D map (unknown cells), in (0, 1)

  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// k_C for a 3D cell edge: config.collision_factor if set, else the smallest k with
/// k * alpha >= vehicle diameter (eq. (11), docs/algorithms.md §7.1).
[[nodiscard]] int CollisionFactor(const ProjectionConfig& config, double resolution_m);

/// The start-up zone of docs/algorithms.md §8.1: 3D band cells with no evidence of occupancy
/// (P <= P_init) whose centre lies within radius_m (horizontally) of center_m count as free in
/// C (the explorer's view only; the 3D map is not changed). Not only cells still exactly at
/// P_init: Kestrel also frees those a few free rays grazed (P_init > P > C_thresh),
/// which would otherwise block the start more than unseen cells do: in office, a vehicle that
/// left the start cell found it closed behind it and ended exploration in a dead end.
struct StartupFreeZone {
  Eigen::Vector2d center_m{Eigen::Vector2d::Zero()};  ///< start position (x, y), m, W
  double radius_m{0.0};                               ///< m
};

/// The radius alpha_C/2 + alpha_C/(2 tan(vfov/2)) of docs/algorithms.md §8.1, m.
/// Precondition: 0 < vertical_fov_rad < pi.
[[nodiscard]] double StartupFreeRadius(double collision_cell_m, double vertical_fov_rad);

/// The collision map C and the combined map B, computed in one pass over the band.
struct CollisionProjection {
  GridMap2D collision;      ///< P(C_k), eq. (12), cells of edge alpha_C
  GridMap2D combined;       ///< P(B_k), eq. (16), same cells
  int collision_factor{1};  ///< k_C used
};

/// Projects C (eq. 12) and B (eq. 16) from the 3D map (file comment for the open choices).
/// `startup` (optional) applies the start-up rule to C and to B's maximum.
/// @throws std::invalid_argument if the view or config is invalid.
[[nodiscard]] CollisionProjection ProjectCollisionMaps(
    const OccupancyGridView& map, const ProjectionConfig& config,
    const std::optional<StartupFreeZone>& startup = std::nullopt);

/// Projects E (eqs. 14-15): cells of edge alpha, one per 3D column.
/// @throws std::invalid_argument if the view or config is invalid, or no cell of the map lies
/// between floor and ceiling.
[[nodiscard]] GridMap2D ProjectEntropyMap(const OccupancyGridView& map,
                                          const ProjectionConfig& config);

/// The layer of 3D cells containing height z_m (cells of edge alpha, P of each cell): what a
/// planar scanner at that height sees, for its rays in the two-map gain.
/// @throws std::invalid_argument if the view is invalid or z_m lies outside the map.
[[nodiscard]] GridMap2D ProjectLayer(const OccupancyGridView& map, double z_m);

/// Traversability of a collision cell, eq. (13): P(C_k) <= C_thresh.
[[nodiscard]] inline bool IsTraversable(double collision_probability, double collision_threshold) {
  return collision_probability <= collision_threshold;
}

}  // namespace kestrel
