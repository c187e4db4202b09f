#include "control/safety.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace kestrel {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// A trajectory from `from` to `to` in `duration_s` (linear in time), starting at start_s.
PiecewisePolynomialTrajectory Line(const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                                   double start_s, double duration_s) {
  PolynomialSegment segment;
  segment.duration_s = duration_s;
  for (int axis = 0; axis < 3; ++axis) {
    segment.coefficients[static_cast<size_t>(axis)] = {from[axis],
                                                       (to[axis] - from[axis]) / duration_s};
  }
  segment.coefficients[3] = {0.0};
  return *PiecewisePolynomialTrajectory::Create(start_s, {segment}, nullptr);
}

// Given a supervisor whose vehicle follows its set points perfectly.
class SafetyTest : public ::testing::Test {
 protected:
  SafetyDecision Step(double t, double last_pose_s) {
    const SafetyDecision d = supervisor_.Update(t, &state_, last_pose_s);
    if (d.motors_enabled) {
      state_.position_m = d.setpoint.position_m;
      state_.velocity_mps = d.setpoint.velocity_mps;
    }
    return d;
  }
  // Runs from t0 to t1 at 100 Hz with poses fresh at every step.
  SafetyDecision RunFresh(double t0, double t1) {
    SafetyDecision d;
    for (double t = t0; t <= t1 + 1e-9; t += 0.01) d = Step(t, t);
    return d;
  }
  void TakeOffToHold() {
    ASSERT_TRUE(supervisor_.HandleCommand(FlightCommand::kTakeoff, 0.0, &state_, 0.0));
    const SafetyDecision d = RunFresh(0.0, 3.0);
    ASSERT_EQ(d.mode, FlightMode::kHold) << d.reason;
  }

  SafetyConfig config_;
  SafetySupervisor supervisor_{config_};
  VehicleState state_;  // on the ground at the origin
};

TEST_F(SafetyTest, TakeOffHoldTrackLandIdle) {
  EXPECT_EQ(supervisor_.mode(), FlightMode::kIdle);
  EXPECT_FALSE(supervisor_.Update(0.0, &state_, 0.0).motors_enabled);
  ASSERT_TRUE(supervisor_.HandleCommand(FlightCommand::kTakeoff, 0.0, &state_, 0.0));
  SafetyDecision d = Step(1.0, 1.0);
  EXPECT_EQ(d.mode, FlightMode::kTakeoff);
  EXPECT_TRUE(d.motors_enabled);
  EXPECT_TRUE(d.reset_integrals);
  EXPECT_NEAR(d.setpoint.position_m.z(), 0.5, 1e-12);  // 0.5 m/s for 1 s
  d = RunFresh(1.0, 3.0);
  EXPECT_EQ(d.mode, FlightMode::kHold);
  EXPECT_NEAR(d.setpoint.position_m.z(), 1.0, 1e-12);

  // A trajectory in HOLD starts TRACK.
  std::string reason;
  ASSERT_TRUE(supervisor_.AcceptTrajectory(Line({0, 0, 1}, {2, 1, 1}, 3.0, 2.0), 3.0, &reason));
  d = Step(4.0, 4.0);
  EXPECT_EQ(d.mode, FlightMode::kTrack);
  EXPECT_LT((d.setpoint.position_m - Eigen::Vector3d(1, 0.5, 1)).norm(), 1e-12);
  EXPECT_FALSE(d.reset_integrals);

  // LAND descends from where it was and ends in IDLE on the ground.
  ASSERT_TRUE(supervisor_.HandleCommand(FlightCommand::kLand, 4.0, &state_, 4.0));
  d = Step(5.0, 5.0);
  EXPECT_EQ(d.mode, FlightMode::kLand);
  EXPECT_NEAR(d.setpoint.position_m.z(), 0.6, 1e-9);
  EXPECT_LT((d.setpoint.position_m.head<2>() - Eigen::Vector2d(1, 0.5)).norm(), 1e-12);
  state_.velocity_mps.setZero();
  d = RunFresh(5.0, 8.0);
  EXPECT_EQ(d.mode, FlightMode::kIdle) << d.reason;
  EXPECT_FALSE(d.motors_enabled);
  EXPECT_EQ(d.reason, "landed");
}

