// kestrel-explorer: entropy-based exploration (docs/algorithms.md §6-§9).
#include <cstdlib>
#include <stdexcept>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "common/config_publisher.h"
#include "common/identity.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "common/sim_truth_clock.h"
#include "exploration/explorer_node.h"

namespace {
const char* const kUsage =
    "usage: kestrel-explorer [--config config/exploration/explorer.yaml] [--set key=value]...\n"
    "                        [--lcm-url URL]\n"
    "Subscribes to MAP3D, MAP3D_DELTA, POSE_VICON and CONTROLLER_STATUS; after the commanded\n"
    "take-off it turns a full circle, explores, returns home and asks to land. Publishes\n"
    "TRAJECTORY, EXPLORATION_STATUS, MAP2D_* and a heartbeat.\n";
}  // namespace

int main(int argc, char** argv) {
  return kestrel::RunProcess(
      "kestrel-explorer", argc, argv, kUsage,
      [](const kestrel::ProcessArgs& args, kestrel::ConfigNode& node) {
        kestrel::ExplorerNodeConfig config = kestrel::LoadExplorerNodeConfig(node);
        node.CheckNoUnknownKeys();
        // No run_id set: the run's, from the runner that started it; a respawn within the run
        // resumes from its state file (docs/design.md §2.5).
        if (config.run_id.empty()) config.run_id = kestrel::RunIdFromEnvironment();
        lcm::LCM lcm(args.lcm_url);
        if (!lcm.good()) throw std::runtime_error("cannot open LCM at '" + args.lcm_url + "'");
        const std::unique_ptr<kestrel::Clock> clock =
            kestrel::MakeProcessClock(lcm, args.sim_clock_channel);
        kestrel::ExplorerNode explorer(lcm, config, *clock);
        const kestrel::ConfigPublisher params(
            lcm, *clock, "kestrel-explorer",
            kestrel::ParamsChannelFor(config.vehicle_prefix + config.heartbeat_channel), args,
            node);
        kestrel::NodeLoop loop(lcm, *clock);
        loop.AddTimer("step", 50000, [&](int64_t) { explorer.Step(); });
        return loop.Run();
      });
}
