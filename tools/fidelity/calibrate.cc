#include "tools/fidelity/calibrate.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "common/config.h"
#include "mapping/ray_caster.h"
#include "sim/ground_truth.h"
#include "sim/world_ray_caster.h"
#include "tools/fidelity/log_replay.h"
#include "tools/map_score/map_scorer.h"

namespace kestrel {

namespace {

// The mapper's correction and offset of sensor s.
MountCorrection ConfiguredMount(const MapperSensorConfig& s) {
  MountCorrection c;
  c.translation_m = s.mount_correction_m;
  c.rotation_rad = s.mount_correction_rad;
  c.stamp_offset_s = s.stamp_offset_s;
  return c;
}

// Fits every sensor's mount and stamp offset to the log (docs/algorithms.md §3.7).
void FitMounts(const CalibrationRunConfig& config, const MapperConfig& mapper_config,
               const WorldRayCaster& caster, std::vector<SensorCalibrationResult>* results) {
  if (mapper_config.vehicle_prefixes.size() != 1) {
    throw std::runtime_error(
        "mount calibration needs a log of one vehicle (the mapper holds one mount per sensor); "
        "the configuration fuses " +
        std::to_string(mapper_config.vehicle_prefixes.size()));
  }
  LogReplay replay;
  MapperNode& mapper = replay.mapper(replay.AddMapper(mapper_config));
  std::vector<MountCalibrator> calibrators;
  for (const auto& s : mapper_config.sensors) {
    calibrators.emplace_back(caster, s.X_BS, s.model.z_min_m, s.model.z_max_m,
                             mapper_config.pose_history, config.mount_options);
  }
  mapper.SetPoseObserver([&](size_t, int64_t utime, const Pose3& X_WB) {
    for (MountCalibrator& c : calibrators) c.AddPose(utime, X_WB);
  });
  mapper.SetScanObserver([&](const MapperNode::AppliedScan& scan) {
    // The scan's rays in its own frame: the same readings, the sensor at the origin.
    MapperNode::AppliedScan in_sensor_frame = scan;
    in_sensor_frame.X_WS = Pose3{};
    calibrators[scan.sensor].AddScan(scan.utime, in_sensor_frame.Rays());
  });
  replay.Run(PathUnderRoot(config.root, config.log_path));
  for (size_t i = 0; i < mapper_config.sensors.size(); ++i) {
    SensorCalibrationResult& r = (*results)[i];
    const bool planar = mapper_config.sensors[i].kind == "scan";
    r.mount_required = {true, true, !planar, !planar, !planar, true, true};
    r.configured_mount = ConfiguredMount(mapper_config.sensors[i]);
    r.mount = calibrators[i].Fit(r.configured_mount, r.mount_required);
  }
}

}  // namespace

std::vector<std::string> MountOverrides(size_t sensor, const MountCorrection& c) {
  const std::string key = "sensors." + std::to_string(sensor) + ".";
  char text[160];
  std::vector<std::string> out;
  std::snprintf(text, sizeof text, "%smount_correction_m=[%.5f, %.5f, %.5f]", key.c_str(),
                c.translation_m.x(), c.translation_m.y(), c.translation_m.z());
  out.emplace_back(text);
  std::snprintf(text, sizeof text, "%smount_correction_rad=[%.6f, %.6f, %.6f]", key.c_str(),
                c.rotation_rad.x(), c.rotation_rad.y(), c.rotation_rad.z());
  out.emplace_back(text);
  std::snprintf(text, sizeof text, "%sstamp_offset_s=%.5f", key.c_str(), c.stamp_offset_s);
  out.emplace_back(text);
  return out;
}

SimulatedMountTruth SimulatedMountTruthOf(const SimConfig& config) {
  const Simulator sim(config, 0);
  const auto correction = [](const Pose3& X_BS, const Pose3& true_X_BS, double offset_s,
                             double latency_s) {
    const Pose3 C = X_BS.inverse() * true_X_BS;
    MountCorrection c;
    c.translation_m = C.p;
    c.rotation_rad = RotationVectorOf(C.q);
    c.stamp_offset_s = offset_s - latency_s;
    return c;
  };
  const SensorErrorsConfig& e = config.errors;
  return SimulatedMountTruth{correction(config.vehicle.X_BS_xtion, sim.true_X_BS_depth(),
                                        e.depth_time_offset_s, e.mocap_residual_latency_s),
                             correction(config.vehicle.X_BS_hokuyo, sim.true_X_BS_lidar(),
                                        e.lidar_time_offset_s, e.mocap_residual_latency_s)};
}

std::vector<SensorCalibrationResult> CalibrateFromLog(const CalibrationRunConfig& config) {
  if (config.every < 1) throw std::invalid_argument("CalibrateFromLog: every must be >= 1");
  const World world = LoadWorld(PathUnderRoot(config.root, config.world_file));
  const WorldRayCaster caster(world);
  std::vector<std::string> overrides = config.overrides;
  std::vector<SensorCalibrationResult> out;
  {
    const MapperConfig configured =
        LoadReplayMapperConfig(config.root, config.mapper_file, overrides, world);
    out.resize(configured.sensors.size());
    if (config.mount) {
      FitMounts(config, configured, caster, &out);
      // The sensor models are fitted with the mounts and offsets that fitted.
      for (size_t i = 0; i < out.size(); ++i) {
        if (!out[i].mount.ok) continue;
        for (std::string& o : MountOverrides(i, out[i].mount.value)) overrides.push_back(o);
      }
    }
  }
  const MapperConfig mapper_config =
      LoadReplayMapperConfig(config.root, config.mapper_file, overrides, world);
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
    if (!s.model.no_return_informs) calibrators.back().LeaveOutOutOfRangeRays();
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
  for (size_t i = 0; i < mapper_config.sensors.size(); ++i) {
    const auto& s = mapper_config.sensors[i];
    SensorCalibrationResult& r = out[i];
    r.name = s.name;
    r.z_min_m = s.model.z_min_m;
    r.z_max_m = s.model.z_max_m;
    r.configured_sigma_m = s.model.sigma_m;
    r.configured_p_rand = s.model.p_rand;
    r.configured_p_miss = s.model.p_miss;
    r.fit = calibrators[i].Fit();
    r.rays_left_map = left_map[i];
  }
  return out;
}

}  // namespace kestrel
