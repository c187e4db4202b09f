#include "exploration/trajectory_planner.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "common/trajectory_message.h"

namespace kestrel {
namespace {

// d-th derivative (any d) of sum c_i t^i at t.
double Derivative(const std::vector<double>& c, int d, double t) {
  double v = 0.0;
  for (size_t i = static_cast<size_t>(d); i < c.size(); ++i) {
    double f = 1.0;
    for (int j = 0; j < d; ++j) f *= static_cast<double>(i) - j;
    v += c[i] * f * std::pow(t, static_cast<double>(i) - d);
  }
  return v;
}

// A single rest-to-rest piece is the smoothstep a + (b - a)(35x^4 - 84x^5 + 70x^6 - 20x^7).
TEST(TrajectoryPlanner, SinglePieceIsSmoothstep) {
  const std::vector<Eigen::Vector3d> pts{{0, 0, 1}, {2, -1, 1}};
  const auto segs = SolveMinimumDerivative(pts, {3.0}, 4, Eigen::Vector3d::Zero());
  ASSERT_TRUE(segs.has_value());
  for (double x = 0.0; x <= 1.0; x += 0.05) {
    const double s =
        35 * std::pow(x, 4) - 84 * std::pow(x, 5) + 70 * std::pow(x, 6) - 20 * std::pow(x, 7);
    EXPECT_NEAR(Derivative((*segs)[0].coefficients[0], 0, 3.0 * x), 2.0 * s, 1e-9);
    EXPECT_NEAR(Derivative((*segs)[0].coefficients[1], 0, 3.0 * x), -1.0 * s, 1e-9);
    EXPECT_NEAR(Derivative((*segs)[0].coefficients[2], 0, 3.0 * x), 1.0, 1e-9);
  }
}

// Random waypoints and durations: positions met, start velocity and end rest, derivatives 1..k
// continuous (constraints) and, for the optimum, also k+1..2k-2 (the optimality conditions of
// the minimum-derivative problem, which the constraints do not impose).
TEST(TrajectoryPlanner, MeetsWaypointsWithContinuity) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int k : {3, 4}) {
    for (int trial = 0; trial < 40; ++trial) {
      const int n = 2 + trial % 7;
      std::vector<Eigen::Vector3d> pts;
      std::vector<double> dur;
      for (int i = 0; i <= n; ++i) pts.emplace_back(3 * u(rng), 3 * u(rng), 1 + 0.2 * u(rng));
      for (int i = 0; i < n; ++i) dur.push_back(1.5 + u(rng));
      const Eigen::Vector3d v0(0.3 * u(rng), 0.3 * u(rng), 0.0);
      const auto segs = SolveMinimumDerivative(pts, dur, k, v0);
      ASSERT_TRUE(segs.has_value());
      ASSERT_EQ(static_cast<int>(segs->size()), n);
      for (int axis = 0; axis < 3; ++axis) {
        const auto& first = (*segs)[0].coefficients[static_cast<size_t>(axis)];
        EXPECT_NEAR(Derivative(first, 1, 0.0), v0[axis], 1e-8);
        for (int d = 2; d < k; ++d) EXPECT_NEAR(Derivative(first, d, 0.0), 0.0, 1e-7);
        const auto& last = segs->back().coefficients[static_cast<size_t>(axis)];
        for (int d = 1; d < k; ++d) EXPECT_NEAR(Derivative(last, d, dur.back()), 0.0, 1e-7);
        for (int s = 0; s < n; ++s) {
          const auto& c = (*segs)[static_cast<size_t>(s)].coefficients[static_cast<size_t>(axis)];
          EXPECT_NEAR(Derivative(c, 0, 0.0), pts[static_cast<size_t>(s)][axis], 1e-8);
          EXPECT_NEAR(Derivative(c, 0, dur[static_cast<size_t>(s)]),
                      pts[static_cast<size_t>(s) + 1][axis], 1e-8);
          if (s + 1 == n) continue;
          const auto& next =
              (*segs)[static_cast<size_t>(s) + 1].coefficients[static_cast<size_t>(axis)];
          for (int d = 1; d <= 2 * k - 2; ++d) {
            const double a = Derivative(c, d, dur[static_cast<size_t>(s)]);
            const double b = Derivative(next, d, 0.0);
            EXPECT_NEAR(a, b, 1e-6 * (1.0 + std::abs(a))) << "k " << k << " d " << d;
          }
        }
      }
    }
  }
}

