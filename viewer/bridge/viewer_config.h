#pragma once
/// @file
/// Configuration of kestrel-viewer (config/viewer.yaml): where it listens, which channels
/// it shows, how often it updates the pages and what the scene keeps.

#include <cstddef>
#include <string>
#include <vector>

#include "common/config.h"
#include "viewer/bridge/viewer_scene.h"

namespace kestrel {

struct ViewerConfig {
  std::string host{"127.0.0.1"};  ///< listen address; must be a loopback address (127.x.y.z)
  int port{8740};                 ///< TCP port of the page and WebSocket (0: any free port)
  std::string web_root;           ///< folder with index.html ("" = installed, else built page)
  double update_rate_hz{10.0};    ///< update frames per second sent to the pages (coalesced)
  /// A page with more than this many bytes still unsent gets no updates; once it drained, it
  /// gets one fresh snapshot (its queue never grows without bound).
  int64_t max_client_buffer_bytes{8 << 20};
  int max_clients{16};  ///< pages served at once; more connections are refused
  /// Origins (scheme://host[:port]) whose pages may open the page's WebSocket besides the pages
  /// served here (viewer/bridge/viewer_server.h WebSocketOriginAllowed). Empty by default.
  std::vector<std::string> allowed_origins;
  /// The Foxglove WebSocket endpoint (viewer/foxglove/foxglove_server.h) on `host`: its port
  /// (-1: off, 0: any free port) and how often the map's changed blocks are sent.
  int foxglove_port{8765};
  double foxglove_map_rate_hz{1.0};
  /// Origins whose pages may connect to the Foxglove endpoint besides its own loopback origin:
  /// ["https://app.foxglove.dev"] lets Foxglove's web app in a browser connect. Empty by default
  /// (Foxglove's desktop app sends no Origin and always may).
  std::vector<std::string> foxglove_allowed_origins;

  std::string map_channel{"MAP3D"};                       ///< map3d_chunk_t snapshots
  std::string delta_channel{"MAP3D_DELTA"};               ///< map3d_delta_t
  std::string map_status_channel{"MAP_STATUS"};           ///< map_status_t (entropy history)
  std::string map2d_channels{"MAP2D_.*"};                 ///< grid_map_t, an LCM regex
  std::string pose_channel{"POSE_VICON"};                 ///< pose_t of the vehicle
  std::string trajectory_channel{"TRAJECTORY"};           ///< trajectory_t (the current plan)
  std::string exploration_channel{"EXPLORATION_STATUS"};  ///< exploration_status_t
  std::string heartbeat_channel{"HEARTBEAT_VIEWER"};
  /// The vehicles shown (docs/design.md §7.10): each one's prefix goes before the pose,
  /// trajectory, exploration and 2D-map channels above (V2_POSE_VICON, V2_MAP2D_.*); the map
  /// channels are shared. Letters, digits and '_' only, no two alike, 1 to 16 of them. One
  /// vehicle without a prefix by default.
  std::vector<std::string> vehicle_prefixes{""};

  ViewerSceneConfig scene;  ///< threshold, history sizes (channels, vehicles from the above)

  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// Reads a ViewerConfig from YAML (keys as in config/viewer.yaml), then Validate()s it.
/// @throws ConfigError on a bad or out-of-range value.
[[nodiscard]] ViewerConfig LoadViewerConfig(const ConfigNode& node);

}  // namespace kestrel
