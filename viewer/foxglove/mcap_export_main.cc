// kestrel-mcap-export: a recorded run (LCM log) as an MCAP file for Foxglove.
#include <chrono>
#include <cstdio>

#include "common/command_line.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "viewer/foxglove/mcap_export.h"

namespace {
const char* const kUsage =
    "usage: kestrel-mcap-export --log RUN.lcmlog --out RUN.mcap [--compression zstd|none]\n"
    "                           [--map-period S] [--threshold P]\n"
    "Writes the run's topics as Foxglove shows them live (kestrel-viewer's ws://127.0.0.1:8765):\n"
    "/map (cubes of the cells with P above the threshold, every S s of the log), /tf,\n"
    "/map2d/<name>, /trajectory, /candidates and /params/<process> (each process's\n"
    "configuration), JSON with JSON Schemas, in indexed chunks.\n";
}  // namespace

int main(int argc, char** argv) {
  kestrel::foxglove::McapExportConfig config;
  std::string compression = "zstd";
  return kestrel::RunProcess(
      "kestrel-mcap-export", argc, argv, kUsage,
      [&](CLI::App& app) {
        app.add_option("--log", config.log_path)->required();
        app.add_option("--out", config.out_path)->required();
        app.add_option("--compression", compression)->check(CLI::IsMember({"zstd", "none"}));
        app.add_option("--map-period", config.map_period_s)->check(kestrel::cli::Positive());
        app.add_option("--threshold", config.bridge.occupied_threshold)
            ->check(kestrel::cli::Within(0.0, 0.999));
      },
      [&](const kestrel::ProcessArgs&, kestrel::ConfigNode&) {
        // A batch tool: Ctrl-C or SIGTERM ends it at once (nothing half-done is worth saving).
        kestrel::NodeLoop::RestoreDefaultSignalActions();
        config.compression = compression == "none" ? "" : compression;
        const auto start = std::chrono::steady_clock::now();
        const kestrel::foxglove::McapExportSummary s = kestrel::foxglove::ExportMcap(config);
        const double wall_s =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        std::printf("%s: %lld events, %lld messages, %.1f MB in %.2f s%s\n",
                    config.out_path.c_str(), static_cast<long long>(s.events),
                    static_cast<long long>(s.messages), static_cast<double>(s.bytes) / 1e6, wall_s,
                    s.refused > 0 ? (", " + std::to_string(s.refused) + " refused").c_str() : "");
        for (const auto& [topic, count] : s.per_topic) {
          std::printf("  %-22s %lld\n", topic.c_str(), static_cast<long long>(count));
        }
        return 0;
      });
}
