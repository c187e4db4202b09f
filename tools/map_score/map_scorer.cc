#include "tools/map_score/map_scorer.h"

namespace kestrel {

MapScorer::MapScorer(const World& world, const WorldRayCaster& caster, const GridSpec& grid,
                     double max_range_m, double vertical_fov_rad)
    : grid_(grid), truth_(VoxelizeWorld(world, grid)) {
  ObservabilityConfig oc;
  oc.max_range_m = max_range_m;
  oc.elevation_min_rad = -0.5 * vertical_fov_rad;
  oc.elevation_max_rad = 0.5 * vertical_fov_rad;
  observable_ = ComputeObservableCells(world, caster, grid, oc).observable;
}

MapQuality MapScorer::Score(const std::function<double(const CellIndex&)>& probability,
                            double p_init) const {
  std::vector<double> p(grid_.size());
  for (int z = 0; z < grid_.dims.z(); ++z) {
    for (int y = 0; y < grid_.dims.y(); ++y) {
      for (int x = 0; x < grid_.dims.x(); ++x) {
        p[grid_.IndexOf(Eigen::Vector3i(x, y, z))] = probability(CellIndex{x, y, z});
      }
    }
  }
  return ComputeMapQuality(p, truth_, observable_, p_init);
}

}  // namespace kestrel