// A random maze with corridors one collision cell wide (perfect maze by depth-first search).
std::vector<bool> Maze(int w, int h, std::mt19937& rng) {
  std::vector<bool> t(static_cast<size_t>(w * h), false);
  std::vector<std::pair<int, int>> stack{{1, 1}};
  t[static_cast<size_t>(1 + w)] = true;
  while (!stack.empty()) {
    const auto [x, y] = stack.back();
    std::vector<std::pair<int, int>> next;
    const int d[4][2] = {{2, 0}, {-2, 0}, {0, 2}, {0, -2}};
    for (const auto& m : d) {
      const int nx = x + m[0], ny = y + m[1];
      if (nx > 0 && ny > 0 && nx < w - 1 && ny < h - 1 && !t[static_cast<size_t>(nx + w * ny)]) {
        next.push_back({nx, ny});
      }
    }
    if (next.empty()) {
      stack.pop_back();
      continue;
    }
    const auto [nx, ny] = next[rng() % next.size()];
    t[static_cast<size_t>((x + nx) / 2 + w * ((y + ny) / 2))] = true;
    t[static_cast<size_t>(nx + w * ny)] = true;
    stack.push_back({nx, ny});
  }
  // Open a few extra walls so that diagonals and wider rooms appear.
  for (int i = 0; i < w * h / 10; ++i) {
    const int x = 1 + static_cast<int>(rng() % static_cast<unsigned>(w - 2));
    const int y = 1 + static_cast<int>(rng() % static_cast<unsigned>(h - 2));
    t[static_cast<size_t>(x + w * y)] = true;
  }
  return t;
}

// Oracle for the disc check: distance from p to every blocked (or outside) cell square >= r.
bool DiscInsideBrute(const GridMap2D& g, const std::vector<bool>& allowed, const Eigen::Vector2d& p,
                     double r) {
  for (int y = -1; y <= g.height; ++y) {
    for (int x = -1; x <= g.width; ++x) {
      if (g.Contains(x, y) && allowed[static_cast<size_t>(g.IndexOf(x, y))]) continue;
      const double x0 = g.origin_m.x() + x * g.resolution_m,
                   y0 = g.origin_m.y() + y * g.resolution_m;
      const double dx = std::max({x0 - p.x(), 0.0, p.x() - x0 - g.resolution_m});
      const double dy = std::max({y0 - p.y(), 0.0, p.y() - y0 - g.resolution_m});
      if (std::hypot(dx, dy) < r) return false;
    }
  }
  return true;
}

