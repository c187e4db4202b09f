#include "tools/fidelity/octomap_peer.h"

#include <octomap/OcTree.h>

#include <stdexcept>

namespace kestrel {

OctoMapPeer::OctoMapPeer(const GridSpec& grid)
    : grid_(grid), tree_(std::make_unique<octomap::OcTree>(grid.resolution_m)) {
  if (!(grid.resolution_m > 0.0) || (grid.dims.array() <= 0).any()) {
    throw std::invalid_argument("OctoMapPeer: the grid must have a positive resolution and size");
  }
}

OctoMapPeer::~OctoMapPeer() = default;

void OctoMapPeer::InsertScan(const std::vector<SensorRay>& rays, double max_range_m) {
  if (rays.empty()) return;
  const Eigen::Vector3d origin = rays.front().origin_W - grid_.min_m;
  octomap::Pointcloud cloud;
  cloud.reserve(rays.size());
  for (const SensorRay& r : rays) {
    if (r.origin_W != rays.front().origin_W) {
      throw std::invalid_argument("OctoMapPeer::InsertScan: the rays of a scan share one origin");
    }
    if (r.reading.kind != ReadingKind::kReturn) continue;
    const Eigen::Vector3d end = r.origin_W + r.reading.z_m * r.direction_W - grid_.min_m;
    cloud.push_back(static_cast<float>(end.x()), static_cast<float>(end.y()),
                    static_cast<float>(end.z()));
  }
  tree_->insertPointCloud(
      cloud,
      octomap::point3d(static_cast<float>(origin.x()), static_cast<float>(origin.y()),
                       static_cast<float>(origin.z())),
      max_range_m);
  ++scans_;
}

double OctoMapPeer::ProbabilityAt(const Eigen::Vector3i& c, double unknown) const {
  const double a = grid_.resolution_m;
  const octomap::OcTreeNode* node =
      tree_->search(static_cast<float>((c.x() + 0.5) * a), static_cast<float>((c.y() + 0.5) * a),
                    static_cast<float>((c.z() + 0.5) * a));
  return node == nullptr ? unknown : node->getOccupancy();
}

}  // namespace kestrel
