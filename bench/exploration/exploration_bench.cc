// One full replan of the explorer on the paper's simulation map.
//
// The 3D map is built by Kestrel's exact mapper from synthetic frames of a closed room with
// interior walls and a table (walls at x = +-3.9 m, y = +-5.9 m, floor z = 0, ceiling 2.4 m
// above the map's top, as in the paper's set-up): a full turn
// (12 headings, an 80 x 60 depth frame and a 682-beam planar scan each) at h = 0.75 m from each
// of 16 positions covering the south-west half of the room (ScanPositions), so about half of the
// map is explored; the *WholeRoom benchmarks use 40 positions over the whole room instead. The
// vehicle then replans from (-2.4, -0.5). KESTREL_BENCH_DUMP=1 prints the collision map first.
// Reported per mode: wall time per replan (one core), and as counters the number of candidates,
// rays per candidate, distinct rays cast and the stage times.
//
// Run: build-explore/bench/exploration/exploration_bench --benchmark_min_time=2

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <memory>
#include <vector>

#include "common/se3.h"
#include "exploration/planner.h"
#include "exploration/volumetric_gain.h"
#include "mapping/occupancy_map.h"
#include "mapping/scan_integrator.h"

namespace kestrel {
namespace {

struct Box {
  Eigen::Vector3d lo, hi;
};

// The world: room shell (as slabs) and interior obstacles.
const std::vector<Box>& World() {
  static const std::vector<Box> boxes{
      {{-4.5, -6.5, -0.5}, {4.5, 6.5, 0.0}},   // floor
      {{-4.5, -6.5, 2.4}, {4.5, 6.5, 2.6}},    // ceiling, above the map (z <= 1.5)
      {{-4.5, -6.5, -0.5}, {-3.9, 6.5, 2.0}},  // west wall
      {{3.9, -6.5, -0.5}, {4.5, 6.5, 2.0}},    // east wall
      {{-4.5, -6.5, -0.5}, {4.5, -5.9, 2.0}},  // south wall
      {{-4.5, 5.9, -0.5}, {4.5, 6.5, 2.0}},    // north wall
      {{-1.0, -5.9, 0.0}, {-0.8, 1.0, 2.4}},   // interior wall
      {{1.0, 2.0, 0.0}, {3.9, 2.2, 2.4}},      // interior wall
      {{1.5, -3.0, 0.0}, {2.5, -2.0, 0.8}},    // table
  };
  return boxes;
}

// Slab test: distance along unit u from o to the first box, +inf if none.
double Range(const Eigen::Vector3d& o, const Eigen::Vector3d& u) {
  double best = std::numeric_limits<double>::infinity();
  for (const Box& b : World()) {
    double t0 = 0.0, t1 = best;
    bool hit = true;
    for (int a = 0; a < 3 && hit; ++a) {
      if (u[a] == 0.0) {
        hit = o[a] >= b.lo[a] && o[a] <= b.hi[a];
        continue;
      }
      double ta = (b.lo[a] - o[a]) / u[a], tb = (b.hi[a] - o[a]) / u[a];
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
      hit = t0 <= t1;
    }
    if (hit) best = std::min(best, t0);
  }
  return best;
}

// Where the vehicle has been (the south-west half of the room): every 1.5 m along the west
// corridor, then east of the interior wall to y = -2.
// With `everywhere`, a grid of positions over the whole room instead (the largest reachable
// area, hence the largest candidate set, late in an exploration).
std::vector<Eigen::Vector2d> ScanPositions(bool everywhere) {
  std::vector<Eigen::Vector2d> out;
  if (everywhere) {
    for (double y = -5.0; y <= 5.1; y += 1.5) {
      for (double x : {-3.0, -1.8, 0.0, 1.5, 3.0}) out.emplace_back(x, y);
    }
    return out;
  }
  for (double y = -5.0; y <= 1.1; y += 1.5) {
    out.emplace_back(-3.0, y);
    out.emplace_back(-1.8, y);
  }
  for (double x = 0.0; x <= 3.1; x += 1.5) {
    out.emplace_back(x, -5.0);
    out.emplace_back(x, -3.5);
  }
  return out;
}

std::unique_ptr<DenseOccupancyMap> BuildMap(bool everywhere) {
  MapLimits limits;  // the paper's simulation map
  OccupancyLimits occupancy;
  auto map = MakeExactDenseMap(limits, occupancy, 4.0);
  ScanIntegrator integrator(map.get());
  const SensorModel xtion(SensorModelConfig::Xtion());
  const SensorModel hokuyo(SensorModelConfig::Hokuyo());
  const Pose3 X_BC{Eigen::Vector3d(0.15, 0.0, 0.05), Eigen::Quaterniond(0.5, -0.5, 0.5, -0.5)};
  const Pose3 X_BL{Eigen::Vector3d(0.10, 0.0, 0.12), Eigen::Quaterniond::Identity()};
  const int w = 80, h = 60;
  DepthIntrinsics k{w / (2.0 * std::tan(0.5 * 58.0 * M_PI / 180.0)),
                    h / (2.0 * std::tan(0.5 * 45.0 * M_PI / 180.0)), (w - 1) / 2.0, (h - 1) / 2.0};
  for (const Eigen::Vector2d& p : ScanPositions(everywhere)) {
    for (int i = 0; i < 12; ++i) {
      Pose3 X_WB{Eigen::Vector3d(p.x(), p.y(), 0.75), QuaternionFromYaw(2.0 * M_PI * i / 12)};
      const Pose3 X_WC = X_WB * X_BC;
      std::vector<uint16_t> depth(static_cast<size_t>(w * h));
      for (int v = 0; v < h; ++v) {
        for (int u = 0; u < w; ++u) {
          const Eigen::Vector3d ray_C((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
          const double r = Range(X_WC.p, (X_WC.q * ray_C).normalized());
          const double z = r / ray_C.norm();  // depth along the optical axis
          depth[static_cast<size_t>(v * w + u)] =
              r < 4.0 ? static_cast<uint16_t>(std::lround(z * 1000.0)) : 0;
        }
      }
      integrator.IntegrateDepthImage(X_WC, k, depth.data(), w, h, 0.001, xtion);
      const Pose3 X_WL = X_WB * X_BL;
      std::vector<float> ranges(682);
      const double a0 = -0.5 * 239.77 * M_PI / 180.0, da = 239.77 * M_PI / 180.0 / 681;
      for (int j = 0; j < 682; ++j) {
        const Eigen::Vector3d u_L(std::cos(a0 + j * da), std::sin(a0 + j * da), 0.0);
        const double r = Range(X_WL.p, X_WL.q * u_L);
        ranges[static_cast<size_t>(j)] =
            r < 4.0 ? static_cast<float>(r) : std::numeric_limits<float>::infinity();
      }
      integrator.IntegratePlanarScan(X_WL, a0, da, ranges.data(), 682, hokuyo);
    }
  }
  return map;
}

const DenseOccupancyMap& Map(bool everywhere) {
  static const std::unique_ptr<DenseOccupancyMap> half = BuildMap(false);
  if (!everywhere) return *half;
  static const std::unique_ptr<DenseOccupancyMap> full = BuildMap(true);
  return *full;
}

void Replan(benchmark::State& state, ExplorationMode mode, GainMethod method = GainMethod::kFast,
            bool cold = false, bool everywhere = false) {
  const DenseOccupancyMap& map = Map(everywhere);
  PlannerConfig config;
  config.mode = mode;
  config.gain.method = method;
  const std::unique_ptr<ExplorationPlanner> planner = MakePlanner(config);
  PlannerInput in;
  in.map = ViewOf(map.grid());
  in.position_m = Eigen::Vector3d(-2.4, -0.5, 0.75);
  in.yaw_rad = 0.3;
  PlanResult r;
  static bool dumped = false;
  if (!dumped && std::getenv("KESTREL_BENCH_DUMP") != nullptr) {  // C, y up, for inspection
    dumped = true;
    r = planner->Plan(in);
    const GridMap2D& c = r.collision.collision;
    for (int y = c.height - 1; y >= 0; --y) {
      for (int x = 0; x < c.width; ++x) {
        const double p = c.at(x, y);
        std::fputc(c.IndexOf(x, y) == r.field.start ? 'S'
                   : p <= 0.05                      ? '.'
                   : p < 0.5                        ? '?'
                                                    : '#',
                   stderr);
      }
      std::fputc('\n', stderr);
    }
  }
  for (auto _ : state) {
    if (cold) {  // a new planner: every ray kernel is built (the first replan of a flight)
      std::unique_ptr<ExplorationPlanner> fresh = MakePlanner(config);
      r = fresh->Plan(in);
      benchmark::DoNotOptimize(r.chosen);
      continue;
    }
    r = planner->Plan(in);
    benchmark::DoNotOptimize(r.chosen);
  }
  state.counters["candidates"] = static_cast<double>(r.candidates.size());
  state.counters["rays_per_candidate"] = static_cast<double>(r.gain_stats.rays_per_pose);
  state.counters["rays_cast"] = static_cast<double>(r.gain_stats.rays_cast);
  state.counters["kernels_built"] = static_cast<double>(r.gain_stats.kernels_built);
  state.counters["cells_per_ray"] = r.gain_stats.rays_cast > 0
                                        ? static_cast<double>(r.gain_stats.ray_cells) /
                                              static_cast<double>(r.gain_stats.rays_cast)
                                        : 0.0;
  state.counters["projection_ms"] = 1e3 * r.timings.projection_s;
  state.counters["gain_ms"] = 1e3 * r.timings.gain_s;
  state.counters["dijkstra_ms"] = 1e3 * r.timings.dijkstra_s;
  state.counters["trajectory_ms"] = 1e3 * r.timings.trajectory_s;
  state.counters["ok"] = r.status == PlanStatus::kGoal ? 1.0 : 0.0;
  state.counters["k_C"] = r.collision.collision_factor;
  state.counters["best_gain_nats"] = r.best_unweighted_gain_nats;
  state.counters["waypoints"] = static_cast<double>(r.trajectory.waypoints.size());
  state.counters["rest_waypoints"] = r.trajectory.stop_waypoints;
  state.counters["flight_s"] =
      r.trajectory.trajectory ? r.trajectory.trajectory->duration_s() : 0.0;
  int traversable = 0, reachable = 0;
  for (size_t i = 0; i < r.collision.collision.values.size(); ++i) {
    traversable += r.collision.collision.values[i] <= config.projection.collision_threshold;
    reachable += r.field.Reachable(static_cast<int>(i));
  }
  state.counters["traversable_cells"] = traversable;
  state.counters["reachable_cells"] = reachable;
  state.SetLabel(r.reason);
}

void BM_ReplanCombined(benchmark::State& state) { Replan(state, ExplorationMode::kCombined); }
void BM_ReplanTwoMap(benchmark::State& state) { Replan(state, ExplorationMode::kTwoMap); }
void BM_ReplanFrontier(benchmark::State& state) { Replan(state, ExplorationMode::kFrontier); }
// The first replan of a flight: no ray kernel built yet (later replans reuse them, since the
// candidates sit on the same lattice).
void BM_ReplanCombinedCold(benchmark::State& state) {
  Replan(state, ExplorationMode::kCombined, GainMethod::kFast, true);
}
void BM_ReplanTwoMapCold(benchmark::State& state) {
  Replan(state, ExplorationMode::kTwoMap, GainMethod::kFast, true);
}
BENCHMARK(BM_ReplanCombinedCold)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReplanTwoMapCold)->Unit(benchmark::kMillisecond);

// The room explored everywhere: the largest candidate set.
void BM_ReplanCombinedWholeRoom(benchmark::State& state) {
  Replan(state, ExplorationMode::kCombined, GainMethod::kFast, false, true);
}
void BM_ReplanCombinedWholeRoomCold(benchmark::State& state) {
  Replan(state, ExplorationMode::kCombined, GainMethod::kFast, true, true);
}
void BM_ReplanTwoMapWholeRoom(benchmark::State& state) {
  Replan(state, ExplorationMode::kTwoMap, GainMethod::kFast, false, true);
}
BENCHMARK(BM_ReplanCombinedWholeRoom)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReplanCombinedWholeRoomCold)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReplanTwoMapWholeRoom)->Unit(benchmark::kMillisecond);

// The same replans with the direct (n_r+1)^2 expected entropy, for comparison.
void BM_ReplanCombinedDirect(benchmark::State& state) {
  Replan(state, ExplorationMode::kCombined, GainMethod::kDirect);
}
void BM_ReplanTwoMapDirect(benchmark::State& state) {
  Replan(state, ExplorationMode::kTwoMap, GainMethod::kDirect);
}
BENCHMARK(BM_ReplanCombined)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReplanCombinedDirect)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReplanTwoMapDirect)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReplanTwoMap)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReplanFrontier)->Unit(benchmark::kMillisecond);

