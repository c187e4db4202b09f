#include "exploration/planner.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "exploration/entropy_planner.h"
#include "exploration/frontier_planner.h"
#include "exploration/planning_pipeline.h"
#include "exploration/volumetric_planner.h"
#include "tests/exploration/test_input.h"

namespace kestrel {
namespace {

// A hand-made 3D map over x, y in [-3, 3), z in [-0.15, 1.5) at 0.075 m: outer walls, an inner
// wall at x = 0.6 for y < 0.9, floor below z = 0. Cells within `known_radius_m` of the origin are
// observed (free 1e-4 and walls and floor 0.9999: the map's clamp, where a well-observed cell
// ends); everything else is P_init 0.1.
struct RoomMap {
  Eigen::Vector3i dims{80, 80, 22};
  Eigen::Vector3d origin{-3.0, -3.0, -0.15};
  double alpha{0.075};
  std::vector<float> values;

  explicit RoomMap(double known_radius_m, double unseen_band_radius_m = 0.0) {
    values.assign(static_cast<size_t>(dims.prod()), 0.1f);
    for (int k = 0; k < dims.z(); ++k) {
      for (int j = 0; j < dims.y(); ++j) {
        for (int i = 0; i < dims.x(); ++i) {
          const double x = origin.x() + (i + 0.5) * alpha, y = origin.y() + (j + 0.5) * alpha;
          const double z = origin.z() + (k + 0.5) * alpha;
          if (std::hypot(x, y) > known_radius_m) continue;
          // A ring of unseen cells at the top and bottom of the band near the start (what a
          // level camera misses during the start-up turn).
          if (std::hypot(x, y) < unseen_band_radius_m && (z < 0.4 || z > 1.1)) continue;
          const bool wall = i < 3 || j < 3 || i >= dims.x() - 3 || j >= dims.y() - 3 ||
                            (std::abs(x - 0.6) < 0.1 && y < 0.9) || z < 0.0;
          at(i, j, k) = wall ? 0.9999f : 1e-4f;
        }
      }
    }
  }
  float& at(int i, int j, int k) {
    return values[static_cast<size_t>(i + dims.x() * (j + dims.y() * k))];
  }
  OccupancyGridView view() const { return test::GridView(dims, origin, alpha, values); }
};

PlannerInput InputAt(const RoomMap& map, Eigen::Vector2d xy) {
  return test::InputOn(map.view(), xy.x(), xy.y());
}

void ExpectTrajectoryInside(const PlanResult& r, const PlannerInput& in, const PlannerConfig& c) {
  ASSERT_TRUE(r.trajectory.trajectory.has_value());
  const GridMap2D& cm = r.collision.collision;
  const std::vector<bool> allowed =
      AllowedCells(cm, TraversableCells(cm, c.projection.collision_threshold),
                   in.position_m.head<2>(), c.trajectory.vehicle_radius_m);
  for (const TrajectorySample& s : r.trajectory.trajectory->Sample(0.01)) {
    ASSERT_TRUE(DiscClear(cm, allowed, s.flat.position_m.head<2>(), c.trajectory.vehicle_radius_m));
    ASSERT_NEAR(s.flat.position_m.z(), 0.75, 1e-6);
  }
}

// Combined mode: the chosen candidate maximises I * bump, its gain is eq. (10) on B, and the
// trajectory reaches it inside traversable cells.
TEST(Planner, CombinedChoosesMaxObjectiveAndReachesIt) {
  const RoomMap map(2.2);
  PlannerConfig config;
  config.mode = ExplorationMode::kCombined;
  EntropyPlanner planner(config);
  const PlannerInput in = InputAt(map, {-1.0, -1.0});
  const PlanResult r = planner.Plan(in);
  ASSERT_EQ(r.status, PlanStatus::kGoal) << r.reason;
  ASSERT_GE(r.chosen, 0);
  const Candidate& best = r.candidates[static_cast<size_t>(r.chosen)];
  for (const Candidate& c : r.candidates) EXPECT_LE(c.objective(), best.objective());
  GainEvaluator eval(config.gain);
  EXPECT_NEAR(eval.PoseGain(r.collision.combined, best.position_m, best.yaw_rad), best.gain_nats,
              1e-9 * best.gain_nats);
  EXPECT_EQ(r.candidates.size() % 8, 0u);
  EXPECT_GT(r.best_unweighted_gain_nats, config.candidates.end_gain_nats);
  EXPECT_EQ(r.end_test_gain_nats, r.best_unweighted_gain_nats);
  const FlatOutput end = r.trajectory.trajectory->Evaluate(1e9);
  EXPECT_NEAR((end.position_m.head<2>() - best.position_m).norm(), 0.0, 1e-8);
  ExpectTrajectoryInside(r, in, config);
  EXPECT_GT(r.gain_stats.rays_per_pose, 140);
}

// Two-map mode plans too, with gains from E.
TEST(Planner, TwoMapPlans) {
  const RoomMap map(2.2);
  PlannerConfig config;
  config.mode = ExplorationMode::kTwoMap;
  EntropyPlanner planner(config);
  const PlannerInput in = InputAt(map, {-1.0, -1.0});
  const PlanResult r = planner.Plan(in);
  ASSERT_EQ(r.status, PlanStatus::kGoal) << r.reason;
  ASSERT_TRUE(r.entropy.has_value());
  EXPECT_GT(r.end_test_gain_nats, config.candidates.end_entropy_gain_nats);  // unknown remains
  EXPECT_LT(r.end_test_gain_nats, r.best_unweighted_gain_nats);
  const Candidate& best = r.candidates[static_cast<size_t>(r.chosen)];
  GainEvaluator eval(config.gain);
  EXPECT_NEAR(eval.PoseGain(*r.entropy, best.position_m, best.yaw_rad), best.gain_nats,
              1e-9 * best.gain_nats);
  ExpectTrajectoryInside(r, in, config);
}

// A fully observed map ends exploration in both planners.
TEST(Planner, ExploredMapEndsExploration) {
  const RoomMap map(100.0);
  PlannerConfig config;
  for (ExplorationMode mode : {ExplorationMode::kCombined, ExplorationMode::kTwoMap,
                               ExplorationMode::kFrontier, ExplorationMode::kVolumetric}) {
    config.mode = mode;
    const PlanResult r = MakePlanner(config)->Plan(InputAt(map, {-1.0, -1.0}));
    EXPECT_EQ(r.status, PlanStatus::kExplorationDone) << ModeName(mode) << " " << r.reason;
    if (mode != ExplorationMode::kFrontier) {
      EXPECT_LT(r.end_test_gain_nats,
                mode == ExplorationMode::kTwoMap       ? config.candidates.end_entropy_gain_nats
                : mode == ExplorationMode::kVolumetric ? config.volumetric.end_gain_nats
                                                       : config.candidates.end_gain_nats);
      EXPECT_FALSE(r.candidates.empty());
      std::printf("%s: best gain %.3f nats, end-test gain %.3f nats\n", ModeName(mode),
                  r.best_unweighted_gain_nats, r.end_test_gain_nats);
    }
    if (mode == ExplorationMode::kCombined) {
      EXPECT_EQ(r.end_test_gain_nats, r.best_unweighted_gain_nats);
    }
    if (mode == ExplorationMode::kVolumetric) {
      EXPECT_EQ(r.end_rule, "gain rule");
    }
  }
}

// The frontier baseline goes to the nearest reachable cell bordering unknown B cells.
TEST(Planner, FrontierChoosesNearestFrontier) {
  const RoomMap map(2.2);
  PlannerConfig config;
  FrontierPlanner planner(config);
  const PlannerInput in = InputAt(map, {-1.0, -1.0});
  const PlanResult r = planner.Plan(in);
  ASSERT_EQ(r.status, PlanStatus::kGoal) << r.reason;
  const GridMap2D& c = r.collision.collision;
  double nearest = 1e9;
  for (int i = 0; i < c.size(); ++i) {
    if (!r.field.Reachable(i) || i == r.field.start || c.values[static_cast<size_t>(i)] > 0.05)
      continue;
    const Cell2 cell = c.CellAt(i);
    bool frontier = false;
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const Cell2 n{cell.x + dx, cell.y + dy};
        if (!c.Contains(n)) continue;
        frontier |= c.at(n) > 0.05 && c.at(n) >= 0.05 && c.at(n) <= 0.5;
      }
    }
    if (frontier) nearest = std::min(nearest, r.field.distance_m[static_cast<size_t>(i)]);
  }
  EXPECT_EQ(r.candidates[static_cast<size_t>(r.chosen)].distance_m, nearest);
  ExpectTrajectoryInside(r, in, config);
}

