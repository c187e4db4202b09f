#pragma once
/// @file
/// OctoMap (liboctomap) as a peer mapper on Kestrel's lattice (docs/algorithms.md §12.3): its
/// own OcTree with its default sensor model (hit 0.7, miss 0.4, clamps 0.1192 / 0.971) and its
/// usual input, OcTree::insertPointCloud of each scan's returns from the sensor's origin with the
/// sensor's z_max as the maximum range. A "no return" carries no point and so no update, as in
/// octomap_server. Every coordinate is shifted by -grid.min_m, so that OctoMap's voxels (edges at
/// multiples of the resolution) are exactly Kestrel's cells: cell (i, j, k) is the voxel centred
/// at ((i + 0.5) alpha, ...) after the shift.

#include <memory>
#include <vector>

#include "mapping/scan_integrator.h"
#include "sim/ground_truth.h"

namespace octomap {
class OcTree;
}

namespace kestrel {

class OctoMapPeer {
 public:
  /// An empty tree at grid.resolution_m. @throws std::invalid_argument on a bad grid.
  explicit OctoMapPeer(const GridSpec& grid);
  ~OctoMapPeer();
  OctoMapPeer(const OctoMapPeer&) = delete;
  OctoMapPeer& operator=(const OctoMapPeer&) = delete;

  /// Inserts one scan: the end points of its returns (ReadingKind::kReturn; the others are
  /// skipped) from the rays' common origin, at most max_range_m long. All rays must share one
  /// origin (one scan).
  void InsertScan(const std::vector<SensorRay>& rays, double max_range_m);

  /// P of cell c, or `unknown` if the tree holds no node there.
  [[nodiscard]] double ProbabilityAt(const Eigen::Vector3i& c, double unknown = 0.5) const;
  /// Number of scans inserted.
  [[nodiscard]] int64_t scans() const { return scans_; }
  /// The tree (for export).
  [[nodiscard]] const octomap::OcTree& tree() const { return *tree_; }

 private:
  GridSpec grid_;
  std::unique_ptr<octomap::OcTree> tree_;
  int64_t scans_{0};
};

}  // namespace kestrel
