// kestrel-motors: the controller's rotor thrusts (MOTOR_COMMAND) to BL-Ctrl ESCs over I2C.
#include <stdexcept>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/command_line.h"
#include "common/config_publisher.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "common/vehicle_config.h"
#include "drivers/motors/motors_node.h"

namespace {
constexpr char kUsage[] =
    "kestrel-motors [--config config/drivers/motors.yaml] [--vehicle FILE] [--set key=value]...\n"
    "Writes the controller's rotor thrusts (MOTOR_COMMAND) to BL-Ctrl ESCs on an I2C bus\n"
    "(bus: /dev/i2c-N, or unix:PATH for kestrel-esc-emulator), through the vehicle's ESC map\n"
    "(--vehicle, default config/vehicle/paper.yaml); heartbeat on HEARTBEAT_MOTORS. Keys: see\n"
    "drivers/motors/motors_node.h and config/drivers/motors.yaml.\n";
}  // namespace

int main(int argc, char** argv) {
  std::string vehicle_path = "config/vehicle/paper.yaml";
  return kestrel::RunProcess(
      "kestrel-motors", argc, argv, kUsage,
      [&](CLI::App& app) { app.add_option("--vehicle", vehicle_path); },
      [&](const kestrel::ProcessArgs& args, kestrel::ConfigNode& config) {
        const kestrel::MotorsConfig motors = kestrel::LoadMotorsConfig(config);
        const kestrel::VehicleConfig vehicle = kestrel::LoadVehicleConfigFile(vehicle_path, config);
        config.CheckNoUnknownKeys();
        // Before LCM starts its receive thread, which inherits the policy (docs/design.md §2.6).
        kestrel::ApplyRealtimeAndLog(motors.realtime);
        lcm::LCM lcm(args.lcm_url);
        if (!lcm.good()) throw std::runtime_error("LCM init failed for '" + args.lcm_url + "'");
        kestrel::WallClock clock;
        kestrel::MotorsNode node(lcm, motors, vehicle.esc, clock);
        const kestrel::ConfigPublisher params(lcm, clock, "kestrel-motors",
                                              kestrel::ParamsChannelFor(motors.heartbeat_channel),
                                              args, config);
        kestrel::NodeLoop loop(lcm, clock);
        loop.AddTimer("refresh", kestrel::SecondsToUtime(1.0 / motors.refresh_hz),
                      [&node](int64_t) { node.Refresh(); });
        loop.AddTimer("heartbeat", kestrel::SecondsToUtime(motors.heartbeat_period_s),
                      [&node](int64_t) { node.PublishHeartbeat(); });
        return loop.Run();
      });
}