// On random maze-like grids: the trajectory starts at the vehicle, ends at the goal with the
// goal's heading, passes its waypoints at the knots, respects the speed and acceleration limits,
// and every sample (0.01 s) keeps the vehicle's disc inside traversable cells.
TEST(TrajectoryPlanner, SamplesKeepDiscInsideTraversableCellsOnMazes) {
  std::mt19937 rng(21);
  TrajectoryConfig config;
  int planned = 0, repaired = 0, stopped = 0;
  for (int trial = 0; trial < 25; ++trial) {
    const int w = 9 + 2 * (trial % 4), h = 9 + 2 * ((trial / 4) % 3);
    const std::vector<bool> t = Maze(w, h, rng);
    GridMap2D c = GridMap2D::Filled({-4.0, -6.0}, 0.9, 0.75, w, h, 0.0);
    for (int i = 0; i < w * h; ++i)
      c.values[static_cast<size_t>(i)] = t[static_cast<size_t>(i)] ? 0.0 : 0.9;
    const Cell2 start{1, 1};
    const DistanceField f = ComputeDistanceField(w, h, t, start, 0.9);
    int goal = -1;
    double far = 0.0;
    for (int i = 0; i < w * h; ++i) {
      if (f.Reachable(i) && f.distance_m[static_cast<size_t>(i)] > far && rng() % 3 == 0) {
        far = f.distance_m[static_cast<size_t>(i)];
        goal = i;
      }
    }
    ASSERT_GE(goal, 0);
    const Eigen::Vector2d s2 = c.CenterOf(start) + Eigen::Vector2d(0.003, -0.002);
    const Eigen::Vector3d s3(s2.x(), s2.y(), 0.7);
    const double goal_yaw = 2.0 * M_PI * (trial % 8) / 8.0;
    // Every other trial replans in flight: 0.2 m/s along the first step of the path.
    Eigen::Vector3d v0 = Eigen::Vector3d::Zero();
    const std::vector<int> path = f.PathTo(goal);
    if (trial % 2 == 1 && path.size() > 1) {
      const Eigen::Vector2d d = c.CenterOf(c.CellAt(path[1])) - c.CenterOf(c.CellAt(path[0]));
      v0.head<2>() = 0.2 * d.normalized();
    }
    config.derivative_order = trial % 3 == 2 ? 3 : 4;  // minimum jerk in a third of the trials
    const TrajectoryPlan plan =
        PlanTrajectory(c, t, f, goal, s3, v0, 0.3, goal_yaw, 0.75, 100.0, config);
    ASSERT_TRUE(plan.trajectory.has_value()) << plan.error;
    ++planned;
    repaired += plan.repair_rounds > 0;
    stopped += plan.stop_waypoints;
    const auto& traj = *plan.trajectory;
    EXPECT_NEAR((traj.Evaluate(100.0).position_m - s3).norm(), 0.0, 1e-9);
    const Eigen::Vector2d g2 = c.CenterOf(c.CellAt(goal));
    const FlatOutput end = traj.Evaluate(traj.end_time_s());
    EXPECT_NEAR((end.position_m - Eigen::Vector3d(g2.x(), g2.y(), 0.75)).norm(), 0.0, 1e-8);
    EXPECT_NEAR(std::remainder(end.yaw_rad - goal_yaw, 2.0 * M_PI), 0.0, 1e-8);
    // Waypoints at the knots.
    double knot = 100.0;
    for (size_t s = 0; s < plan.waypoints.size(); ++s) {
      EXPECT_NEAR((traj.Evaluate(knot).position_m - plan.waypoints[s]).norm(), 0.0, 1e-7);
      if (s < traj.segments().size()) knot += traj.segments()[s].duration_s;
    }
    const std::vector<bool> allowed = AllowedCells(c, t, s2, config.vehicle_radius_m);
    for (const TrajectorySample& s : traj.Sample(0.01)) {
      ASSERT_TRUE(DiscInsideBrute(c, allowed, s.flat.position_m.head<2>(), config.vehicle_radius_m))
          << "trial " << trial << " t " << s.time_s;
      ASSERT_LE(s.flat.velocity_mps.norm(), config.max_speed_mps * (1 + 1e-9));
      ASSERT_LE(s.flat.acceleration_mps2.norm(), config.max_acceleration_mps2 * (1 + 1e-9));
      ASSERT_LE(std::abs(s.flat.yaw_rate_radps), config.max_yaw_rate_radps * (1 + 1e-9));
    }
  }
  std::printf("planned %d, midpoint-repaired %d, rests at waypoints %d\n", planned, repaired,
              stopped);
}

// Replans in flight start with the vehicle's velocity. Stretching time cannot meet the limits
// when the start velocity makes the first piece overshoot, so the planner must give up on it
// and start from rest, with a bounded duration, never stretching time without end (which once
// asked Sample() for 10^9 samples: std::bad_alloc).
TEST(TrajectoryPlanner, StartVelocityNeverMakesTimeDiverge) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  TrajectoryConfig config;
  int planned = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const int w = 9 + 2 * (trial % 4), h = 9 + 2 * ((trial / 4) % 3);
    const std::vector<bool> t = Maze(w, h, rng);
    GridMap2D c = GridMap2D::Filled({0.0, 0.0}, 0.9, 0.75, w, h, 0.0);
    for (int i = 0; i < w * h; ++i)
      c.values[static_cast<size_t>(i)] = t[static_cast<size_t>(i)] ? 0.0 : 0.9;
    const Cell2 start{1, 1};
    const DistanceField f = ComputeDistanceField(w, h, t, start, 0.9);
    std::vector<int> reachable;
    for (int i = 0; i < w * h; ++i) {
      if (f.Reachable(i) && i != c.IndexOf(start)) reachable.push_back(i);
    }
    ASSERT_FALSE(reachable.empty());
    const int goal = reachable[rng() % reachable.size()];
    // Anywhere in the start cell, at up to 0.5 m/s in any direction (0.44 m/s once diverged).
    const Eigen::Vector2d s2 = c.CenterOf(start) + 0.4 * Eigen::Vector2d(u(rng), u(rng));
    const Eigen::Vector3d v0(0.5 * u(rng), 0.5 * u(rng), 0.0);
    config.derivative_order = trial % 2 == 0 ? 4 : 3;
    const TrajectoryPlan plan = PlanTrajectory(c, t, f, goal, {s2.x(), s2.y(), 0.75}, v0,
                                               u(rng) * M_PI, u(rng) * M_PI, 0.75, 0.0, config);
    if (!plan.trajectory) continue;  // e.g. no safe path from a start inside a wall's margin
    ++planned;
    // A start from rest needs no stretching beyond a few times the trapezoid times of its
    // (possibly repaired) waypoints and the turn.
    double path_m = 0.0;
    for (size_t i = 0; i + 1 < plan.waypoints.size(); ++i) {
      path_m += (plan.waypoints[i + 1] - plan.waypoints[i]).norm();
    }
    const double bound_s =
        16.0 * (path_m / config.max_speed_mps + 2.0 * static_cast<double>(plan.waypoints.size())) +
        60.0;
    ASSERT_LT(plan.trajectory->end_time_s(), bound_s) << "trial " << trial;
    for (const TrajectorySample& s : plan.trajectory->Sample(0.02)) {
      ASSERT_LE(s.flat.velocity_mps.norm(), config.max_speed_mps * (1 + 1e-9)) << trial;
    }
  }
  EXPECT_GT(planned, 300);
}

