// kestrel-report-export: the data step of kestrel-report (viewer/report/report_export.h): reads
// a run's LCM log and writes the CSV files that kestrel_report.py draws.
#include <cmath>
#include <cstdio>

#include "common/command_line.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "viewer/report/report_export.h"

namespace {
const char* const kUsage =
    "usage: kestrel-report-export --log RUN.lcmlog --out DIR [--world config/worlds/lasr.yaml]\n"
    "                             [--times 30,60] [--threshold 0.5] [--range-m 4.0]\n"
    "                             [--vfov-deg 45]\n"
    "Rebuilds the 3D map from the log's MAP3D/MAP3D_DELTA messages and writes DIR/timeseries.csv,\n"
    "vehicles.csv, trajectory.csv (and trajectory_<prefix>.csv for the other vehicles),\n"
    "plans.csv, candidates.csv, map2d_index.csv, map2d_*.csv, occupied.csv, truth.csv (with\n"
    "--world) and meta.csv. --times: seconds since the first MAP_STATUS at which to keep the 2D\n"
    "maps (default: half way and the end). The vehicles are the prefixes P of the log's\n"
    "P + POSE_VICON channels (V1_POSE_VICON, ...; one vehicle: POSE_VICON).\n";

}  // namespace

int main(int argc, char** argv) {
  kestrel::ReportExportConfig rc;
  double vfov_deg = rc.vertical_fov_rad * 180.0 / M_PI;
  return kestrel::RunProcess(
      "kestrel-report-export", argc, argv, kUsage,
      [&](CLI::App& app) {
        app.add_option("--log", rc.log_path)->required();
        app.add_option("--out", rc.out_dir)->required();
        app.add_option("--world", rc.world_path);
        app.add_option("--times", rc.map2d_times_s)->delimiter(',')->allow_extra_args(false);
        app.add_option("--threshold", rc.occupied_threshold);
        app.add_option("--range-m", rc.sensor_range_m);
        app.add_option("--vfov-deg", vfov_deg);
      },
      [&](const kestrel::ProcessArgs&, kestrel::ConfigNode&) {
        // A batch tool: Ctrl-C or SIGTERM ends it at once (nothing half-done is worth saving).
        kestrel::NodeLoop::RestoreDefaultSignalActions();
        rc.vertical_fov_rad = vfov_deg * M_PI / 180.0;
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
