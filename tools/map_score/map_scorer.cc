#include "tools/map_score/map_scorer.h"

#include <algorithm>
#include <cmath>

namespace kestrel {

MapScorer::MapScorer(const World& world, const WorldRayCaster& caster, const GridSpec& grid,
                     double max_range_m, double vertical_fov_rad, bool camera_no_return_informs,
                     double camera_depth_range_m)
    : grid_(grid), truth_(VoxelizeWorld(world, grid)) {
  observable_ = ComputeObservableCells(world, caster, grid,
                                       SensorSweep(max_range_m, vertical_fov_rad,
                                                   camera_no_return_informs, camera_depth_range_m))
                    .observable;
}

std::vector<double> MapScorer::Probabilities(
    const std::function<double(const CellIndex&)>& probability) const {
  std::vector<double> p(grid_.size());
  for (int z = 0; z < grid_.dims.z(); ++z) {
    for (int y = 0; y < grid_.dims.y(); ++y) {
      for (int x = 0; x < grid_.dims.x(); ++x) {
        p[grid_.IndexOf(Eigen::Vector3i(x, y, z))] = probability(CellIndex{x, y, z});
      }
    }
  }
  return p;
}

MapQuality MapScorer::Score(const std::function<double(const CellIndex&)>& probability,
                            double p_init) const {
  return ComputeMapQuality(Probabilities(probability), truth_, observable_, p_init);
}

MapScorer::UnknownCells MapScorer::Unknown(
    const std::function<double(const CellIndex&)>& probability, double p_init, double bin_m) const {
  UnknownCells u;
  const double extent_x = grid_.dims.x() * grid_.resolution_m;
  const double extent_y = grid_.dims.y() * grid_.resolution_m;
  u.bins_x = static_cast<int>(std::ceil(extent_x / bin_m));
  u.bins_y = static_cast<int>(std::ceil(extent_y / bin_m));
  u.per_bin.assign(static_cast<size_t>(u.bins_x) * u.bins_y, 0);
  u.per_layer.assign(grid_.dims.z(), 0);
  for (int z = 0; z < grid_.dims.z(); ++z) {
    for (int y = 0; y < grid_.dims.y(); ++y) {
      for (int x = 0; x < grid_.dims.x(); ++x) {
        if (observable_[grid_.IndexOf(Eigen::Vector3i(x, y, z))] == 0) continue;
        const double p = probability(CellIndex{x, y, z});
        if (p < 0.5 * p_init || p > 0.5) continue;  // known, as in ComputeMapQuality
        (p == p_init ? u.never_updated : u.updated) += 1;
        ++u.per_layer[z];
        const int bx =
            std::min(u.bins_x - 1, static_cast<int>((x + 0.5) * grid_.resolution_m / bin_m));
        const int by =
            std::min(u.bins_y - 1, static_cast<int>((y + 0.5) * grid_.resolution_m / bin_m));
        ++u.per_bin[static_cast<size_t>(by) * u.bins_x + bx];
      }
    }
  }
  return u;
}

}  // namespace kestrel
