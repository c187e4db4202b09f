// The claims a map makes without grounds (tools/map_score/map_claims.h,
// docs/algorithms.md §12.5), each counted on a hand-built map against a room whose answer is known
// cell by cell.
#include "tools/map_score/map_claims.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "sim/ray_reach.h"

namespace kestrel {
namespace {

// A closed 3 x 2 m room (walls 0.24 m thick, a floor and a roof outside the grid), on a 0.1 m
// grid from (-0.5, -0.5, 0) to (3.5, 2.5, 1); the start at (1.5, 1, 0) flies at 0.5 m.
class MapClaimsTest : public ::testing::Test {
 protected:
  MapClaimsTest() : grid_(GridSpec::FromLimits({-0.5, -0.5, 0}, {3.5, 2.5, 1.0}, 0.1)) {
    const auto wall = [&](Eigen::Vector3d lo, Eigen::Vector3d hi) {
      WorldBox b;
      b.center_m = 0.5 * (lo + hi);
      b.half_extents_m = 0.5 * (hi - lo);
      world_.boxes.push_back(b);
    };
    // Faces off the cells' centres and edges, so that no depth is a tie with half a cell.
    wall({-0.22, -0.22, 0}, {0.02, 2.22, 1});  // west
    wall({2.98, -0.22, 0}, {3.22, 2.22, 1});   // east
    wall({0, -0.22, 0}, {3, 0.02, 1});         // south
    wall({0, 1.98, 0}, {3, 2.22, 1});          // north
    world_.start_X_WB.p = Eigen::Vector3d(1.5, 1.0, 0.0);
    world_.exploration_height_m = 0.5;
    truth_ = VoxelizeWorld(world_, grid_);
  }
  size_t At(double x, double y, double z) const {
    return grid_.IndexOf(Eigen::Vector3i(static_cast<int>(std::floor((x + 0.5) / 0.1)),
                                         static_cast<int>(std::floor((y + 0.5) / 0.1)),
                                         static_cast<int>(std::floor(z / 0.1))));
  }

  GridSpec grid_;
  World world_;
  std::vector<uint8_t> truth_;
};

TEST_F(MapClaimsTest, CountsEachKindOfClaim) {
  const ClaimTracker tracker(world_, grid_, truth_);
  // The cells centred at x = -0.05 and 3.05 lie 7 cm deep in the west and east walls (more than
  // half a cell): in solid. The one at 3.35 is just outside the east wall, the one at -0.45
  // farther out: outside, not in solid.
  std::vector<uint8_t> known_free(grid_.size(), 0);
  for (const size_t i : {At(1, 1, 0.5), At(2, 1, 0.5), At(-0.05, 1.05, 0.55), At(3.05, 1.05, 0.55),
                         At(3.35, 1.05, 0.55), At(-0.45, 1.05, 0.55)}) {
    known_free[i] = 1;
  }
  EXPECT_EQ(tracker.in_solid()[At(-0.05, 1.05, 0.55)], 1);
  EXPECT_EQ(tracker.in_solid()[At(3.35, 1.05, 0.55)], 0);
  const MapClaims c = tracker.Claims(known_free);
  EXPECT_EQ(c.known_free, 6u);
  EXPECT_EQ(c.free_in_solid, 2u);
  EXPECT_EQ(c.free_outside, 2u);
  EXPECT_EQ(tracker.outside()[At(1, 1, 0.5)], 0);
  EXPECT_EQ(tracker.outside()[At(0.05, 1.05, 0.55)], 0) << "the wall's cell (partly solid)";
  EXPECT_EQ(tracker.outside()[At(3.35, 1.05, 0.55)], 1);
  EXPECT_EQ(c.free_unreached, -1) << "no reach record";
  EXPECT_EQ(c.freed_early, -1);
  EXPECT_FALSE(c.none());
}

// With a reach record: cells known free that no ray reached, and cells freed before any did,
// with the largest lead; a map that claims only reached cells, after they were reached, has
// nothing to answer for.
TEST_F(MapClaimsTest, UnreachedAndFreedEarlyAgainstTheReachRecord) {
  RayReach reach(grid_);
  reach.AddRay({0.55, 1.05, 0.55}, {1, 0, 0}, 1.0, 10.0);  // x 0.55 .. 1.55 at t = 10 s
  ClaimTracker tracker(world_, grid_, truth_);
  std::vector<uint8_t> free_at_5(grid_.size(), 0), free_at_20(grid_.size(), 0);
  free_at_5[At(1.05, 1.05, 0.55)] = 1;  // 5 s before the ray got there
  free_at_20 = free_at_5;
  free_at_20[At(1.25, 1.05, 0.55)] = 1;
  free_at_20[At(2.55, 1.05, 0.55)] = 1;  // beyond the ray's end: never reached
  tracker.Sample(5.0, free_at_5);
  tracker.Sample(20.0, free_at_20);
  const MapClaims c = tracker.Claims(free_at_20, &reach.first_reach_s());
  EXPECT_EQ(c.known_free, 3u);
  EXPECT_EQ(c.free_unreached, 1);
  EXPECT_EQ(c.freed_early, 2) << "the cell freed at 5 s, and the one never reached";
  EXPECT_DOUBLE_EQ(c.max_lead_s, 5.0);

  ClaimTracker honest(world_, grid_, truth_);
  std::vector<uint8_t> later(grid_.size(), 0);
  later[At(1.05, 1.05, 0.55)] = later[At(1.25, 1.05, 0.55)] = 1;
  honest.Sample(12.0, later);
  const MapClaims h = honest.Claims(later, &reach.first_reach_s());
  EXPECT_TRUE(h.none());
  EXPECT_EQ(h.free_unreached, 0);
  EXPECT_EQ(h.freed_early, 0);
}

TEST(KnownFree, EachMapsOwnRule) {
  const std::vector<double> p{0.01, 0.05, 0.049, 0.2, 0.6};
  EXPECT_EQ(KnownFreeBelow(p, 0.1), (std::vector<uint8_t>{1, 0, 1, 0, 0}));
  EXPECT_EQ(KnownFreeBelow(p, 0.5), (std::vector<uint8_t>{1, 1, 1, 1, 0}));
  EXPECT_EQ(KnownFreeObserved(p, {1, 1, 0, 1, 1}), (std::vector<uint8_t>{1, 1, 0, 1, 0}));
}

}  // namespace
}  // namespace kestrel
