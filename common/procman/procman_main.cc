// kestrel-procman: runs the commands of a bot-procman process sheet for one host (a deputy).
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <sstream>
#include <thread>

#include <lcm/lcm-cpp.hpp>

#include "common/command_line.h"
#include "common/identity.h"
#include "common/log.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "common/procman/deputy.h"
#include "common/procman/exec_line.h"

namespace {
const char* const kUsage =
    "usage: kestrel-procman SHEET --host NAME [--log-dir DIR] [--env-file FILE]\n"
    "                       [--start TARGET]... [--script NAME] [--exit-after-script]\n"
    "Runs the commands of SHEET (bot-procman format) whose host is NAME as a bot-procman deputy\n"
    "named NAME: executes them as the deputy does (no shell; only $VAR and ${VAR} expanded),\n"
    "reports on PMD_INFO2 and PROCMAN_STATUS, obeys a sheriff's PMD_ORDERS2 (bot-procman-sheriff,\n"
    "kestrel-cmd procman, another runner's script), publishes their output on PMD_PRINTF and in\n"
    "LOG_DIR/<id>.log, respawns auto_respawn commands, and stops them all on SIGINT/SIGTERM.\n"
    "Exits with 1 if another deputy named NAME answers at start.\n"
    "Every command it starts, and every respawn, sees the same $KESTREL_RUN_ID: the runner's own,\n"
    "or a new one it makes. Variables the sheet uses and the environment leaves unset take their\n"
    "defaults from FILE (NAME=value lines; default: kestrel.env beside SHEET, if present).\n"
    "  TARGET: all | cmd:ID | group:PATH       (started at once)\n"
    "  --script NAME        run the sheet's script NAME; other hosts' commands are ordered on\n"
    "                       PMD_ORDERS2 as a sheriff does, to whichever deputy runs that host\n"
    "                       (created on it from the sheet if it does not have them)\n"
    "  --exit-after-script  stop everything and exit when the script is done\n"
    "  --dry-run            print what each of NAME's commands would execute (environment\n"
    "                       settings, words, the program found on PATH) and exit: 1 if a\n"
    "                       program is not found or a word still holds a '$'\n";

/// Sets every variable of the defaults file that the environment leaves unset.
void ApplyEnvironmentDefaults(const std::string& path, bool required) {
  std::ifstream in(path);
  if (!in) {
    if (required) throw std::runtime_error("cannot read environment defaults " + path);
    return;
  }
  std::ostringstream text;
  text << in.rdbuf();
  std::string applied;
  for (const kestrel::procman::EnvironmentDefault& d :
       kestrel::procman::ParseEnvironmentDefaults(text.str(), path)) {
    if (std::getenv(d.name.c_str()) != nullptr) continue;  // NOLINT(concurrency-mt-unsafe)
    setenv(d.name.c_str(), d.value.c_str(), 0);
    applied += " " + d.name + "=" + d.value;
  }
  kestrel::Log(kestrel::LogLevel::kInfo, "environment defaults from " + path + ":" +
                                             (applied.empty() ? " none unset" : applied));
}

/// --dry-run: what each command of `host` would execute. Returns the exit status.
int PrintExecLines(const kestrel::procman::Sheet& sheet, const std::string& host) {
  const char* path = std::getenv("PATH");  // NOLINT(concurrency-mt-unsafe)
  int problems = 0;
  for (const kestrel::procman::Command& c : sheet.commands) {
    if (c.host != host) continue;
    const kestrel::procman::ExecLine line =
        kestrel::procman::ParseExecLine(c.exec, kestrel::procman::EnvironmentLookup());
    std::printf("%s:\n", c.id.c_str());
    for (const auto& [name, value] : line.environment) {
      std::printf("  env  %s=%s\n", name.c_str(), value.c_str());
    }
    for (const std::string& word : line.argv) {
      std::printf("  word [%s]%s\n", word.c_str(),
                  word.find('$') != std::string::npos ? "   <- unexpanded '$'" : "");
      if (word.find('$') != std::string::npos) ++problems;
    }
    const std::optional<std::string> program =
        line.argv.empty() ? std::nullopt
                          : kestrel::procman::ResolveProgram(line.argv[0], path ? path : "");
    std::printf("  program %s\n", program ? program->c_str() : "NOT FOUND");
    if (!program) ++problems;
  }
  return problems == 0 ? 0 : 1;
}

/// As a bot-procman deputy: the runner's own folder first on PATH.
void PutOwnFolderOnPath(const char* argv0) {
  const std::string self(argv0);
  const size_t slash = self.rfind('/');
  if (slash == std::string::npos) return;
  const char* path = std::getenv("PATH");  // NOLINT(concurrency-mt-unsafe)
  const std::string folder = self.substr(0, slash);
  setenv("PATH", (folder + (path != nullptr ? ":" + std::string(path) : "")).c_str(), 1);
}
}  // namespace

