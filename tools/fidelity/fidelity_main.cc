// kestrel-fidelity: the fidelity benchmark (docs/algorithms.md §12.3). One recorded log replayed
// into several kestrel-mapper configurations and OctoMap, each scored against the simulator's
// truth of the world.
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "common/command_line.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "tools/fidelity/fidelity.h"

namespace {
const char* const kUsage =
    "usage: kestrel-fidelity --log RUN.lcmlog --world config/worlds/lasr.yaml\n"
    "                        [--config config/mapper.yaml] [--set key=value]...\n"
    "                        [--variant LABEL:key=value,key=value]... [--no-octomap]\n"
    "                        [--period-s 10] [--csv FILE] [--curve FILE] [--reach FILE]\n"
    "Replays the log into one kestrel-mapper per variant (the --config file with --set, then the\n"
    "variant's overrides; default variants: exact, and log_odds:model=log_odds) and into OctoMap\n"
    "(its default sensor model, the same resolution, fed the first variant's scans), and prints\n"
    "each map's known fraction, accuracy, Brier score and ROC AUC against the world's truth, the\n"
    "accuracy and Brier score over the cells every map knows, and the entropy drop per scan.\n"
    "--csv writes that table, --curve the figures every --period-s of log time.\n"
    "Each map's cells known free without grounds (docs/algorithms.md section 12.5): half a cell "
    "or\n"
    "more inside a solid, outside the building (not connected to the start), and with --reach "
    "(the\n"
    "flight's record from kestrel-mission --reach) never reached by a ray, or freed before a ray\n"
    "reached them.\n";

// "label:k=v,k=v" -> variant.
kestrel::FidelityVariant ParseVariant(const std::string& text) {
  kestrel::FidelityVariant v;
  const size_t colon = text.find(':');
  v.label = text.substr(0, colon);
  if (v.label.empty()) throw kestrel::ConfigError("--variant '" + text + "' has no label");
  if (colon != std::string::npos) {
    std::stringstream ss(text.substr(colon + 1));
    for (std::string o; std::getline(ss, o, ',');) {
      if (!o.empty()) v.mapper_overrides.push_back(o);
    }
  }
  return v;
}

}  // namespace

int main(int argc, char** argv) {
  kestrel::FidelityConfig fc;
  std::vector<std::string> variants;
  std::string csv_path, curve_path;
  bool no_octomap = false;
  return kestrel::RunProcess(
      "kestrel-fidelity", argc, argv, kUsage,
      [&](CLI::App& app) {
        app.add_option("--log", fc.log_path)->required();
        app.add_option("--world", fc.world_file)->required();
        app.add_option("--variant", variants)->allow_extra_args(false);
        app.add_flag("--no-octomap", no_octomap);
        app.add_option("--period-s", fc.sample_period_s)->check(kestrel::cli::NonNegative());
        app.add_option("--csv", csv_path);
        app.add_option("--curve", curve_path);
        app.add_option("--reach", fc.reach_path);
      },
      [&](const kestrel::ProcessArgs& args, kestrel::ConfigNode&) {
        // A batch tool: Ctrl-C or SIGTERM ends it at once (nothing half-done is worth saving).
        kestrel::NodeLoop::RestoreDefaultSignalActions();
        if (!args.config_path.empty()) fc.mapper_file = args.config_path;
        fc.base_overrides = args.overrides;
        fc.octomap = !no_octomap;
        if (variants.empty()) variants = {"exact", "log_odds:model=log_odds"};
        for (const auto& v : variants) fc.variants.push_back(ParseVariant(v));
        const kestrel::FidelityResult r = kestrel::RunFidelity(fc);
        std::printf("%s: %.1f s of log, %zu cells known in every map\n", fc.log_path.c_str(),
                    r.log_duration_s, r.common_known_cells);
        std::printf("%-16s %7s %8s %7s %7s | %8s %7s | %9s %7s | %8s %8s %8s\n", "map", "known",
                    "accuracy", "Brier", "AUC", "c.acc", "c.Brier", "dH/scan", "scans", "fl.free",
                    "fl.occ", "at surf");
        std::ofstream csv;
        if (!csv_path.empty()) {
          csv.open(csv_path);
          csv << "map,prior,observable,known_fraction,accuracy,brier,roc_auc,common_cells,"
                 "common_accuracy,common_brier,entropy_start_bits,entropy_end_bits,scans,"
                 "entropy_drop_per_scan_bits,false_free,false_occupied,false_occupied_at_surface,"
                 "known_free,free_in_solid,free_outside,free_unreached,freed_early,"
                 "max_lead_s\n";
        }
        for (const auto& s : r.scores) {
          std::printf(
              "%-16s %7.4f %8.4f %7.4f %7.4f | %8.4f %7.4f | %9.2f %7lld | %8zu %8zu %8zu\n",
              s.label.c_str(), s.quality.known_fraction, s.quality.accuracy, s.quality.brier,
              s.quality.roc_auc, s.common_accuracy, s.common_brier, s.entropy_drop_per_scan_bits,
              static_cast<long long>(s.scans), s.false_free, s.false_occupied,
              s.false_occupied_at_surface);
          if (csv.is_open()) {
            csv << s.label << ',' << s.prior << ',' << s.quality.observable_cells << ','
                << s.quality.known_fraction << ',' << s.quality.accuracy << ',' << s.quality.brier
                << ',' << s.quality.roc_auc << ',' << r.common_known_cells << ','
                << s.common_accuracy << ',' << s.common_brier << ',' << s.entropy_start_bits << ','
                << s.entropy_end_bits << ',' << s.scans << ',' << s.entropy_drop_per_scan_bits
                << ',' << s.false_free << ',' << s.false_occupied << ','
                << s.false_occupied_at_surface << ',' << s.claims.known_free << ','
                << s.claims.free_in_solid << ',' << s.claims.free_outside << ','
                << s.claims.free_unreached << ',' << s.claims.freed_early << ','
                << s.claims.max_lead_s << '\n';
          }
        }
        std::printf("cells known free without grounds (-1: needs --reach):\n");
        std::printf("%-16s %9s %8s %9s %9s %9s %8s\n", "map", "known fr.", "in solid", "outside",
                    "unreached", "early", "lead s");
        for (const auto& s : r.scores) {
          std::printf("%-16s %9zu %8zu %9zu %9lld %9lld %8.1f\n", s.label.c_str(),
                      s.claims.known_free, s.claims.free_in_solid, s.claims.free_outside,
                      static_cast<long long>(s.claims.free_unreached),
                      static_cast<long long>(s.claims.freed_early), s.claims.max_lead_s);
        }
        if (!curve_path.empty()) {
          std::ofstream curve(curve_path);
          curve << "t_s,map,known_fraction,accuracy,brier,roc_auc,entropy_bits\n";
          for (const auto& s : r.curve) {
            curve << s.t_s << ',' << s.label << ',' << s.quality.known_fraction << ','
                  << s.quality.accuracy << ',' << s.quality.brier << ',' << s.quality.roc_auc << ','
                  << s.entropy_bits << '\n';
          }
        }
        return 0;
      });
}