// A trajectory during TAKEOFF (the explorer's climb and start-up turn, docs/exploration.md
// "Start-up: the turn while climbing") is refused until the take-off set point has risen
// takeoff_track_min_rise_m (0.2 m: 0.4 s at 0.5 m/s), then starts TRACK at once.
TEST_F(SafetyTest, TrajectoryDuringTakeoffTracksOnceAirborne) {
  ASSERT_TRUE(supervisor_.HandleCommand(FlightCommand::kTakeoff, 0.0, &state_, 0.0));
  SafetyDecision d = RunFresh(0.0, 0.2);
  ASSERT_EQ(d.mode, FlightMode::kTakeoff);
  std::string reason;
  EXPECT_FALSE(supervisor_.AcceptTrajectory(Line({0, 0, 0.1}, {0, 0, 1}, 0.2, 1.8), 0.2, &reason));
  EXPECT_NE(reason.find("TAKEOFF"), std::string::npos) << reason;
  d = RunFresh(0.21, 0.6);
  EXPECT_EQ(d.mode, FlightMode::kTakeoff);
  EXPECT_TRUE(d.reset_integrals);
  EXPECT_NEAR(d.setpoint.position_m.z(), 0.3, 1e-9);

  ASSERT_TRUE(supervisor_.AcceptTrajectory(Line({0, 0, 0.3}, {0, 0, 1}, 0.6, 1.4), 0.6, &reason))
      << reason;
  d = Step(1.0, 1.0);
  EXPECT_EQ(d.mode, FlightMode::kTrack) << d.reason;
  EXPECT_NEAR(d.setpoint.position_m.z(), 0.3 + 0.7 * 0.4 / 1.4, 1e-9);
  EXPECT_FALSE(d.reset_integrals);
  // After the trajectory (and its time-out): HOLD where it ended, not the take-off's climb.
  d = RunFresh(1.01, 4.0);
  EXPECT_EQ(d.mode, FlightMode::kHold) << d.reason;
  EXPECT_NEAR(d.setpoint.position_m.z(), 1.0, 1e-9);
}

TEST_F(SafetyTest, TakeoffNeedsIdleAndAFreshPose) {
  EXPECT_FALSE(supervisor_.HandleCommand(FlightCommand::kTakeoff, 1.0, &state_, 0.5));  // stale
  EXPECT_FALSE(supervisor_.HandleCommand(FlightCommand::kTakeoff, 1.0, nullptr, 1.0));
  EXPECT_FALSE(supervisor_.HandleCommand(FlightCommand::kTakeoff, 1.0, &state_, -kInf));
  EXPECT_FALSE(supervisor_.HandleCommand(FlightCommand::kTrack, 1.0, &state_, 1.0));
  EXPECT_FALSE(supervisor_.HandleCommand(FlightCommand::kHold, 1.0, &state_, 1.0));
  EXPECT_FALSE(supervisor_.HandleCommand(static_cast<FlightCommand>(42), 1.0, &state_, 1.0));
  EXPECT_EQ(supervisor_.mode(), FlightMode::kIdle);
}

// E-stop cuts the motors at once, from any mode, and stays until IDLE.
TEST_F(SafetyTest, EstopCutsMotorsAndLatches) {
  TakeOffToHold();
  ASSERT_TRUE(supervisor_.HandleCommand(FlightCommand::kEstop, 3.0, &state_, 3.0));
  EXPECT_FALSE(supervisor_.last_decision().motors_enabled);
  SafetyDecision d = Step(3.01, 3.01);
  EXPECT_EQ(d.mode, FlightMode::kEstop);
  EXPECT_FALSE(d.motors_enabled);
  EXPECT_FALSE(supervisor_.HandleCommand(FlightCommand::kTakeoff, 3.02, &state_, 3.02));
  EXPECT_FALSE(supervisor_.HandleCommand(FlightCommand::kLand, 3.02, &state_, 3.02));
  ASSERT_TRUE(supervisor_.HandleCommand(FlightCommand::kIdle, 3.03, &state_, 3.03));
  EXPECT_EQ(supervisor_.mode(), FlightMode::kIdle);
  // IDLE is refused in flight (motors off only through ESTOP).
  state_ = VehicleState{};
  TakeOffToHold();
  EXPECT_FALSE(supervisor_.HandleCommand(FlightCommand::kIdle, 3.0, &state_, 3.0));
}

