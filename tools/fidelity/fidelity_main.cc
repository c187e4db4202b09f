// kestrel-fidelity: the fidelity benchmark (docs/algorithms.md §12.3). One recorded log replayed
// into several kestrel-mapper configurations and OctoMap, each scored against the simulator's
// truth of the world.
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "common/command_line.h"
#include "common/process.h"
#include "tools/fidelity/fidelity.h"

namespace {
const char* const kUsage =
    "usage: kestrel-fidelity --log RUN.lcmlog --world config/worlds/lasr.yaml\n"
    "                        [--config config/mapper.yaml] [--set key=value]...\n"
    "                        [--variant LABEL:key=value,key=value]... [--no-octomap]\n"
    "                        [--period-s 10] [--csv FILE] [--curve FILE]\n"
    "Replays the log into one kestrel-mapper per variant (the --config file with --set, then the\n"
    "variant's overrides, separated by commas outside brackets; default variants: exact, and\n"
    "log_odds:model=log_odds) and into OctoMap (its default sensor model, the same resolution,\n"
    "fed the first variant's scans), and prints\n"
    "each map's known fraction, accuracy, Brier score and ROC AUC against the world's truth, the\n"
    "accuracy and Brier score over the cells every map knows, and the entropy drop per scan.\n"
    "--csv writes that table, --curve the figures every --period-s of log time.\n";

// "label:k=v,k=v" -> variant. A comma inside brackets belongs to a list value (k=[a, b, c]).
kestrel::FidelityVariant ParseVariant(const std::string& text) {
  kestrel::FidelityVariant v;
  const size_t colon = text.find(':');
  v.label = text.substr(0, colon);
  if (v.label.empty()) throw kestrel::ConfigError("--variant '" + text + "' has no label");
  if (colon != std::string::npos) {
    std::string o;
    int depth = 0;
    for (const char c : text.substr(colon + 1) + ",") {
      depth += c == '[' ? 1 : c == ']' ? -1 : 0;
      if (c == ',' && depth <= 0) {
        if (!o.empty()) v.mapper_overrides.push_back(o);
        o.clear();
      } else {
        o += c;
      }
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
      },
      [&](const kestrel::ProcessArgs& args, kestrel::ConfigNode&) {
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
                 "entropy_drop_per_scan_bits,false_free,false_occupied,false_occupied_at_surface\n";
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
                << '\n';
          }
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
