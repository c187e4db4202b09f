// kestrel-calibrate: estimates the mapper's sensor models (sigma, p_rand, p_miss of each sensor)
// and, with --mount, each sensor's mount correction and stamp offset (docs/algorithms.md §3.7)
// from a recorded run against the world's surfaces, and writes them as kestrel-mapper overrides.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <optional>
#include <string>

#include "common/command_line.h"
#include "common/config.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "tools/fidelity/calibrate.h"

namespace {
const char* const kUsage =
    "usage: kestrel-calibrate --log RUN.lcmlog --world config/worlds/lasr.yaml\n"
    "                         [--config config/mapper.yaml] [--set key=value]... [--every 4]\n"
    "                         [--mount [--rays-per-scan 24]] [--out FILE]\n"
    "                         [--truth-sim config/sim/sim_ci.yaml [--truth-sim-set k=v]...\n"
    "                          [--truth-seed 1]]\n"
    "Pairs the log's scans with its poses as kestrel-mapper does (the --config file), casts every\n"
    "ray of every --every-th scan of each sensor against the world for its true range, and fits\n"
    "each sensor's sigma (about the model's cell distance d_k), p_rand and p_miss by maximum\n"
    "likelihood. --mount first fits each sensor's mount correction (3 translations, 3 rotations,\n"
    "in the sensor frame) and stamp offset to the ranges of up to --rays-per-scan returns of\n"
    "every scan (robust Gauss-Newton), and the sensor models with them; a sensor whose mount the\n"
    "log cannot determine is named with the reason, and keeps its configured mount. Prints the\n"
    "values beside the configured ones; --out writes them as overrides, one\n"
    "sensors.I.KEY=VALUE a line, for --set of kestrel-mapper, kestrel-mission (--mapper-set) and\n"
    "kestrel-fidelity. --truth-sim (a simulated run's sim file, overrides and seed, as given to\n"
    "kestrel-mission) adds what the simulator did to the mounts and clocks, for comparison.\n";

void PrintMount(const kestrel::SensorCalibrationResult& r, const kestrel::MountCorrection* truth) {
  using kestrel::FormatMountParameter;
  const kestrel::MountFit& m = r.mount;
  std::printf("%s mount: %lld scans, %lld returns, %lld used, scale %.1f -> %.1f mm, %d steps%s\n",
              r.name.c_str(), static_cast<long long>(m.scans), static_cast<long long>(m.returns),
              static_cast<long long>(m.returns_used), 1e3 * m.scale_start_m, 1e3 * m.scale_end_m,
              m.iterations, m.ok ? "" : " -- NOT FITTED");
  if (!m.ok) {
    std::printf("  %s: the mount could not be fitted: %s; its configured mount stays\n",
                r.name.c_str(), m.why.c_str());
    return;
  }
  std::printf("  %-14s %13s %13s %13s%s\n", "parameter", "fit", "std. error", "configured",
              truth != nullptr ? "          true     fit - true" : "");
  for (int k = 0; k < kestrel::kMountParameters; ++k) {
    const bool held = m.held[static_cast<size_t>(k)];
    std::printf("  %-14s %13s %13s %13s", kestrel::MountParameterName(k),
                FormatMountParameter(k, m.value[k]).c_str(),
                held ? "held" : FormatMountParameter(k, m.standard_error[k]).c_str(),
                FormatMountParameter(k, r.configured_mount[k]).c_str());
    if (truth != nullptr) {
      std::printf(" %13s %13s", FormatMountParameter(k, (*truth)[k]).c_str(),
                  held ? "-" : FormatMountParameter(k, m.value[k] - (*truth)[k]).c_str());
    }
    if (held) {
      std::printf("  (not determined: standard error %s when free)",
                  FormatMountParameter(k, m.free_standard_error[k]).c_str());
    }
    std::printf("\n");
  }
}

}  // namespace