// A vehicle whose disc grazes a door frame (a known-occupied cell beside its own) first moves
// back to the middle of its cell: no sample comes nearer the frame than the start did, and past
// the start cell's centre every disc stays inside traversable cells. (Allowing the frame cell
// for the whole trajectory let paths cut the corner: office's door collisions.)
TEST(TrajectoryPlanner, NeverCutsThroughAnOccupiedCellItStartsNextTo) {
  const int w = 5, h = 5;
  GridMap2D c = GridMap2D::Filled({0.0, 0.0}, 0.9, 0.75, w, h, 0.0);
  std::vector<bool> t(static_cast<size_t>(w * h), true);
  for (int x : {0, 1, 3, 4}) {  // the wall on row 2 with a door at (2, 2)
    c.at(x, 2) = 0.95;
    t[static_cast<size_t>(c.IndexOf(x, 2))] = false;
  }
  const Cell2 start{2, 2};
  const DistanceField f = ComputeDistanceField(w, h, t, start, 0.9);
  TrajectoryConfig config;
  const Eigen::Vector2d frame_lo(0.9, 1.8), frame_hi(1.8, 2.7);  // cell (1, 2)
  const auto distance_to_frame = [&](const Eigen::Vector2d& p) {
    const Eigen::Vector2d q = p.cwiseMax(frame_lo).cwiseMin(frame_hi);
    return (p - q).norm();
  };
  for (const int goal : {c.IndexOf(0, 4), c.IndexOf(0, 0), c.IndexOf(1, 3)}) {
    const Eigen::Vector2d s2 = c.CenterOf(start) + Eigen::Vector2d(-0.15, 0.2);  // 0.3 m away
    const TrajectoryPlan plan = PlanTrajectory(c, t, f, goal, {s2.x(), s2.y(), 0.75},
                                               Eigen::Vector3d::Zero(), 0.0, 0.0, 0.75, 0.0, config);
    ASSERT_TRUE(plan.trajectory.has_value()) << plan.error;
    ASSERT_GE(plan.waypoints.size(), 3u);
    const Eigen::Vector2d centre = c.CenterOf(start);
    EXPECT_NEAR((plan.waypoints[1].head<2>() - centre).norm(), 0.0, 1e-12);  // kept as a waypoint
    const double start_distance = distance_to_frame(s2);
    const double first_piece_s = plan.trajectory->segments()[0].duration_s;
    for (const TrajectorySample& smp : plan.trajectory->Sample(0.01)) {
      const Eigen::Vector2d p = smp.flat.position_m.head<2>();
      EXPECT_GE(distance_to_frame(p), start_distance - 0.01) << "goal " << goal << " t " << smp.time_s;
      if (smp.time_s > first_piece_s) {
        ASSERT_TRUE(DiscInsideBrute(c, t, p, config.vehicle_radius_m)) << "t " << smp.time_s;
      }
    }
  }
}

