// OctoMap as a peer on Kestrel's lattice (tools/fidelity/octomap_peer.h): a return marks the
// cell Kestrel's grid puts its end point in, with OctoMap's hit, and the cells the ray crosses
// before it with OctoMap's miss, on a grid whose corner is not a multiple of the resolution.
#include "tools/fidelity/octomap_peer.h"

#include <gtest/gtest.h>

#include <cmath>

namespace kestrel {
namespace {

TEST(OctoMapPeer, PutsHitsAndMissesInKestrelsCells) {
  GridSpec grid;
  grid.min_m = Eigen::Vector3d(-4.0, -6.0, -0.15);  // -53.3, -80, -2 cells of 7.5 cm
  grid.resolution_m = 0.075;
  grid.dims = Eigen::Vector3i(107, 160, 22);
  OctoMapPeer peer(grid);
  const auto cell_of = [&](const Eigen::Vector3d& p) {
    return ((p - grid.min_m) / grid.resolution_m).array().floor().cast<int>().matrix().eval();
  };
  SensorModelConfig mc = SensorModelConfig::Xtion();
  const SensorModel model(mc);
  SensorRay ray;
  ray.origin_W = Eigen::Vector3d(0.31, -1.17, 0.93);
  ray.direction_W = Eigen::Vector3d(1.0, 0.4, -0.1).normalized();
  ray.reading = model.Classify(2.5);
  ASSERT_EQ(ray.reading.kind, ReadingKind::kReturn);
  SensorRay no_return = ray;
  no_return.direction_W = Eigen::Vector3d(-1.0, 0.0, 0.0);
  no_return.reading = model.Classify(std::numeric_limits<double>::infinity());
  peer.InsertScan({ray, no_return}, 4.0);
  EXPECT_EQ(peer.scans(), 1);

  const Eigen::Vector3d end = ray.origin_W + 2.5 * ray.direction_W;
  EXPECT_NEAR(peer.ProbabilityAt(cell_of(end)), 0.7, 1e-6);
  // Cells well inside the ray's path (away from the end cell): OctoMap's miss.
  for (double t = 0.05; t < 2.4; t += 0.1) {
    const Eigen::Vector3i c = cell_of(ray.origin_W + t * ray.direction_W);
    if (c == cell_of(end)) continue;
    EXPECT_NEAR(peer.ProbabilityAt(c), 0.4, 1e-6) << t;
  }
  // Beyond the return, off the ray, and along the no-return ray: untouched.
  EXPECT_EQ(peer.ProbabilityAt(cell_of(ray.origin_W + 3.0 * ray.direction_W), -1.0), -1.0);
  EXPECT_EQ(peer.ProbabilityAt(cell_of(ray.origin_W + Eigen::Vector3d(0, 0.5, 0)), -1.0), -1.0);
  EXPECT_EQ(peer.ProbabilityAt(cell_of(ray.origin_W + Eigen::Vector3d(-1.0, 0, 0)), -1.0), -1.0);
}

TEST(OctoMapPeer, RefusesRaysFromTwoOrigins) {
  GridSpec grid;
  grid.dims = Eigen::Vector3i(10, 10, 10);
  OctoMapPeer peer(grid);
  SensorRay a, b;
  b.origin_W = Eigen::Vector3d(0.1, 0, 0);
  EXPECT_THROW(peer.InsertScan({a, b}, 4.0), std::invalid_argument);
}

}  // namespace
}  // namespace kestrel
