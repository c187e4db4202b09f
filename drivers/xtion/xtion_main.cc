// kestrel-xtion: the ASUS Xtion depth camera (OpenNI2) -> kestrel::depth_image_t on DEPTH_XTION.
#include <cstdio>

#include "common/clock.h"
#include "common/command_line.h"
#include "common/config_publisher.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "drivers/xtion/xtion_config.h"
#include "drivers/xtion/xtion_node.h"

namespace {
const char kUsage[] =
    "usage: kestrel-xtion [--config config/drivers/xtion.yaml] [--set key=value] [--list]\n"
    "Streams the OpenNI2 depth camera selected by `device` (\"\" first, \"#N\", \"BUS@ADDRESS\" "
    "or\n"
    "a serial number) and publishes depth_image_t on `channel`, heartbeat on heartbeat_channel.\n"
    "  --list   print the devices OpenNI2 sees (uri, serial) and exit\n";
}  // namespace

int main(int argc, char** argv) {
  bool list = false;
  return kestrel::RunProcess(
      "kestrel-xtion", argc, argv, kUsage, [&](CLI::App& app) { app.add_flag("--list", list); },
      [&](const kestrel::ProcessArgs& args, kestrel::ConfigNode& config) {
        const kestrel::XtionConfig xtion_config = kestrel::LoadXtionConfig(config);
        config.CheckNoUnknownKeys();
        lcm::LCM lcm(args.lcm_url);
        if (!lcm.good()) {
          std::fprintf(stderr, "kestrel-xtion: cannot open LCM '%s'\n", args.lcm_url.c_str());
          return 1;
        }
        kestrel::WallClock clock;
        kestrel::XtionNode node(lcm, xtion_config, clock);
        if (list) {
          for (const auto& d : node.ListDevices()) {
            std::printf("%s serial=%s\n", d.uri.c_str(), d.serial.c_str());
          }
          return 0;
        }
        const kestrel::ConfigPublisher params(
            lcm, clock, "kestrel-xtion", kestrel::ParamsChannelFor(xtion_config.heartbeat_channel),
            args, config);
        kestrel::NodeLoop loop(lcm, clock);
        loop.AddTimer("heartbeat", kestrel::SecondsToUtime(xtion_config.heartbeat_period_s),
                      [&node](int64_t) { node.PublishHeartbeat(); });
        // Frames arrive from OpenNI2, not LCM: wait for them in Poll (at most 20 ms, so timers
        // stay on time), then let the loop fire due timers.
        while (!kestrel::NodeLoop::signal_received()) {
          node.Poll(20);
          if (!loop.RunOnce(0)) return 1;
        }
        node.PublishHeartbeat();
        return 0;
      });
}