// The planned trajectory travels as a TRAJECTORY message unchanged (common/trajectory_message.h).
TEST(TrajectoryPlanner, RoundTripsThroughTheMessage) {
  std::vector<bool> t(25, true);
  GridMap2D c = GridMap2D::Filled({0.0, 0.0}, 0.9, 0.75, 5, 5, 0.0);
  const DistanceField f = ComputeDistanceField(5, 5, t, {0, 0}, 0.9);
  const TrajectoryPlan plan =
      PlanTrajectory(c, t, f, c.IndexOf(4, 3), Eigen::Vector3d(0.45, 0.45, 0.7),
                     Eigen::Vector3d::Zero(), 0.0, 2.0, 0.75, 12.5, TrajectoryConfig());
  ASSERT_TRUE(plan.trajectory.has_value()) << plan.error;
  std::string error;
  const auto back = FromMessage(ToMessage(*plan.trajectory, 1, 2), &error);
  ASSERT_TRUE(back.has_value()) << error;
  for (double time = 12.5; time < plan.trajectory->end_time_s(); time += 0.37) {
    const FlatOutput a = plan.trajectory->Evaluate(time), b = back->Evaluate(time);
    EXPECT_NEAR((a.position_m - b.position_m).norm(), 0.0, 1e-6);
    EXPECT_NEAR(a.yaw_rad, b.yaw_rad, 1e-6);
  }
}

// A wall found across the remaining path makes it unsafe; behind the vehicle it does not.
TEST(TrajectoryPlanner, RemainingPathClearSeesNewObstacles) {
  std::vector<bool> t(7, true);
  GridMap2D c = GridMap2D::Filled({0.0, 0.0}, 0.9, 0.75, 7, 1, 0.0);
  const DistanceField f = ComputeDistanceField(7, 1, t, {0, 0}, 0.9);
  const TrajectoryPlan plan =
      PlanTrajectory(c, t, f, 6, Eigen::Vector3d(0.45, 0.45, 0.75), Eigen::Vector3d::Zero(), 0.0,
                     0.0, 0.75, 0.0, TrajectoryConfig());
  ASSERT_TRUE(plan.trajectory.has_value()) << plan.error;
  const double r = TrajectoryConfig().vehicle_radius_m;
  EXPECT_TRUE(RemainingPathClear(*plan.trajectory, 0.0, c, t, r));
  std::vector<bool> blocked = t;
  blocked[4] = false;  // a wall in cell 4
  EXPECT_FALSE(RemainingPathClear(*plan.trajectory, 0.0, c, blocked, r));
  // Once the vehicle has passed cell 4 (x > 4.5 m + r), the wall no longer matters.
  double passed = 0.0;
  for (const TrajectorySample& s : plan.trajectory->Sample(0.01)) {
    if (s.flat.position_m.x() > 4.5 + r + 1e-6) {
      passed = s.time_s;
      break;
    }
  }
  ASSERT_GT(passed, 0.0);
  EXPECT_TRUE(RemainingPathClear(*plan.trajectory, passed, c, blocked, r));
}

// Line of sight is checked against the disc: a segment grazing a blocked corner is rejected even
// when its centre line stays in free cells.
TEST(TrajectoryPlanner, LineOfSightUsesTheDisc) {
  GridMap2D c = GridMap2D::Filled({0.0, 0.0}, 1.0, 0.0, 3, 3, 0.0);
  std::vector<bool> t(9, true);
  t[static_cast<size_t>(c.IndexOf(1, 1))] = false;  // a blocked centre cell
  // From (0.5, 0.5) to (2.5, 0.5): centre line y = 0.5 never enters cell (1,1) (y >= 1).
  EXPECT_TRUE(SegmentClear(c, t, {0.5, 0.5}, {2.5, 0.5}, 0.4));
  EXPECT_FALSE(SegmentClear(c, t, {0.5, 0.5}, {2.5, 0.5}, 0.55));
  // Diagonal from (0.5, 0.5) to (2.5, 2.5) crosses the blocked cell.
  EXPECT_FALSE(SegmentClear(c, t, {0.5, 0.5}, {2.5, 2.5}, 0.1));
  EXPECT_TRUE(DiscClear(c, t, {0.5, 0.5}, 0.49));
  EXPECT_FALSE(DiscClear(c, t, {0.5, 0.5}, 0.51));  // touches the grid's outside
}

}  // namespace
}  // namespace kestrel
