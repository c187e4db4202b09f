// kestrel-controller: the geometric SE(3) flight controller process (runs on the vehicle).
// Reads POSE_VICON, IMU, TRAJECTORY, COMMAND; writes MOTOR_COMMAND, CONTROLLER_STATUS and a
// heartbeat. See control/controller_node.h.
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <stdexcept>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "common/command_line.h"
#include "common/config_publisher.h"
#include "common/heartbeat.h"
#include "common/identity.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "common/realtime.h"
#include "common/sim_truth_clock.h"
#include "control/controller_node.h"

namespace {
const char* const kUsage =
    "usage: kestrel-controller [--vehicle FILE] [--config FILE] [--set key=value]...\n"
    "                          [--lcm-url URL] [--sim-clock SIM_TRUTH]\n"
    "  --vehicle FILE  vehicle parameters (default config/vehicle/paper.yaml)\n"
    "  --config FILE   controller YAML (rate_hz, channels, controller, estimator, safety,\n"
    "                  state_path, run_id, takeover_max_gap_s, realtime); optional, defaults\n"
    "                  otherwise\n"
    "  realtime.fifo_priority, realtime.lock_memory, realtime.cpus: the rate loop's real-time\n"
    "  settings (docs/design.md §2.6); off by default, a refused one is a warning\n"
    "  loop_timing_path: at exit, the run's histograms of the loop's lateness and of the IMU\n"
    "  sample's age at each motor command (CSV, 10 us bins); \"\" (default): none\n"
    "  run_id unset: $KESTREL_RUN_ID; with state_path set, a controller respawned within the same\n"
    "  run sends nothing until a fresh pose comes, then takes the vehicle over in HOLD if that\n"
    "  pose shows it airborne (docs/design.md §2.5)\n";
}  // namespace