// A goal the vehicle has reached is never chosen again (candidates.skip_reached_goals): the
// entropy planner drops that cell and heading, the frontier planner that cell; with the option
// off, the same input gives the same choice again.
TEST(Planner, ReachedGoalsAreNotChosenAgain) {
  const RoomMap map(2.2);
  PlannerConfig config;
  for (const ExplorationMode mode : {ExplorationMode::kCombined, ExplorationMode::kFrontier}) {
    config.mode = mode;
    std::unique_ptr<ExplorationPlanner> planner = MakePlanner(config);
    PlannerInput in = InputAt(map, {-1.0, -1.0});
    const PlanResult first = planner->Plan(in);
    ASSERT_EQ(first.status, PlanStatus::kGoal) << ModeName(mode) << ": " << first.reason;
    const Candidate& goal = first.candidates[static_cast<size_t>(first.chosen)];
    in.reached_goals.emplace_back(goal.position_m.x(), goal.position_m.y(), goal.yaw_rad);
    in.reached_views.emplace_back(goal.position_m.x(), goal.position_m.y(), goal.yaw_rad);
    const PlanResult second = planner->Plan(in);
    ASSERT_EQ(second.status, PlanStatus::kGoal) << ModeName(mode) << ": " << second.reason;
    const Candidate& next = second.candidates[static_cast<size_t>(second.chosen)];
    if (mode == ExplorationMode::kFrontier) {
      // The frontier cells the view covered are no longer frontiers: the next goal looks
      // elsewhere (another place, or the same place at a heading outside the covered window).
      const double turn = std::abs(std::remainder(next.yaw_rad - goal.yaw_rad, 2.0 * M_PI));
      EXPECT_TRUE(next.cell != goal.cell ||
                  turn > 0.5 * config.frontier.horizontal_fov_deg * M_PI / 180.0)
          << "turn " << turn;
    } else {
      EXPECT_FALSE(next.cell == goal.cell && next.yaw_rad == goal.yaw_rad);
      for (const Candidate& c : second.candidates) {
        EXPECT_FALSE(c.cell == goal.cell && c.yaw_rad == goal.yaw_rad) << "scored again";
      }
      EXPECT_EQ(second.candidates.size() + 1, first.candidates.size());
    }
    config.candidates.skip_reached_goals = false;
    const PlanResult again = MakePlanner(config)->Plan(in);
    EXPECT_EQ(again.candidates[static_cast<size_t>(again.chosen)].cell, goal.cell);
    config.candidates.skip_reached_goals = true;
  }
}

// Combined mode's check on E (candidates.end_check_entropy_map): the band is seen free
// everywhere, so B's min rule calls every collision cell known and B's test ends exploration,
// but a disc 1 m around the origin is unseen below 0.4 m and above 1.1 m: E still sees it, and
// the plan flies on with E's gains. With the check off, exploration ends.
TEST(Planner, CombinedChecksEntropyMapBeforeEnding) {
  const RoomMap map(100.0, 1.0);
  PlannerConfig config;
  config.mode = ExplorationMode::kCombined;
  PlannerInput in = InputAt(map, {-1.95, -1.95});
  const PlanResult r = EntropyPlanner(config).Plan(in);
  ASSERT_EQ(r.status, PlanStatus::kGoal) << r.reason;
  EXPECT_TRUE(r.gains_from_entropy_map);
  EXPECT_GE(r.end_test_gain_nats, config.candidates.end_entropy_gain_nats);
  EXPECT_LT(r.best_unweighted_gain_nats, 1e9);
  config.candidates.end_check_entropy_map = false;
  const PlanResult b_only = EntropyPlanner(config).Plan(in);
  EXPECT_EQ(b_only.status, PlanStatus::kExplorationDone) << b_only.reason;
  EXPECT_LT(b_only.end_test_gain_nats, config.candidates.end_gain_nats);
  EXPECT_FALSE(b_only.gains_from_entropy_map);
}

