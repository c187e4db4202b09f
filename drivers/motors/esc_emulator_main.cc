// kestrel-esc-emulator: BL-Ctrl ESCs behind an I2C socket (kestrel-motors' bus unix:PATH); the
// rotor thrusts they were given go out as motor_command_t for a simulator (docs/design.md §7.12).
#include <cstdio>
#include <stdexcept>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/command_line.h"
#include "common/identity.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "common/realtime.h"
#include "common/vehicle_config.h"
#include "drivers/motors/esc_emulator.h"
#include "kestrel/motor_command_t.hpp"

namespace {
constexpr char kUsage[] =
    "kestrel-esc-emulator [--vehicle FILE] [--set key=value]...\n"
    "Emulates BL-Ctrl ESCs on an I2C socket and publishes the rotor thrusts they were given.\n"
    "Keys: bus (unix:PATH, as kestrel-motors' bus), protocol (blctrl_v1 | blctrl_v2),\n"
    "      addresses ([41, 42, 43, 44]: 0x29..), channel (DEV_MOTOR_COMMAND), esc_timeout_s "
    "(0.5),\n"
    "      realtime.fifo_priority, realtime.lock_memory, realtime.cpus (docs/design.md §2.6; "
    "off).\n";
}  // namespace

int main(int argc, char** argv) {
  std::string vehicle_path = "config/vehicle/paper.yaml";
  return kestrel::RunProcess(
      "kestrel-esc-emulator", argc, argv, kUsage,
      [&](CLI::App& app) { app.add_option("--vehicle", vehicle_path); },
      [&](const kestrel::ProcessArgs& args, kestrel::ConfigNode& config) {
        std::string bus = "unix:/tmp/kestrel-run/esc.sock";
        std::string protocol = "blctrl_v2";
        std::vector<double> addresses = {0x29, 0x2a, 0x2b, 0x2c};
        std::string channel = "DEV_MOTOR_COMMAND";
        double esc_timeout_s = 0.5;
        config.Read("bus", &bus);
        config.Read("protocol", &protocol, std::vector<std::string>{"blctrl_v1", "blctrl_v2"});
        config.Read("addresses", &addresses, kestrel::Range::Closed(0x08, 0x77));
        config.Read("channel", &channel);
        config.Read("esc_timeout_s", &esc_timeout_s, kestrel::Range::Positive());
        const kestrel::VehicleConfig vehicle = kestrel::LoadVehicleConfigFile(vehicle_path, config);
        // Optional real-time scheduling (docs/design.md §7.12): the emulated device must not stall
        // on a busy host, as the real one does not.
        const kestrel::RealtimeConfig realtime = kestrel::ReadRealtimeConfig(config);
        config.CheckNoUnknownKeys();
        if (realtime.requested()) kestrel::ApplyRealtimeAndLog(realtime);
        if (bus.rfind("unix:", 0) != 0) throw std::invalid_argument("bus must be unix:PATH");
        std::vector<int> rotor_addresses(addresses.begin(), addresses.end());
        kestrel::EscEmulator escs(*kestrel::ParseBlCtrlVersion(protocol), rotor_addresses,
                                  vehicle.esc, esc_timeout_s);
        lcm::LCM lcm(args.lcm_url);
        if (!lcm.good()) throw std::runtime_error("LCM init failed for '" + args.lcm_url + "'");
        kestrel::WallClock clock;
        kestrel::motor_command_t out{};
        out.epoch = kestrel::NewPublisherEpoch();
        out.num_motors = static_cast<int32_t>(rotor_addresses.size());
        const auto publish = [&] {
          out.utime = clock.NowUtime();
          out.thrust_N = escs.thrust_N();
          out.armed = false;
          out.total_thrust_N = 0.0;
          for (const int s : escs.set_points()) out.armed = out.armed || s > 0;
          for (const double t : out.thrust_N) out.total_thrust_N += t;
          lcm.publish(channel, &out);
          ++out.seq;
        };
        kestrel::I2cSocketServer server(bus.substr(5), [&](kestrel::I2cMessage& m) {
          return escs.Handle(m, clock.NowUtime());
        });
        std::printf("%s\n", bus.c_str());
        std::fflush(stdout);
        kestrel::NodeLoop::InstallSignalHandlers();
        while (!kestrel::NodeLoop::signal_received()) {
          server.Poll(5);
          if (escs.TakeCompleteRefresh() || escs.ApplyTimeout(clock.NowUtime())) publish();
        }
        return 0;
      });
}
