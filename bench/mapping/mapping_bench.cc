// Mapping throughput on identical synthetic frames (bench/mapping/synthetic_scene.h): Kestrel's
// exact model (dense and growing grid), Kestrel's log-odds baseline, and OctoMap's
// insertPointCloud (liboctomap, discretize = false, maxrange 4 m), 0.075 m cells, the paper's map
// x -4..4, y -6..6, z -0.15..1.5 m. One iteration applies one frame; frames cycle.
// Counters: rays/s (returns and "no return" rays to 4 m) and cell updates/s. Rays are cast eight
// at a time (ScanIntegrator); the exact model runs once per instruction set this CPU runs
// (BM_KestrelExact_<isa>_*: scalar, sse4, avx2, avx3 here; the same map with each), or only the
// one the environment variable KESTREL_ISA names; the log-odds baseline with the default
// kernels. The *Threaded* variants (worker thread on) are timed in wall time and also report
// rays/busiest_cpu_s: rays per CPU second of the busier of the two threads, the rate on two
// otherwise idle cores (the machine is shared, so wall time overstates their cost).
#include <benchmark/benchmark.h>

#include <octomap/OcTree.h>

#include <algorithm>
#include <cstdlib>
#include <ctime>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "bench/mapping/synthetic_scene.h"
#include "mapping/scan_integrator.h"

