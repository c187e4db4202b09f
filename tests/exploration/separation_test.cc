// Several vehicles: where another vehicle is expected over time, and the closest approach of a
// trajectory to the others (exploration/separation.h), against closed-form answers for straight
// constant-speed lines.
#include "exploration/separation.h"

#include <gtest/gtest.h>

#include <cmath>

namespace kestrel {
namespace {

// A straight flight from a to b at constant speed over duration_s, starting at start_s, heading
// yaw_rad (one linear segment per axis).
PiecewisePolynomialTrajectory Line(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                   double start_s, double duration_s, double yaw_rad = 0.0) {
  PolynomialSegment s;
  s.duration_s = duration_s;
  for (int i = 0; i < 3; ++i) s.coefficients[i] = {a[i], (b[i] - a[i]) / duration_s};
  s.coefficients[3] = {yaw_rad};
  std::string error;
  auto t = PiecewisePolynomialTrajectory::Create(start_s, {s}, &error);
  EXPECT_TRUE(t.has_value()) << error;
  return *t;
}

TEST(Separation, PeerPositionFollowsTrajectoryThenHoldsElseLastSeen) {
  PeerMotion peer;
  EXPECT_FALSE(PeerPositionAt(peer, 0.0).has_value()) << "nothing known";
  peer.seen = true;
  peer.position_m = Eigen::Vector3d(5, 5, 1);
  EXPECT_EQ(*PeerPositionAt(peer, 3.0), peer.position_m) << "no trajectory: where it was seen";
  peer.trajectory = Line({0, 0, 1}, {4, 0, 1}, 10.0, 4.0);
  EXPECT_EQ(*PeerPositionAt(peer, 9.0), peer.position_m) << "before its trajectory starts";
  EXPECT_NEAR((*PeerPositionAt(peer, 11.0) - Eigen::Vector3d(1, 0, 1)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((*PeerPositionAt(peer, 100.0) - Eigen::Vector3d(4, 0, 1)).norm(), 0.0, 1e-12)
      << "after its end: holding there";
  // Seen after its trajectory's end (landed at (4, 0, 0)): where it was seen, at any time.
  peer.position_m = Eigen::Vector3d(4, 0, 0);
  peer.position_time_s = 15.0;
  EXPECT_EQ(*PeerPositionAt(peer, 11.0), peer.position_m);
  EXPECT_EQ(*PeerPositionAt(peer, 100.0), peer.position_m);
  peer.position_time_s = 13.0;  // seen during it: the trajectory
  EXPECT_NEAR((*PeerPositionAt(peer, 100.0) - Eigen::Vector3d(4, 0, 1)).norm(), 0.0, 1e-12);
  peer.seen = false;
  EXPECT_NEAR((*PeerPositionAt(peer, 9.0) - Eigen::Vector3d(0, 0, 1)).norm(), 0.0, 1e-12)
      << "not seen: its trajectory's start";
}

TEST(Separation, AVehicleFarEnoughBelowIsClear) {
  // Own flies at 1 m over (2, 0); the peer has landed there (z = 0.05).
  const PiecewisePolynomialTrajectory own = Line({0, 0, 1}, {4, 0, 1}, 10.0, 4.0);
  PeerMotion landed{"V2_", std::nullopt, {2, 0, 0.05}, true, 9.0};
  EXPECT_TRUE(std::isinf(ClosestApproach(own, 10.0, {landed}, 0.6, 0.05).distance_m));
  EXPECT_TRUE(std::isinf(SeparationAt({2, 0, 1}, landed, 12.0, 0.6)));
  // Less than the vertical separation below: the horizontal distance counts.
  EXPECT_NEAR(ClosestApproach(own, 10.0, {landed}, 1.0, 0.05).distance_m, 0.0, 1e-9);
  EXPECT_NEAR(SeparationAt({2, 0.3, 1}, landed, 12.0, 1.0), 0.3, 1e-12);
}

TEST(Separation, ClosestApproachToAHoveringVehicleIsTheLinesDistance) {
  // Own: (0, 0) to (4, 0) in 4 s; the peer hovers at (2, 0.5): 0.5 m at t = 12 s.
  const PiecewisePolynomialTrajectory own = Line({0, 0, 1}, {4, 0, 1}, 10.0, 4.0);
  PeerMotion peer;
  peer.name = "V2_";
  peer.seen = true;
  peer.position_m = Eigen::Vector3d(2, 0.5, 1);
  const Separation s = ClosestApproach(own, 10.0, {peer}, 0.6, 0.05);
  EXPECT_NEAR(s.distance_m, 0.5, 1e-9);
  EXPECT_NEAR(s.time_s, 12.0, 1e-9);
  EXPECT_EQ(s.peer, "V2_");
  // From t = 13 s on, only the rest is checked: from (3, 0), nearest at the start.
  EXPECT_NEAR(ClosestApproach(own, 13.0, {peer}, 0.6, 0.05).distance_m, std::hypot(1.0, 0.5), 1e-9);
}

TEST(Separation, CrossingPathsConflictOnlyWhenTheyMeetInTime) {
  // Own along x through (2, 0) at t = 12 s; the peer along y through (2, 0).
  const PiecewisePolynomialTrajectory own = Line({0, 0, 1}, {4, 0, 1}, 10.0, 4.0);
  PeerMotion same_time{"V2_", Line({2, -2, 1}, {2, 2, 1}, 10.0, 4.0), {2, -2, 1}, true, 9.0};
  EXPECT_NEAR(ClosestApproach(own, 10.0, {same_time}, 0.6, 0.05).distance_m, 0.0, 1e-9);
  // The peer starts 20 s later, waiting at (2, -2) until then; own holds at (4, 0) from 14 s.
  PeerMotion later{"V2_", Line({2, -2, 1}, {2, 2, 1}, 30.0, 4.0), {2, -2, 1}, true, 9.0};
  const Separation s = ClosestApproach(own, 10.0, {later}, 0.6, 0.05);
  // Own at time t <= 14 is (t - 10, 0); the peer waits at (2, -2) until 30 s: the nearest is
  // 2 m (own passing x = 2 at 12 s), and 2 m again when the peer crosses y = 0 at 32 s.
  EXPECT_NEAR(s.distance_m, 2.0, 1e-9);
  // Several peers: the nearest one counts.
  PeerMotion far{"V3_", std::nullopt, {10, 10, 1}, true, 9.0};
  EXPECT_EQ(ClosestApproach(own, 10.0, {far, same_time}, 0.6, 0.05).peer, "V2_");
  EXPECT_TRUE(std::isinf(ClosestApproach(own, 10.0, {}, 0.6, 0.05).distance_m));
}

TEST(Separation, PeerGoalsAreTheTrajectoryEnds) {
  PeerMotion a{"V2_", Line({0, 0, 1}, {3, 4, 1}, 0.0, 5.0, 1.25), {0, 0, 1}, true, -1.0};
  PeerMotion b{"V3_", std::nullopt, {1, 1, 1}, true, -1.0};
  const std::vector<Eigen::Vector3d> goals = PeerGoals({a, b});
  ASSERT_EQ(goals.size(), 1u) << "a vehicle without a trajectory has no goal";
  EXPECT_NEAR((goals[0] - Eigen::Vector3d(3, 4, 1.25)).norm(), 0.0, 1e-12);
}

}  // namespace
}  // namespace kestrel
