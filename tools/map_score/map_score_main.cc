// kestrel-map-score: scores a saved Kestrel map against the simulator's ground truth of a world
// (docs/algorithms.md §12.2: known fraction, accuracy, Brier score, ROC AUC over the observable
// cells). The map's lattice must be the world's (map limits and resolution).
#include <cmath>
#include <cstdio>
#include <string>

#include "common/command_line.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "mapping/map_file.h"
#include "tools/map_score/map_scorer.h"

namespace {
const char* const kUsage =
    "usage: kestrel-map-score --world config/worlds/lasr.yaml --map FILE.kmap\n"
    "                         [--range-m 4.0] [--vfov-deg 45] [--octomap FILE.bt] [--ply FILE]\n"
    "                         [--unknown-bin-m M]\n"
    "Prints the map's quality against the world's ground truth; optionally exports the map.\n"
    "--unknown-bin-m M also prints where the observable cells that are not known lie: a plan view\n"
    "of M x M m columns (north up; '.' none, 1-9 tens of percent of the column's cells, '#' "
    "more),\n"
    "the count per grid layer, and how many were never updated.\n";

}  // namespace

int main(int argc, char** argv) {
  std::string world_path, map_path, octomap_path, ply_path;
  double range_m = 4.0, vfov_deg = 45.0, unknown_bin_m = 0.0;
  return kestrel::RunProcess(
      "kestrel-map-score", argc, argv, kUsage,
      [&](CLI::App& app) {
        app.add_option("--world", world_path)->required();
        app.add_option("--map", map_path)->required();
        app.add_option("--range-m", range_m)->check(kestrel::cli::Positive());
        app.add_option("--vfov-deg", vfov_deg)->check(kestrel::cli::Within(1.0, 180.0));
        app.add_option("--octomap", octomap_path);
        app.add_option("--ply", ply_path);
        app.add_option("--unknown-bin-m", unknown_bin_m)->check(kestrel::cli::NonNegative());
      },
      [&](const kestrel::ProcessArgs&, kestrel::ConfigNode&) {
        // A batch tool: Ctrl-C or SIGTERM ends it at once (nothing half-done is worth saving).
        kestrel::NodeLoop::RestoreDefaultSignalActions();
        const kestrel::World world = kestrel::LoadWorld(world_path);
        const auto loaded = kestrel::LoadDenseMap(map_path);
        const kestrel::DenseGrid& g = loaded.map->grid();
        const kestrel::GridSpec grid{g.geometry().origin_m(), g.geometry().resolution_m(),
                                     Eigen::Vector3i(g.dims().x, g.dims().y, g.dims().z)};
        const kestrel::WorldRayCaster caster(world);
        const kestrel::MapScorer scorer(world, caster, grid, range_m, vfov_deg * M_PI / 180.0);
        const double p_init = loaded.map->updater().ProbabilityOf(g.initial_value());
        const kestrel::MapQuality q = scorer.Score(
            [&](const kestrel::CellIndex& c) { return loaded.map->ProbabilityAt(c); }, p_init);
        std::printf(
            "known fraction: %.4f of %zu observable cells; accuracy %.4f; Brier %.4f; ROC AUC "
            "%.4f\n",
            q.known_fraction, q.observable_cells, q.accuracy, q.brier, q.roc_auc);
        if (unknown_bin_m > 0.0) {
          const auto u = scorer.Unknown(
              [&](const kestrel::CellIndex& c) { return loaded.map->ProbabilityAt(c); }, p_init,
              unknown_bin_m);
          std::printf("unknown observable cells: %zu never updated, %zu updated but not known\n",
                      u.never_updated, u.updated);
          // A column holds (bin / resolution)^2 * layers cells; print tens of percent of it.
          const double column_cells =
              std::pow(unknown_bin_m / grid.resolution_m, 2) * static_cast<double>(grid.dims.z());
          for (int by = u.bins_y - 1; by >= 0; --by) {
            std::printf("  y %5.1f  ", by * unknown_bin_m + grid.min_m.y());
            for (int bx = 0; bx < u.bins_x; ++bx) {
              const size_t n = u.per_bin[static_cast<size_t>(by) * u.bins_x + bx];
              const int tenths = static_cast<int>(std::ceil(10.0 * n / column_cells));
              std::putchar(n == 0 ? '.' : tenths > 9 ? '#' : static_cast<char>('0' + tenths));
            }
            std::putchar('\n');
          }
          for (int z = 0; z < grid.dims.z(); ++z) {
            if (u.per_layer[z] == 0) continue;
            std::printf("  layer %3d (z %.3f m): %zu\n", z,
                        grid.min_m.z() + (z + 0.5) * grid.resolution_m, u.per_layer[z]);
          }
        }
        if (!octomap_path.empty()) kestrel::ExportOctoMap(octomap_path, *loaded.map);
        if (!ply_path.empty()) kestrel::ExportOccupiedPly(ply_path, *loaded.map);
        return 0;
      });
}
