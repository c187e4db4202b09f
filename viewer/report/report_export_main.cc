// kestrel-report-export: the data step of kestrel-report (viewer/report/report_export.h): reads
// a run's LCM log and writes the CSV files that kestrel_report.py draws.
#include <cstdio>
#include <sstream>

#include "common/process.h"
#include "viewer/report/report_export.h"

namespace {
const char* const kUsage =
    "usage: kestrel-report-export --log RUN.lcmlog --out DIR [--world config/worlds/lasr.yaml]\n"
    "                             [--times 30,60] [--threshold 0.5] [--range-m 4.0]\n"
    "                             [--vfov-deg 45]\n"
    "Rebuilds the 3D map from the log's MAP3D/MAP3D_DELTA messages and writes DIR/timeseries.csv,\n"
    "trajectory.csv, plans.csv, candidates.csv, map2d_index.csv, map2d_*.csv, occupied.csv,\n"
    "truth.csv (with --world) and meta.csv. --times: seconds since the first MAP_STATUS at which\n"
    "to keep the 2D maps (default: half way and the end).\n";

std::vector<double> ParseTimes(const std::string& text) {
  std::vector<double> times;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    size_t used = 0;
    double t = 0.0;
    try {
      t = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != item.size()) {
      throw kestrel::ConfigError("--times: '" + item + "' is not a number of seconds");
    }
    times.push_back(t);
  }
  return times;
}

double ParseNumber(const std::string& flag, const std::string& text) {
  size_t used = 0;
  double v = 0.0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size()) {
    throw kestrel::ConfigError(flag + ": '" + text + "' is not a number");
  }
  return v;
}
}  // namespace

int main(int argc, char** argv) {
  return kestrel::RunProcess(
      "kestrel-report-export", argc, argv, kUsage,
      [](const kestrel::ProcessArgs& args, kestrel::ConfigNode&) {
        kestrel::ReportExportConfig rc;
        const auto& p = args.positional;
        for (size_t i = 0; i < p.size(); ++i) {
          auto value = [&]() -> std::string {
            if (i + 1 >= p.size()) throw kestrel::ConfigError(p[i] + " needs a value\n" + kUsage);
            return p[++i];
          };
          if (p[i] == "--log") {
            rc.log_path = value();
          } else if (p[i] == "--out") {
            rc.out_dir = value();
          } else if (p[i] == "--world") {
            rc.world_path = value();
          } else if (p[i] == "--times") {
            rc.map2d_times_s = ParseTimes(value());
          } else if (p[i] == "--threshold") {
            rc.occupied_threshold = ParseNumber(p[i], value());
          } else if (p[i] == "--range-m") {
            rc.sensor_range_m = ParseNumber(p[i], value());
          } else if (p[i] == "--vfov-deg") {
            rc.vertical_fov_rad = ParseNumber(p[i], value()) * M_PI / 180.0;
          } else {
            throw kestrel::ConfigError("unexpected argument '" + p[i] + "'\n" + kUsage);
          }
        }
        if (rc.log_path.empty() || rc.out_dir.empty()) {
          throw kestrel::ConfigError(std::string("--log and --out are required\n") + kUsage);
        }
        try {
          rc.Validate();
        } catch (const std::invalid_argument& e) {
          throw kestrel::ConfigError(e.what());
        }
        const kestrel::ReportExportSummary s = kestrel::ExportReportData(rc);
        std::printf(
            "kestrel-report-export: %lld events, %zu samples over %.1f s, %zu occupied cells, "
            "%zu truth cells, %lld plans, %lld 2D maps -> %s\n",
            static_cast<long long>(s.events), s.samples, s.duration_s, s.occupied_cells,
            s.truth_cells, static_cast<long long>(s.plans),
            static_cast<long long>(s.map2d_messages), rc.out_dir.c_str());
        return 0;
      });
}