// Section 8: after the start-up turn the top and bottom of the band near the start are unseen;
// without the start-up rule nothing around the vehicle is traversable, with it the first plan
// leaves the start cell.
TEST(Planner, StartupRuleLetsFirstPlanLeaveStartCell) {
  // The vehicle in collision cell (2, 2) = [-1.2, -0.3]^2; the unseen ring (1.7 m around the
  // origin) reaches into every cell it could step to, so without the rule none is traversable.
  const RoomMap map(2.6, 1.7);
  PlannerConfig config;
  config.mode = ExplorationMode::kCombined;
  EntropyPlanner planner(config);
  PlannerInput in = InputAt(map, {-0.75, -0.75});
  const PlanResult without = planner.Plan(in);
  EXPECT_NE(without.status, PlanStatus::kGoal);
  in.startup_center_m = in.position_m.head<2>();
  const PlanResult with = planner.Plan(in);
  ASSERT_EQ(with.status, PlanStatus::kGoal) << with.reason;
  EXPECT_NE(with.candidates[static_cast<size_t>(with.chosen)].cell, with.field.start);
  ExpectTrajectoryInside(with, in, config);
}

// Flying home: a trajectory to the cell of a given point.
TEST(Planner, PlanToPointReachesHome) {
  const RoomMap map(2.2);
  PlannerConfig config;
  const PlannerInput in = InputAt(map, {-1.0, 1.0});
  const PlanResult r = PlanToPoint(config, in, {-0.6, -0.6}, 0.0);
  ASSERT_EQ(r.status, PlanStatus::kGoal) << r.reason;
  const GridMap2D& c = r.collision.collision;
  const Eigen::Vector2d home = c.CenterOf(*c.CellOf({-0.6, -0.6}));
  EXPECT_NEAR((r.trajectory.trajectory->Evaluate(1e9).position_m.head<2>() - home).norm(), 0.0,
              1e-8);
  ExpectTrajectoryInside(r, in, config);
}

// A corridor 40 m long (x 0..40, free y 0.3..2.7, walls beyond, floor below z = 0, a ceiling in
// the top cell layer), everything observed except alcoves in its north wall (unknown cells at
// y 2.7..3.225, the wall's last cell row behind them) of the given x ranges. The back wall matters:
// the depth camera's 0 is no evidence (docs/algorithms.md §3.4), so a ray that leaves the map
// through unknown cells predicts nothing, and an alcove with nothing behind it is worth little.
test::TestMap CorridorMap(const std::vector<std::pair<double, double>>& alcoves) {
  const Eigen::Vector3i dims{534, 44, 22};
  const Eigen::Vector3d origin{0.0, 0.0, -0.15};
  const double alpha = 0.075;
  return {dims, origin, alpha,
          test::FillGrid(dims, origin, alpha, 1e-4f, [&](double x, double y, double z, float* v) {
            if (z < 0.0 || z > 1.4 || y < 0.3 || y > 2.7) *v = 0.9999f;
            for (const auto& [x0, x1] : alcoves) {
              if (x >= x0 && x < x1 && y > 2.7 && y < 3.225 && z >= 0.0 && z < 1.4) *v = 0.1f;
            }
          })};
}

// Local first (volumetric.local_horizon_m): a 1.2 m alcove 3 m ahead against a 4 m one 10 m
// ahead in a 40 m corridor (the paper's d_max, 1.05 x the farthest cell, is about 41 m, so its
// bump barely tells 3 m from 10 m). With the horizon the near alcove is the goal; without it the
// far one. And a pose below the end threshold is never the goal while one above it lies within
// the horizon.
TEST(Planner, VolumetricLocalFirst) {
  PlannerConfig config;
  config.mode = ExplorationMode::kVolumetric;
  const test::TestMap two = CorridorMap({{4.0, 5.2}, {10.0, 14.0}});
  auto goal_x = [&](const test::TestMap& map, double horizon_m) {
    config.volumetric.local_horizon_m = horizon_m;
    const PlanResult r = VolumetricPlanner(config).Plan(map.Input(1.0, 1.5));
    EXPECT_EQ(r.status, PlanStatus::kGoal) << r.reason;
    if (r.chosen < 0) return -1.0;
    const Candidate& c = r.candidates[static_cast<size_t>(r.chosen)];
    EXPECT_GE(c.gain_nats, config.volumetric.end_gain_nats);
    return c.position_m.x();
  };
  const double local = goal_x(two, 12.0);
  const double global = goal_x(two, 0.0);
  EXPECT_LT(local, 7.0) << "the near alcove";
  EXPECT_GT(global, 7.0) << "the large alcove, where the flat bump leads";
  // A 0.15 m alcove (below the end threshold from any pose) near, a large one 8 m ahead: local
  // first never takes the near one.
  const test::TestMap faint = CorridorMap({{2.5, 2.65}, {8.0, 12.0}});
  EXPECT_GT(goal_x(faint, 12.0), 5.0);
}

// Mode volumetric_tour (docs/exploration.md, "The information tour"): a 2 m alcove 6-8 m behind
// the vehicle (x = 2-4, the vehicle at x = 10) and two 4 m ones ahead (x = 14-18 and 22-26). The
// gain rule's goal is the largest gain x bump, ahead (the bump barely tells 6 m from 8 m); the
// tour's open path visits the near end first, since going back later costs the corridor twice,
// so its goal is behind. Sites lie where the alcoves are; the first site of the tour is behind.
TEST(Planner, VolumetricTourVisitsTheNearEndFirst) {
  const test::TestMap map = CorridorMap({{2.0, 4.0}, {14.0, 18.0}, {22.0, 26.0}});
  PlannerConfig config;
  config.mode = ExplorationMode::kVolumetric;
  const PlanResult greedy = VolumetricPlanner(config).Plan(map.Input(10.0, 1.5));
  ASSERT_EQ(greedy.status, PlanStatus::kGoal) << greedy.reason;
  EXPECT_GT(greedy.candidates[static_cast<size_t>(greedy.chosen)].position_m.x(), 10.0);

  config.mode = ExplorationMode::kVolumetricTour;
  VolumetricPlanner planner(config);
  EXPECT_EQ(planner.mode(), ExplorationMode::kVolumetricTour);
  const PlanResult tour = planner.Plan(map.Input(10.0, 1.5));
  ASSERT_EQ(tour.status, PlanStatus::kGoal) << tour.reason;
  const Candidate& goal = tour.candidates[static_cast<size_t>(tour.chosen)];
  EXPECT_LT(goal.position_m.x(), 8.0) << "the alcove behind first";
  EXPECT_GE(goal.gain_nats, config.volumetric.end_gain_nats);
  ASSERT_FALSE(planner.tour_sites().empty());
  ASSERT_EQ(planner.tour_order().size(), planner.tour_sites().size());
  // Every site's best pose sees an alcove: within 4 m (the Xtion's z_max) of one.
  for (const InfoSite& s : planner.tour_sites()) {
    const double x = s.best.xy_m.x();
    const double to_alcove =
        std::min({std::abs(x - 3.0) - 1.0, std::abs(x - 16.0) - 2.0, std::abs(x - 24.0) - 2.0});
    EXPECT_LT(to_alcove, 4.0) << "site at x = " << x;
    EXPECT_GE(s.best.gain_nats, config.volumetric.end_gain_nats);
  }
  const InfoSite& first = planner.tour_sites()[static_cast<size_t>(planner.tour_order().front())];
  EXPECT_LT(first.best.xy_m.x(), 8.0);
  // Sites on both sides of the vehicle.
  bool ahead = false;
  for (const InfoSite& s : planner.tour_sites()) ahead = ahead || s.best.xy_m.x() > 14.0;
  EXPECT_TRUE(ahead);
}