namespace kestrel::bench {
namespace {

constexpr int kFrames = 8;

const std::vector<DepthFrame>& DepthFramesOf(int width, int height) {
  static std::map<std::pair<int, int>, std::vector<DepthFrame>> cache;
  auto it = cache.find({width, height});
  if (it == cache.end()) {
    it =
        cache.emplace(std::make_pair(width, height), MakeDepthFrames(width, height, kFrames)).first;
  }
  return it->second;
}

const std::vector<ScanFrame>& ScanFrames() {
  static const std::vector<ScanFrame> frames = MakeScanFrames(kFrames);
  return frames;
}

double CpuSeconds(clockid_t clock) {
  timespec ts{};
  clock_gettime(clock, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// CPU seconds of the busier thread over a timed loop (the caller's or all the others').
class BusiestThreadTimer {
 public:
  BusiestThreadTimer()
      : process0_(CpuSeconds(CLOCK_PROCESS_CPUTIME_ID)),
        main0_(CpuSeconds(CLOCK_THREAD_CPUTIME_ID)) {}
  [[nodiscard]] double Seconds() const {
    const double process = CpuSeconds(CLOCK_PROCESS_CPUTIME_ID) - process0_;
    const double main = CpuSeconds(CLOCK_THREAD_CPUTIME_ID) - main0_;
    return std::max(main, process - main);
  }

 private:
  double process0_;
  double main0_;
};

void RunDepth(benchmark::State& state, ScanIntegrator* integrator,
              const SensorModelConfig& model = SensorModelConfig::Xtion()) {
  const auto& frames =
      DepthFramesOf(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  const SensorModel xtion(model);
  ScanStats total;
  size_t f = 0;
  const BusiestThreadTimer busiest;
  for (auto _ : state) {
    const DepthFrame& frame = frames[f++ % frames.size()];
    total += integrator->IntegrateDepthImage(frame.X_WS, frame.intrinsics, frame.depth.data(),
                                             frame.width, frame.height, frame.depth_scale_m, xtion);
  }
  if (integrator->worker_thread()) {
    state.counters["rays/busiest_cpu_s"] =
        static_cast<double>(total.rays_applied) / busiest.Seconds();
  }
  state.counters["rays/s"] =
      benchmark::Counter(static_cast<double>(total.rays_applied), benchmark::Counter::kIsRate);
  state.counters["cells/s"] =
      benchmark::Counter(static_cast<double>(total.cells_updated), benchmark::Counter::kIsRate);
  state.counters["cells/ray"] =
      static_cast<double>(total.cells_updated) / static_cast<double>(total.rays_applied);
  state.counters["no_return"] =
      static_cast<double>(total.rays_no_return) / static_cast<double>(total.rays_applied);
}

void RunScan(benchmark::State& state, ScanIntegrator* integrator) {
  const auto& frames = ScanFrames();
  const SensorModel hokuyo(SensorModelConfig::Hokuyo());
  ScanStats total;
  size_t f = 0;
  const BusiestThreadTimer busiest;
  for (auto _ : state) {
    const ScanFrame& frame = frames[f++ % frames.size()];
    total += integrator->IntegratePlanarScan(frame.X_WS, frame.angle_min_rad, frame.angle_step_rad,
                                             frame.ranges_m.data(),
                                             static_cast<int>(frame.ranges_m.size()), hokuyo);
  }
  if (integrator->worker_thread()) {
    state.counters["rays/busiest_cpu_s"] =
        static_cast<double>(total.rays_applied) / busiest.Seconds();
  }
  state.counters["rays/s"] =
      benchmark::Counter(static_cast<double>(total.rays_applied), benchmark::Counter::kIsRate);
  state.counters["cells/s"] =
      benchmark::Counter(static_cast<double>(total.cells_updated), benchmark::Counter::kIsRate);
  state.counters["cells/ray"] =
      static_cast<double>(total.cells_updated) / static_cast<double>(total.rays_applied);
}

// The exact model with the kernels of instruction set `isa`, on one thread or with the worker.
void BM_KestrelExact_Depth(benchmark::State& state, const std::string& isa, bool threaded) {
  auto map = MakeExactDenseMap(MapLimits{}, OccupancyLimits{}, 4.0);
  ScanIntegrator integrator(map.get(), ScanIntegrator::Options{threaded, isa});
  RunDepth(state, &integrator);
}
// The same with range bands (docs/algorithms.md §3.8: 1 degree, surface within 0.1 m).
void BM_KestrelExactBands_Depth(benchmark::State& state, const std::string& isa) {
  auto map = MakeExactDenseMap(MapLimits{}, OccupancyLimits{}, 4.0);
  ScanIntegrator integrator(map.get(), ScanIntegrator::Options{false, isa});
  SensorModelConfig model = SensorModelConfig::Xtion();
  model.direction_uncertainty_rad = 0.0175;
  model.band_surface_max_m = 0.1;
  RunDepth(state, &integrator, model);
}
void BM_KestrelExactGrowing_Depth(benchmark::State& state, const std::string& isa) {
  auto map = MakeExactGrowingMap(MapLimits{}, OccupancyLimits{}, 4.0);
  ScanIntegrator integrator(map.get(), ScanIntegrator::Options{false, isa});
  RunDepth(state, &integrator);
}
void BM_KestrelExact_Scan682(benchmark::State& state, const std::string& isa, bool threaded) {
  auto map = MakeExactDenseMap(MapLimits{}, OccupancyLimits{}, 4.0);
  ScanIntegrator integrator(map.get(), ScanIntegrator::Options{threaded, isa});
  RunScan(state, &integrator);
}
void BM_KestrelLogOdds_Depth(benchmark::State& state) {
  auto map = MakeLogOddsDenseMap(MapLimits{}, LogOddsConfig{}, 4.0);
  ScanIntegrator integrator(map.get());
  RunDepth(state, &integrator);
}
void BM_KestrelLogOdds_Scan682(benchmark::State& state) {
  auto map = MakeLogOddsDenseMap(MapLimits{}, LogOddsConfig{}, 4.0);
  ScanIntegrator integrator(map.get());
  RunScan(state, &integrator);
}

// OctoMap input: the same rays as end points (no-return rays as points beyond maxrange, which
// OctoMap clears up to maxrange), built before timing.
struct OctoFrame {
  octomap::Pointcloud cloud;
  octomap::point3d origin;
  size_t cells{0};  // free + occupied keys of computeUpdate (OctoMap de-duplicates per scan)
};

octomap::point3d ToOcto(const Eigen::Vector3d& p) {
  return octomap::point3d(static_cast<float>(p.x()), static_cast<float>(p.y()),
                          static_cast<float>(p.z()));
}

std::vector<OctoFrame> OctoDepthFrames(int width, int height) {
  std::vector<OctoFrame> out;
  for (const DepthFrame& frame : DepthFramesOf(width, height)) {
    OctoFrame o;
    o.origin = ToOcto(frame.X_WS.p);
    const Eigen::Matrix3d R = frame.X_WS.rotation();
    for (int v = 0; v < frame.height; ++v) {
      for (int u = 0; u < frame.width; ++u) {
        const Eigen::Vector3d ray_S((u - frame.intrinsics.cx) / frame.intrinsics.fx,
                                    (v - frame.intrinsics.cy) / frame.intrinsics.fy, 1.0);
        const uint16_t raw = frame.depth[static_cast<size_t>(v * frame.width + u)];
        const double range = raw == 0 ? 5.0 : raw * frame.depth_scale_m * ray_S.norm();
        o.cloud.push_back(ToOcto(frame.X_WS.p + range * (R * ray_S.normalized())));
      }
    }
    out.push_back(std::move(o));
  }
  return out;
}

std::vector<OctoFrame> OctoScanFrames() {
  std::vector<OctoFrame> out;
  for (const ScanFrame& frame : ScanFrames()) {
    OctoFrame o;
    o.origin = ToOcto(frame.X_WS.p);
    const Eigen::Matrix3d R = frame.X_WS.rotation();
    for (size_t i = 0; i < frame.ranges_m.size(); ++i) {
      const double a = frame.angle_min_rad + static_cast<double>(i) * frame.angle_step_rad;
      const double range = std::isfinite(frame.ranges_m[i]) ? frame.ranges_m[i] : 5.0;
      o.cloud.push_back(
          ToOcto(frame.X_WS.p + range * (R * Eigen::Vector3d(std::cos(a), std::sin(a), 0.0))));
    }
    out.push_back(std::move(o));
  }
  return out;
}

void RunOcto(benchmark::State& state, std::vector<OctoFrame>& frames) {
  octomap::OcTree tree(0.075);
  for (OctoFrame& f : frames) {
    octomap::KeySet free_cells, occupied_cells;
    tree.computeUpdate(f.cloud, f.origin, free_cells, occupied_cells, 4.0);
    f.cells = free_cells.size() + occupied_cells.size();
  }
  double rays = 0.0, cells = 0.0;
  size_t i = 0;
  for (auto _ : state) {
    const OctoFrame& f = frames[i++ % frames.size()];
    tree.insertPointCloud(f.cloud, f.origin, 4.0, /*lazy_eval=*/false, /*discretize=*/false);
    rays += static_cast<double>(f.cloud.size());
    cells += static_cast<double>(f.cells);
  }
  state.counters["rays/s"] = benchmark::Counter(rays, benchmark::Counter::kIsRate);
  state.counters["cells/s"] = benchmark::Counter(cells, benchmark::Counter::kIsRate);
  state.counters["cells/ray"] = cells / rays;
}

void BM_OctoMap_Depth(benchmark::State& state) {
  std::vector<OctoFrame> frames =
      OctoDepthFrames(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  RunOcto(state, frames);
}
void BM_OctoMap_Scan682(benchmark::State& state) {
  std::vector<OctoFrame> frames = OctoScanFrames();
  RunOcto(state, frames);
}

// Registers every benchmark, workload by workload (each depth resolution, then the scan): the
// exact model once per instruction set, on one thread and with the worker, then the log-odds
// baseline and OctoMap. The instruction sets are those this CPU runs
// (ScanIntegrator::SupportedInstructionSets), or the one KESTREL_ISA names.
void RegisterAll() {
  std::vector<std::string> isas = ScanIntegrator::SupportedInstructionSets();
  const char* forced = std::getenv("KESTREL_ISA");
  if (forced != nullptr && forced[0] != '\0') isas = {ScanIntegrator::ResolveInstructionSet("")};
  const auto name = [](const char* what, const std::string& isa, const char* kind) {
    return std::string("BM_") + what + "_" + isa + "_" + kind;
  };
  for (const auto& [width, height] : {std::pair{160, 120}, {320, 240}, {640, 480}}) {
    for (const bool threaded : {false, true}) {
      for (const std::string& isa : isas) {
        auto* b = benchmark::RegisterBenchmark(
            name(threaded ? "KestrelExactThreaded" : "KestrelExact", isa, "Depth").c_str(),
            BM_KestrelExact_Depth, isa, threaded);
        b->Args({width, height})->Unit(benchmark::kMillisecond);
        if (threaded) b->UseRealTime();
      }
    }
    benchmark::RegisterBenchmark(name("KestrelExactBands", isas.back(), "Depth").c_str(),
                                 BM_KestrelExactBands_Depth, isas.back())
        ->Args({width, height})
        ->Unit(benchmark::kMillisecond);
    if (width == 160) {
      for (const std::string& isa : isas) {
        benchmark::RegisterBenchmark(name("KestrelExactGrowing", isa, "Depth").c_str(),
                                     BM_KestrelExactGrowing_Depth, isa)
            ->Args({width, height})
            ->Unit(benchmark::kMillisecond);
      }
    }
    for (auto* b :
         {benchmark::RegisterBenchmark("BM_KestrelLogOdds_Depth", BM_KestrelLogOdds_Depth),
          benchmark::RegisterBenchmark("BM_OctoMap_Depth", BM_OctoMap_Depth)}) {
      b->Args({width, height})->Unit(benchmark::kMillisecond);
    }
  }
  for (const bool threaded : {false, true}) {
    for (const std::string& isa : isas) {
      auto* b = benchmark::RegisterBenchmark(
          name(threaded ? "KestrelExactThreaded" : "KestrelExact", isa, "Scan682").c_str(),
          BM_KestrelExact_Scan682, isa, threaded);
      b->Unit(benchmark::kMicrosecond);
      if (threaded) b->UseRealTime();
    }
  }
  benchmark::RegisterBenchmark("BM_KestrelLogOdds_Scan682", BM_KestrelLogOdds_Scan682)
      ->Unit(benchmark::kMicrosecond);
  benchmark::RegisterBenchmark("BM_OctoMap_Scan682", BM_OctoMap_Scan682)
      ->Unit(benchmark::kMicrosecond);
}

}  // namespace
}  // namespace kestrel::bench

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  kestrel::bench::RegisterAll();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
