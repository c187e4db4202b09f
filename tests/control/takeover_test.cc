// DecideTakeover (control/takeover.h): a respawned controller takes the vehicle over when a fresh
// pose shows it airborne, however late that pose comes, and never on stale or inconsistent
// evidence (docs/design.md §2.5).
#include "control/takeover.h"

#include <gtest/gtest.h>

#include <limits>

namespace kestrel {
namespace {

class TakeoverTest : public ::testing::Test {
 protected:
  TakeoverTest() {
    previous_.ground_z_m = 0.1;
    previous_.alive_s = 100.0;  // the previous controller's last life sign
    state_.position_m = Eigen::Vector3d(1.0, 2.0, 0.9);
  }

  // The verdict at time_s with the newest pose stamped pose_s.
  TakeoverDecision At(double time_s, double pose_s) const {
    return DecideTakeover(previous_, time_s, &state_, pose_s, safety_, kMaxGapS);
  }

  static constexpr double kMaxGapS = 10.0;
  PreviousFlight previous_;
  VehicleState state_;
  SafetyConfig safety_;  // pose_timeout_s 0.1, landed_height_m 0.08, landed_speed_mps 0.3
};

// Without an estimate, or with only a stale pose, the controller keeps waiting: no deadline.
TEST_F(TakeoverTest, WaitsForAFreshPoseWithoutADeadline) {
  EXPECT_EQ(DecideTakeover(previous_, 100.5, nullptr, -std::numeric_limits<double>::infinity(),
                           safety_, kMaxGapS)
                .verdict,
            TakeoverVerdict::kWait);
  const TakeoverDecision stale = At(103.0, 102.8);
  EXPECT_EQ(stale.verdict, TakeoverVerdict::kWait);
  EXPECT_NE(stale.reason.find("0.200 s old"), std::string::npos) << stale.reason;
}

// A first fresh pose 0.5, 1, 2 or 5 s after the last life sign that shows the vehicle up: HOLD.
TEST_F(TakeoverTest, LateFreshPoseOfAnAirborneVehicleTakesItOver) {
  for (const double late_s : {0.5, 1.0, 2.0, 5.0}) {
    const TakeoverDecision d = At(100.0 + late_s + 0.01, 100.0 + late_s);
    EXPECT_EQ(d.verdict, TakeoverVerdict::kHold) << late_s << ": " << d.reason;
  }
  previous_.landing = true;
  EXPECT_EQ(At(102.01, 102.0).verdict, TakeoverVerdict::kLand);
}

// Low but falling, or high: airborne. Low and slow: on the ground.
TEST_F(TakeoverTest, OnTheGroundMeansLowAndSlow) {
  state_.position_m.z() = previous_.ground_z_m + 0.05;
  const TakeoverDecision ground = At(101.01, 101.0);
  EXPECT_EQ(ground.verdict, TakeoverVerdict::kStayIdle);
  EXPECT_NE(ground.reason.find("on the ground"), std::string::npos) << ground.reason;
  state_.velocity_mps = Eigen::Vector3d(0, 0, -0.5);
  EXPECT_EQ(At(101.01, 101.0).verdict, TakeoverVerdict::kHold) << "still falling";
  state_.velocity_mps.setZero();
  state_.position_m.z() = previous_.ground_z_m + 0.09;
  EXPECT_EQ(At(101.01, 101.0).verdict, TakeoverVerdict::kHold);
}

// A vehicle seen off the ground more than max_gap_s after its controller's last life sign is
// held up by something else; a pose stamped well before it is from another clock.
TEST_F(TakeoverTest, StaleOrInconsistentEvidenceNeverArms) {
  EXPECT_EQ(At(110.0, 109.99).verdict, TakeoverVerdict::kHold) << "9.99 s: still within";
  const TakeoverDecision stale = At(110.02, 110.01);
  EXPECT_EQ(stale.verdict, TakeoverVerdict::kStayIdle);
  EXPECT_NE(stale.reason.find("takeover_max_gap_s"), std::string::npos) << stale.reason;
  EXPECT_EQ(At(99.5, 99.45).verdict, TakeoverVerdict::kHold) << "stamped just before the sign";
  const TakeoverDecision other_clock = At(3.0, 2.99);
  EXPECT_EQ(other_clock.verdict, TakeoverVerdict::kStayIdle);
  EXPECT_NE(other_clock.reason.find("another clock"), std::string::npos) << other_clock.reason;
}

// A non-finite estimate is no evidence: wait (the estimator rejects such poses anyway).
TEST_F(TakeoverTest, NonFiniteStateWaits) {
  state_.position_m.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(At(101.01, 101.0).verdict, TakeoverVerdict::kWait);
}

}  // namespace
}  // namespace kestrel