// The planner's first plan from `in` into *first: a goal worth more than the end threshold (the
// pose the viewed- and flown-pose tests then mask).
void FirstGoalPlan(VolumetricPlanner* planner, const PlannerInput& in, const PlannerConfig& config,
                   PlanResult* first) {
  *first = planner->Plan(in);
  ASSERT_EQ(first->status, PlanStatus::kGoal) << first->reason;
  ASSERT_GE(first->chosen, 0);
  ASSERT_GT(first->candidates[static_cast<size_t>(first->chosen)].gain_nats,
            config.volumetric.end_gain_nats);
}

// skip_viewed_poses: a pose the vehicle reached as a goal (reached_goals) keeps no gain in the
// choice or the end rule; without the option the same pose is chosen again.
TEST(Planner, VolumetricViewedPosesKeepNoGain) {
  const RoomMap map(2.2);
  PlannerConfig config;
  config.mode = ExplorationMode::kVolumetric;
  config.volumetric.skip_viewed_poses = true;
  VolumetricPlanner planner(config);
  PlannerInput in = InputAt(map, {-1.0, -1.0});
  PlanResult first;
  ASSERT_NO_FATAL_FAILURE(FirstGoalPlan(&planner, in, config, &first));
  const Candidate goal = first.candidates[static_cast<size_t>(first.chosen)];
  // A goal 0.2 m from the candidate's position, 10 deg off its heading, was reached while the
  // vehicle faced 40 deg away from it (mid-turn): nothing is masked.
  in.reached_goals.emplace_back(goal.position_m.x() + 0.2, goal.position_m.y(),
                                goal.yaw_rad + 10.0 * M_PI / 180.0);
  in.reached_views.emplace_back(goal.position_m.x() + 0.2, goal.position_m.y(),
                                goal.yaw_rad + 50.0 * M_PI / 180.0);
  const PlanResult passed = planner.Plan(in);
  ASSERT_GE(passed.chosen, 0);
  EXPECT_EQ(passed.candidates[static_cast<size_t>(passed.chosen)].cell, goal.cell);
  EXPECT_EQ(passed.candidates[static_cast<size_t>(passed.chosen)].yaw_rad, goal.yaw_rad);
  // Facing it (5 deg off the goal's heading): the pose keeps no gain.
  in.reached_views.back().z() = goal.yaw_rad + 15.0 * M_PI / 180.0;
  const PlanResult second = planner.Plan(in);
  ASSERT_EQ(second.status, PlanStatus::kGoal) << second.reason;
  const Candidate& next = second.candidates[static_cast<size_t>(second.chosen)];
  EXPECT_FALSE(next.cell == goal.cell && next.yaw_rad == goal.yaw_rad);
  int listed = 0;
  for (const Candidate& c : second.candidates) {
    if (c.cell != goal.cell) continue;
    if (c.yaw_rad == goal.yaw_rad) {
      EXPECT_EQ(c.gain_nats, 0.0) << "the viewed heading";
      ++listed;
    } else {
      EXPECT_EQ(c.gain_nats, [&] {  // the other headings keep their gains, bit for bit
        for (const Candidate& f : first.candidates) {
          if (f.cell == c.cell && f.yaw_rad == c.yaw_rad) return f.gain_nats;
        }
        return c.gain_nats;
      }());
    }
  }
  EXPECT_EQ(listed, 1);
  config.volumetric.skip_viewed_poses = false;
  const PlanResult again = VolumetricPlanner(config).Plan(in);
  const Candidate& same = again.candidates[static_cast<size_t>(again.chosen)];
  EXPECT_EQ(same.cell, goal.cell);
  EXPECT_EQ(same.yaw_rad, goal.yaw_rad);
}

// A pose the vehicle flew through facing its heading keeps no gain (skip_flown_poses): within
// candidate_spacing_m / 2 of the position and within half a heading step; not farther, not
// facing elsewhere, and not with the rule off.
TEST(Planner, VolumetricFlownPosesKeepNoGain) {
  const RoomMap map(2.2);
  PlannerConfig config;
  config.mode = ExplorationMode::kVolumetric;
  config.volumetric.skip_flown_poses = true;
  VolumetricPlanner planner(config);
  PlannerInput in = InputAt(map, {-1.0, -1.0});
  PlanResult first;
  ASSERT_NO_FATAL_FAILURE(FirstGoalPlan(&planner, in, config, &first));
  const Candidate goal = first.candidates[static_cast<size_t>(first.chosen)];
  const auto gain_of_goal = [&](const PlanResult& r) {
    for (const Candidate& c : r.candidates) {
      if (c.cell == goal.cell && c.yaw_rad == goal.yaw_rad) return c.gain_nats;
    }
    return -1.0;
  };
  const double deg = M_PI / 180.0;
  const double n_yaw = config.candidates.n_yaw;
  ASSERT_GT(180.0 / n_yaw, 10.0);  // half a step is more than 10 deg
  const Eigen::Vector3d facing(goal.position_m.x() + 0.2, goal.position_m.y(),
                               goal.yaw_rad + 5.0 * deg);
  for (const Eigen::Vector3d& away :
       {Eigen::Vector3d(facing.x(), facing.y(), goal.yaw_rad + 180.0 / n_yaw * deg + 5.0 * deg),
        Eigen::Vector3d(goal.position_m.x() + 0.5, goal.position_m.y(), facing.z())}) {
    in.flown_views = {away};
    EXPECT_EQ(gain_of_goal(planner.Plan(in)), goal.gain_nats) << away.transpose();
  }
  in.flown_views = {facing};
  const PlanResult flown = planner.Plan(in);
  EXPECT_EQ(gain_of_goal(flown), 0.0);
  ASSERT_GE(flown.chosen, 0);
  const Candidate& next = flown.candidates[static_cast<size_t>(flown.chosen)];
  EXPECT_FALSE(next.cell == goal.cell && next.yaw_rad == goal.yaw_rad);
  config.volumetric.skip_flown_poses = false;
  EXPECT_EQ(gain_of_goal(VolumetricPlanner(config).Plan(in)), goal.gain_nats);
}

