#pragma once
/// @file
/// Cells the vehicle has looked at again and again without learning anything (docs/exploration.md,
/// "Unlearned cells"). The gain of eqs. (7)-(10) is exact for the model, and the model is wrong
/// for two kinds of cells:
///  - cells no reading can inform: with the depth camera's 0 no evidence (docs/algorithms.md §3.4)
///    a cell that only rays seeing nothing cross (the air above a lab's partitions, with no ceiling
///    within range) keeps its prior for ever, while the prior P_init says a return is likely;
///  - contested cells: a cell partly occupied, or one whose rays disagree through correlated
///    errors (mount, stamp), swings between free and occupied as the evidence comes; with a clamp
///    that lets cells come back (map.p_min 0.03) it never settles.
/// The predicted gain of both never comes, so a greedy explorer chases them and the gain rule of
/// the end never fires. UnlearnedCells keeps a ledger: each time the vehicle has scanned from a
/// pose (a look), every uncertain cell in the sensors' view whose entropy did not drop by
/// min_entropy_drop_nats since the first look of its streak counts one look more; a drop starts
/// a new streak. After `looks` such looks the cell is unlearned for good: the gain reads it as
/// certain (its side of 0.5), so the explorer no longer flies for it, and the end rule fires over
/// what can still be learned. The map itself is untouched; traversability reads the real
/// probabilities. The unlearned cells are counted and located (Regions) for the status and the
/// mission's summary.
///
/// Pure: no clock, no LCM; the explorer calls Look once per plan with the cells in view
/// (CellsInView) and takes the gain's view from ApplyTo.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "exploration/projected_maps.h"
#include "exploration/volumetric_gain.h"

namespace kestrel {

/// When a cell counts as unlearned.
struct UnlearnedCellsConfig {
  bool enabled{true};  ///< false: nothing is ever marked (the gain reads the map as it is)
  /// Looks in a streak (the first one included) that mark a cell, >= 2: the first sets the
  /// reference, each later one without an entropy drop adds one.
  int looks{5};
  /// An entropy drop smaller than this since the streak's first look is "nothing learned", nats;
  /// a cell with less entropy than this left is nearly certain: a look neither counts nor ends
  /// its streak.
  double min_entropy_drop_nats{0.05};
  /// Cells at or beyond the map's clamp (P <= this or >= 1 - this) are certain for now: a look
  /// there neither counts nor ends the streak.
  double certain_probability{1e-4};

  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// Where unlearned cells lie: one 26-connected region.
struct UnlearnedRegion {
  size_t cells{0};                                      ///< cells in the region
  double entropy_nats{0.0};                             ///< their entropy in the map now
  Eigen::Vector3d min_m{Eigen::Vector3d::Zero()};       ///< bounding box, W, m
  Eigen::Vector3d max_m{Eigen::Vector3d::Zero()};       ///< (cell corners)
  Eigen::Vector3d centroid_m{Eigen::Vector3d::Zero()};  ///< mean of the cell centres, W, m
  double mean_probability{0.0};                         ///< mean P of its cells now
};

/// The ledger of the file comment over one map lattice. Not thread-safe.
class UnlearnedCells {
 public:
  /// @throws std::invalid_argument if config.Validate() throws.
  explicit UnlearnedCells(const UnlearnedCellsConfig& config);

  /// One look: `in_view` holds the linear indices (x + nx (y + ny z)) of the cells the sensors
  /// covered from the pose the vehicle scanned from (duplicates allowed); `map` is the map now.
  /// A map of another lattice than the last look's starts a new ledger.
  void Look(const OccupancyGridView& map, const std::vector<int32_t>& in_view);

  /// Whether cell `linear_index` is unlearned (false for a lattice never looked at).
  [[nodiscard]] bool unlearned(int32_t linear_index) const;
  /// Unlearned cells.
  [[nodiscard]] size_t count() const { return count_; }
  /// Looks taken.
  [[nodiscard]] int64_t looks() const { return looks_taken_; }

  /// The gain's view: `probability` (the map's values, same lattice, modified in place) with every
  /// unlearned cell read as certain: P_certain if P <= 0.5, else 1 - P_certain.
  void ApplyTo(std::vector<float>* probability, double certain_probability) const;

  /// The unlearned cells' regions in `map` (26-connected), largest first, at most max_regions;
  /// *total_entropy_nats (if not null) gets the entropy of all unlearned cells.
  [[nodiscard]] std::vector<UnlearnedRegion> Regions(const OccupancyGridView& map,
                                                     size_t max_regions,
                                                     double* total_entropy_nats = nullptr) const;

  [[nodiscard]] const UnlearnedCellsConfig& config() const { return config_; }

 private:
  UnlearnedCellsConfig config_;
  Eigen::Vector3i dims_{Eigen::Vector3i::Zero()};
  Eigen::Vector3d origin_m_{Eigen::Vector3d::Zero()};
  double resolution_m_{0.0};
  std::vector<uint8_t> streak_;      // looks without learning in the current streak; kMarked
  std::vector<float> reference_h_;   // entropy at the streak's first look, nats
  std::vector<uint32_t> last_look_;  // the look that last counted the cell (duplicates in a look)
  size_t count_{0};
  int64_t looks_taken_{0};
};

/// The linear indices of the cells the sensors cover from `position_m` at heading `yaw_rad`, with
/// the volumetric gain's ray geometry (docs/exploration.md) at a finer spacing: `rows` elevation
/// rows over each sensor's vertical field of view (one for a planar scanner) and azimuths
/// 2 pi b / azimuth_bins inside its horizontal one, from its origin raised by its height offset;
/// each ray from z_min (nearer cells are the blind zone, which teaches nothing) to z_max or the
/// map's edge, ending after the first cell with P > 0.5 (what lies behind it is not in view).
[[nodiscard]] std::vector<int32_t> CellsInView(const OccupancyGridView& map,
                                               const std::vector<VolumetricSensor>& sensors,
                                               const Eigen::Vector3d& position_m, double yaw_rad,
                                               int azimuth_bins, int rows);

}  // namespace kestrel