// Pose lost for 1 s (< land_timeout_s): HOLD after pose_timeout_s, TRACK again when poses return.
TEST_F(SafetyTest, ShortPoseLossHoldsThenResumesTracking) {
  TakeOffToHold();
  ASSERT_TRUE(supervisor_.AcceptTrajectory(Line({0, 0, 1}, {3, 0, 1}, 3.0, 10.0), 3.0, nullptr));
  SafetyDecision d = RunFresh(3.0, 4.0);
  ASSERT_EQ(d.mode, FlightMode::kTrack);
  const double last_pose = 4.0;
  d = Step(4.05, last_pose);
  EXPECT_EQ(d.mode, FlightMode::kTrack);  // within pose_timeout_s
  d = Step(4.15, last_pose);
  EXPECT_EQ(d.mode, FlightMode::kHold);
  const Eigen::Vector3d held = d.setpoint.position_m;
  for (double t = 4.2; t < 5.0; t += 0.01) {
    d = Step(t, last_pose);
    ASSERT_EQ(d.mode, FlightMode::kHold);
    ASSERT_EQ(d.setpoint.position_m, held);
  }
  d = Step(5.0, 5.0);  // poses back after 1 s
  EXPECT_EQ(d.mode, FlightMode::kTrack) << d.reason;
  EXPECT_NEAR(d.setpoint.position_m.x(), 0.6, 1e-9);  // the trajectory at t = 5 s
}

// Pose lost for longer than land_timeout_s (2 s): LAND, which continues even when poses return.
TEST_F(SafetyTest, LongPoseLossLands) {
  TakeOffToHold();
  SafetyDecision d;
  for (double t = 3.01; t < 5.0; t += 0.01) {
    d = Step(t, 3.0);
    ASSERT_NE(d.mode, FlightMode::kLand) << t;
  }
  d = Step(5.01, 3.0);
  EXPECT_EQ(d.mode, FlightMode::kLand);
  EXPECT_TRUE(d.motors_enabled);
  d = Step(5.5, 5.5);
  EXPECT_EQ(d.mode, FlightMode::kLand);
}

// A landing without poses (blind): the estimate follows the set point down (as an IMU that does
// not register a soft touchdown lets it), so the height test must not end the landing at the
// ground height; the set point goes on below the geofence floor to blind_land_depth_m under the
// ground and the landing ends there, not before.
TEST_F(SafetyTest, BlindLandingDescendsToItsDepthBeforeDisarming) {
  TakeOffToHold();  // hover 1 m above the ground at z = 0; poses stop at t = 3
  SafetyDecision d;
  double lowest_setpoint_z = kInf;
  double t = 3.01;
  for (; t < 20.0; t += 0.01) {
    d = Step(t, 3.0);
    if (d.mode == FlightMode::kIdle) break;
    if (d.mode == FlightMode::kLand)
      lowest_setpoint_z = std::min(lowest_setpoint_z, d.setpoint.position_m.z());
  }
  ASSERT_EQ(d.mode, FlightMode::kIdle) << d.reason;
  EXPECT_FALSE(d.motors_enabled);
  // LAND at 5 s, 1 m + blind_land_depth_m = 2 m at 0.4 m/s: 5 s later.
  EXPECT_NEAR(t, 3.0 + config_.land_timeout_s + 2.0 / config_.land_speed_mps, 0.03);
  EXPECT_NEAR(lowest_setpoint_z, -config_.blind_land_depth_m, 0.005);
  EXPECT_LT(lowest_setpoint_z, config_.geofence_min_m.z());
}

