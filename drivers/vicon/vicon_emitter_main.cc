// kestrel-vicon-emitter: sends the Vicon UDP object stream to 127.0.0.1 from SIM_TRUTH or a
// synthetic circle (vicon_emitter.h).
#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/config_publisher.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "drivers/vicon/vicon_config.h"
#include "drivers/vicon/vicon_emitter.h"

namespace {
const char kUsage[] =
    "kestrel-vicon-emitter: sends the Vicon Tracker UDP object stream on loopback only.\n"
    "Usage: kestrel-vicon-emitter [--config config/drivers/vicon_emitter.yaml]\n"
    "                             [--set source=sim_truth|synthetic] [--set port=51001] ...\n";
}  // namespace

int main(int argc, char** argv) {
  return kestrel::RunProcess(
      "kestrel-vicon-emitter", argc, argv, kUsage,
      [](const kestrel::ProcessArgs& args, kestrel::ConfigNode& config_node) {
        const kestrel::ViconEmitterConfig config = kestrel::LoadViconEmitterConfig(config_node);
        config_node.CheckNoUnknownKeys();
        lcm::LCM lcm(args.lcm_url);
        if (!lcm.good()) throw std::runtime_error("LCM init failed for '" + args.lcm_url + "'");
        kestrel::WallClock clock;
        kestrel::ViconEmitterNode node(lcm, config, clock);
        const kestrel::ConfigPublisher params(lcm, clock, "kestrel-vicon-emitter",
                                              kestrel::ParamsChannelFor(config.heartbeat_channel),
                                              args, config_node);
        kestrel::NodeLoop loop(lcm, clock);
        node.AddTimers(loop);
        return loop.Run();
      });
}
