// kestrel-controller: the geometric SE(3) flight controller process (runs on the vehicle).
// Reads POSE_VICON, IMU, TRAJECTORY, COMMAND; writes MOTOR_COMMAND, CONTROLLER_STATUS and a
// heartbeat. See control/controller_node.h.
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/config.h"
#include "common/heartbeat.h"
#include "common/log.h"
#include "common/node_loop.h"
#include "control/controller_node.h"

namespace {

void PrintUsage() {
  std::printf(
      "usage: kestrel-controller [--vehicle FILE] [--config FILE] [--lcm-url URL]\n"
      "  --vehicle FILE  vehicle parameters (default config/vehicle/paper.yaml)\n"
      "  --config FILE   controller YAML (rate_hz, channels, controller, estimator, safety);\n"
      "                  optional, defaults otherwise\n"
      "  --lcm-url URL   LCM provider (default: LCM's default, e.g. udpm://...?ttl=0)\n");
}

}  // namespace

int main(int argc, char** argv) {
  std::string vehicle_path = "config/vehicle/paper.yaml";
  std::string config_path;
  std::string lcm_url;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      PrintUsage();
      return 0;
    }
    if (i + 1 >= argc || (arg != "--vehicle" && arg != "--config" && arg != "--lcm-url")) {
      std::fprintf(stderr, "kestrel-controller: bad argument '%s'\n", arg.c_str());
      PrintUsage();
      return 2;
    }
    const std::string value = argv[++i];
    if (arg == "--vehicle") vehicle_path = value;
    if (arg == "--config") config_path = value;
    if (arg == "--lcm-url") lcm_url = value;
  }
  kestrel::SetLogProcessName("kestrel-controller");
  try {
    const kestrel::VehicleConfig vehicle = kestrel::LoadVehicleConfigFile(vehicle_path);
    kestrel::ControllerConfig config;
    config.flight.vehicle = vehicle;
    if (!config_path.empty()) {
      config = kestrel::LoadControllerConfig(kestrel::ConfigNode::LoadFile(config_path), vehicle);
    }
    config.Validate();
    lcm::LCM lcm(lcm_url);
    if (!lcm.good()) {
      kestrel::Log(kestrel::LogLevel::kError, "LCM failed to start with url '" + lcm_url + "'");
      return 1;
    }
    kestrel::WallClock clock;
    kestrel::ControllerNode node(lcm, config, clock);
    kestrel::Heartbeat heartbeat(lcm, clock, "kestrel-controller", "HEARTBEAT_CONTROLLER");
    kestrel::NodeLoop loop(lcm, clock);
    loop.AddTimer("control", kestrel::SecondsToUtime(1.0 / config.rate_hz),
                  [&node](int64_t utime) { node.Tick(utime); });
    loop.AddTimer("heartbeat", 1000000, [&](int64_t) {
      heartbeat.SetState(kestrel::heartbeat_t::STATE_OK);
      heartbeat.SetValue("mode", static_cast<double>(node.flight().supervisor().mode()));
      heartbeat.SetValue("drops", static_cast<double>(node.drops().total()));
      heartbeat.SetLastError(node.drops().last_reason());
      heartbeat.Publish();
    });
    loop.AddShutdownHook([&] {
      heartbeat.SetState(kestrel::heartbeat_t::STATE_STOPPING);
      heartbeat.Publish();
    });
    kestrel::NodeLoop::InstallSignalHandlers();
    return loop.Run();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "kestrel-controller: %s\n", e.what());
    return 1;
  }
}
