// Information sites and travel times (exploration/info_sites.h) on a small synthetic grid.
#include "exploration/info_sites.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

namespace kestrel {
namespace {

// A 10 x 10 m grid of 0.25 m cells (40 x 40), traversable but for a 2 m band (a wall and the
// clearance either side of it, as the fine traversability leaves them) at x in [4, 6) m with a
// 1.5 m gap at y in [1, 2.5) m.
struct Fixture {
  GridMap2D grid = GridMap2D::Filled({0.0, 0.0}, 0.25, 1.0, 40, 40, 0.0);
  std::vector<bool> traversable = std::vector<bool>(1600, true);
  Fixture() {
    for (int y = 0; y < 40; ++y) {
      if (y >= 4 && y < 10) continue;
      for (int x = 16; x < 24; ++x) traversable[static_cast<size_t>(grid.IndexOf(x, y))] = false;
    }
  }
  SitePose Pose(int x, int y, double yaw, double gain) const {
    return SitePose{grid.IndexOf(x, y), grid.CenterOf({x, y}), yaw, gain};
  }
};

// Poses near two unknown regions (around (1.5, 1.5) m and (8, 8) m) hold gain; poses elsewhere
// hold less than the threshold. The sites are the two tiles of 4 m holding the gainful poses, each
// with its best pose.
TEST(InfoSites, GroupsGainfulPosesIntoTiles) {
  Fixture f;
  std::vector<SitePose> poses = {
      f.Pose(5, 6, 0.0, 12.0),   f.Pose(6, 6, 1.0, 30.0),
      f.Pose(3, 2, 2.0, 9.0),    f.Pose(33, 33, 0.5, 20.0),
      f.Pose(35, 34, 0.0, 25.0), f.Pose(20, 20, 0.0, 3.9),  // below the threshold: no site
      f.Pose(10, 30, 0.0, 1.0),
  };
  const std::vector<InfoSite> sites = GroupSites(f.grid, poses, 16, 4.0);
  ASSERT_EQ(sites.size(), 2U);
  EXPECT_EQ(sites[0].tile, 0);          // cells x, y in [0, 16)
  EXPECT_EQ(sites[1].tile, 2 + 3 * 2);  // three tiles along x, tile (2, 2)
  EXPECT_EQ(sites[0].best.cell, f.grid.IndexOf(6, 6));
  EXPECT_DOUBLE_EQ(sites[0].best.gain_nats, 30.0);
  EXPECT_EQ(sites[0].poses, 3);
  EXPECT_DOUBLE_EQ(sites[0].total_gain_nats, 51.0);
  EXPECT_EQ(sites[1].best.cell, f.grid.IndexOf(35, 34));
  EXPECT_EQ(sites[1].poses, 2);
  EXPECT_TRUE(GroupSites(f.grid, poses, 16, 31.0).empty());
  EXPECT_THROW((void)GroupSites(f.grid, poses, 0, 4.0), std::invalid_argument);
}

// Every entry equals the Dijkstra path length between the poses (around the wall, through its
// gap; with random step weights) over the speed, or the turn over the yaw rate when that takes
// longer; the vehicle's row comes from its own field; the return to the vehicle costs nothing.
TEST(InfoSites, TravelTimesAreDijkstraTimes) {
  Fixture f;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(1.0, 3.0);
  std::vector<double> weight(1600);
  for (double& w : weight) w = u(rng);
  const std::vector<SitePose> poses = {f.Pose(5, 30, 0.0, 10.0), f.Pose(35, 30, 0.0, 10.0),
                                       f.Pose(35, 5, 0.0, 10.0), f.Pose(36, 5, M_PI, 10.0)};
  const std::vector<InfoSite> sites = GroupSites(f.grid, poses, 1, 4.0);
  ASSERT_EQ(sites.size(), 4U);
  const DistanceField vehicle = ComputeDistanceField(40, 40, f.traversable, {2, 2}, 0.25, weight);
  TravelTimeConfig config;
  config.speed_mps = 0.8;
  config.yaw_rate_radps = 0.5;
  const TourProblem p =
      TravelTimes(vehicle, 0.0, sites, 40, 40, f.traversable, 0.25, weight, config);
  ASSERT_EQ(p.n, 5);
  for (int i = 0; i <= 4; ++i) {
    const SitePose* a = i == 0 ? nullptr : &sites[static_cast<size_t>(i - 1)].best;
    const DistanceField field =
        a == nullptr
            ? vehicle
            : ComputeDistanceField(40, 40, f.traversable, f.grid.CellAt(a->cell), 0.25, weight);
    const double yaw_a = a == nullptr ? 0.0 : a->yaw_rad;
    for (int j = 1; j <= 4; ++j) {
      if (i == j) continue;
      const SitePose& b = sites[static_cast<size_t>(j - 1)].best;
      const double d = field.distance_m[static_cast<size_t>(b.cell)];
      const double turn = std::abs(std::remainder(b.yaw_rad - yaw_a, 2.0 * M_PI));
      EXPECT_NEAR(p.c(i, j), std::max(d / 0.8, turn / 0.5), 1e-9) << i << " -> " << j;
    }
    if (i > 0) {
      EXPECT_EQ(p.c(i, 0), 0.0);
    }
  }
  // Nodes in tile order: 1 (35, 5), 2 (36, 5) facing the other way, 3 (5, 30), 4 (35, 30).
  // Around the wall: (5, 30) to (35, 30) goes through the gap, much longer than straight.
  EXPECT_GT(p.c(3, 4), 1.5 * 7.5 / 0.8);
  // Next door but facing the other way: the turn decides (pi / 0.5 s).
  EXPECT_NEAR(p.c(1, 2), M_PI / 0.5, 1e-9);
  EXPECT_NEAR(p.c(2, 1), M_PI / 0.5, 1e-9);
}

// On a grid coarsened 4 times the site-to-site times stay within two coarse cells' diagonal of
// the exact ones (unit weights), and the vehicle's row stays exact. (A coarse cell is usable when
// any of its cells is, so an untraversable band narrower than two coarse cells would let the
// coarse search cut through it; the fine traversability's band around a wall is at least
// 2 (radius + margin) = 1.08 m, 14 cells of 7.5 cm, which holds two whole coarse cells of 4.)
TEST(InfoSites, CoarseTravelTimesStayClose) {
  Fixture f;
  const std::vector<SitePose> poses = {f.Pose(5, 30, 0.0, 10.0), f.Pose(35, 30, 0.0, 10.0),
                                       f.Pose(35, 5, 0.0, 10.0)};
  const std::vector<InfoSite> sites = GroupSites(f.grid, poses, 1, 4.0);
  const DistanceField vehicle = ComputeDistanceField(40, 40, f.traversable, {2, 2}, 0.25);
  TravelTimeConfig exact;
  TravelTimeConfig coarse;
  coarse.coarsen = 4;
  const TourProblem a = TravelTimes(vehicle, 0.0, sites, 40, 40, f.traversable, 0.25, {}, exact);
  const TourProblem b = TravelTimes(vehicle, 0.0, sites, 40, 40, f.traversable, 0.25, {}, coarse);
  for (int i = 0; i < 4; ++i) {
    for (int j = 1; j < 4; ++j) {
      if (i == j) continue;
      if (i == 0) {
        EXPECT_DOUBLE_EQ(a.c(i, j), b.c(i, j));
      } else {
        EXPECT_NEAR(a.c(i, j), b.c(i, j), 2.0 * std::sqrt(2.0) * 1.0) << i << " -> " << j;
      }
    }
  }
}

}  // namespace
}  // namespace kestrel