// The volumetric planner reuses a position's gains only while the map within its rays' reach is
// unchanged: after a change, its plan equals a fresh planner's, candidate for candidate.
TEST(Planner, VolumetricReuseIsExact) {
  RoomMap map(2.2);
  PlannerConfig config;
  config.mode = ExplorationMode::kVolumetric;
  VolumetricPlanner planner(config);
  const PlannerInput in = InputAt(map, {-1.0, -1.0});
  const PlanResult first = planner.Plan(in);
  ASSERT_EQ(first.status, PlanStatus::kGoal) << first.reason;
  EXPECT_EQ(planner.reused_positions(), 0);
  // Every position is bounded on a cold cache; the plan counts them (kestrel-mission --plans-csv).
  EXPECT_EQ(first.volumetric_stats.positions, first.volumetric_stats.poses_bounded);
  EXPECT_GE(first.volumetric_stats.positions * config.candidates.n_yaw,
            static_cast<long>(first.candidates.size()));
  const PlanResult again = planner.Plan(in);
  EXPECT_GT(planner.reused_positions(), 0);
  EXPECT_EQ(again.volumetric_stats.positions, first.volumetric_stats.positions);
  ASSERT_EQ(again.chosen, first.chosen);
  // New map data near the vehicle: some cells seen free.
  for (int k = 8; k < 14; ++k) {
    for (int j = 45; j < 52; ++j) {
      for (int i = 45; i < 52; ++i) map.at(i, j, k) = 0.02f;
    }
  }
  const PlanResult reused = planner.Plan(in);
  VolumetricPlanner fresh_planner(config);
  const PlanResult fresh = fresh_planner.Plan(in);
  ASSERT_EQ(reused.status, fresh.status);
  ASSERT_EQ(reused.chosen >= 0, fresh.chosen >= 0);
  const Candidate& a = reused.candidates[static_cast<size_t>(reused.chosen)];
  const Candidate& b = fresh.candidates[static_cast<size_t>(fresh.chosen)];
  EXPECT_EQ(a.cell, b.cell);
  EXPECT_EQ(a.yaw_rad, b.yaw_rad);
  EXPECT_EQ(a.gain_nats, b.gain_nats);
  EXPECT_EQ(reused.best_unweighted_gain_nats, fresh.best_unweighted_gain_nats);
  // Every candidate both evaluated has the same gain, bit for bit.
  int compared = 0;
  for (const Candidate& c : reused.candidates) {
    for (const Candidate& d : fresh.candidates) {
      if (c.cell == d.cell && c.yaw_rad == d.yaw_rad) {
        EXPECT_EQ(c.gain_nats, d.gain_nats) << "cell " << c.cell;
        ++compared;
      }
    }
  }
  EXPECT_GT(compared, 8);
}

// Bad input and edge cases of the volumetric mode: each gives a clear status, never a crash.
TEST(Planner, VolumetricEdgeCases) {
  PlannerConfig config;
  config.mode = ExplorationMode::kVolumetric;
  {  // Outside the map: a failed plan that says so, and no way home from there.
    RoomMap map(100.0);
    const PlanResult r = MakePlanner(config)->Plan(InputAt(map, {10.0, 10.0}));
    EXPECT_EQ(r.status, PlanStatus::kFailed);
    EXPECT_EQ(r.reason, "vehicle outside the map");
    EXPECT_EQ(PlanToPoint(config, InputAt(map, {10.0, 10.0}), {0.0, 0.0}, 0.0).status,
              PlanStatus::kFailed);
  }
  {  // A NaN pose.
    RoomMap map(100.0);
    PlannerInput in = InputAt(map, {0.0, 0.0});
    in.velocity_mps.x() = std::nan("");
    const PlanResult r = MakePlanner(config)->Plan(in);
    EXPECT_EQ(r.status, PlanStatus::kFailed);
    EXPECT_NE(r.reason.find("not finite"), std::string::npos) << r.reason;
  }
  {  // Inside an obstacle (a solid 1 m block of furniture around the vehicle): nothing
     // reachable: a failed plan with the rule (the explorer ends exploration after
     // max_failed_plans of them), and the flight home fails with its own reason.
    RoomMap map(100.0);
    for (int k = 0; k < map.dims.z(); ++k) {
      for (int j = 0; j < map.dims.y(); ++j) {
        for (int i = 0; i < map.dims.x(); ++i) {
          const double x = map.origin.x() + (i + 0.5) * map.alpha + 1.5;
          const double y = map.origin.y() + (j + 0.5) * map.alpha - 1.5;
          if (std::abs(x) < 0.5 && std::abs(y) < 0.5) map.at(i, j, k) = 0.9999f;
        }
      }
    }
    const PlanResult r = MakePlanner(config)->Plan(InputAt(map, {-1.5, 1.5}));
    EXPECT_EQ(r.status, PlanStatus::kFailed);  // the explorer ends after max_failed_plans
    EXPECT_EQ(r.end_rule, "no reachable candidate");
    const PlanResult home = PlanToPoint(config, InputAt(map, {-1.5, 1.5}), {-2.0, -2.0}, 0.0);
    EXPECT_EQ(home.status, PlanStatus::kFailed);
    EXPECT_FALSE(home.reason.empty());
  }
  {  // Boxed in by new obstacles: a ring of occupied cells 0.6 m around the vehicle.
    RoomMap map(100.0);
    for (int k = 0; k < map.dims.z(); ++k) {
      for (int j = 0; j < map.dims.y(); ++j) {
        for (int i = 0; i < map.dims.x(); ++i) {
          const double x = map.origin.x() + (i + 0.5) * map.alpha + 1.5;
          const double y = map.origin.y() + (j + 0.5) * map.alpha + 1.5;
          const double d = std::hypot(x, y);
          if (d > 0.55 && d < 0.7) map.at(i, j, k) = 0.9999f;
        }
      }
    }
    const PlanResult r = MakePlanner(config)->Plan(InputAt(map, {-1.5, -1.5}));
    EXPECT_EQ(r.status, PlanStatus::kFailed) << r.reason;
    EXPECT_EQ(r.end_rule, "no reachable candidate");
    EXPECT_EQ(PlanToPoint(config, InputAt(map, {-1.5, -1.5}), {1.5, 1.5}, 0.0).status,
              PlanStatus::kFailed);
  }
  {  // A fully known closed room: nothing left to learn, the gain rule ends it.
    RoomMap map(100.0);
    const PlanResult r = MakePlanner(config)->Plan(InputAt(map, {-1.5, -1.5}));
    EXPECT_EQ(r.status, PlanStatus::kExplorationDone);
    EXPECT_EQ(r.end_rule, "gain rule");
  }
}

