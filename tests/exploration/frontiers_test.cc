// Frontiers on the fine traversability (exploration/frontiers.h): frontier cells against their
// definition by brute force, enclosed unknown space, sight, covered cells and the best heading;
// and the frontier baseline's choice on a 3D map (exploration/fine_frontier_planner.h).
#include "exploration/frontiers.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "exploration/fine_frontier_planner.h"
#include "exploration/planner.h"
#include "tests/exploration/test_input.h"

namespace kestrel {
namespace {

constexpr double kAlpha = 0.1;
constexpr double kFreeThreshold = 0.05;
constexpr float kFree = 1e-4f, kUnknown = 0.1f, kOccupied = 0.9999f;

// A band of w x h cells from (0, 0) at kAlpha, every cell `fill`; unknown follows the values as
// ComputeTraversability defines it (P in [P_init / 2, 0.5]).
struct Band {
  Traversability t;
  Band(int w, int h, float fill) {
    t.band = GridMap2D::Filled(Eigen::Vector2d::Zero(), kAlpha, 0.75, w, h, fill);
    Sync();
  }
  void Set(int x, int y, float p) { t.band.values[static_cast<size_t>(t.band.IndexOf(x, y))] = p; }
  // Every cell whose centre lies in [x0, x1) x [y0, y1) (m).
  void Rect(double x0, double y0, double x1, double y1, float p) {
    for (int y = 0; y < t.band.height; ++y) {
      for (int x = 0; x < t.band.width; ++x) {
        const Eigen::Vector2d c = t.band.CenterOf({x, y});
        if (c.x() >= x0 && c.x() < x1 && c.y() >= y0 && c.y() < y1) Set(x, y, p);
      }
    }
  }
  void Sync() {
    t.unknown.assign(t.band.values.size(), false);
    for (size_t i = 0; i < t.band.values.size(); ++i) {
      t.unknown[i] = t.band.values[i] >= 0.05 && t.band.values[i] <= 0.5;
    }
  }
  int Index(double x, double y) const { return t.band.IndexOf(*t.band.CellOf({x, y})); }
};

TEST(Frontiers, CellsMatchTheirDefinitionByBruteForce) {
  std::mt19937 rng(7);
  const float kinds[] = {kFree, kUnknown, kOccupied, 0.03f, 0.3f};
  for (int trial = 0; trial < 20; ++trial) {
    Band b(17, 11, kFree);
    std::uniform_int_distribution<int> pick(0, 4);
    for (double& v : b.t.band.values) v = kinds[pick(rng)];
    b.Sync();
    const std::vector<bool> f = FrontierCells(b.t, kFreeThreshold);
    for (int y = 0; y < 11; ++y) {
      for (int x = 0; x < 17; ++x) {
        bool expected = false;
        if (b.t.unknown[static_cast<size_t>(b.t.band.IndexOf(x, y))]) {
          const int dx[] = {1, -1, 0, 0}, dy[] = {0, 0, 1, -1};
          for (int k = 0; k < 4; ++k) {
            const int nx = x + dx[k], ny = y + dy[k];
            if (nx < 0 || ny < 0 || nx >= 17 || ny >= 11) continue;
            expected = expected || b.t.band.values[static_cast<size_t>(b.t.band.IndexOf(nx, ny))] <=
                                       kFreeThreshold;
          }
        }
        EXPECT_EQ(f[static_cast<size_t>(b.t.band.IndexOf(x, y))], expected)
            << "trial " << trial << " cell " << x << ", " << y;
      }
    }
  }
}

TEST(Frontiers, UnknownSpaceEnclosedByOccupiedCellsIsNoFrontier) {
  // Free 4 x 3 m; a solid block (walls occupied, inside never seen) and, east, an open unknown
  // strip beyond x = 3.5.
  Band b(40, 30, kFree);
  b.Rect(1.0, 1.0, 2.0, 2.0, kOccupied);
  b.Rect(1.1, 1.1, 1.9, 1.9, kUnknown);
  b.Rect(3.5, 0.0, 4.0, 3.0, kUnknown);
  b.Sync();
  const std::vector<bool> f = FrontierCells(b.t, kFreeThreshold);
  int count = 0;
  for (int y = 0; y < 30; ++y) {
    for (int x = 0; x < 40; ++x) {
      const bool is = f[static_cast<size_t>(b.t.band.IndexOf(x, y))];
      count += is;
      if (is) {
        EXPECT_EQ(x, 35) << "only the strip's west edge, not the block's inside";
      }
    }
  }
  EXPECT_EQ(count, 30);
}

TEST(Frontiers, SightNeedsKnownFreeCellsOnTheWay) {
  Band b(40, 10, kFree);
  b.Rect(2.0, 0.0, 2.1, 0.5, kOccupied);  // a wall across the lower half
  b.Rect(2.0, 0.5, 2.1, 0.7, kUnknown);   // and an unknown patch above it
  b.Sync();
  const int target_low = b.Index(3.05, 0.25), target_high = b.Index(3.05, 0.85);
  EXPECT_FALSE(InSight(b.t.band, {0.55, 0.25}, target_low, kFreeThreshold)) << "behind the wall";
  EXPECT_TRUE(InSight(b.t.band, {0.55, 0.85}, target_high, kFreeThreshold));
  EXPECT_FALSE(InSight(b.t.band, {0.55, 0.6}, b.Index(3.05, 0.6), kFreeThreshold))
      << "past uncertain space";
  // What a reached view covered: only known occupied cells hide a cell.
  EXPECT_TRUE(InSight(b.t.band, {0.55, 0.6}, b.Index(3.05, 0.6), kOccupiedBandP));
  EXPECT_FALSE(InSight(b.t.band, {0.55, 0.25}, target_low, kOccupiedBandP)) << "behind the wall";
  // The target itself may be anything (it is the frontier being looked at).
  b.Set(30, 8, kUnknown);
  EXPECT_TRUE(InSight(b.t.band, {0.55, 0.85}, b.t.band.IndexOf(30, 8), kFreeThreshold));
}

TEST(Frontiers, AViewClearsWhatItCoveredOnly) {
  // Unknown strip east of x = 3.0 (frontier column x = 3.05); a view at (1.0, 1.5).
  Band b(40, 30, kFree);
  b.Rect(3.0, 0.0, 4.0, 3.0, kUnknown);
  b.Rect(1.5, 2.2, 1.6, 3.0, kOccupied);  // a wall that hides the strip's north end from the view
  b.Sync();
  const FrontierView view{0.7, 4.0, 60.0 * M_PI / 180.0};
  const std::vector<bool> all = FrontierCells(b.t, kFreeThreshold);
  auto cleared_by = [&](const Eigen::Vector3d& v) {
    std::vector<bool> f = all;
    const int n = ClearCoveredFrontiers(b.t.band, {v}, view, &f);
    std::vector<int> rows;
    for (int y = 0; y < 30; ++y) {
      if (all[static_cast<size_t>(b.t.band.IndexOf(30, y))] &&
          !f[static_cast<size_t>(b.t.band.IndexOf(30, y))]) {
        rows.push_back(y);
      }
    }
    EXPECT_EQ(static_cast<int>(rows.size()), n);
    return rows;
  };
  // Facing east: the rows within +-30 deg of east and in sight: |y - 1.5| <= 2.05 tan 30 = 1.18.
  const std::vector<int> east = cleared_by({1.0, 1.5, 0.0});
  ASSERT_FALSE(east.empty());
  for (const int y : east) {
    const double cy = (y + 0.5) * kAlpha;
    EXPECT_LE(std::abs(std::atan2(cy - 1.5, 2.05)), 30.0 * M_PI / 180.0 + 1e-9);
    EXPECT_TRUE(InSight(b.t.band, {1.0, 1.5}, b.t.band.IndexOf(30, y), kFreeThreshold));
  }
  EXPECT_EQ(east.size(), 24u);  // rows 3..26: within the field of view (brute-force count)
  EXPECT_TRUE(cleared_by({1.0, 1.5, M_PI}).empty()) << "facing away";
  EXPECT_TRUE(cleared_by({2.7, 1.5, 0.0}).empty()) << "nearer than the minimum range";
  EXPECT_TRUE(cleared_by({1.0, 2.8, 0.0}).size() < 8u) << "the wall hides most of the strip";
}

TEST(Frontiers, BestHeadingFacesTheLargerFrontier) {
  Band b(60, 60, kFree);
  b.Rect(5.0, 2.0, 6.0, 4.0, kUnknown);  // east of (3, 3): 20 frontier cells at x = 5.05
  b.Rect(0.5, 2.8, 1.0, 3.2, kUnknown);  // west: a small patch, 14 frontier cells
  b.Sync();
  const std::vector<bool> f = FrontierCells(b.t, kFreeThreshold);
  const FrontierView view{0.7, 4.0, 58.0 * M_PI / 180.0};
  int seen = 0;
  const double yaw = BestFrontierHeading(b.t.band, f, {3.0, 3.0}, view, kFreeThreshold, 36, &seen);
  // Every cell of x = 5.05 lies within +-29 deg of east (|dy| <= 0.95 < 2.05 tan 29 deg).
  EXPECT_NEAR(std::remainder(yaw, 2.0 * M_PI), 0.0, 10.0 * M_PI / 180.0 + 1e-9);
  EXPECT_EQ(seen, 20);
  // With a 2 m range only the west patch is in view from (1.8, 3): its east face (4 cells) is in
  // sight, the cells behind it are not.
  const FrontierView short_view{0.7, 2.0, 58.0 * M_PI / 180.0};
  int west = 0;
  const double west_yaw =
      BestFrontierHeading(b.t.band, f, {1.8, 3.0}, short_view, kFreeThreshold, 36, &west);
  EXPECT_NEAR(std::abs(std::remainder(west_yaw, 2.0 * M_PI)), M_PI, 30.0 * M_PI / 180.0 + 1e-9);
  EXPECT_GE(west, 4);
  EXPECT_LT(west, 14);
  // With no unknown space at all, nothing is seen.
  Band empty(30, 30, kFree);
  const std::vector<bool> none = FrontierCells(empty.t, kFreeThreshold);
  (void)BestFrontierHeading(empty.t.band, none, {1.5, 1.5}, view, kFreeThreshold, 36, &seen);
  EXPECT_EQ(seen, 0);
}

// The baseline on a 3D map: a free room 6 x 4 m with a solid block whose inside was never seen
// (west) and an open unknown region (east, beyond x = 4.5).
test::TestMap BlockRoom() {
  const Eigen::Vector3i dims{80, 54, 20};
  const Eigen::Vector3d origin{0.0, 0.0, -0.15};
  const double alpha = 0.075;
  return {dims, origin, alpha,
          test::FillGrid(dims, origin, alpha, kFree, [](double x, double y, double z, float* v) {
            const bool outer = x < 0.15 || y < 0.15 || y > 3.9 || z < 0.0;
            const bool block = x > 0.3 && x < 1.5 && y > 1.0 && y < 3.0;
            const bool inside = x > 0.45 && x < 1.35 && y > 1.15 && y < 2.85;
            if (x > 4.5 && !outer) *v = kUnknown;
            if (outer || block) *v = kOccupied;
            if (inside) *v = kUnknown;
          })};
}

TEST(Frontiers, BaselineFacesOpenUnknownSpaceNotTheInsideOfABlock) {
  const test::TestMap room = BlockRoom();
  PlannerConfig config;
  config.mode = ExplorationMode::kFrontier;
  FineFrontierPlanner planner(config);
  const PlanResult r = planner.Plan(room.Input(2.2, 2.0));
  ASSERT_EQ(r.status, PlanStatus::kGoal) << r.reason;
  const Candidate& goal = r.candidates[static_cast<size_t>(r.chosen)];
  // The nearest cell that sees the east frontier (x = 4.54) from at least 0.7 m, facing east.
  EXPECT_LT(std::abs(std::remainder(goal.yaw_rad, 2.0 * M_PI)), 30.0 * M_PI / 180.0);
  EXPECT_LT(goal.distance_m, 0.5) << "a cell near the vehicle already sees it";

  // Once a reached view has covered the east frontier, and the block's inside is no frontier,
  // nothing is left: the baseline ends.
  PlannerInput done = room.Input(2.2, 2.0);
  for (double y = 0.5; y < 3.8; y += 0.5) done.reached_views.emplace_back(3.6, y, 0.0);
  const PlanResult end = planner.Plan(done);
  EXPECT_EQ(end.status, PlanStatus::kExplorationDone) << end.reason;
  EXPECT_EQ(end.end_rule, "no reachable frontier");
}

// A 10 m x 4 m room, known free but for a strip of unknown cells along its south wall (y 0.15 to
// 0.3 m: what the sensors never resolve, e.g. a skirting the camera sees only at grazing angles)
// and, if open_from_x_m < 10, for the whole room east of it (open unknown space).
test::TestMap StripRoom(double open_from_x_m = 10.0) {
  const Eigen::Vector3i dims{134, 54, 20};
  const Eigen::Vector3d origin{0.0, 0.0, -0.15};
  const double alpha = 0.075;
  return {dims, origin, alpha,
          test::FillGrid(dims, origin, alpha, kFree, [&](double x, double y, double z, float* v) {
            if (y < 0.3 || x > open_from_x_m) *v = kUnknown;
            if (x < 0.15 || x > 9.9 || y < 0.15 || y > 3.9 || z < 0.0) *v = kOccupied;
          })};
}

TEST(Frontiers, BaselineMovesOnAlongAFrontierItCannotResolve) {
  const test::TestMap room = StripRoom();
  PlannerConfig config;
  config.mode = ExplorationMode::kFrontier;
  PlannerInput input = room.Input(2.5, 1.0);
  // Goals reached at x = 1 and 2.5 m facing every way covered the strip to about x = 6.4 m: the
  // strip's other cells hide none of it from there (unknown, not occupied).
  for (const double x : {1.0, 2.5}) {
    for (int h = 0; h < 8; ++h) input.reached_views.emplace_back(x, 1.0, h * M_PI / 4.0 - M_PI);
  }
  FineFrontierPlanner planner(config);
  const PlanResult r = planner.Plan(input);
  ASSERT_EQ(r.status, PlanStatus::kGoal) << r.reason;
  const Candidate& goal = r.candidates[static_cast<size_t>(r.chosen)];
  // The next goal sees the uncovered strip (x > 6.4 m), in sight past known free cells only:
  // more than a metre on, not the next cell over.
  EXPECT_GT(goal.distance_m, 1.2);
  EXPECT_GT(goal.position_m.x(), 3.6);
  EXPECT_LT(std::abs(std::remainder(goal.yaw_rad, 2.0 * M_PI)), M_PI / 2.0) << "facing on, east";
}

TEST(Frontiers, BaselineGoalsSeeTheFrontierFromGoalRange) {
  const test::TestMap room = StripRoom(5.0);  // open unknown space east of x = 5 m
  PlannerConfig config;
  config.mode = ExplorationMode::kFrontier;
  PlannerInput input = room.Input(1.0, 2.0);
  for (int h = 0; h < 8; ++h) input.reached_views.emplace_back(1.0, 2.0, h * M_PI / 4.0 - M_PI);
  const PlanResult r = FineFrontierPlanner(config).Plan(input);
  ASSERT_EQ(r.status, PlanStatus::kGoal) << r.reason;
  const Candidate& goal = r.candidates[static_cast<size_t>(r.chosen)];
  // The frontier (x = 5.0 m) within goal_max_range_m (2.5 m) of the goal: 1.5 m on at least.
  EXPECT_GT(goal.position_m.x(), 5.0 - config.frontier.goal_max_range_m - 0.1);
  EXPECT_LT(std::abs(std::remainder(goal.yaw_rad, 2.0 * M_PI)), M_PI / 4.0) << "facing it";
  // Goals that may see it at the camera's whole range stop short, a cell or two on.
  config.frontier.goal_max_range_m = config.frontier.view_max_range_m;
  const PlanResult near = FineFrontierPlanner(config).Plan(input);
  ASSERT_EQ(near.status, PlanStatus::kGoal) << near.reason;
  EXPECT_LT(near.candidates[static_cast<size_t>(near.chosen)].distance_m, 0.3);
}

}  // namespace
}  // namespace kestrel
