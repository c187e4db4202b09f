#include "tools/fidelity/calibrate.h"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "common/config.h"
#include "mapping/ray_caster.h"
#include "sim/ground_truth.h"
#include "sim/world_ray_caster.h"
#include "tools/fidelity/log_replay.h"
#include "tools/map_score/map_scorer.h"

namespace kestrel {

std::vector<SensorCalibrationResult> CalibrateFromLog(const CalibrationRunConfig& config) {
  if (config.every < 1) throw std::invalid_argument("CalibrateFromLog: every must be >= 1");
  const World world = LoadWorld(PathUnderRoot(config.root, config.world_file));
  const WorldRayCaster caster(world);
  const MapperConfig mapper_config =
      LoadReplayMapperConfig(config.root, config.mapper_file, config.overrides, world);
  LogReplay replay;
  MapperNode& mapper = replay.mapper(replay.AddMapper(mapper_config));
  // The world voxelised on the mapper's lattice: the model's first occupied cell of a ray is the
  // first cell of the mapper's own traversal (mapping/ray_caster.h) that the truth holds occupied.
  const GridGeometry& geometry = mapper.geometry();
  const GridSpec grid = GridSpecOf(geometry);
  const std::vector<uint8_t> truth = VoxelizeWorld(world, grid);
  const RayCaster ray_caster(geometry);
  std::vector<SensorCalibrator> calibrators;
  std::vector<RayCells> cells;
  std::vector<int64_t> seen(mapper_config.sensors.size(), 0);
  std::vector<int64_t> left_map(mapper_config.sensors.size(), 0);
  for (const auto& s : mapper_config.sensors) {
    calibrators.emplace_back(s.model.z_min_m, s.model.z_max_m);
    cells.emplace_back(s.model.z_max_m, geometry.resolution_m());
  }
  mapper.SetScanObserver([&](const MapperNode::AppliedScan& scan) {
    if (seen[scan.sensor]++ % config.every != 0) return;
    SensorCalibrator& cal = calibrators[scan.sensor];
    RayCells& walk = cells[scan.sensor];
    const double z_max = scan.model->config().z_max_m;
    for (const SensorRay& ray : scan.Rays()) {
      if (ray.reading.kind == ReadingKind::kInvalid) continue;
      const double d = caster.CastRay(ray.origin_W, ray.direction_W, z_max);
      double d_k = std::numeric_limits<double>::infinity();
      const int n = ray_caster.CastWithLinearIndex(ray.origin_W, ray.direction_W, z_max, &walk);
      for (int k = 0; k < n; ++k) {
        if (truth[walk.linear_index[static_cast<size_t>(k)]] != 0) {
          d_k = walk.distance_m[static_cast<size_t>(k)];
          break;
        }
      }
      // A return from a surface outside the map (a wall above the map's top) says nothing the
      // map can hold about the sensor: left out. A ray leaving the map without a return is an
      // empty ray to the model, and stays.
      const bool returned = ray.reading.kind == ReadingKind::kReturn;
      if (returned && !std::isfinite(d_k) && walk.left_bounds) {
        ++left_map[scan.sensor];
        continue;
      }
      cal.Add(d, d_k, returned, returned ? ray.reading.z_m : 0.0);
    }
  });
  replay.Run(PathUnderRoot(config.root, config.log_path));
  std::vector<SensorCalibrationResult> out;
  for (size_t i = 0; i < mapper_config.sensors.size(); ++i) {
    const auto& s = mapper_config.sensors[i];
    SensorCalibrationResult r;
    r.name = s.name;
    r.z_min_m = s.model.z_min_m;
    r.z_max_m = s.model.z_max_m;
    r.configured_sigma_m = s.model.sigma_m;
    r.configured_p_rand = s.model.p_rand;
    r.configured_p_miss = s.model.p_miss;
    r.fit = calibrators[i].Fit();
    r.rays_left_map = left_map[i];
    out.push_back(r);
  }
  return out;
}

}  // namespace kestrel
