// gain_probe: where a pose's predicted 3D gain comes from. Loads a Kestrel map file, evaluates
// the volumetric gain of a pose (exploration/volumetric_gain.h) and lists its most informative
// rays with the uncertain cells along them.
// Usage: gain_probe MAP_FILE X Y Z YAW [RAYS [OPAQUE_P]]
//        gain_probe --plan MAP_FILE X Y Z [REPEAT [BINS XTION_ROWS SPACING_M]]
//        (one volumetric replan, timed by stage)
//        gain_probe --traversability MAP_FILE X Y Z [whole [BAND_M]]   (fine traversability)
//        gain_probe --frontier MAP_FILE X Y Z   (one frontier-baseline plan)
//        gain_probe --cells MAP_FILE X Y Z0 Z1 [HALF_CELLS]   (P of the cells around (X, Y) per
//        layer)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "common/config.h"
#include "exploration/explorer_config.h"
#include "exploration/frontiers.h"
#include "exploration/information_gain.h"
#include "exploration/planner.h"
#include "exploration/projected_maps.h"
#include "exploration/volumetric_gain.h"
#include "exploration/volumetric_planner.h"
#include "mapping/map_file.h"
#include "mapping/occupancy_map.h"
#include "mapping/ray_caster.h"

using namespace kestrel;  // NOLINT(google-build-using-namespace): a small tool

