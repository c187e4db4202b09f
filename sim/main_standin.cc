// kestrel-sim-standin: one sensor driver's stand-in in a simulation, relaying the simulator's
// device channel to the driver channel (sim/standin_node.h, docs/design.md §7.11).
#include <memory>
#include <stdexcept>

#include <lcm/lcm-cpp.hpp>

#include "common/config_publisher.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "common/sim_truth_clock.h"
#include "sim/standin_node.h"

namespace {
const char kUsage[] =
    "usage: kestrel-sim-standin [--config config/sim/standin.yaml] --set sensor=depth|scan\n"
    "                           [--set drop_fraction=0.1] [--lcm-url URL] [--sim-clock SIM_TRUTH]\n"
    "Stands in for the depth camera or LIDAR driver when kestrel-sim runs with\n"
    "sensor_device_prefix: relays DEV_DEPTH_XTION to DEPTH_XTION (or DEV_SCAN_HOKUYO to\n"
    "SCAN_HOKUYO) with its own seq and epoch, losing drop_fraction of the frames (seeded), and\n"
    "reports relayed and dropped frames on HEARTBEAT_STANDIN_DEPTH (or _SCAN).\n";
}  // namespace

int main(int argc, char** argv) {
  return kestrel::RunProcess(
      "kestrel-sim-standin", argc, argv, kUsage,
      [](const kestrel::ProcessArgs& args, kestrel::ConfigNode& node) {
        const kestrel::StandinConfig config = kestrel::LoadStandinConfig(node);
        lcm::LCM lcm(args.lcm_url);
        if (!lcm.good()) throw std::runtime_error("cannot open LCM at '" + args.lcm_url + "'");
        const std::unique_ptr<kestrel::Clock> clock =
            kestrel::MakeProcessClock(lcm, args.sim_clock_channel);
        kestrel::StandinNode standin(lcm, config, *clock);
        const kestrel::ConfigPublisher params(lcm, *clock, "kestrel-sim-standin",
                                              kestrel::ParamsChannelFor(config.heartbeat_channel),
                                              args, node);
        kestrel::NodeLoop loop(lcm, *clock);
        standin.AddTimers(loop);
        return loop.Run();
      });
}
