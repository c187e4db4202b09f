// kestrel-hokuyo: streams a Hokuyo LIDAR (SCIP 2.0 over a serial port) as planar_scan_t.
#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/config_publisher.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "drivers/hokuyo/hokuyo_node.h"

namespace {
constexpr char kUsage[] =
    "kestrel-hokuyo [--config config/drivers/hokuyo.yaml] [--set key=value]... [--lcm-url URL]\n"
    "Streams a Hokuyo URG-04LX / UTM-30LX (SCIP 2.0) on SCAN_HOKUYO, heartbeat on\n"
    "HEARTBEAT_HOKUYO. Keys: see drivers/hokuyo/hokuyo_config.h.\n";
}  // namespace

int main(int argc, char** argv) {
  return kestrel::RunProcess(
      "kestrel-hokuyo", argc, argv, kUsage,
      [](const kestrel::ProcessArgs& args, kestrel::ConfigNode& config) {
        const kestrel::HokuyoConfig hokuyo_config = kestrel::LoadHokuyoConfig(config);
        config.CheckNoUnknownKeys();
        lcm::LCM lcm(args.lcm_url);
        if (!lcm.good()) throw std::runtime_error("LCM init failed for '" + args.lcm_url + "'");
        kestrel::WallClock clock;
        kestrel::HokuyoNode node(lcm, hokuyo_config, clock);
        const kestrel::ConfigPublisher params(
            lcm, clock, "kestrel-hokuyo",
            kestrel::ParamsChannelFor(hokuyo_config.heartbeat_channel), args, config);
        kestrel::NodeLoop loop(lcm, clock);
        return node.Run(loop);
      });
}