// Blind, a vehicle that stops following the set point down (its IMU saw the touchdown) is
// declared landed once the set point is blind_landed_gap_m below it.
TEST_F(SafetyTest, BlindLandingEndsWhenTheVehicleStopsFollowing) {
  TakeOffToHold();
  SafetyDecision d;
  double t = 3.01;
  for (; t < 5.02; t += 0.01) d = Step(t, 3.0);
  ASSERT_EQ(d.mode, FlightMode::kLand);
  // The vehicle stops at 0.5 m (e.g. on a table the estimate did not know).
  for (; t < 20.0; t += 0.01) {
    d = supervisor_.Update(t, &state_, 3.0);
    if (state_.position_m.z() > 0.5) {
      state_.position_m = d.setpoint.position_m;
      state_.velocity_mps = d.setpoint.velocity_mps;
    } else {
      state_.velocity_mps.setZero();
    }
    if (d.mode == FlightMode::kIdle) break;
  }
  ASSERT_EQ(d.mode, FlightMode::kIdle) << d.reason;
  EXPECT_NEAR(d.setpoint.position_m.z(), 0.5 - config_.blind_landed_gap_m, 0.01);
}

TEST_F(SafetyTest, StaleTrajectoryHolds) {
  TakeOffToHold();
  ASSERT_TRUE(supervisor_.AcceptTrajectory(Line({0, 0, 1}, {1, 0, 1}, 3.0, 1.0), 3.0, nullptr));
  SafetyDecision d = RunFresh(3.0, 4.9);
  EXPECT_EQ(d.mode, FlightMode::kTrack);  // hovering at the end, within the time-out
  d = RunFresh(4.9, 5.1);
  EXPECT_EQ(d.mode, FlightMode::kHold);
  EXPECT_EQ(d.reason, "trajectory stale");
  EXPECT_LT((d.setpoint.position_m - Eigen::Vector3d(1, 0, 1)).norm(), 1e-12);
  EXPECT_FALSE(supervisor_.HandleCommand(FlightCommand::kTrack, 5.2, &state_, 5.2));
}

TEST_F(SafetyTest, GeofenceRefusesTrajectoriesAndLandsOutside) {
  TakeOffToHold();
  std::string reason;
  EXPECT_FALSE(supervisor_.AcceptTrajectory(Line({0, 0, 1}, {5, 0, 1}, 3.0, 5.0), 3.0, &reason));
  EXPECT_NE(reason.find("geofence"), std::string::npos) << reason;
  EXPECT_EQ(supervisor_.mode(), FlightMode::kHold);
  // The vehicle itself outside the fence by more than the margin: LAND.
  state_.position_m = Eigen::Vector3d(4.5, 0.0, 1.0);
  const SafetyDecision d = supervisor_.Update(3.1, &state_, 3.1);
  EXPECT_EQ(d.mode, FlightMode::kLand);
  EXPECT_TRUE((d.setpoint.position_m.array() <= config_.geofence_max_m.array()).all());
}

TEST_F(SafetyTest, NonFiniteInputIsRejected) {
  TakeOffToHold();
  const SafetyDecision before = supervisor_.last_decision();
  const SafetyDecision same =
      supervisor_.Update(std::numeric_limits<double>::quiet_NaN(), &state_, 3.0);
  EXPECT_EQ(same.mode, before.mode);
  EXPECT_FALSE(supervisor_.HandleCommand(FlightCommand::kLand,
                                         std::numeric_limits<double>::quiet_NaN(), &state_, 3.0));
  VehicleState bad = state_;
  bad.velocity_mps.x() = std::numeric_limits<double>::quiet_NaN();
  const SafetyDecision d = supervisor_.Update(3.1, &bad, 3.1);
  EXPECT_EQ(d.mode, FlightMode::kEstop);
  EXPECT_FALSE(d.motors_enabled);
  EXPECT_TRUE(d.setpoint.IsFinite());
}

TEST(SafetyConfig, ValidateNamesFieldAndRange) {
  SafetyConfig config;
  config.land_timeout_s = 0.05;  // below pose_timeout_s
  try {
    config.Validate();
    ADD_FAILURE();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("safety.land_timeout_s = 0.05"), std::string::npos);
  }
}

}  // namespace
}  // namespace kestrel

