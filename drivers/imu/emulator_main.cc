// kestrel-imu-emulator: a VN-100 on a pseudo-terminal (docs/protocols.md §7.5), fed by the
// simulator's IMU (imu_t on DEV_IMU, hardware in the loop) or, with source=synthetic, a level
// IMU at rest at 800 Hz. Prints the tty path to open.
#include <chrono>
#include <cstdio>
#include <string>
#include <thread>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/lcm_decode.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "common/realtime.h"
#include "drivers/imu/vn100_emulator.h"
#include "kestrel/imu_t.hpp"

namespace {
constexpr char kUsage[] =
    "kestrel-imu-emulator [--set key=value]... [--lcm-url URL]\n"
    "Emulates a VectorNav VN-100 on a pseudo-terminal and prints its path. Keys: link_path\n"
    "(a stable symlink to the tty), source (lcm | synthetic), channel (imu_t in, DEV_IMU: the\n"
    "samples at the device's 800 Hz base rate), clock_offset_s (the device clock's power-on\n"
    "time before the first sample, s), realtime.fifo_priority, realtime.lock_memory,\n"
    "realtime.cpus (docs/design.md §2.6; off by default).\n";
}  // namespace

int main(int argc, char** argv) {
  return kestrel::RunProcess(
      "kestrel-imu-emulator", argc, argv, kUsage,
      [](const kestrel::ProcessArgs& args, kestrel::ConfigNode& config) {
        std::string link_path, source = "lcm", channel = "DEV_IMU";
        double clock_offset_s = 12.5;
        config.Read("link_path", &link_path);
        config.Read("source", &source, std::vector<std::string>{"lcm", "synthetic"});
        config.Read("channel", &channel);
        config.Read("clock_offset_s", &clock_offset_s, kestrel::Range::NonNegative());
        // Optional real-time scheduling (docs/design.md §7.12): the emulated device must not stall
        // on a busy host, as the real one does not.
        const kestrel::RealtimeConfig realtime = kestrel::ReadRealtimeConfig(config);
        config.CheckNoUnknownKeys();
        if (realtime.requested()) kestrel::ApplyRealtimeAndLog(realtime);
        kestrel::Vn100Emulator device(link_path);
        std::printf("%s\n", device.device_path().c_str());
        std::fflush(stdout);
        kestrel::NodeLoop::InstallSignalHandlers();
        // The device clock: ns since its power-on, which came clock_offset_s before the first
        // sample (the driver maps it to host time, docs/protocols.md §7.4).
        int64_t first_utime = -1;
        const auto to_device = [&](int64_t utime) {
          if (first_utime < 0) first_utime = utime;
          return static_cast<uint64_t>(utime - first_utime) * 1000u +
                 static_cast<uint64_t>(clock_offset_s * 1e9);
        };
        if (source == "synthetic") {
          kestrel::WallClock clock;
          auto next = std::chrono::steady_clock::now();
          while (!kestrel::NodeLoop::signal_received()) {
            device.Poll();
            kestrel::Vn100Sample s;
            s.time_startup_ns = to_device(clock.NowUtime());
            s.accel_mps2 = {0.0F, 0.0F, -9.80665F};
            device.Sample(s);
            next += std::chrono::microseconds(1250);
            std::this_thread::sleep_until(next);
          }
          return 0;
        }
        lcm::LCM lcm(args.lcm_url);
        if (!lcm.good()) throw std::runtime_error("LCM init failed for '" + args.lcm_url + "'");
        kestrel::GuardedSubscriptions subscriptions(lcm);
        int64_t malformed = 0;
        subscriptions.Add<kestrel::imu_t>(
            channel,
            [&](const std::string&, const kestrel::imu_t& m) {
              kestrel::Vn100Sample s;
              s.time_startup_ns = to_device(m.utime);
              // Kestrel's body to the device's frame (y and z negated both ways).
              const std::array<float, 3> w = {static_cast<float>(m.angular_velocity_radps[0]),
                                              static_cast<float>(m.angular_velocity_radps[1]),
                                              static_cast<float>(m.angular_velocity_radps[2])};
              const std::array<float, 3> a = {static_cast<float>(m.specific_force_mps2[0]),
                                              static_cast<float>(m.specific_force_mps2[1]),
                                              static_cast<float>(m.specific_force_mps2[2])};
              const std::array<double, 3> wd = kestrel::Vn100ToBody(w);
              const std::array<double, 3> ad = kestrel::Vn100ToBody(a);
              for (int k = 0; k < 3; ++k) {
                s.angular_rate_radps[k] = static_cast<float>(wd[k]);
                s.accel_mps2[k] = static_cast<float>(ad[k]);
              }
              device.Sample(s);
            },
            [&](const std::string& ch, const std::string& reason) {
              if (malformed++ % 100 == 0) {
                std::fprintf(stderr, "kestrel-imu-emulator: %s: dropped a malformed imu_t: %s\n",
                             ch.c_str(), reason.c_str());
              }
            });
        while (!kestrel::NodeLoop::signal_received()) {
          lcm.handleTimeout(1);
          device.Poll();
        }
        return 0;
      });
}