int main(int argc, char** argv) {
  kestrel::CalibrationRunConfig cc;
  std::string out_path, truth_sim;
  std::vector<std::string> truth_sim_overrides;
  int64_t truth_seed = 1;
  return kestrel::RunProcess(
      "kestrel-calibrate", argc, argv, kUsage,
      [&](CLI::App& app) {
        app.add_option("--log", cc.log_path)->required();
        app.add_option("--world", cc.world_file)->required();
        app.add_option("--every", cc.every)->check(kestrel::cli::Positive());
        app.add_flag("--mount", cc.mount);
        app.add_option("--rays-per-scan", cc.mount_options.rays_per_scan)
            ->check(kestrel::cli::Positive());
        app.add_option("--out", out_path);
        app.add_option("--truth-sim", truth_sim);
        app.add_option("--truth-sim-set", truth_sim_overrides)->allow_extra_args(false);
        app.add_option("--truth-seed", truth_seed);
      },
      [&](const kestrel::ProcessArgs& args, kestrel::ConfigNode&) {
        // A batch tool: Ctrl-C or SIGTERM ends it at once (nothing half-done is worth saving).
        kestrel::NodeLoop::RestoreDefaultSignalActions();
        if (!args.config_path.empty()) cc.mapper_file = args.config_path;
        cc.overrides = args.overrides;
        std::optional<kestrel::SimulatedMountTruth> truth;
        if (!truth_sim.empty()) {
          kestrel::ConfigNode sim =
              kestrel::ConfigNode::LoadFile(kestrel::PathUnderRoot(cc.root, truth_sim));
          for (const auto& o : truth_sim_overrides) sim.ApplyOverride(o);
          sim.ApplyOverride("seed=" + std::to_string(truth_seed));
          truth = kestrel::SimulatedMountTruthOf(kestrel::LoadSimConfig(sim, cc.root));
        }
        const auto results = kestrel::CalibrateFromLog(cc);
        std::ofstream out;
        if (!out_path.empty()) {
          out.open(out_path);
          if (!out) throw std::runtime_error("cannot write " + out_path);
          out << "# kestrel-calibrate --log " << cc.log_path << " --world " << cc.world_file
              << (cc.mount ? " --mount" : "") << " (docs/algorithms.md §3.7)\n";
        }
        for (size_t i = 0; i < results.size() && cc.mount; ++i) {
          const auto& r = results[i];
          const kestrel::MountCorrection* t = nullptr;
          if (truth) t = r.name == "xtion" ? &truth->depth : &truth->lidar;
          PrintMount(r, t);
          if (out.is_open() && r.mount.ok) {
            for (const std::string& o : kestrel::MountOverrides(i, r.mount.value)) out << o << "\n";
          }
        }
        std::printf("%-8s %9s %9s %9s %9s | %9s %9s %9s | %10s %10s %9s %7s\n", "sensor", "sigma_m",
                    "(surface)", "p_rand", "p_miss", "was sigma", "p_rand", "p_miss", "rays in",
                    "returns", "left map", "EM iter");
        for (size_t i = 0; i < results.size(); ++i) {
          const auto& r = results[i];
          std::printf(
              "%-8s %9.4f %9.4f %9.4f %9.4f | %9.4f %9.4f %9.4f | %10lld %10lld %9lld %7d%s\n",
              r.name.c_str(), r.fit.sigma_m, r.fit.sigma_surface_m, r.fit.p_rand, r.fit.p_miss,
              r.configured_sigma_m, r.configured_p_rand, r.configured_p_miss,
              static_cast<long long>(r.fit.rays_in_range),
              static_cast<long long>(r.fit.returns_in_range),
              static_cast<long long>(r.rays_left_map), r.fit.iterations,
              r.fit.converged ? "" : " (not converged)");
          if (out.is_open()) {
            // Rounded up to 0.1 mm and 1e-4: what a configuration file holds.
            const auto up = [](double v) { return std::ceil(v * 1e4) / 1e4; };
            out << "sensors." << i << ".model.sigma_m=" << up(r.fit.sigma_m) << "\n"
                << "sensors." << i << ".model.p_rand=" << up(r.fit.p_rand) << "\n"
                << "sensors." << i << ".model.p_miss=" << up(r.fit.p_miss) << "\n";
          }
        }
        int failed = 0;
        for (const auto& r : results) failed += cc.mount && !r.mount.ok ? 1 : 0;
        return failed > 0 ? 3 : 0;
      });
}
