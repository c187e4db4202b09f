// kestrel-mission: the whole system in one process, deterministic (tools/mission/mission.h).
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>

#include "common/command_line.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "common/process_usage.h"
#include "tools/mission/mission.h"

namespace {
const char* const kUsage =
    "usage: kestrel-mission [--root DIR] [--world FILE] [--seed N] [--max-time S] [--csv FILE]\n"
    "                       [--plans-csv FILE]\n"
    "                       [--map FILE] [--octomap FILE.bt] [--ply FILE] [--sim FILE]\n"
    "                       [--reach FILE]\n"
    "                       [--log FILE.lcmlog] [--drop-sensors FRACTION]\n"
    "                       [--mocap-outage-at S --mocap-outage DURATION_S]\n"
    "                       [--sim-set k=v]... [--mapper-set k=v]...\n"
    "                       [--explorer-set k=v]... [--no-quality] [--verbose] [--soak S]\n"
    "                       [--progress S] [--vehicles N [--vehicle-spacing M]]\n"
    "                       [--stop-at-known FRACTION]\n"
    "Runs simulator, controller, mapper and explorer in lockstep over memq:// and prints a\n"
    "summary (known fraction, accuracy, Brier score against the simulator's ground truth).\n"
    "--soak S flies missions back to back in this one process (seeds N, N+1, ...) until S\n"
    "simulated seconds in all, and prints after each one the process's resident memory, open\n"
    "files and threads (docs/design.md section 7.9); the summary is the last flight's.\n"
    "--progress S prints a line on stderr every S simulated seconds (time, explorer state, known\n"
    "fraction, entropy, path, collisions); default 10, 0 for none, and none when CI=true.\n"
    "--vehicles N (1 to 4) flies N vehicles (V1_, V2_, ...), each with its controller and\n"
    "explorer, into one mapper; they start --vehicle-spacing M (default 1.5) apart.\n"
    "--stop-at-known F ends the run once the map is F known (time and path to it).\n"
    "--reach FILE writes which cells the simulator's rays reached and when (for\n"
    "kestrel-fidelity --reach and kestrel-map-score --reach; docs/algorithms.md section 12.5).\n"
    "SIGINT (Ctrl-C) or SIGTERM ends the run after the current simulated step: the summary of\n"
    "the flight so far (\"end: interrupted by SIGINT ...\") and every file asked for are written,\n"
    "and the exit code is 130 (SIGINT) or 143 (SIGTERM).\n";

// One soak line: the flight, its outcome and what the process holds after it.
void PrintSoakLine(int flight, const kestrel::MissionConfig& mc, const kestrel::MissionResult& r,
                   double total_s) {
  const std::optional<kestrel::ProcessUsage> u = kestrel::ReadProcessUsage();
  std::printf(
      "soak flight %d: seed %lld, %.1f s simulated (%.1f s in all), known %.4f, collisions %d, "
      "%s, mapper queue at most %zu; process: RSS %lld KiB (peak %lld KiB), open files %d, "
      "threads %d\n",
      flight, static_cast<long long>(mc.seed), r.sim_time_s, total_s, r.quality.known_fraction,
      r.collisions, r.landed ? "landed" : "not landed", r.mapper_queue_max,
      static_cast<long long>(u ? u->rss_kib : -1), static_cast<long long>(u ? u->peak_rss_kib : -1),
      u ? u->open_files : -1, u ? u->threads : -1);
  std::fflush(stdout);
}
}  // namespace

int main(int argc, char** argv) {
  kestrel::MissionConfig mc;
  double soak_s = 0.0;
  const char* ci = std::getenv("CI");
  mc.progress_period_s = ci != nullptr && std::string(ci) == "true" ? 0.0 : 10.0;
  return kestrel::RunProcess(
      "kestrel-mission", argc, argv, kUsage,
      [&](CLI::App& app) {
        app.add_option("--root", mc.root);
        app.add_option("--world", mc.world_file);
        app.add_option("--seed", mc.seed);
        app.add_option("--max-time", mc.max_time_s)->check(kestrel::cli::Positive());
        app.add_option("--csv", mc.csv_path);
        app.add_option("--plans-csv", mc.plans_csv_path);
        app.add_option("--map", mc.map_path);
        app.add_option("--reach", mc.reach_path);
        app.add_option("--drop-sensors", mc.sensor_drop_fraction)
            ->check(kestrel::cli::Within(0.0, 1.0));
        app.add_option("--mocap-outage-at", mc.mocap_outage_at_s)
            ->check(kestrel::cli::NonNegative());
        app.add_option("--mocap-outage", mc.mocap_outage_s)->check(kestrel::cli::NonNegative());
        app.add_option("--log", mc.log_path);
        app.add_option("--octomap", mc.octomap_path);
        app.add_option("--ply", mc.ply_path);
        app.add_option("--sim", mc.sim_file);
        app.add_option("--sim-set", mc.sim_overrides)->allow_extra_args(false);
        app.add_option("--mapper-set", mc.mapper_overrides)->allow_extra_args(false);
        app.add_option("--explorer-set", mc.explorer_overrides)->allow_extra_args(false);
        app.add_flag("--no-quality", [&](int64_t) { mc.compute_quality = false; });
        app.add_flag("--verbose", mc.verbose);
        app.add_option("--progress", mc.progress_period_s)->check(kestrel::cli::NonNegative());
        app.add_option("--soak", soak_s)->check(kestrel::cli::NonNegative());
        app.add_option("--vehicles", mc.vehicles)->check(CLI::Range(1, 4));
        app.add_option("--vehicle-spacing", mc.vehicle_spacing_m)->check(kestrel::cli::Positive());
        app.add_option("--stop-at-known", mc.stop_at_known)->check(kestrel::cli::Within(0.0, 1.0));
      },
      [&](const kestrel::ProcessArgs& args, kestrel::ConfigNode&) {
        mc.command_line = args.command_line;
        // Ctrl-C and SIGTERM (timeout, a runner's stop) end the flight at the next step.
        mc.stop_requested = [] { return kestrel::NodeLoop::signal_received(); };
        if (!(soak_s >= 0.0)) throw kestrel::ConfigError("--soak needs S >= 0 simulated seconds");
        double total_s = 0.0;
        kestrel::MissionResult r;
        for (int flight = 1; flight == 1 || (total_s < soak_s && !r.interrupted);
             ++flight, ++mc.seed) {
          r = kestrel::RunMission(mc);
          total_s += r.sim_time_s;
          if (soak_s > 0.0) PrintSoakLine(flight, mc, r, total_s);
        }
        const int signum = kestrel::NodeLoop::received_signal();
        if (r.interrupted) {
          r.end_reason = std::string("interrupted by ") +
                         (signum == SIGTERM ? "SIGTERM" : "SIGINT") + " (" + r.end_reason +
                         "): the figures are those of the flight so far";
        }
        std::printf("%s", kestrel::MissionSummary(r).c_str());
        std::fflush(stdout);
        return r.interrupted ? kestrel::NodeLoop::ExitCodeForSignal(signum) : 0;
      });
}