int main(int argc, char** argv) {
  using kestrel::procman::Deputy;
  std::string sheet_path, script, env_file;
  std::vector<std::string> starts;
  bool exit_after_script = false;
  bool dry_run = false;
  kestrel::procman::DeputyConfig config;
  return kestrel::RunProcess(
      "kestrel-procman", argc, argv, kUsage,
      [&](CLI::App& app) {
        app.add_option("sheet", sheet_path)->required();
        app.add_option("--host", config.host)->required();
        app.add_option("--log-dir", config.log_dir);
        app.add_option("--env-file", env_file);
        app.add_option("--start", starts)->allow_extra_args(false);
        app.add_option("--script", script);
        app.add_flag("--exit-after-script", exit_after_script);
        app.add_flag("--dry-run", dry_run);
      },
      [&](const kestrel::ProcessArgs& args, kestrel::ConfigNode&) {
        const kestrel::procman::Sheet sheet = kestrel::procman::LoadSheet(sheet_path);
        const size_t slash = sheet_path.rfind('/');
        ApplyEnvironmentDefaults(
            env_file.empty() ? (slash == std::string::npos ? "" : sheet_path.substr(0, slash + 1)) +
                                   "kestrel.env"
                             : env_file,
            !env_file.empty());
        PutOwnFolderOnPath(argv[0]);
        // One run id for every command and respawn of this runner (docs/design.md §3.5); a dry run
        // shows the commands with the one it would give them.
        const std::string run_id = kestrel::EnsureRunIdInEnvironment();
        if (dry_run) return PrintExecLines(sheet, config.host);
        kestrel::Log(kestrel::LogLevel::kInfo, std::string("run id ") + run_id + " ($" +
                                                   kestrel::kRunIdEnvironmentVariable +
                                                   " of every command)");
        lcm::LCM lcm(args.lcm_url);
        if (!lcm.good()) throw std::runtime_error("cannot open LCM at '" + args.lcm_url + "'");
        kestrel::WallClock clock;
        Deputy deputy(lcm, sheet, config, clock);
        for (const std::string& t : starts) {
          if (t == "all") {
            deputy.Order(kestrel::procman::SheriffVerb::kStart, true, "");
          } else if (t.rfind("cmd:", 0) == 0) {
            deputy.Order(kestrel::procman::SheriffVerb::kStart, false, t.substr(4));
          } else if (t.rfind("group:", 0) == 0) {
            deputy.Order(kestrel::procman::SheriffVerb::kStart, true, t.substr(6));
          } else {
            throw std::invalid_argument("--start " + t + ": use all, cmd:ID or group:PATH");
          }
        }
        if (!script.empty()) deputy.RunScript(script);
        kestrel::NodeLoop loop(lcm, clock);
        loop.AddTimer("poll", 50000, [&](int64_t) {
          deputy.Poll();
          if (!deputy.name_conflict().empty()) {
            throw std::runtime_error(deputy.name_conflict() + ": exiting, as a deputy does");
          }
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
