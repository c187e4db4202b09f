// kestrel-vicon: Vicon Tracker UDP object stream in, pose_t on POSE_VICON out (vicon_node.h).
#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/config_publisher.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "drivers/vicon/vicon_config.h"
#include "drivers/vicon/vicon_node.h"

namespace {
const char kUsage[] =
    "kestrel-vicon: bridges the Vicon Tracker UDP object stream to LCM pose_t (POSE_VICON).\n"
    "Usage: kestrel-vicon [--config config/drivers/vicon.yaml] [--set port=51001] ...\n";
}  // namespace

int main(int argc, char** argv) {
  return kestrel::RunProcess(
      "kestrel-vicon", argc, argv, kUsage,
      [](const kestrel::ProcessArgs& args, kestrel::ConfigNode& config_node) {
        const kestrel::ViconConfig config = kestrel::LoadViconConfig(config_node);
        config_node.CheckNoUnknownKeys();
        lcm::LCM lcm(args.lcm_url);
        if (!lcm.good()) throw std::runtime_error("LCM init failed for '" + args.lcm_url + "'");
        kestrel::WallClock clock;
        kestrel::ViconNode node(lcm, config, clock);
        const kestrel::ConfigPublisher params(lcm, clock, "kestrel-vicon",
                                              kestrel::ParamsChannelFor(config.heartbeat_channel),
                                              args, config_node);
        kestrel::NodeLoop loop(lcm, clock);
        node.AddTimers(loop);
        node.StartReceiveThread();
        return loop.Run();
      });
}
