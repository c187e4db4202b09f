// kestrel-calibrate: estimates the mapper's sensor models (sigma, p_rand, p_miss of each sensor,
// docs/algorithms.md §3.7) from a recorded run against the world's surfaces, and writes them as
// kestrel-mapper overrides.
#include <cstdio>
#include <fstream>
#include <string>

#include "common/command_line.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "tools/fidelity/calibrate.h"

namespace {
const char* const kUsage =
    "usage: kestrel-calibrate --log RUN.lcmlog --world config/worlds/lasr.yaml\n"
    "                         [--config config/mapper.yaml] [--set key=value]... [--every 4]\n"
    "                         [--out FILE]\n"
    "Pairs the log's scans with its poses as kestrel-mapper does (the --config file), casts every\n"
    "ray of every --every-th scan of each sensor against the world for its true range, and fits\n"
    "each sensor's sigma (about the model's cell distance d_k), p_rand and p_miss by maximum\n"
    "likelihood. Prints them beside the configured values; --out writes them as overrides, one\n"
    "sensors.I.model.KEY=VALUE a line, for --set of kestrel-mapper, kestrel-mission\n"
    "(--mapper-set) and kestrel-fidelity.\n";
}  // namespace

int main(int argc, char** argv) {
  kestrel::CalibrationRunConfig cc;
  std::string out_path;
  return kestrel::RunProcess(
      "kestrel-calibrate", argc, argv, kUsage,
      [&](CLI::App& app) {
        app.add_option("--log", cc.log_path)->required();
        app.add_option("--world", cc.world_file)->required();
        app.add_option("--every", cc.every)->check(kestrel::cli::Positive());
        app.add_option("--out", out_path);
      },
      [&](const kestrel::ProcessArgs& args, kestrel::ConfigNode&) {
        // A batch tool: Ctrl-C or SIGTERM ends it at once (nothing half-done is worth saving).
        kestrel::NodeLoop::RestoreDefaultSignalActions();
        if (!args.config_path.empty()) cc.mapper_file = args.config_path;
        cc.overrides = args.overrides;
        const auto results = kestrel::CalibrateFromLog(cc);
        std::printf("%-8s %9s %9s %9s %9s | %9s %9s %9s | %10s %10s %9s %7s\n", "sensor", "sigma_m",
                    "(surface)", "p_rand", "p_miss", "was sigma", "p_rand", "p_miss", "rays in",
                    "returns", "left map", "EM iter");
        std::ofstream out;
        if (!out_path.empty()) {
          out.open(out_path);
          if (!out) throw std::runtime_error("cannot write " + out_path);
          out << "# kestrel-calibrate --log " << cc.log_path << " --world " << cc.world_file
              << " (docs/algorithms.md §3.7)\n";
        }
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
        return 0;
      });
}
