// kestrel-mission: the whole system in one process, deterministic (tools/mission/mission.h).
#include <cstdio>

#include "common/process.h"
#include "tools/mission/mission.h"

namespace {
const char* const kUsage =
    "usage: kestrel-mission [--root DIR] [--world FILE] [--seed N] [--max-time S] [--csv FILE]\n"
    "                       [--plans-csv FILE]\n"
    "                       [--map FILE] [--octomap FILE.bt] [--ply FILE] [--sim FILE]\n"
    "                       [--log FILE.lcmlog] [--drop-sensors FRACTION]\n"
    "                       [--mocap-outage-at S --mocap-outage DURATION_S]\n"
    "                       [--sim-set k=v]... [--mapper-set k=v]...\n"
    "                       [--explorer-set k=v]... [--no-quality] [--verbose]\n"
    "Runs simulator, controller, mapper and explorer in lockstep over memq:// and prints a\n"
    "summary (known fraction, accuracy, Brier score against the simulator's ground truth).\n";
}  // namespace

int main(int argc, char** argv) {
  return kestrel::RunProcess(
      "kestrel-mission", argc, argv, kUsage,
      [](const kestrel::ProcessArgs& args, kestrel::ConfigNode&) {
        kestrel::MissionConfig mc;
        const auto& p = args.positional;
        for (size_t i = 0; i < p.size(); ++i) {
          auto value = [&]() -> std::string {
            if (i + 1 >= p.size()) throw kestrel::ConfigError(p[i] + " needs a value");
            return p[++i];
          };
          if (p[i] == "--root")
            mc.root = value();
          else if (p[i] == "--world")
            mc.world_file = value();
          else if (p[i] == "--seed")
            mc.seed = std::stoll(value());
          else if (p[i] == "--max-time")
            mc.max_time_s = std::stod(value());
          else if (p[i] == "--csv")
            mc.csv_path = value();
          else if (p[i] == "--plans-csv")
            mc.plans_csv_path = value();
          else if (p[i] == "--map")
            mc.map_path = value();
          else if (p[i] == "--drop-sensors")
            mc.sensor_drop_fraction = std::stod(value());
          else if (p[i] == "--mocap-outage-at")
            mc.mocap_outage_at_s = std::stod(value());
          else if (p[i] == "--mocap-outage")
            mc.mocap_outage_s = std::stod(value());
          else if (p[i] == "--log")
            mc.log_path = value();
          else if (p[i] == "--octomap")
            mc.octomap_path = value();
          else if (p[i] == "--ply")
            mc.ply_path = value();
          else if (p[i] == "--sim")
            mc.sim_file = value();
          else if (p[i] == "--sim-set")
            mc.sim_overrides.push_back(value());
          else if (p[i] == "--mapper-set")
            mc.mapper_overrides.push_back(value());
          else if (p[i] == "--explorer-set")
            mc.explorer_overrides.push_back(value());
          else if (p[i] == "--no-quality")
            mc.compute_quality = false;
          else if (p[i] == "--verbose")
            mc.verbose = true;
          else
            throw kestrel::ConfigError("unexpected argument '" + p[i] + "'\n" + kUsage);
        }
        const kestrel::MissionResult r = kestrel::RunMission(mc);
        std::printf("%s", kestrel::MissionSummary(r).c_str());
        return 0;
      });
}
