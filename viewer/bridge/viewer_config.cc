#include "viewer/bridge/viewer_config.h"

#include <stdexcept>

#include "common/check.h"
#include "common/vehicle_prefixes.h"
#include "viewer/bridge/viewer_server.h"

namespace kestrel {

void ViewerConfig::Validate() const {
  KESTREL_THROW_UNLESS(host.rfind("127.", 0) == 0 || host == "localhost",
                       "host = '" << host << "' must be a loopback address (127.x.y.z)");
  KESTREL_THROW_UNLESS(port >= 0 && port <= 65535, "port = " << port << " outside [0, 65535]");
  KESTREL_THROW_UNLESS(update_rate_hz > 0 && update_rate_hz <= 100,
                       "update_rate_hz = " << update_rate_hz << " outside (0, 100]");
  KESTREL_THROW_UNLESS(max_client_buffer_bytes >= 65536,
                       "max_client_buffer_bytes = " << max_client_buffer_bytes << " below 65536");
  KESTREL_THROW_UNLESS(max_clients >= 1, "max_clients = " << max_clients << " below 1");
  KESTREL_THROW_UNLESS(scene.occupied_threshold >= 0 && scene.occupied_threshold < 1,
                       "occupied_threshold = " << scene.occupied_threshold << " outside [0, 1)");
  KESTREL_THROW_UNLESS(scene.path_min_step_m >= 0,
                       "path_min_step_m = " << scene.path_min_step_m << " below 0");
  KESTREL_THROW_UNLESS(
      scene.max_path_points >= 2 && scene.max_entropy_points >= 2 && scene.max_plan_points >= 2,
      "max_path_points, max_entropy_points and max_plan_points must be >= 2");
  KESTREL_THROW_UNLESS(scene.plan_sample_period_s > 0,
                       "plan_sample_period_s = " << scene.plan_sample_period_s << " must be > 0");
  KESTREL_THROW_UNLESS(scene.max_candidates >= 0,
                       "max_candidates = " << scene.max_candidates << " below 0");
  // The same rules as the mapper's and the simulator's vehicles (docs/design.md §7.10).
  ValidateVehiclePrefixes(vehicle_prefixes);
  for (const auto* list : {&allowed_origins, &foxglove_allowed_origins}) {
    for (const std::string& origin : *list) {
      const std::string why = CheckAllowedOrigin(origin);
      KESTREL_THROW_UNLESS(
          why.empty(), (list == &allowed_origins ? "allowed_origins" : "foxglove.allowed_origins")
                           << ": " << why);
    }
  }
}

ViewerConfig LoadViewerConfig(const ConfigNode& node) {
  ViewerConfig c;
  node.Read("host", &c.host);
  node.Read("port", &c.port, Range::Closed(0, 65535));
  node.Read("web_root", &c.web_root);
  node.Read("update_rate_hz", &c.update_rate_hz, Range{0.0, 100.0, false, true});
  node.Read("max_client_buffer_bytes", &c.max_client_buffer_bytes, Range::AtLeast(65536));
  node.Read("max_clients", &c.max_clients, Range::AtLeast(1));
  node.Read("allowed_origins", &c.allowed_origins);
  if (node.Has("foxglove")) {
    const ConfigNode f = node.Child("foxglove");
    f.Read("port", &c.foxglove_port, Range::Closed(-1, 65535));
    f.Read("map_rate_hz", &c.foxglove_map_rate_hz, Range{0.0, 100.0, false, true});
    f.Read("allowed_origins", &c.foxglove_allowed_origins);
  }
  if (node.Has("channels")) {
    const ConfigNode ch = node.Child("channels");
    ch.Read("map", &c.map_channel);
    ch.Read("delta", &c.delta_channel);
    ch.Read("map_status", &c.map_status_channel);
    ch.Read("map2d", &c.map2d_channels);
    ch.Read("pose", &c.pose_channel);
    ch.Read("trajectory", &c.trajectory_channel);
    ch.Read("exploration", &c.exploration_channel);
    ch.Read("heartbeat", &c.heartbeat_channel);
  }
  ReadVehiclePrefixes(node, "vehicles", &c.vehicle_prefixes);
  if (node.Has("scene")) {
    const ConfigNode s = node.Child("scene");
    s.Read("occupied_threshold", &c.scene.occupied_threshold, Range{0.0, 1.0, true, false});
    s.Read("path_min_step_m", &c.scene.path_min_step_m, Range::NonNegative());
    s.Read("max_path_points", &c.scene.max_path_points, Range::AtLeast(2));
    s.Read("max_entropy_points", &c.scene.max_entropy_points, Range::AtLeast(2));
    s.Read("plan_sample_period_s", &c.scene.plan_sample_period_s, Range::Positive());
    s.Read("max_plan_points", &c.scene.max_plan_points, Range::AtLeast(2));
    s.Read("max_candidates", &c.scene.max_candidates, Range::NonNegative());
  }
  try {
    c.Validate();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(node.file() + ": " + e.what());
  }
  c.scene.channels = {{"map", c.map_channel},
                      {"delta", c.delta_channel},
                      {"map_status", c.map_status_channel},
                      {"map2d", c.map2d_channels},
                      {"pose", c.pose_channel},
                      {"trajectory", c.trajectory_channel},
                      {"exploration", c.exploration_channel}};
  c.scene.vehicles = c.vehicle_prefixes;
  return c;
}

}  // namespace kestrel
