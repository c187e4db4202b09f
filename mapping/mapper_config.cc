#include "mapping/mapper_config.h"

#include <unistd.h>

#include "common/check.h"
#include "common/identity.h"
#include "common/vehicle_config.h"
#include "common/vehicle_prefixes.h"
#include "mapping/mapping_config.h"

namespace kestrel {

std::vector<MapperSensorConfig> DefaultMapperSensors() {
  const VehicleConfig vehicle;
  MapperSensorConfig xtion;
  xtion.X_BS = vehicle.X_BS_xtion;
  MapperSensorConfig hokuyo;
  hokuyo.name = "hokuyo";
  hokuyo.channel = "SCAN_HOKUYO";
  hokuyo.kind = "scan";
  hokuyo.model = SensorModelConfig::Hokuyo();
  hokuyo.X_BS = vehicle.X_BS_hokuyo;
  return {xtion, hokuyo};
}

void MapperConfig::Validate() const {
  KESTREL_THROW_UNLESS(grid == "dense" || grid == "growing",
                       "grid = '" << grid << "' must be dense or growing");
  KESTREL_THROW_UNLESS(model == "exact" || model == "log_odds",
                       "model = '" << model << "' must be exact or log_odds");
  KESTREL_THROW_UNLESS(
      instruction_set.empty() || instruction_set == "scalar" || instruction_set == "avx512",
      "instruction_set = '" << instruction_set << "' must be empty, scalar or avx512");
  limits.Validate();
  occupancy.Validate();
  log_odds.Validate();
  pose_history.Validate();
  KESTREL_THROW_UNLESS(!sensors.empty(), "sensors: at least one sensor is needed");
  ValidateVehiclePrefixes(vehicle_prefixes);
  for (const auto& s : sensors) {
    KESTREL_THROW_UNLESS(
        s.kind == "depth" || s.kind == "scan",
        "sensors." << s.name << ".kind = '" << s.kind << "' must be depth or scan");
    s.model.Validate();
  }
  KESTREL_THROW_UNLESS(snapshot_period_s >= 0 && delta_period_s >= 0 && status_period_s > 0,
                       "periods must be >= 0 (status > 0)");
  KESTREL_THROW_UNLESS(
      snapshot_blocks_per_chunk >= 1 && snapshot_blocks_per_chunk <= 4096,
      "snapshot_blocks_per_chunk = " << snapshot_blocks_per_chunk << " must be in [1, 4096]");
  KESTREL_THROW_UNLESS(
      map_message_max_bytes >= 8192 && map_message_max_bytes <= (64 << 20),
      "map_message_max_bytes = " << map_message_max_bytes << " must be in [8192, 67108864]");
  KESTREL_THROW_UNLESS(snapshot_bytes_per_s >= 0,
                       "snapshot_bytes_per_s = " << snapshot_bytes_per_s << " must be >= 0");
  KESTREL_THROW_UNLESS(checkpoint_period_s > 0,
                       "checkpoint_period_s = " << checkpoint_period_s << " must be > 0");
  KESTREL_THROW_UNLESS(run_id.empty() || CheckRunId(run_id).empty(),
                       "run_id = '" << run_id << "': " << CheckRunId(run_id));
  KESTREL_THROW_UNLESS(resume == "same_run" || resume == "any",
                       "resume = '" << resume << "' must be same_run or any");
  KESTREL_THROW_UNLESS(max_queue >= 1, "max_queue = " << max_queue << " must be >= 1");
  KESTREL_THROW_UNLESS(max_backlog_s > 0, "max_backlog_s = " << max_backlog_s << " must be > 0");
  KESTREL_THROW_UNLESS(
      order_wait_s >= 0 && order_wait_s < max_backlog_s,
      "order_wait_s = " << order_wait_s
                        << " must be >= 0 and below max_backlog_s = " << max_backlog_s);
  KESTREL_THROW_UNLESS(catch_up_wait_s >= 0,
                       "catch_up_wait_s = " << catch_up_wait_s << " must be >= 0");
}

namespace {

std::string ResolvePath(const std::string& relative, const std::string& config_file) {
  if (relative.empty() || relative[0] == '/') return relative;
  const size_t slash = config_file.rfind('/');
  if (slash != std::string::npos) {
    std::string beside = config_file.substr(0, slash + 1) + relative;
    if (access(beside.c_str(), R_OK) == 0) return beside;
  }
  return relative;
}

}  // namespace

MapperConfig LoadMapperConfig(const ConfigNode& node) {
  MapperConfig c;
  node.Read("grid", &c.grid, {"dense", "growing"});
  node.Read("model", &c.model, {"exact", "log_odds"});
  if (node.Has("map")) {  // limits, resolution, P_init and the clamp share one section
    const ConfigNode map = node.Child("map");
    ReadMapLimits(map, &c.limits);
    ReadOccupancyLimits(map, &c.occupancy);
  }
  if (node.Has("log_odds")) ReadLogOddsConfig(node.Child("log_odds"), &c.log_odds);
  VehicleConfig vehicle;
  if (node.Has("vehicle_config")) {
    std::string path;
    node.Read("vehicle_config", &path);
    vehicle = LoadVehicleConfigFile(ResolvePath(path, node.file()), node);
  }
  c.sensors = DefaultMapperSensors();
  c.sensors[0].X_BS = vehicle.X_BS_xtion;
  c.sensors[1].X_BS = vehicle.X_BS_hokuyo;
  if (node.Has("sensors")) {
    c.sensors.clear();
    for (const ConfigNode& s : node.Elements("sensors")) {
      MapperSensorConfig sensor;
      s.ReadRequired("name", &sensor.name, std::vector<std::string>{"xtion", "hokuyo"});
      sensor.kind = sensor.name == "xtion" ? "depth" : "scan";
      sensor.channel = sensor.name == "xtion" ? "DEPTH_XTION" : "SCAN_HOKUYO";
      sensor.model =
          sensor.name == "xtion" ? SensorModelConfig::Xtion() : SensorModelConfig::Hokuyo();
      sensor.X_BS = sensor.name == "xtion" ? vehicle.X_BS_xtion : vehicle.X_BS_hokuyo;
      s.Read("channel", &sensor.channel);
      if (s.Has("model")) ReadSensorModelConfig(s.Child("model"), &sensor.model);
      c.sensors.push_back(sensor);
    }
  }
  node.Read("pose_channel", &c.pose_channel);
  ReadVehiclePrefixes(node, "vehicles", &c.vehicle_prefixes);
  if (node.Has("pose_history")) ReadPoseHistoryConfig(node.Child("pose_history"), &c.pose_history);
  node.Read("map_channel", &c.map_channel);
  node.Read("delta_channel", &c.delta_channel);
  node.Read("status_channel", &c.status_channel);
  node.Read("heartbeat_channel", &c.heartbeat_channel);
  node.Read("snapshot_period_s", &c.snapshot_period_s, Range::NonNegative());
  node.Read("delta_period_s", &c.delta_period_s, Range::NonNegative());
  node.Read("status_period_s", &c.status_period_s, Range::Positive());
  node.Read("snapshot_blocks_per_chunk", &c.snapshot_blocks_per_chunk, Range::Closed(1, 4096));
  node.Read("map_message_max_bytes", &c.map_message_max_bytes, Range::Closed(8192, 64 << 20));
  node.Read("snapshot_bytes_per_s", &c.snapshot_bytes_per_s, Range::NonNegative());
  node.Read("checkpoint_path", &c.checkpoint_path);
  node.Read("checkpoint_period_s", &c.checkpoint_period_s, Range::Positive());
  node.Read("run_id", &c.run_id);
  node.Read("resume", &c.resume, {"same_run", "any"});
  node.Read("max_queue", &c.max_queue, Range::Closed(1, 100000));
  node.Read("max_backlog_s", &c.max_backlog_s, Range::Positive());
  node.Read("decisions_channel", &c.decisions_channel);
  node.Read("decisions_log", &c.decisions_log);
  node.Read("order_wait_s", &c.order_wait_s, Range::NonNegative());
  node.Read("catch_up_log", &c.catch_up_log);
  node.Read("catch_up_wait_s", &c.catch_up_wait_s, Range::NonNegative());
  node.Read("traversal_thread", &c.traversal_thread);
  node.Read("instruction_set", &c.instruction_set, {"", "scalar", "avx512"});
  try {
    c.Validate();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(node.file() + ": " + e.what());
  }
  return c;
}

}  // namespace kestrel
