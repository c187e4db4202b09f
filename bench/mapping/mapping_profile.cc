// Fixed-work mapping driver for instruction counts (valgrind --tool=callgrind, perf stat) and
// thread-CPU timing on a shared machine, on the same synthetic frames as mapping_bench.
//
//   mapping_profile <exact|exact_growing|log_odds> <160|320|640|scan> [frames] [threads]
//
// Warms up with every frame once (the map reaches its steady state), then applies `frames`
// frames (default 16) inside a callgrind instrumentation window and prints rays, cells, the
// CPU time of every thread of the process, the wall time, rays per CPU second, and the map hash
// and entropy (identical inputs must give identical hashes, whatever `threads` is).
// threads = 2 enables the scan integrator's worker thread. KESTREL_ISA=<name> forces an
// instruction set's kernels (scalar, sse4, avx2, avx3, ...; printed as isa=).
#if __has_include(<valgrind/callgrind.h>)
#include <valgrind/callgrind.h>
#else  // without valgrind's header (Debian package valgrind) the window marks are no-ops
#define CALLGRIND_START_INSTRUMENTATION
#define CALLGRIND_STOP_INSTRUMENTATION
#endif

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>

#include "bench/mapping/synthetic_scene.h"

namespace kestrel::bench {
namespace {

double CpuSeconds(clockid_t clock) {
  timespec ts{};
  clock_gettime(clock, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

template <class Map>
int Run(Map* map, const std::string& kind, int frames, int threads) {
  ScanIntegrator integrator(map, ScanIntegrator::Options{threads >= 2, ""});
  const SensorModel xtion(SensorModelConfig::Xtion());
  const SensorModel hokuyo(SensorModelConfig::Hokuyo());
  std::vector<DepthFrame> depth;
  std::vector<ScanFrame> scans;
  constexpr int kFrames = 8;
  if (kind == "scan") {
    scans = MakeScanFrames(kFrames);
  } else {
    const int w = std::atoi(kind.c_str());
    if (w != 160 && w != 320 && w != 640) {
      std::fprintf(stderr, "unknown kind %s\n", kind.c_str());
      return 2;
    }
    depth = MakeDepthFrames(w, w * 3 / 4, kFrames);
  }
  const auto apply = [&](int f) {
    if (!scans.empty()) {
      const ScanFrame& s = scans[static_cast<size_t>(f % kFrames)];
      return integrator.IntegratePlanarScan(s.X_WS, s.angle_min_rad, s.angle_step_rad,
                                            s.ranges_m.data(), static_cast<int>(s.ranges_m.size()),
                                            hokuyo);
    }
    const DepthFrame& d = depth[static_cast<size_t>(f % kFrames)];
    return integrator.IntegrateDepthImage(d.X_WS, d.intrinsics, d.depth.data(), d.width, d.height,
                                          d.depth_scale_m, xtion);
  };
  for (int f = 0; f < kFrames; ++f) apply(f);  // warm-up: steady-state map
  ScanStats total;
  const double cpu0 = CpuSeconds(CLOCK_PROCESS_CPUTIME_ID);
  const double main0 = CpuSeconds(CLOCK_THREAD_CPUTIME_ID);
  const auto wall0 = std::chrono::steady_clock::now();
  CALLGRIND_START_INSTRUMENTATION;
  for (int f = 0; f < frames; ++f) {
    total += apply(f);
    [[maybe_unused]] volatile double h = map->entropy_nats();  // queried after every frame
  }
  CALLGRIND_STOP_INSTRUMENTATION;
  const double cpu = CpuSeconds(CLOCK_PROCESS_CPUTIME_ID) - cpu0;
  const double main_cpu = CpuSeconds(CLOCK_THREAD_CPUTIME_ID) - main0;
  // With a worker thread, the rate on two otherwise idle cores is bounded by the busier
  // thread: rays / max(main thread CPU, other threads' CPU).
  const double busiest = std::max(main_cpu, cpu - main_cpu);
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  std::printf(
      "%s %s isa=%s frames=%d threads=%d rays=%llu cells=%llu cpu_s=%.4f main_cpu_s=%.4f "
      "wall_s=%.4f "
      "rays_per_cpu_s=%.3fM rays_per_busiest_thread_cpu_s=%.3fM rays_per_wall_s=%.3fM "
      "hash=%016llx entropy=%.17g\n",
      map->updater().name(), kind.c_str(), integrator.instruction_set(), frames, threads,
      static_cast<unsigned long long>(total.rays_applied),
      static_cast<unsigned long long>(total.cells_updated), cpu, main_cpu, wall,
      1e-6 * static_cast<double>(total.rays_applied) / cpu,
      1e-6 * static_cast<double>(total.rays_applied) / busiest,
      1e-6 * static_cast<double>(total.rays_applied) / wall,
      static_cast<unsigned long long>(map->Hash()), map->entropy_nats());
  return 0;
}

}  // namespace
}  // namespace kestrel::bench

int main(int argc, char** argv) {
  using namespace kestrel;
  if (argc < 3) {
    std::fprintf(stderr,
                 "usage: %s <exact|exact_growing|log_odds> <160|320|640|scan> [frames] "
                 "[threads]\n",
                 argv[0]);
    return 2;
  }
  const std::string model = argv[1];
  const std::string kind = argv[2];
  const int frames = argc > 3 ? std::atoi(argv[3]) : 16;
  const int threads = argc > 4 ? std::atoi(argv[4]) : 1;
  if (model == "exact") {
    auto map = MakeExactDenseMap(MapLimits{}, OccupancyLimits{}, 4.0);
    return bench::Run(map.get(), kind, frames, threads);
  }
  if (model == "exact_growing") {
    auto map = MakeExactGrowingMap(MapLimits{}, OccupancyLimits{}, 4.0);
    return bench::Run(map.get(), kind, frames, threads);
  }
  if (model == "log_odds") {
    auto map = MakeLogOddsDenseMap(MapLimits{}, LogOddsConfig{}, 4.0);
    return bench::Run(map.get(), kind, frames, threads);
  }
  std::fprintf(stderr, "unknown model %s\n", model.c_str());
  return 2;
}