namespace kestrel {
namespace {

// The far-start rule (docs/design.md §2.5): in HOLD and TRACK a trajectory whose set point now is
// farther than max_trajectory_start_offset_m from the current set point is refused, with a reason
// that begins with kFarStartReason, and the set point does not move; one that starts at the set
// point is flown.
TEST_F(SafetyTest, RefusesATrajectoryThatWouldStepTheSetPoint) {
  TakeOffToHold();
  const Eigen::Vector3d held = supervisor_.last_decision().setpoint.position_m;
  std::string reason;
  const Eigen::Vector3d far = held + Eigen::Vector3d(0.5, 0.0, 0.0);
  EXPECT_FALSE(supervisor_.AcceptTrajectory(Line(far, far + Eigen::Vector3d(1, 0, 0), 3.0, 2.0),
                                            3.0, &reason));
  EXPECT_EQ(reason.rfind(kFarStartReason, 0), 0u) << reason;
  SafetyDecision d = RunFresh(3.0, 3.5);
  EXPECT_EQ(d.mode, FlightMode::kHold);
  EXPECT_LT((d.setpoint.position_m - held).norm(), 1e-9) << "the set point moved";
  // Within the offset (0.2 m < 0.3 m): flown.
  const Eigen::Vector3d near = held + Eigen::Vector3d(0.2, 0.0, 0.0);
  ASSERT_TRUE(supervisor_.AcceptTrajectory(Line(near, near + Eigen::Vector3d(1, 0, 0), 3.5, 2.0),
                                           3.5, &reason))
      << reason;
  EXPECT_EQ(RunFresh(3.5, 3.6).mode, FlightMode::kTrack);
  // In TRACK, against the flown set point: a trajectory starting 1 m behind it is refused.
  const Eigen::Vector3d now = supervisor_.last_decision().setpoint.position_m;
  EXPECT_FALSE(supervisor_.AcceptTrajectory(Line(now - Eigen::Vector3d(1, 0, 0), now, 3.6, 2.0),
                                            3.6, &reason));
  EXPECT_EQ(reason.rfind(kFarStartReason, 0), 0u) << reason;
  EXPECT_EQ(RunFresh(3.6, 3.7).mode, FlightMode::kTrack);
}

// A takeover (a controller restarted in flight) holds where the vehicle is, with zero velocity,
// from IDLE only and with a fresh pose; "landing" resumes LAND, and the landing ends at the given
// ground height.
TEST_F(SafetyTest, TakeoverHoldsWhereTheVehicleIs) {
  state_.position_m = Eigen::Vector3d(1.0, 2.0, 0.9);
  state_.velocity_mps = Eigen::Vector3d(0.3, 0.0, -0.5);
  std::string reason;
  EXPECT_FALSE(supervisor_.Takeover(10.0, state_, 9.0, 0.0, false, &reason)) << "stale pose";
  EXPECT_NE(reason.find("no fresh pose"), std::string::npos) << reason;
  ASSERT_TRUE(supervisor_.Takeover(10.0, state_, 10.0, 0.1, false, &reason)) << reason;
  SafetyDecision d = supervisor_.Update(10.0, &state_, 10.0);
  EXPECT_EQ(d.mode, FlightMode::kHold);
  EXPECT_TRUE(d.motors_enabled);
  EXPECT_LT((d.setpoint.position_m - Eigen::Vector3d(1.0, 2.0, 0.9)).norm(), 1e-12);
  EXPECT_EQ(d.setpoint.velocity_mps.norm(), 0.0);
  EXPECT_DOUBLE_EQ(supervisor_.ground_z_m(), 0.1);
  EXPECT_FALSE(supervisor_.Takeover(10.1, state_, 10.1, 0.0, false, &reason)) << "not from HOLD";

  SafetySupervisor landing(config_);
  ASSERT_TRUE(landing.Takeover(10.0, state_, 10.0, 0.0, true, &reason)) << reason;
  EXPECT_EQ(landing.Update(10.0, &state_, 10.0).mode, FlightMode::kLand);
}

}  // namespace
}  // namespace kestrel