// The volumetric gain (exploration/volumetric_gain.h) of candidate positions in the half-explored
// room: 24 cell centres (x, y) of the map's lattice at h = 0.75 m, as the planner's candidates
// sit, evaluated in turn with 8 headings (CandidateConfig::n_yaw). The templates are built before
// the timing (once per map geometry and height). Counters: rays (all sensors, all bins x rows) and
// cells per position, rays/s, milliseconds per position.
std::vector<Eigen::Vector3d> VolumetricPositions(const GridGeometry& g) {
  std::vector<Eigen::Vector3d> out;
  for (double y = -5.0; y <= 1.0; y += 1.2) {
    for (double x : {-3.2, -2.4, -1.6, 0.5}) {
      Eigen::Vector3d c = g.CenterOf(*g.CellOf(Eigen::Vector3d(x, y, 0.75)));
      c.z() = 0.75;
      out.push_back(c);
    }
  }
  return out;
}

void VolumetricPose(benchmark::State& state, bool with_gain) {
  const DenseOccupancyMap& map = Map(false);
  const OccupancyGridView view = ViewOf(map.grid());
  const std::vector<Eigen::Vector3d> positions = VolumetricPositions(map.grid().geometry());
  VolumetricGainConfig config;
  config.azimuth_bins = static_cast<int>(state.range(0));
  VolumetricGainEvaluator evaluator(config);
  for (int warm = 0; warm < 2; ++warm) evaluator.Evaluate(view, positions[0], 8, with_gain);
  VolumetricGainStats stats;
  size_t next = 0;
  double best = 0.0;
  for (auto _ : state) {
    const PoseGains g = evaluator.Evaluate(view, positions[next], 8, with_gain, &stats);
    best = std::max(best, with_gain ? g.gain_nats[0] : g.bound_nats[0]);
    next = (next + 1) % positions.size();
  }
  benchmark::DoNotOptimize(best);
  const double n = static_cast<double>(state.iterations());
  state.counters["positions"] = static_cast<double>(positions.size());
  state.counters["rays_per_position"] = static_cast<double>(stats.rays) / n;
  state.counters["cells_per_ray"] =
      static_cast<double>(stats.ray_cells) / std::max<double>(1.0, static_cast<double>(stats.rays));
  state.counters["templated_fraction"] = static_cast<double>(stats.templated_rays) /
                                         std::max<double>(1.0, static_cast<double>(stats.rays));
  state.counters["templates_built"] = static_cast<double>(stats.templates_built);
  state.counters["rays_per_s"] =
      benchmark::Counter(static_cast<double>(stats.rays), benchmark::Counter::kIsRate);
  state.counters["ms_per_position"] =
      benchmark::Counter(1e-3 * n, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void BM_VolumetricGainPose(benchmark::State& state) { VolumetricPose(state, true); }
void BM_VolumetricBoundPose(benchmark::State& state) { VolumetricPose(state, false); }
// Argument: azimuth_bins (120: the default, one ray per 3 degrees per row; 60: per 6 degrees).
BENCHMARK(BM_VolumetricGainPose)->Arg(120)->Arg(60)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_VolumetricBoundPose)->Arg(120)->Arg(60)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace kestrel

BENCHMARK_MAIN();