// Paths keep the preferred clearance where the room allows (docs/exploration.md,
// "Traversability"): round the inner wall's end 0.84 m off it, not at the bare 0.54 m that the
// margin allows and that a shortest path (the preference off) takes.
TEST(Planner, VolumetricPathsKeepThePreferredClearance) {
  RoomMap map(100.0);
  PlannerConfig config;
  config.mode = ExplorationMode::kVolumetric;
  const auto least_clearance = [&](const PlannerConfig& c) {
    // From the west of the inner wall (x = 0.5..0.7, y < 0.9) to its east: round its end.
    const PlanResult r = PlanToPoint(c, InputAt(map, {-1.5, -1.5}), {1.8, -1.5}, 0.0);
    EXPECT_EQ(r.status, PlanStatus::kGoal) << r.reason;
    double least = std::numeric_limits<double>::infinity();
    if (!r.trajectory.trajectory || !r.traversability) return least;
    const GridMap2D& clearance = r.traversability->clearance;
    for (const TrajectorySample& smp : r.trajectory.trajectory->Sample(0.01)) {
      const auto cell = clearance.CellOf(smp.flat.position_m.head<2>());
      if (cell) least = std::min(least, clearance.at(cell->x, cell->y));
    }
    return least;
  };
  const double required = config.trajectory.vehicle_radius_m + config.volumetric.margin_m;
  ASSERT_GT(config.volumetric.preferred_clearance_m, 0.2);
  ASSERT_GT(config.volumetric.clearance_weight, 0.0);
  EXPECT_GE(least_clearance(config),
            required + config.volumetric.preferred_clearance_m - map.alpha);
  PlannerConfig off = config;
  off.volumetric.preferred_clearance_m = 0.0;
  EXPECT_LT(least_clearance(off), required + 0.1);
}

// A wall across the room at y = 0.45..0.6 m with a door of n whole free cells.
// The vehicle (0.44 m radius) plans from the south room to the north one: through 14 cells
// (1.05 m) it passes on the door's middle line, the passage points (exploration/traversability.h,
// step 3b), keeping radius + passage margin - alpha/2 from every blocked cell; 13 cells, or 14
// with the passage margin at the full margin, are closed.
TEST(Planner, VolumetricPassesAnEvenDoorThroughItsMiddle) {
  const auto plan = [](int n, double passage_margin_m, double* least_m, double* worst_offset_m) {
    RoomMap map(100.0);
    for (int k = 0; k < map.dims.z(); ++k) {  // clear the inner wall, build the door wall
      for (int j = 3; j < map.dims.y() - 3; ++j) {
        for (int i = 3; i < map.dims.x() - 3; ++i) {
          const double y = map.origin.y() + (j + 0.5) * map.alpha;
          const double z = map.origin.z() + (k + 0.5) * map.alpha;
          const bool door = i >= 40 - n / 2 && i < 40 - n / 2 + n;  // cell 40 starts at x = 0
          map.at(i, j, k) = z < 0.0 || (y > 0.45 && y < 0.6 && !door) ? 0.9999f : 1e-4f;
        }
      }
    }
    const double middle = (40 - n / 2 + 0.5 * n) * map.alpha + map.origin.x();
    PlannerConfig config;
    config.mode = ExplorationMode::kVolumetric;
    config.volumetric.passage_margin_m = passage_margin_m;
    // Diagonally across the door, so that pruning keeps a waypoint in it.
    const PlanResult r =
        PlanToPoint(config, InputAt(map, {middle - 1.2, -1.5}), {middle + 1.2, 1.8}, 0.0);
    if (r.status != PlanStatus::kGoal || !r.trajectory.trajectory) return false;
    // Blocked band cells (every wall cell here spans the band) against the sampled centre.
    const GridMap2D& band = r.collision.collision;
    *least_m = std::numeric_limits<double>::infinity();
    *worst_offset_m = 0.0;
    for (const TrajectorySample& smp : r.trajectory.trajectory->Sample(0.01)) {
      const Eigen::Vector2d p = smp.flat.position_m.head<2>();
      if (std::abs(p.y() - 0.525) > 0.6) continue;  // near the door
      for (int y = 0; y < band.height; ++y) {
        for (int x = 0; x < band.width; ++x) {
          if (band.at(x, y) <= config.projection.collision_threshold) continue;
          *least_m = std::min(*least_m, (band.CenterOf({x, y}) - p).norm() - 0.5 * map.alpha);
        }
      }
      if (std::abs(p.y() - 0.525) < 0.075) {  // in the wall's rows
        *worst_offset_m = std::max(*worst_offset_m, std::abs(p.x() - middle));
      }
    }
    return true;
  };
  double least = 0.0, offset = 0.0;
  ASSERT_TRUE(plan(14, 0.08, &least, &offset));
  EXPECT_GE(least, 0.44 + 0.08 - 0.5 * 0.075);
  EXPECT_LE(offset, 0.5 * 0.075);                 // in the half cells next to the middle line
  EXPECT_FALSE(plan(13, 0.08, &least, &offset));  // and the far room is out of reach:
  EXPECT_FALSE(plan(14, 0.10, &least, &offset));
  ASSERT_TRUE(plan(15, 0.10, &least, &offset));  // 15 cells: through the middle cell's centre
  EXPECT_GE(least, 0.44 + 0.10 - 0.5 * 0.075);
}

