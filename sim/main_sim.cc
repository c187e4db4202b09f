// kestrel-sim: the Bullet quadrotor and depth-ray simulator as a process (docs/design.md §2.1).
#include <chrono>
#include <cstdio>
#include <fstream>
#include <thread>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/config_publisher.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "common/realtime.h"
#include "sim/sim_node.h"

namespace {

constexpr const char* kUsage =
    "usage: kestrel-sim [--config config/sim/sim.yaml] [--set key=value]... [--lcm-url URL]\n"
    "Simulates the vehicle, its sensors and motion capture in a world file, publishing\n"
    "POSE_VICON, IMU, DEPTH_XTION, SCAN_HOKUYO, SIM_TRUTH and HEARTBEAT_SIM; reads MOTOR_COMMAND\n"
    "(mode dynamic) or TRAJECTORY (mode kinematic). speed_factor 1 runs in real time, 0 as fast\n"
    "as possible; run_duration_s > 0 stops after that much simulated time. world_file and\n"
    "vehicle_file are relative to the working directory or, failing that, to the repository root\n"
    "two levels above the config file. realtime.fifo_priority, realtime.lock_memory,\n"
    "realtime.cpus: real-time scheduling (docs/design.md §2.6; the hardware-in-the-loop sheet\n"
    "asks for it), off by default.\n";

bool Exists(const std::string& path) { return std::ifstream(path).good(); }

}  // namespace

int main(int argc, char** argv) {
  return kestrel::RunProcess(
      "kestrel-sim", argc, argv, kUsage,
      [](const kestrel::ProcessArgs& args, kestrel::ConfigNode& config) {
        std::string base_dir;
        std::string world_file;
        config.Read("world_file", &world_file);
        if (!world_file.empty() && world_file[0] != '/' && !Exists(world_file)) {
          const size_t slash = args.config_path.find_last_of('/');
          base_dir =
              (slash == std::string::npos ? std::string(".") : args.config_path.substr(0, slash)) +
              "/../..";
        }
        // Optional real-time scheduling (docs/design.md §2.6, §7.12): in hardware in the loop the
        // simulator is the world the vehicle's drivers read; a busy host must not stall it.
        const kestrel::RealtimeConfig realtime = kestrel::ReadRealtimeConfig(config);
        const kestrel::SimConfig sim_config = kestrel::LoadSimConfig(config, base_dir);
        if (realtime.requested()) kestrel::ApplyRealtimeAndLog(realtime);
        lcm::LCM lcm(args.lcm_url);
        if (!lcm.good()) {
          std::fprintf(stderr, "kestrel-sim: LCM initialisation failed\n");
          return 1;
        }
        // Simulated time starts at the wall time, and the pacing below counts from the same
        // moment: building the world takes a while, which the simulation catches up on at
        // once, so that its stamps are wall time (a controller on the wall clock, as on the
        // vehicle, would otherwise see every pose and IMU sample that much old).
        kestrel::SimClock clock(kestrel::WallClock().NowUtime());
        const auto wall_start = std::chrono::steady_clock::now();
        kestrel::SimNode node(lcm, sim_config, clock);
        const kestrel::ConfigPublisher params(
            lcm, clock, "kestrel-sim", kestrel::ParamsChannelFor(sim_config.heartbeat_channel),
            args, config);
        const int64_t start_utime = clock.NowUtime();
        while (!kestrel::NodeLoop::signal_received()) {
          while (lcm.handleTimeout(0) > 0) {
          }
          node.Step();
          const double sim_s = kestrel::UtimeToSeconds(clock.NowUtime() - start_utime);
          if (sim_config.run_duration_s > 0.0 && sim_s >= sim_config.run_duration_s) break;
          if (sim_config.speed_factor > 0.0) {
            std::this_thread::sleep_until(
                wall_start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                 std::chrono::duration<double>(sim_s / sim_config.speed_factor)));
          }
        }
        const double simulated_s = kestrel::UtimeToSeconds(clock.NowUtime() - start_utime);
        const double wall_s =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
        std::printf(
            "kestrel-sim: %.3f s simulated in %.3f s, real-time factor %.2f, %d collisions\n",
            simulated_s, wall_s, wall_s > 0.0 ? simulated_s / wall_s : 0.0,
            node.simulator().vehicle().collision_count());
        return 0;
      });
}
