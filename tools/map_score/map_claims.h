#pragma once
/// @file
/// Cells a map declares free without grounds (docs/algorithms.md §12.5). A map may be wrong about a
/// cell a sensor saw; these are the cells it claims to know although no reading could tell it:
///  - in solid: known free, the cell's centre at least half a cell deep inside a solid;
///  - outside: known free, held free by the truth but not connected to the start through cells the
///    truth holds free (face neighbours): outside the building, or sealed inside something (a
///    surface cell, partly solid, read free is a wrong cell, not a claim without grounds);
///  - unreached: known free, and no sensor ray of this flight physically reached the cell
///    (sim/ray_reach.h; needs the flight's reach record);
///  - freed early: known free at some sample before the first ray reached it (needs the reach
///    record and samples taken during the flight), with the largest lead.
/// "Known free" is each map's own rule: P < p_init/2 for the exact and log-odds maps, observed and
/// P < 0.5 for OctoMap (docs/algorithms.md §12.2).

#include <cstdint>
#include <limits>
#include <vector>

#include "sim/ground_truth.h"
#include "sim/world.h"

namespace kestrel {

/// The counts of the file comment.
struct MapClaims {
  size_t known_free{0};        ///< cells the map holds known free (all cells of the grid)
  size_t free_in_solid{0};     ///< ... whose centre is at least alpha/2 inside a solid
  size_t free_outside{0};      ///< ... truth-free but not connected to the start through such cells
  int64_t free_unreached{-1};  ///< ... that no ray of the flight reached (-1: no record)
  int64_t freed_early{-1};     ///< known free before first reached (-1: no record or samples)
  double max_lead_s{0.0};      ///< largest (first reached - first known free), s
  /// Whether every count that was measured is zero.
  [[nodiscard]] bool none() const {
    return free_in_solid == 0 && free_outside == 0 && free_unreached <= 0 && freed_early <= 0;
  }
};

/// Tracks one map's claims against the ground truth of one grid. Not thread-safe.
class ClaimTracker {
 public:
  /// `truth` as MapScorer::truth() (VoxelizeWorld on `grid`, GridSpec order); the half-cell-deep
  /// mask is taken from `world`, the inside from the cell of the world's start at the exploration
  /// height. @throws std::invalid_argument on sizes that disagree.
  ClaimTracker(const World& world, const GridSpec& grid, const std::vector<uint8_t>& truth);

  /// A sample of the map at time_s (s after the flight's start, the reach record's clock):
  /// known_free[i] != 0 where the map holds cell i known free now. Records each cell's first
  /// known-free time.
  void Sample(double time_s, const std::vector<uint8_t>& known_free);

  /// The claims of the map whose known-free mask is `known_free` (the final map). With the
  /// flight's reach record (RayReach::first_reach_s(): one time per cell, +inf never) also the
  /// unreached cells, and with samples taken the cells freed early.
  [[nodiscard]] MapClaims Claims(const std::vector<uint8_t>& known_free,
                                 const std::vector<double>* first_reach_s = nullptr) const;

  /// Per cell: 1 where `known_free` makes a claim without grounds (in solid, outside, or, with
  /// the reach record, unreached).
  [[nodiscard]] std::vector<uint8_t> ClaimMask(const std::vector<uint8_t>& known_free,
                                               const std::vector<double>* first_reach_s) const;

  /// Per cell: 1 where its centre lies at least half a cell inside a solid.
  [[nodiscard]] const std::vector<uint8_t>& in_solid() const { return in_solid_; }
  /// Per cell: 1 where the truth holds it free and it is not connected to the start through such
  /// cells (outside the building).
  [[nodiscard]] const std::vector<uint8_t>& outside() const { return outside_; }

 private:
  GridSpec grid_;
  std::vector<uint8_t> outside_;
  std::vector<uint8_t> in_solid_;
  std::vector<double> first_free_s_;  // per cell, first sample known free (+inf: never)
  bool sampled_{false};
};

/// Where the cells of a mask lie: counts per column bin of bin_m x bin_m (row-major from the
/// grid's minimum corner, x fastest) and per grid layer.
struct MaskPlanView {
  int bins_x{0}, bins_y{0};
  std::vector<size_t> per_bin;    ///< bins_x * bins_y
  std::vector<size_t> per_layer;  ///< grid.dims.z()
};
[[nodiscard]] MaskPlanView PlanViewOf(const GridSpec& grid, const std::vector<uint8_t>& mask,
                                      double bin_m);

/// Known-free masks by each map's rule (file comment): P < p_init / 2.
[[nodiscard]] std::vector<uint8_t> KnownFreeBelow(const std::vector<double>& probability,
                                                  double p_init);
/// Observed and P < 0.5 (OctoMap, whose clamp lies above P_init / 2).
[[nodiscard]] std::vector<uint8_t> KnownFreeObserved(const std::vector<double>& probability,
                                                     const std::vector<uint8_t>& observed);

}  // namespace kestrel