namespace {

int PlanOnce(int argc, char** argv) {
  const LoadedMap<DenseOccupancyMap> loaded = LoadDenseMap(argv[2]);
  PlannerConfig config;
  config.projection.height_m = std::atof(argv[5]);
  if (argc > 9) {
    config.volumetric.gain.azimuth_bins = std::atoi(argv[7]);
    config.volumetric.gain.sensors[0].rows = std::atoi(argv[8]);
    config.volumetric.candidate_spacing_m = std::atof(argv[9]);
  }
  VolumetricPlanner planner(config);
  PlannerInput in;
  in.map = ViewOf(loaded.map->grid());
  in.position_m = Eigen::Vector3d(std::atof(argv[3]), std::atof(argv[4]), std::atof(argv[5]));
  const int repeat = argc > 6 ? std::atoi(argv[6]) : 3;
  for (int i = 0; i < repeat; ++i) {
    const PlanResult r = planner.Plan(in);
    std::printf(
        "status %d (%s): total %.1f ms = traversability %.1f + dijkstra %.1f + gain %.1f + "
        "trajectory %.1f; %zu candidates evaluated exactly, best gain %.2f nats; rays %ld, "
        "evaluated %ld, skipped %ld\n",
        static_cast<int>(r.status), r.reason.c_str(), 1e3 * r.timings.total_s,
        1e3 * r.timings.projection_s, 1e3 * r.timings.dijkstra_s, 1e3 * r.timings.gain_s,
        1e3 * r.timings.trajectory_s, r.candidates.size() / 8, r.best_unweighted_gain_nats,
        r.volumetric_stats.rays, r.volumetric_stats.rays_evaluated,
        r.volumetric_stats.rays_skipped);
    if (r.chosen >= 0) {
      const Candidate& c = r.candidates[static_cast<size_t>(r.chosen)];
      std::printf("goal (%.2f, %.2f) yaw %.2f rad: gain %.2f nats, %.2f m away, bump %.3f\n",
                  c.position_m.x(), c.position_m.y(), c.yaw_rad, c.gain_nats, c.distance_m, c.bump);
    }
  }
  return 0;
}

// One frontier-baseline plan from (x, y) at height z: the frontier cells, the cells examined
// nearest first and what each sees, the goal.
int FrontierOnce(char** argv) {
  const LoadedMap<DenseOccupancyMap> loaded = LoadDenseMap(argv[2]);
  // The shipped explorer configuration (run from the repository root), in frontier mode.
  PlannerConfig config =
      LoadExplorerNodeConfig(ConfigNode::LoadFile("config/exploration/explorer.yaml"))
          .explorer.planner;
  config.mode = ExplorationMode::kFrontier;
  config.projection.height_m = std::atof(argv[5]);
  const std::unique_ptr<ExplorationPlanner> planner = MakePlanner(config);
  PlannerInput in;
  in.map = ViewOf(loaded.map->grid());
  in.position_m = Eigen::Vector3d(std::atof(argv[3]), std::atof(argv[4]), std::atof(argv[5]));
  const PlanResult r = planner->Plan(in);
  const Traversability& t = *r.traversability;
  const std::vector<bool> f = FrontierCells(t, config.projection.collision_threshold);
  std::printf("%ld frontier cells; %zu cells examined; status %d (%s)\n",
              std::count(f.begin(), f.end(), true), r.candidates.size(), static_cast<int>(r.status),
              r.reason.c_str());
  if (r.chosen >= 0) {
    const Candidate& c = r.candidates[static_cast<size_t>(r.chosen)];
    std::printf("goal (%.2f, %.2f) yaw %.2f rad, %.2f m away\n", c.position_m.x(), c.position_m.y(),
                c.yaw_rad, c.distance_m);
  }
  return 0;
}

// ASCII picture of the fine traversability around (x, y): '#' blocked by a known occupied cell,
// '?' blocked by unknown space, '-' free but short of clearance, 'p' a passage cell (paths only),
// '.' traversable, 'V' (x, y).
int Traversable(int argc, char** argv) {
  const LoadedMap<DenseOccupancyMap> loaded = LoadDenseMap(argv[2]);
  PlannerConfig config;
  config.projection.height_m = std::atof(argv[5]);
  const Eigen::Vector2d xy(std::atof(argv[3]), std::atof(argv[4]));
  if (argc > 7) {
    config.volumetric.band_below_m = std::atof(argv[7]);
    config.volumetric.band_above_m = std::atof(argv[7]);
  }
  const Traversability t =
      ComputeTraversability(ViewOf(loaded.map->grid()), FineTraversabilityConfig(config));
  const auto c = t.band.CellOf(xy);
  if (!c) return 1;
  const bool whole = argc > 6;  // the whole map, every second cell
  const int step = whole ? 2 : 1;
  const int y0 = whole ? t.band.height - 1 : c->y + 30, y1 = whole ? 0 : c->y - 30;
  const int x0 = whole ? 0 : c->x - 40, x1 = whole ? t.band.width - 1 : c->x + 40;
  for (int y = y0; y >= y1; y -= step) {
    for (int x = x0; x <= x1; x += step) {
      if (!t.band.Contains(x, y)) {
        std::putchar(' ');
        continue;
      }
      const size_t i = static_cast<size_t>(t.band.IndexOf(x, y));
      char ch = t.traversable[i]                                  ? '.'
                : t.passage_points.count(static_cast<int>(i)) > 0 ? 'p'
                : t.clearance.values[i] > 0                       ? '-'
                : t.unknown[i]                                    ? '?'
                                                                  : '#';
      if (x == c->x && y == c->y) ch = 'V';
      std::putchar(ch);
    }
    std::putchar('\n');
  }
  const size_t own = static_cast<size_t>(t.band.IndexOf(*c));
  std::printf("at (%.2f, %.2f): band P %.4f, clearance %.3f m (needed %.3f m)\n", xy.x(), xy.y(),
              t.band.values[own], t.clearance.values[own],
              FineTraversabilityConfig(config).required_clearance_m());
  return 0;
}

// P of the cells within HALF_CELLS of (x, y), one block per layer from z0 to z1, north up, as
// two digits (P x 100, '##' for P > 0.99); the cell containing (x, y) in brackets.
int Cells(int argc, char** argv) {
  const LoadedMap<DenseOccupancyMap> loaded = LoadDenseMap(argv[2]);
  const GridGeometry& g = loaded.map->grid().geometry();
  const double x = std::atof(argv[3]), y = std::atof(argv[4]);
  const double z0 = std::atof(argv[5]), z1 = std::atof(argv[6]);
  const int half = argc > 7 ? std::atoi(argv[7]) : 4;
  for (double z = z0; z <= z1 + 1e-9; z += g.resolution_m()) {
    const std::optional<CellIndex> c = g.CellOf(Eigen::Vector3d(x, y, z));
    if (!c) continue;
    std::printf("layer z %.3f m (cell x %d..%d, y %d..%d):\n", g.CenterOf(*c).z(), c->x - half,
                c->x + half, c->y - half, c->y + half);
    for (int dy = half; dy >= -half; --dy) {
      std::printf("  y %6.3f ", g.CenterOf(CellIndex{c->x, c->y + dy, c->z}).y());
      for (int dx = -half; dx <= half; ++dx) {
        const CellIndex n{c->x + dx, c->y + dy, c->z};
        const double p = g.Contains(n) ? loaded.map->ProbabilityAt(n) : -1.0;
        const bool own = dx == 0 && dy == 0;
        if (p < 0) {
          std::printf(own ? "[--]" : " -- ");
        } else if (p > 0.99) {
          std::printf(own ? "[##]" : " ## ");
        } else {
          std::printf(own ? "[%02d]" : " %02d ", static_cast<int>(p * 100));
        }
      }
      std::printf("\n");
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc >= 7 && std::string(argv[1]) == "--cells") return Cells(argc, argv);
  if (argc >= 6 && std::string(argv[1]) == "--plan") return PlanOnce(argc, argv);
  if (argc >= 6 && std::string(argv[1]) == "--traversability") return Traversable(argc, argv);
  if (argc >= 6 && std::string(argv[1]) == "--frontier") return FrontierOnce(argv);
  if (argc < 6) {
    std::fprintf(stderr, "usage: gain_probe MAP_FILE X Y Z YAW [RAYS [OPAQUE_P]]\n");
    return 2;
  }
  const LoadedMap<DenseOccupancyMap> loaded = LoadDenseMap(argv[1]);
  const DenseGrid& grid = loaded.map->grid();
  const OccupancyGridView view = ViewOf(grid);
  const Eigen::Vector3d p(std::atof(argv[2]), std::atof(argv[3]), std::atof(argv[4]));
  const double yaw = std::atof(argv[5]);
  const int show = argc > 6 ? std::atoi(argv[6]) : 10;
  VolumetricGainConfig config;
  if (argc > 7) config.opaque_probability = std::atof(argv[7]);
  VolumetricGainEvaluator evaluator(config);
  const PoseGains g = evaluator.Evaluate(view, p, 8, true);
  for (size_t m = 0; m < g.gain_nats.size(); ++m) {
    std::printf("heading %4.2f rad: gain %8.3f nats, bound %8.3f nats\n", 2 * M_PI * m / 8,
                g.gain_nats[m], g.bound_nats[m]);
  }
  struct Ray {
    double gain;
    int sensor;
    double az, el;
  };
  std::vector<Ray> rays;
  const RayCaster caster(grid.geometry());
  const float clamp = static_cast<float>(config.certain_probability);
  const float opaque = static_cast<float>(config.opaque_probability);
  for (int s = 0; s < static_cast<int>(config.sensors.size()); ++s) {
    const VolumetricSensor& sensor = config.sensors[static_cast<size_t>(s)];
    const SensorModel model(sensor.model);
    RayCells cells(sensor.model.z_max_m, view.resolution_m);
    for (int row = 0; row < sensor.rows; ++row) {
      const double el =
          sensor.vertical_fov_rad > 0
              ? -0.5 * sensor.vertical_fov_rad + sensor.vertical_fov_rad * (row + 0.5) / sensor.rows
              : 0.0;
      for (int b = 0; b < config.azimuth_bins; ++b) {
        const double az = 2 * M_PI * b / config.azimuth_bins;
        if (std::abs(std::remainder(az - yaw - sensor.yaw_offset_rad, 2 * M_PI)) >
            0.5 * sensor.horizontal_fov_rad) {
          continue;
        }
        const Eigen::Vector3d u(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az),
                                std::sin(el));
        const Eigen::Vector3d o = p + Eigen::Vector3d(0, 0, sensor.height_offset_m);
        const int n = caster.Cast(o, u, sensor.model.z_max_m, &cells);
        std::vector<double> entry(n), exit(n), prior(n);
        double e = 0.0;
        for (int k = 0; k < n; ++k) {
          entry[k] = e;
          exit[k] = 2 * cells.distance_m[k] - e;
          e = exit[k];
          float v = grid.Get(cells.cells[k]);
          if (v <= clamp) v = 0.0f;
          if (v >= 1.0f - clamp || v >= opaque) v = 1.0f;
          prior[k] = v;
        }
        ExpectedEntropyScratch scratch;
        const RayEntropy r = ExpectedEntropy::Compute(
            model, entry.data(), exit.data(), cells.distance_m.data(), prior.data(), n,
            config.weight_mode, GainMethod::kFast, &scratch);
        rays.push_back({r.gain_nats(), s, az, el});
      }
    }
  }
  std::sort(rays.begin(), rays.end(), [](const Ray& a, const Ray& b) { return a.gain > b.gain; });
  double total = 0.0;
  for (const Ray& r : rays) total += r.gain;
  std::printf("%zu rays at yaw %.2f, total %.3f nats\n", rays.size(), yaw, total);
  for (int i = 0; i < std::min<int>(show, static_cast<int>(rays.size())); ++i) {
    const Ray& r = rays[static_cast<size_t>(i)];
    const VolumetricSensor& sensor = config.sensors[static_cast<size_t>(r.sensor)];
    std::printf("ray %s az %6.1f el %5.1f deg: gain %.3f nats; uncertain cells (d m, z m, P):",
                sensor.name.c_str(), r.az * 180 / M_PI, r.el * 180 / M_PI, r.gain);
    const Eigen::Vector3d u(std::cos(r.el) * std::cos(r.az), std::cos(r.el) * std::sin(r.az),
                            std::sin(r.el));
    const Eigen::Vector3d o = p + Eigen::Vector3d(0, 0, sensor.height_offset_m);
    RayCells cells(sensor.model.z_max_m, view.resolution_m);
    const int n = caster.Cast(o, u, sensor.model.z_max_m, &cells);
    for (int k = 0; k < n; ++k) {
      const float v = grid.Get(cells.cells[k]);
      if (v > 0.02f && v < 0.98f) {
        std::printf(" (%.2f, %.2f, %.2f)", cells.distance_m[k], o.z() + cells.distance_m[k] * u.z(),
                    v);
      }
    }
    std::printf("\n");
  }
  return 0;
}
