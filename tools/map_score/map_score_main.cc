// kestrel-map-score: scores a saved Kestrel map against the simulator's ground truth of a world
// (docs/algorithms.md §12.2: known fraction, accuracy, Brier score, ROC AUC over the observable
// cells). The map's lattice must be the world's (map limits and resolution).
#include <cmath>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>

#include "common/command_line.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "mapping/map_file.h"
#include "sim/ray_reach.h"
#include "tools/map_score/map_claims.h"
#include "tools/map_score/map_scorer.h"

namespace {
const char* const kUsage =
    "usage: kestrel-map-score --world config/worlds/lasr.yaml --map FILE.kmap\n"
    "                         [--range-m 4.0] [--vfov-deg 45] [--octomap FILE.bt] [--ply FILE]\n"
    "                         [--unknown-bin-m M] [--reach FILE] [--camera-no-return-informs]\n"
    "                         [--claims-bin-m M] [--camera-depth-range-m 8.0]\n"
    "Prints the map's quality against the world's ground truth, and the cells it claims free\n"
    "without grounds (docs/algorithms.md section 12.5; --reach: the flight's ray reach record\n"
    "from kestrel-mission --reach adds the cells no ray reached); optionally exports the map.\n"
    "Observable cells: those a ray of the sweep meets before its first hit; a ray that meets\n"
    "nothing counts only in the LIDAR's plane, as the shipped depth camera's 0 is no evidence,\n"
    "unless --camera-no-return-informs (docs/algorithms.md section 12.1). A ray returns from up\n"
    "to the depth the camera reports (--camera-depth-range-m, axial; the simulator's 8 m).\n"
    "--unknown-bin-m M also prints where the observable cells that are not known lie: a plan view\n"
    "of M x M m columns (north up; '.' none, 1-9 tens of percent of the column's cells, '#' "
    "more),\n"
    "the count per grid layer, and how many were never updated.\n"
    "--claims-bin-m M prints the same view of the cells claimed free without grounds.\n";

// A plan view of counts per bin_m x bin_m column (north up; '.' none, 1-9 tens of percent of
// the column's cells, '#' more) and the count per grid layer.
void PrintPlanView(const kestrel::GridSpec& grid, double bin_m, int bins_x, int bins_y,
                   const std::vector<size_t>& per_bin, const std::vector<size_t>& per_layer) {
  const double column_cells =
      std::pow(bin_m / grid.resolution_m, 2) * static_cast<double>(grid.dims.z());
  for (int by = bins_y - 1; by >= 0; --by) {
    std::printf("  y %5.1f  ", by * bin_m + grid.min_m.y());
    for (int bx = 0; bx < bins_x; ++bx) {
      const size_t n = per_bin[static_cast<size_t>(by) * bins_x + bx];
      const int tenths = static_cast<int>(std::ceil(10.0 * n / column_cells));
      std::putchar(n == 0 ? '.' : tenths > 9 ? '#' : static_cast<char>('0' + tenths));
    }
    std::putchar('\n');
  }
  for (int z = 0; z < grid.dims.z(); ++z) {
    if (per_layer[z] == 0) continue;
    std::printf("  layer %3d (z %.3f m): %zu\n", z, grid.min_m.z() + (z + 0.5) * grid.resolution_m,
                per_layer[z]);
  }
}
}  // namespace

int main(int argc, char** argv) {
  std::string world_path, map_path, octomap_path, ply_path, reach_path;
  double range_m = 4.0, vfov_deg = 45.0, unknown_bin_m = 0.0, claims_bin_m = 0.0;
  double camera_depth_range_m = 8.0;
  bool camera_no_return_informs = false;
  return kestrel::RunProcess(
      "kestrel-map-score", argc, argv, kUsage,
      [&](CLI::App& app) {
        app.add_option("--world", world_path)->required();
        app.add_option("--map", map_path)->required();
        app.add_option("--range-m", range_m)->check(kestrel::cli::Positive());
        app.add_option("--vfov-deg", vfov_deg)->check(kestrel::cli::Within(1.0, 180.0));
        app.add_option("--camera-depth-range-m", camera_depth_range_m)
            ->check(kestrel::cli::NonNegative());
        app.add_option("--octomap", octomap_path);
        app.add_option("--ply", ply_path);
        app.add_option("--unknown-bin-m", unknown_bin_m)->check(kestrel::cli::NonNegative());
        app.add_option("--claims-bin-m", claims_bin_m)->check(kestrel::cli::NonNegative());
        app.add_option("--reach", reach_path);
        app.add_flag("--camera-no-return-informs", camera_no_return_informs);
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
        const kestrel::MapScorer scorer(world, caster, grid, range_m, vfov_deg * M_PI / 180.0,
                                        camera_no_return_informs, camera_depth_range_m);
        const double p_init = loaded.map->updater().ProbabilityOf(g.initial_value());
        const kestrel::MapQuality q = scorer.Score(
            [&](const kestrel::CellIndex& cell) { return loaded.map->ProbabilityAt(cell); },
            p_init);
        std::printf(
            "known fraction: %.4f of %zu observable cells; accuracy %.4f; Brier %.4f; ROC AUC "
            "%.4f\n",
            q.known_fraction, q.observable_cells, q.accuracy, q.brier, q.roc_auc);
        const kestrel::ClaimTracker claims(world, grid, scorer.truth());
        const std::vector<uint8_t> known_free =
            kestrel::KnownFreeBelow(scorer.Probabilities([&](const kestrel::CellIndex& cell) {
              return loaded.map->ProbabilityAt(cell);
            }),
                                    p_init);
        std::optional<kestrel::RayReach> reach;
        if (!reach_path.empty()) {
          reach.emplace(kestrel::ReadRayReachFile(reach_path));
          if (reach->grid().size() != grid.size() || reach->grid().dims != grid.dims) {
            throw std::runtime_error(reach_path + ": its grid is not the map's");
          }
        }
        const kestrel::MapClaims found =
            claims.Claims(known_free, reach ? &reach->first_reach_s() : nullptr);
        std::printf(
            "claims without grounds: %zu cells known free, of which %zu half a cell or more inside "
            "a solid, %zu outside the building, %s never reached by a ray\n",
            found.known_free, found.free_in_solid, found.free_outside,
            found.free_unreached < 0 ? "(no --reach)"
                                     : std::to_string(found.free_unreached).c_str());
        if (claims_bin_m > 0.0) {
          const kestrel::MaskPlanView v = kestrel::PlanViewOf(
              grid, claims.ClaimMask(known_free, reach ? &reach->first_reach_s() : nullptr),
              claims_bin_m);
          std::printf("where the claims without grounds lie:\n");
          PrintPlanView(grid, claims_bin_m, v.bins_x, v.bins_y, v.per_bin, v.per_layer);
        }
        if (unknown_bin_m > 0.0) {
          const auto u = scorer.Unknown(
              [&](const kestrel::CellIndex& cell) { return loaded.map->ProbabilityAt(cell); },
              p_init, unknown_bin_m);
          std::printf("unknown observable cells: %zu never updated, %zu updated but not known\n",
                      u.never_updated, u.updated);
          PrintPlanView(grid, unknown_bin_m, u.bins_x, u.bins_y, u.per_bin, u.per_layer);
        }
        if (!octomap_path.empty()) kestrel::ExportOctoMap(octomap_path, *loaded.map);
        if (!ply_path.empty()) kestrel::ExportOccupiedPly(ply_path, *loaded.map);
        return 0;
      });
}