// ReachesWithin (what the explorer asks of the take-off point before it ends exploration): a plan
// from the south of the inner wall reaches the north through the open end, and not when the map
// closes that end; a paper-mode plan (no fine traversability) always answers true.
TEST(Planner, ReachesWithinFollowsTheDistanceField) {
  PlannerConfig config;
  config.mode = ExplorationMode::kVolumetric;
  RoomMap open(100.0);
  const PlanResult r = MakePlanner(config)->Plan(InputAt(open, {1.5, -1.5}));
  ASSERT_TRUE(r.traversability.has_value()) << r.reason;
  EXPECT_TRUE(ReachesWithin(r, {-1.5, -1.5}, 0.44));
  EXPECT_TRUE(ReachesWithin(r, {1.5, -1.5}, 0.44));
  RoomMap closed(100.0);  // the inner wall (x = 0.5..0.7) run up to the north wall
  for (int k = 0; k < closed.dims.z(); ++k) {
    for (int j = 0; j < closed.dims.y(); ++j) {
      for (int i = 0; i < closed.dims.x(); ++i) {
        const double x = closed.origin.x() + (i + 0.5) * closed.alpha;
        if (std::abs(x - 0.6) < 0.1) closed.at(i, j, k) = 0.9999f;
      }
    }
  }
  const PlanResult c = MakePlanner(config)->Plan(InputAt(closed, {1.5, -1.5}));
  ASSERT_TRUE(c.traversability.has_value()) << c.reason;
  EXPECT_FALSE(ReachesWithin(c, {-1.5, -1.5}, 0.44));
  EXPECT_TRUE(ReachesWithin(c, {1.5, -1.5}, 0.44));
  EXPECT_FALSE(ReachesWithin(c, {50.0, 50.0}, 0.44));  // outside the map
  EXPECT_TRUE(ReachesWithin(PlanResult{}, {50.0, 50.0}, 0.44));
}

// LandingCell (where the explorer lands when no path home exists): with a chair (0.4 m square,
// 0.46 m tall) under the vehicle, the nearest reachable cell whose disc clears the chair; with
// nothing under it, the vehicle's own cell; with the space below the flight unknown, none.
TEST(Planner, LandingCellAvoidsWhatIsBelowTheFlight) {
  PlannerConfig config;
  config.mode = ExplorationMode::kVolumetric;
  const double top = config.projection.height_m - config.volumetric.band_below_m;
  const auto landing = [&](RoomMap& map) {
    const PlannerInput in = InputAt(map, {-1.5, -1.5});
    const PlanResult r = MakePlanner(config)->Plan(in);
    EXPECT_TRUE(r.traversability.has_value()) << r.reason;
    const std::optional<int> cell = LandingCell(r, in.map, 0.44, 0.0, top, 0.05);
    std::optional<Eigen::Vector2d> xy;
    if (cell) {
      EXPECT_TRUE(r.field.Reachable(*cell));
      xy = r.traversability->band.CenterOf(r.traversability->band.CellAt(*cell));
    }
    return xy;
  };
  RoomMap bare(100.0);
  const std::optional<Eigen::Vector2d> own = landing(bare);
  ASSERT_TRUE(own.has_value());
  EXPECT_LT((*own - Eigen::Vector2d(-1.5, -1.5)).norm(), 0.075);
  RoomMap chair(100.0);
  const auto set_below = [&](RoomMap& map, double x0, double x1, double y0, double y1, float p) {
    for (int k = 0; k < map.dims.z(); ++k) {
      for (int j = 0; j < map.dims.y(); ++j) {
        for (int i = 0; i < map.dims.x(); ++i) {
          const double x = map.origin.x() + (i + 0.5) * map.alpha;
          const double y = map.origin.y() + (j + 0.5) * map.alpha;
          const double z = map.origin.z() + (k + 0.5) * map.alpha;
          if (x > x0 && x < x1 && y > y0 && y < y1 && z > 0.0 && z < 0.46) map.at(i, j, k) = p;
        }
      }
    }
  };
  set_below(chair, -1.7, -1.3, -1.7, -1.3, 0.9999f);
  const std::optional<Eigen::Vector2d> away = landing(chair);
  ASSERT_TRUE(away.has_value());
  // The disc misses the chair's cells (centres within 0.2 m of (-1.5, -1.5) on each axis)...
  const Eigen::Vector2d d = (away->array() + 1.5).abs().matrix();
  const double to_chair = std::hypot(std::max(0.0, d.x() - 0.2), std::max(0.0, d.y() - 0.2));
  EXPECT_GT(to_chair, 0.44);
  // ...and is the nearest that does: within a cell and a half of the least such distance.
  EXPECT_LT((*away - Eigen::Vector2d(-1.5, -1.5)).norm(), 0.2 + 0.44 + 0.075 * 3);
  RoomMap unknown(100.0);
  set_below(unknown, -3.0, 3.0, -3.0, 3.0, 0.1f);
  EXPECT_FALSE(landing(unknown).has_value());
}

// New map data can leave the vehicle short of clearance (0.25 m from a wall, 0.49 m needed): it
// escapes along space no tighter than where it is, and the plan flies it away.
TEST(Planner, VolumetricEscapesFromNearAWall) {
  RoomMap map(2.2);
  PlannerConfig config;
  config.mode = ExplorationMode::kVolumetric;
  // The inner wall's face is at x = 0.5 (cells with |x - 0.6| < 0.1): stand 0.25 m west of it.
  const PlannerInput in = InputAt(map, {0.25, -0.5});
  const PlanResult r = MakePlanner(config)->Plan(in);
  ASSERT_EQ(r.status, PlanStatus::kGoal) << r.reason;
  ASSERT_TRUE(r.traversability.has_value());
  const auto start = r.traversability->band.CellOf(in.position_m.head<2>());
  EXPECT_FALSE(
      r.traversability->traversable[static_cast<size_t>(r.traversability->band.IndexOf(*start))]);
  // The trajectory never comes closer to the wall than the start.
  for (const TrajectorySample& smp : r.trajectory.trajectory->Sample(0.05)) {
    EXPECT_LT(smp.flat.position_m.x(), 0.25 + 0.075) << "t " << smp.time_s;
  }
}

}  // namespace
}  // namespace kestrel

