// kestrel-mapper: fuses depth images and planar scans into the exact 3D occupancy map.
#include <cstdlib>

#include <lcm/lcm-cpp.hpp>

#include "common/command_line.h"
#include "common/config_publisher.h"
#include "common/identity.h"
#include "common/log.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "common/sim_truth_clock.h"
#include "mapping/mapper_node.h"

namespace {
const char* const kUsage =
    "usage: kestrel-mapper [--config config/mapper.yaml] [--set key=value]... [--lcm-url URL]\n"
    "                      [--save FILE] [--export-octomap FILE.bt|.ot] [--export-ply FILE]\n"
    "Subscribes to the sensors and poses of its configuration, publishes MAP3D snapshots,\n"
    "MAP3D_DELTA, MAP_STATUS and a heartbeat, checkpoints the map, and on exit (SIGINT/SIGTERM)\n"
    "applies what it can, saves the checkpoint and the files asked for.\n";
}  // namespace

int main(int argc, char** argv) {
  std::string save_path, octomap_path, ply_path;
  return kestrel::RunProcess(
      "kestrel-mapper", argc, argv, kUsage,
      [&](CLI::App& app) {
        app.add_option("--save", save_path);
        app.add_option("--export-octomap", octomap_path);
        app.add_option("--export-ply", ply_path);
      },
      [&](const kestrel::ProcessArgs& args, kestrel::ConfigNode& node) {
        kestrel::MapperConfig config = kestrel::LoadMapperConfig(node);
        node.CheckNoUnknownKeys();
        // No run_id set: the run's, from the runner that started it (docs/design.md §3.5).
        const char* run_id = std::getenv(kestrel::kRunIdEnvironmentVariable);
        if (config.run_id.empty() && run_id != nullptr && *run_id != '\0') {
          const std::string problem = kestrel::CheckRunId(run_id);
          if (!problem.empty()) {
            throw std::invalid_argument(std::string("$") + kestrel::kRunIdEnvironmentVariable +
                                        " = '" + run_id + "': " + problem);
          }
          config.run_id = run_id;
        }
        lcm::LCM lcm(args.lcm_url);
        if (!lcm.good()) throw std::runtime_error("cannot open LCM at '" + args.lcm_url + "'");
        const std::unique_ptr<kestrel::Clock> clock =
            kestrel::MakeProcessClock(lcm, args.sim_clock_channel);
        kestrel::MapperNode mapper(lcm, config, *clock);
        const kestrel::ConfigPublisher params(lcm, *clock, "kestrel-mapper",
                                              kestrel::ParamsChannelFor(config.heartbeat_channel),
                                              args, node);
        while (!kestrel::NodeLoop::signal_received()) {
          // Drain the socket into the node's queue first, so the backlog is visible, then apply
          // one scan at a time.
          while (lcm.handleTimeout(0) > 0) {
          }
          const int done = mapper.ProcessPending(1);
          mapper.PublishDue();
          if (done == 0) lcm.handleTimeout(10);
        }
        kestrel::Log(kestrel::LogLevel::kInfo, "stopping: applying what can be applied, saving");
        while (lcm.handleTimeout(0) > 0) {
        }
        mapper.ProcessPending();
        mapper.PublishStatus();
        mapper.SaveCheckpoint();
        if (!save_path.empty()) mapper.SaveMapFile(save_path);
        if (!octomap_path.empty()) mapper.ExportOctoMapFile(octomap_path);
        if (!ply_path.empty()) mapper.ExportPlyFile(ply_path);
        return 0;
      });
}