int main(int argc, char** argv) {
  std::string vehicle_path = "config/vehicle/paper.yaml";
  return kestrel::RunProcess(
      "kestrel-controller", argc, argv, kUsage,
      [&](CLI::App& app) { app.add_option("--vehicle", vehicle_path); },
      [&](const kestrel::ProcessArgs& args, kestrel::ConfigNode& node) {
        // Where a respawn's start-up goes (docs/design.md §2.5): logged at the first control step.
        const double parsed_s = kestrel::SecondsSinceProcessStart();
        // The process's own keys first: LoadControllerConfig refuses any key it does not know.
        const kestrel::RealtimeConfig realtime = kestrel::ReadRealtimeConfig(node);
        std::string loop_timing_path;  // "": none; else the whole run's histograms, CSV, at exit
        node.Read("loop_timing_path", &loop_timing_path);
        const kestrel::VehicleConfig vehicle = kestrel::LoadVehicleConfigFile(vehicle_path, node);
        kestrel::ControllerConfig config = kestrel::LoadControllerConfig(node, vehicle);
        config.flight.vehicle = vehicle;
        node.CheckNoUnknownKeys();
        // No run_id set: the run's, from the runner that started it; a respawn within the run
        // takes a flying vehicle over (docs/design.md §2.5).
        if (config.run_id.empty()) config.run_id = kestrel::RunIdFromEnvironment();
        config.Validate();
        // Before LCM starts its receive thread, which inherits the policy (docs/design.md §2.6).
        const kestrel::RealtimeOutcome applied = kestrel::ApplyRealtimeAndLog(realtime);
        lcm::LCM lcm(args.lcm_url);
        if (!lcm.good()) throw std::runtime_error("cannot open LCM at '" + args.lcm_url + "'");
        const std::unique_ptr<kestrel::Clock> clock =
            kestrel::MakeProcessClock(lcm, args.sim_clock_channel);
        kestrel::ControllerNode controller(lcm, config, *clock);
        const double ready_s = kestrel::SecondsSinceProcessStart();
        bool first_step = true;
        kestrel::Heartbeat heartbeat(lcm, *clock, "kestrel-controller", config.heartbeat_channel);
        const kestrel::ConfigPublisher params(lcm, *clock, "kestrel-controller",
                                              kestrel::ParamsChannelFor(heartbeat.channel()), args,
                                              node);
        kestrel::NodeLoop loop(lcm, *clock);
        // The rate loop's lateness (when a tick ran minus when it was due): its period jitter.
        // The age of the newest IMU sample when a step's motor command went out. Per heartbeat
        // period, and over the whole run for loop_timing_path.
        kestrel::LoopTiming timing, imu_age, run_timing, run_imu_age;
        // The heartbeat: each second, and once at the first control step, so that a respawn is
        // seen at once (the chaos regression times the controller's absence by it).
        const auto beat = [&] {
          heartbeat.SetState(kestrel::heartbeat_t::STATE_OK);
          heartbeat.SetValue("mode", static_cast<double>(controller.flight().supervisor().mode()));
          heartbeat.SetValue("drops", static_cast<double>(controller.drops().total()));
          // 1 while a respawned controller waits for the pose that decides its takeover (it then
          // sends no motor command and no status).
          heartbeat.SetValue("takeover_pending", controller.takeover_pending() ? 1.0 : 0.0);
          heartbeat.SetDropValues(controller.drops());
          // Over the last heartbeat period; ticks skipped (behind by whole periods) since start.
          heartbeat.SetValue("loop_late_p50_us", static_cast<double>(timing.QuantileUs(0.5)));
          heartbeat.SetValue("loop_late_p99_us", static_cast<double>(timing.QuantileUs(0.99)));
          heartbeat.SetValue("loop_late_max_us", static_cast<double>(timing.max_us()));
          heartbeat.SetValue("loop_ticks_skipped", static_cast<double>(loop.skipped_ticks()));
          heartbeat.SetValue("imu_age_p50_us", static_cast<double>(imu_age.QuantileUs(0.5)));
          heartbeat.SetValue("imu_age_p99_us", static_cast<double>(imu_age.QuantileUs(0.99)));
          heartbeat.SetValue("imu_age_max_us", static_cast<double>(imu_age.max_us()));
          heartbeat.SetValue("realtime_fifo", applied.fifo ? 1.0 : 0.0);
          timing.Reset();
          imu_age.Reset();
          heartbeat.SetLastError(controller.takeover_pending() ? controller.takeover_status()
                                                               : controller.drops().last_reason());
          heartbeat.Publish();
        };
        loop.AddTimer("control", kestrel::SecondsToUtime(1.0 / config.rate_hz), [&](int64_t utime) {
          if (first_step) {
            first_step = false;
            char text[200];
            std::snprintf(text, sizeof(text),
                          "start-up: command line and configuration read %.3f s, LCM and node "
                          "ready %.3f s, first control step %.3f s after exec",
                          parsed_s, ready_s, kestrel::SecondsSinceProcessStart());
            kestrel::Log(kestrel::LogLevel::kInfo, text);
            beat();
          }
          const int64_t late_us = clock->NowUtime() - utime;
          timing.Record(late_us);
          run_timing.Record(late_us);
          controller.Tick(utime);
          if (controller.last_imu_utime() >= 0) {
            const int64_t age_us = clock->NowUtime() - controller.last_imu_utime();
            imu_age.Record(age_us);
            run_imu_age.Record(age_us);
          }
        });
        loop.AddTimer("heartbeat", 1000000, [&](int64_t) { beat(); });
        loop.AddShutdownHook([&] {
          if (!loop_timing_path.empty()) {
            std::ofstream(loop_timing_path)
                << kestrel::LoopTimingCsv({"loop_late", "imu_age"}, {&run_timing, &run_imu_age});
          }
          heartbeat.SetState(kestrel::heartbeat_t::STATE_STOPPING);
          heartbeat.Publish();
        });
        return loop.Run();
      });
}