namespace kestrel {
namespace {

// Whether the segment a-b crosses RoomMap's inner wall (x in 0.6 +- 0.1, y < 0.9), and whether it
// passes within `margin_m` of its end (where half-cell sampling may decide either way).
bool CrossesInnerWall(const Eigen::Vector2d& a, const Eigen::Vector2d& b, double margin_m,
                      bool* near_end) {
  bool crosses = false;
  *near_end = false;
  for (int i = 0; i <= 1000; ++i) {
    const Eigen::Vector2d p = a + (b - a) * (i / 1000.0);
    if (std::abs(p.x() - 0.6) < 0.1 && p.y() < 0.9) crosses = true;
    if ((p - Eigen::Vector2d(0.6, 0.9)).norm() < margin_m) *near_end = true;
  }
  return crosses;
}

// Several vehicles: another vehicle's goal discounts the objective of every candidate within
// peer_view_radius_m in sight of it by 1 - d / radius (none behind a wall), the choice maximises
// the discounted objective, and the chosen pose is no longer the peer's.
TEST(Planner, VolumetricPeerGoalDiscountsThePosesInItsView) {
  const RoomMap map(2.2);
  PlannerConfig config;
  config.mode = ExplorationMode::kVolumetric;
  VolumetricPlanner planner(config);
  PlannerInput in = InputAt(map, {-1.0, -1.0});
  PlanResult first;
  ASSERT_NO_FATAL_FAILURE(FirstGoalPlan(&planner, in, config, &first));
  const Candidate goal = first.candidates[static_cast<size_t>(first.chosen)];
  for (const Candidate& c : first.candidates) EXPECT_EQ(c.discount, 1.0) << "no other vehicle";
  // Two other vehicles: one flies to this goal, one to a place behind the inner wall.
  const Eigen::Vector2d hidden(1.5, -0.5);
  in.peer_goals = {Eigen::Vector3d(goal.position_m.x(), goal.position_m.y(), goal.yaw_rad),
                   Eigen::Vector3d(hidden.x(), hidden.y(), 0.0)};
  const PlanResult shared = VolumetricPlanner(config).Plan(in);
  ASSERT_EQ(shared.status, PlanStatus::kGoal) << shared.reason;
  const double radius = config.volumetric.peer_view_radius_m;
  int discounted = 0, behind_wall = 0;
  for (const Candidate& c : shared.candidates) {
    double expected = 1.0;
    bool undecided = false;
    for (const Eigen::Vector2d& g : {goal.position_m, hidden}) {
      const double d = (c.position_m - g).norm();
      bool near_end = false;
      const bool wall = CrossesInnerWall(c.position_m, g, 0.15, &near_end);
      undecided = undecided || near_end;
      if (d < radius && !wall) expected -= 1.0 - d / radius;
      behind_wall += d < radius && wall && !near_end ? 1 : 0;
    }
    if (undecided) continue;
    EXPECT_NEAR(c.discount, std::max(0.0, expected), 1e-12) << c.position_m.transpose();
    EXPECT_DOUBLE_EQ(c.objective(), c.gain_nats * c.bump * c.discount);
    discounted += c.discount < 1.0 ? 1 : 0;
  }
  EXPECT_GT(discounted, 0);
  EXPECT_GT(behind_wall, 0) << "the test must see a pose hidden from the goal by the wall";
  const Candidate& chosen = shared.candidates[static_cast<size_t>(shared.chosen)];
  EXPECT_NE(chosen.cell, goal.cell) << "the other vehicle's goal is not chosen again";
  for (const Candidate& c : shared.candidates) EXPECT_LE(c.objective(), chosen.objective());
}

// Several vehicles: a trajectory the separation check refuses makes the planner try its next
// candidates; when it refuses every one, the plan fails and says so.
TEST(Planner, VolumetricTrajectoryCheckTriesTheNextCandidates) {
  const RoomMap map(2.2);
  PlannerConfig config;
  config.mode = ExplorationMode::kVolumetric;
  PlannerInput in = InputAt(map, {-1.0, -1.0});
  PlanResult first;
  {
    VolumetricPlanner planner(config);
    ASSERT_NO_FATAL_FAILURE(FirstGoalPlan(&planner, in, config, &first));
  }
  const Candidate goal = first.candidates[static_cast<size_t>(first.chosen)];
  int asked = 0;
  in.trajectory_check = [&](const PiecewisePolynomialTrajectory& t) -> std::string {
    ++asked;
    const Eigen::Vector3d end = t.Evaluate(t.end_time_s()).position_m;
    return (end.head<2>() - goal.position_m).norm() < 0.5 ? "near the first goal" : "";
  };
  const PlanResult next = VolumetricPlanner(config).Plan(in);
  ASSERT_EQ(next.status, PlanStatus::kGoal) << next.reason;
  EXPECT_EQ(next.refused_trajectories, 1);
  EXPECT_EQ(asked, 2);
  const Candidate& chosen = next.candidates[static_cast<size_t>(next.chosen)];
  EXPECT_GE((chosen.position_m - goal.position_m).norm(), 0.5);
  const Eigen::Vector3d end =
      next.trajectory.trajectory->Evaluate(next.trajectory.trajectory->end_time_s()).position_m;
  EXPECT_NEAR((end.head<2>() - chosen.position_m).norm(), 0.0, 1e-6);

  asked = 0;
  in.trajectory_check = [&](const PiecewisePolynomialTrajectory&) -> std::string {
    ++asked;
    return "another vehicle";
  };
  const PlanResult none = VolumetricPlanner(config).Plan(in);
  EXPECT_EQ(none.status, PlanStatus::kFailed);
  EXPECT_EQ(none.chosen, -1);
  EXPECT_EQ(none.refused_trajectories, asked);
  EXPECT_GE(asked, 2);
  EXPECT_LE(asked, 10);
  EXPECT_NE(none.reason.find("separation check"), std::string::npos) << none.reason;
  EXPECT_NE(none.reason.find("another vehicle"), std::string::npos) << none.reason;
}

}  // namespace
}  // namespace kestrel

namespace kestrel {
namespace {

// One rule for the start state (SearchSpace::StartOf): the full state on the fine traversability,
// the paper's start (acceleration and yaw rate left out) on the collision map C.
TEST(PlanningPipeline, StartStateOfEachSpace) {
  PlannerConfig config;
  PlannerInput in;
  in.position_m = Eigen::Vector3d(1.0, 2.0, 0.75);
  in.velocity_mps = Eigen::Vector3d(0.5, 0.0, 0.0);
  in.acceleration_mps2 = Eigen::Vector3d(0.1, -0.2, 0.0);
  in.yaw_rad = 0.3;
  in.yaw_rate_radps = 0.4;
  in.time_s = 12.0;
  const TrajectoryStart fine = SearchSpace::Fine(config).StartOf(in);
  EXPECT_EQ(fine.acceleration_mps2, in.acceleration_mps2);
  EXPECT_EQ(fine.yaw_rate_radps, 0.4);
  const TrajectoryStart coarse = SearchSpace::Collision(config, false).StartOf(in);
  EXPECT_EQ(coarse.position_m, in.position_m);
  EXPECT_EQ(coarse.velocity_mps, in.velocity_mps);
  EXPECT_EQ(coarse.yaw_rad, 0.3);
  EXPECT_EQ(coarse.time_s, 12.0);
  EXPECT_EQ(coarse.acceleration_mps2, Eigen::Vector3d::Zero());
  EXPECT_EQ(coarse.yaw_rate_radps, 0.0);
  config.mode = ExplorationMode::kCombined;
  EXPECT_FALSE(SearchSpace::For(config).fine());
  config.mode = ExplorationMode::kVolumetric;
  EXPECT_TRUE(SearchSpace::For(config).fine());
}

}  // namespace
}  // namespace kestrel
