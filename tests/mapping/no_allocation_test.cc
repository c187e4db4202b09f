// Counts every operator new in this test binary, to show that applying a ray allocates nothing
// once the map and its scratch exist (docs/algorithms.md §4.5).
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>
#include <vector>

#include "mapping/occupancy_map.h"
#include "mapping/scan_integrator.h"

namespace {
std::atomic<uint64_t> g_allocations{0};
}  // namespace

// The replacements pair malloc with free, as they must; GCC (12, at -O1) still takes the free
// in a replaced operator delete for a mismatch with operator new.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
void* operator new(std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
#pragma GCC diagnostic pop

namespace kestrel {
namespace {

// The counter works: a vector allocates.
TEST(NoAllocation, CounterSeesAllocations) {
  const uint64_t before = g_allocations.load();
  std::vector<int> v(100);
  EXPECT_GT(g_allocations.load(), before);
  EXPECT_EQ(v.size(), 100u);
}

// Given a map, its integrator and sensor models, When thousands of rays, a depth image and a scan
// are applied, Then no allocation happens (dense exact, dense log-odds; growing exact once its
// blocks exist; with the worker thread).
TEST(NoAllocation, ApplyingRaysAllocatesNothing) {
  auto exact = MakeExactDenseMap(MapLimits{}, OccupancyLimits{}, 4.0);
  auto log_odds = MakeLogOddsDenseMap(MapLimits{}, LogOddsConfig{}, 4.0);
  auto growing = MakeExactGrowingMap(MapLimits{}, OccupancyLimits{}, 4.0);
  ScanIntegrator into_exact(exact.get());
  ScanIntegrator into_log_odds(log_odds.get());
  ScanIntegrator into_growing(growing.get());
  const SensorModel xtion(SensorModelConfig::Xtion());
  const SensorModel hokuyo(SensorModelConfig::Hokuyo());
  std::vector<uint16_t> depth(80 * 60);
  for (size_t i = 0; i < depth.size(); ++i)
    depth[i] = static_cast<uint16_t>(i % 7 == 0 ? 0 : 600 + i % 3000);
  std::vector<float> ranges(682);
  for (size_t i = 0; i < ranges.size(); ++i) ranges[i] = 0.6f + 0.005f * static_cast<float>(i);
  Pose3 X_WS;
  X_WS.p = Eigen::Vector3d(0.1, 0.2, 0.7);
  const DepthIntrinsics in{75.0, 75.0, 40.0, 30.0};
  const auto apply_all = [&](ScanIntegrator* integrator) {
    for (int i = 0; i < 2000; ++i) {
      const double a = 0.01 * i;
      integrator->IntegrateRay(X_WS.p, Eigen::Vector3d(std::cos(a), std::sin(a), 0.0),
                               0.5 + 0.001 * i, i % 2 ? xtion : hokuyo);
    }
    integrator->IntegrateDepthImage(X_WS, in, depth.data(), 80, 60, 0.001, xtion);
    integrator->IntegratePlanarScan(X_WS, -2.0, 0.006, ranges.data(), 682, hokuyo);
  };
  apply_all(&into_growing);  // allocates its blocks
  auto threaded = MakeExactDenseMap(MapLimits{}, OccupancyLimits{}, 4.0);
  // Creates the worker and its batches once.
  ScanIntegrator into_threaded(threaded.get(), ScanIntegrator::Options{true, ""});
  const uint64_t before = g_allocations.load();
  apply_all(&into_exact);
  apply_all(&into_log_odds);
  apply_all(&into_growing);   // same rays again: blocks exist
  apply_all(&into_threaded);  // scans cast on the worker thread
  EXPECT_EQ(g_allocations.load(), before);
}

}  // namespace
}  // namespace kestrel
