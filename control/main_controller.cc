// kestrel-controller: the geometric SE(3) flight controller process (runs on the vehicle).
// Reads POSE_VICON, IMU, TRAJECTORY, COMMAND; writes MOTOR_COMMAND, CONTROLLER_STATUS and a
// heartbeat. See control/controller_node.h.
#include <cstdlib>
#include <stdexcept>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "common/command_line.h"
#include "common/config_publisher.h"
#include "common/heartbeat.h"
#include "common/identity.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "common/sim_truth_clock.h"
#include "control/controller_node.h"

namespace {
const char* const kUsage =
    "usage: kestrel-controller [--vehicle FILE] [--config FILE] [--set key=value]...\n"
    "                          [--lcm-url URL] [--sim-clock SIM_TRUTH]\n"
    "  --vehicle FILE  vehicle parameters (default config/vehicle/paper.yaml)\n"
    "  --config FILE   controller YAML (rate_hz, channels, controller, estimator, safety,\n"
    "                  state_path, run_id, takeover_window_s); optional, defaults otherwise\n"
    "  run_id unset: $KESTREL_RUN_ID; with state_path set, a controller respawned within the same\n"
    "  run takes a flying vehicle over in HOLD (docs/design.md §2.5)\n";
}  // namespace

int main(int argc, char** argv) {
  std::string vehicle_path = "config/vehicle/paper.yaml";
  return kestrel::RunProcess(
      "kestrel-controller", argc, argv, kUsage,
      [&](CLI::App& app) { app.add_option("--vehicle", vehicle_path); },
      [&](const kestrel::ProcessArgs& args, kestrel::ConfigNode& node) {
        const kestrel::VehicleConfig vehicle = kestrel::LoadVehicleConfigFile(vehicle_path, node);
        kestrel::ControllerConfig config = kestrel::LoadControllerConfig(node, vehicle);
        config.flight.vehicle = vehicle;
        node.CheckNoUnknownKeys();
        // No run_id set: the run's, from the runner that started it; a respawn within the run
        // takes a flying vehicle over (docs/design.md §2.5).
        if (config.run_id.empty()) config.run_id = kestrel::RunIdFromEnvironment();
        config.Validate();
        lcm::LCM lcm(args.lcm_url);
        if (!lcm.good()) throw std::runtime_error("cannot open LCM at '" + args.lcm_url + "'");
        const std::unique_ptr<kestrel::Clock> clock =
            kestrel::MakeProcessClock(lcm, args.sim_clock_channel);
        kestrel::ControllerNode controller(lcm, config, *clock);
        kestrel::Heartbeat heartbeat(lcm, *clock, "kestrel-controller", config.heartbeat_channel);
        const kestrel::ConfigPublisher params(lcm, *clock, "kestrel-controller",
                                              kestrel::ParamsChannelFor(heartbeat.channel()), args,
                                              node);
        kestrel::NodeLoop loop(lcm, *clock);
        loop.AddTimer("control", kestrel::SecondsToUtime(1.0 / config.rate_hz),
                      [&controller](int64_t utime) { controller.Tick(utime); });
        loop.AddTimer("heartbeat", 1000000, [&](int64_t) {
          heartbeat.SetState(kestrel::heartbeat_t::STATE_OK);
          heartbeat.SetValue("mode", static_cast<double>(controller.flight().supervisor().mode()));
          heartbeat.SetValue("drops", static_cast<double>(controller.drops().total()));
          heartbeat.SetDropValues(controller.drops());
          heartbeat.SetLastError(controller.drops().last_reason());
          heartbeat.Publish();
        });
        loop.AddShutdownHook([&] {
          heartbeat.SetState(kestrel::heartbeat_t::STATE_STOPPING);
          heartbeat.Publish();
        });
        return loop.Run();
      });
}
