// kestrel-imu: streams a VectorNav VN-100 (binary output over a serial port) as imu_t.
#include <stdexcept>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/config_publisher.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "drivers/imu/imu_node.h"

namespace {
constexpr char kUsage[] =
    "kestrel-imu [--config config/drivers/imu.yaml] [--set key=value]... [--lcm-url URL]\n"
    "Streams a VectorNav VN-100 (binary output 1 over a serial port) as imu_t on IMU, heartbeat\n"
    "on HEARTBEAT_IMU. Keys: see drivers/imu/imu_node.h and config/drivers/imu.yaml.\n";
}  // namespace

int main(int argc, char** argv) {
  return kestrel::RunProcess(
      "kestrel-imu", argc, argv, kUsage,
      [](const kestrel::ProcessArgs& args, kestrel::ConfigNode& config) {
        const kestrel::ImuConfig imu = kestrel::LoadImuConfig(config);
        config.CheckNoUnknownKeys();
        // Before LCM starts its receive thread, which inherits the policy (docs/design.md §2.6).
        kestrel::ApplyRealtimeAndLog(imu.realtime);
        lcm::LCM lcm(args.lcm_url);
        if (!lcm.good()) throw std::runtime_error("LCM init failed for '" + args.lcm_url + "'");
        kestrel::WallClock clock;
        kestrel::ImuNode node(lcm, imu, clock);
        const kestrel::ConfigPublisher params(lcm, clock, "kestrel-imu",
                                              kestrel::ParamsChannelFor(imu.heartbeat_channel),
                                              args, config);
        kestrel::NodeLoop loop(lcm, clock);
        loop.AddTimer("heartbeat", kestrel::SecondsToUtime(imu.heartbeat_period_s),
                      [&node](int64_t) { node.PublishHeartbeat(); });
        kestrel::NodeLoop::InstallSignalHandlers();
        while (!kestrel::NodeLoop::signal_received()) {
          node.Poll(2);
          loop.RunOnceMicroseconds(0);
        }
        node.PublishHeartbeat();
        kestrel::Log(kestrel::LogLevel::kInfo,
                     "stopped: " + std::to_string(node.published()) + " samples published, " +
                         std::to_string(node.drops().total()) + " drops, " +
                         std::to_string(node.opens()) + " opens");
        return 0;
      });
}
