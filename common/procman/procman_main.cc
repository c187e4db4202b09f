// kestrel-procman: runs the commands of a bot-procman process sheet for one host (a deputy).
#include <chrono>
#include <cstdio>
#include <thread>

#include <lcm/lcm-cpp.hpp>

#include "common/command_line.h"
#include "common/identity.h"
#include "common/log.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "common/procman/deputy.h"

namespace {
const char* const kUsage =
    "usage: kestrel-procman SHEET --host NAME [--log-dir DIR] [--start TARGET]... [--script NAME]\n"
    "                       [--exit-after-script]\n"
    "Runs the commands of SHEET (bot-procman format) whose host is NAME, like a procman deputy:\n"
    "reports their state on PROCMAN_STATUS, obeys PROCMAN_ORDERS (kestrel-cmd), respawns\n"
    "auto_respawn commands, and stops them all on SIGINT/SIGTERM. Every command it starts, and\n"
    "every respawn, sees the same $KESTREL_RUN_ID: the runner's own, or a new one it makes.\n"
    "  TARGET: all | cmd:ID | group:PATH       (started at once)\n"
    "  --script NAME        run the sheet's script NAME (orders other hosts' runners too)\n"
    "  --exit-after-script  stop everything and exit when the script is done\n";
}  // namespace

int main(int argc, char** argv) {
  using kestrel::procman::Deputy;
  std::string sheet_path, script;
  std::vector<std::string> starts;
  bool exit_after_script = false;
  kestrel::procman::DeputyConfig config;
  return kestrel::RunProcess(
      "kestrel-procman", argc, argv, kUsage,
      [&](CLI::App& app) {
        app.add_option("sheet", sheet_path)->required();
        app.add_option("--host", config.host)->required();
        app.add_option("--log-dir", config.log_dir);
        app.add_option("--start", starts)->allow_extra_args(false);
        app.add_option("--script", script);
        app.add_flag("--exit-after-script", exit_after_script);
      },
      [&](const kestrel::ProcessArgs& args, kestrel::ConfigNode&) {
        const kestrel::procman::Sheet sheet = kestrel::procman::LoadSheet(sheet_path);
        // One run id for every command and respawn of this runner (docs/design.md §3.5).
        const std::string run_id = kestrel::EnsureRunIdInEnvironment();
        kestrel::Log(kestrel::LogLevel::kInfo, std::string("run id ") + run_id + " ($" +
                                                   kestrel::kRunIdEnvironmentVariable +
                                                   " of every command)");
        lcm::LCM lcm(args.lcm_url);
        if (!lcm.good()) throw std::runtime_error("cannot open LCM at '" + args.lcm_url + "'");
        kestrel::WallClock clock;
        Deputy deputy(lcm, sheet, config, clock);
        for (const std::string& t : starts) {
          if (t == "all") {
            deputy.Order(kestrel::procman_order_t::ACTION_START, true, "");
          } else if (t.rfind("cmd:", 0) == 0) {
            deputy.Order(kestrel::procman_order_t::ACTION_START, false, t.substr(4));
          } else if (t.rfind("group:", 0) == 0) {
            deputy.Order(kestrel::procman_order_t::ACTION_START, true, t.substr(6));
          } else {
            throw std::invalid_argument("--start " + t + ": use all, cmd:ID or group:PATH");
          }
        }
        if (!script.empty()) deputy.RunScript(script);
        kestrel::NodeLoop loop(lcm, clock);
        loop.AddTimer("poll", 50000, [&](int64_t) {
          deputy.Poll();
          if (exit_after_script && !script.empty() && !deputy.script_running()) loop.RequestStop();
        });
        loop.AddTimer("status", 1000000, [&](int64_t) { deputy.PublishStatus(); });
        const int code = loop.Run();
        kestrel::Log(kestrel::LogLevel::kInfo, "stopping every command");
        deputy.StopAll();
        while (!deputy.AllStopped()) {
          deputy.Poll();
          std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
        deputy.PublishStatus();
        return code;
      });
}
