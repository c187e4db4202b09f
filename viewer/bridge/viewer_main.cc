// kestrel-viewer: the live viewer's bridge; Kestrel's channels in, a web page and WebSocket out.
#include <csignal>
#include <filesystem>
#include <memory>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "common/config_publisher.h"
#include "common/log.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "viewer/bridge/viewer_node.h"
#include "viewer/foxglove/foxglove_node.h"

namespace {
const char* const kUsage =
    "usage: kestrel-viewer [--config config/viewer.yaml] [--set key=value]...\n"
    "                      [--lcm-url URL]\n"
    "Subscribes to MAP3D, MAP3D_DELTA, MAP_STATUS, MAP2D_*, POSE_VICON, TRAJECTORY and\n"
    "EXPLORATION_STATUS (names from the configuration) and serves the live viewer page on\n"
    "http://127.0.0.1:8740/ (host, port): the 3D map as voxels, the 2D maps, pose, trajectory,\n"
    "candidates and the entropy history; a page opened late starts from the current state.\n"
    "Foxglove connects to ws://127.0.0.1:8765 (foxglove.port; -1: off): the map as cubes, the\n"
    "2D maps as grids, the pose as a transform, trajectory and candidates as lines and arrows.\n"
    "Foxglove's desktop app always may; its web app in a browser (https://app.foxglove.dev) only\n"
    "with --set 'foxglove.allowed_origins=[https://app.foxglove.dev]' (every page of that origin\n"
    "may then read the vehicle's state).\n"
    "Several vehicles (vehicles: [{prefix: V1_}, {prefix: V2_}]): the page shows each one's\n"
    "pose, path, plan, goal and explorer state from its prefixed channels; Foxglove shows the\n"
    "first vehicle's.\n";

#ifndef KESTREL_VIEWER_WEB_ROOT
#define KESTREL_VIEWER_WEB_ROOT ""
#endif
#ifndef KESTREL_VIEWER_INSTALLED_WEB_ROOT
#define KESTREL_VIEWER_INSTALLED_WEB_ROOT "../share/kestrel/web"
#endif

// The page when web_root is "": an installed kestrel-viewer's own (relative to its folder),
// else the page staged by the build.
std::string DefaultWebRoot() {
  std::error_code error;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", error);
  if (!error) {
    const std::filesystem::path installed =
        (exe.parent_path() / KESTREL_VIEWER_INSTALLED_WEB_ROOT).lexically_normal();
    if (std::filesystem::exists(installed / "index.html", error)) return installed.string();
  }
  return KESTREL_VIEWER_WEB_ROOT;
}

// The channel prefix of the MAP2D regex ("MAP2D_.*" -> "MAP2D_").
std::string MapPrefixOf(const std::string& regex) {
  const size_t cut = regex.find_first_of(".*[(|\\+?");
  return cut == std::string::npos ? regex : regex.substr(0, cut);
}
}  // namespace

int main(int argc, char** argv) {
  return kestrel::RunProcess(
      "kestrel-viewer", argc, argv, kUsage,
      [](const kestrel::ProcessArgs& args, kestrel::ConfigNode& node) {
        const kestrel::ViewerConfig config = kestrel::LoadViewerConfig(node);
        node.CheckNoUnknownKeys();
        const std::string web_root = config.web_root.empty() ? DefaultWebRoot() : config.web_root;
        std::signal(SIGPIPE, SIG_IGN);  // a page gone mid-send is an error code, not a signal
        lcm::LCM lcm(args.lcm_url);
        if (!lcm.good()) throw std::runtime_error("cannot open LCM at '" + args.lcm_url + "'");
        if (!args.sim_clock_channel.empty()) {
          kestrel::Log(kestrel::LogLevel::kInfo,
                       "--sim-clock ignored: pages are updated in wall-clock time");
        }
        const kestrel::WallClock clock;
        kestrel::ViewerNode viewer(lcm, config, web_root, clock);
        const kestrel::ConfigPublisher params(lcm, clock, "kestrel-viewer",
                                              kestrel::ParamsChannelFor(config.heartbeat_channel),
                                              args, node);
        kestrel::Log(kestrel::LogLevel::kInfo, "serving http://" + config.host + ":" +
                                                   std::to_string(viewer.port()) + "/ from " +
                                                   web_root);
        std::unique_ptr<kestrel::foxglove::FoxgloveNode> foxglove;
        if (config.foxglove_port >= 0) {
          kestrel::foxglove::FoxgloveNodeConfig f;
          f.server.host = config.host;
          f.server.port = config.foxglove_port;
          f.server.allowed_origins = config.foxglove_allowed_origins;
          f.map_rate_hz = config.foxglove_map_rate_hz;
          f.bridge.occupied_threshold = config.scene.occupied_threshold;
          f.bridge.map_channel = config.map_channel;
          f.bridge.delta_channel = config.delta_channel;
          // The first vehicle's channels (one vehicle without a prefix: as before).
          const std::string& vehicle = config.vehicle_prefixes.front();
          f.bridge.pose_channel = vehicle + config.pose_channel;
          f.bridge.trajectory_channel = vehicle + config.trajectory_channel;
          f.bridge.exploration_channel = vehicle + config.exploration_channel;
          f.bridge.map2d_prefix = vehicle + MapPrefixOf(config.map2d_channels);
          foxglove = std::make_unique<kestrel::foxglove::FoxgloveNode>(lcm, f, clock);
        }
        while (!kestrel::NodeLoop::signal_received()) {
          // Drain what LCM has (bounded, so the pages are served under a flood), then sockets.
          int handled = 0;
          while (handled < 500 && lcm.handleTimeout(0) > 0) ++handled;
          viewer.Poll();
          viewer.PublishDue();
          if (foxglove) {
            foxglove->Poll();
            foxglove->PublishDue();
          }
          if (handled == 0) lcm.handleTimeout(5);
        }
        kestrel::Log(kestrel::LogLevel::kInfo, "stopping");
        return 0;
      });
}
