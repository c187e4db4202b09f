#include "exploration/startup_turn.h"

#include <gtest/gtest.h>

#include <cmath>

namespace kestrel {
namespace {

constexpr double kTwoPi = 2.0 * M_PI;

// The state of a take-off climbing at 0.5 m/s, 0.3 m up, slightly off the origin.
TrajectoryStart Climbing() {
  TrajectoryStart s;
  s.position_m = Eigen::Vector3d(5.0, -1.0, 0.3);
  s.velocity_mps = Eigen::Vector3d(0.0, 0.0, 0.5);
  s.acceleration_mps2 = Eigen::Vector3d(0.0, 0.0, 0.1);
  s.yaw_rad = 0.4;
  s.time_s = 100.0;
  return s;
}

// Samples every 1 ms: the limits, no lateral motion, z between the start and h (2 cm tolerance,
// plus 3 v0^2 / a_max on the side the start velocity v0 points to);
// returns the first time the vehicle is within 1 cm of h (and slower than 1 cm/s).
double CheckLimits(const PiecewisePolynomialTrajectory& t, const TrajectoryStart& s, double h,
                   const StartupTurnLimits& limits) {
  double at_height_s = -1.0;
  double last_yaw = s.yaw_rad;
  for (const TrajectorySample& sample : t.Sample(0.001)) {
    const FlatOutput& f = sample.flat;
    EXPECT_NEAR(f.position_m.x(), s.position_m.x(), 1e-12) << sample.time_s;
    EXPECT_NEAR(f.position_m.y(), s.position_m.y(), 1e-12) << sample.time_s;
    EXPECT_EQ(f.velocity_mps.head<2>().norm(), 0.0) << sample.time_s;
    EXPECT_EQ(f.acceleration_mps2.head<2>().norm(), 0.0) << sample.time_s;
    EXPECT_LE(std::abs(f.velocity_mps.z()), limits.max_speed_mps + 1e-9) << sample.time_s;
    EXPECT_LE(std::abs(f.acceleration_mps2.z()), limits.max_acceleration_mps2 + 1e-9)
        << sample.time_s;
    const double v0 = s.velocity_mps.z();
    const double stop = 3.0 * v0 * v0 / limits.max_acceleration_mps2;
    EXPECT_GE(f.position_m.z(), std::min(s.position_m.z(), h) - 0.02 - (v0 < 0 ? stop : 0))
        << sample.time_s;
    EXPECT_LE(f.position_m.z(), std::max(s.position_m.z(), h) + 0.02 + (v0 > 0 ? stop : 0))
        << sample.time_s;
    EXPECT_LE(f.yaw_rate_radps, limits.peak_yaw_rate_radps + 1e-9) << sample.time_s;
    EXPECT_LE(std::abs(f.yaw_acceleration_radps2), 2.0 * limits.peak_yaw_rate_radps + 1e-9)
        << sample.time_s;
    EXPECT_GE(f.yaw_rate_radps, -1e-9) << sample.time_s;  // one way round
    EXPECT_GE(f.yaw_rad, last_yaw - 1e-9) << sample.time_s;
    last_yaw = f.yaw_rad;
    if (at_height_s < 0 && std::abs(f.position_m.z() - h) < 0.01 &&
        std::abs(f.velocity_mps.z()) < 0.01) {
      at_height_s = sample.time_s - t.start_time_s();
    }
  }
  return at_height_s;
}

// The climb continues from the take-off's state (position, velocity, acceleration continuous),
// reaches h early in the turn, and the turn is exactly 2 pi within the yaw-rate limit; with
// either yaw profile.
class ClimbingTurn : public ::testing::TestWithParam<StartupYawProfile> {};

TEST_P(ClimbingTurn, ReachesHeightWhileTurningAFullCircle) {
  const TrajectoryStart s = Climbing();
  const double h = 0.8;
  StartupTurnLimits limits;  // 1 m/s, 1 m/s^2, 0.8 rad/s
  limits.yaw_profile = GetParam();
  std::string error;
  const auto t = PlanStartupTurn(s, h, limits, &error);
  ASSERT_TRUE(t.has_value()) << error;
  EXPECT_DOUBLE_EQ(t->start_time_s(), s.time_s);

  const TrajectoryStart at0 = StateAt(*t, s.time_s);
  EXPECT_LT((at0.position_m - s.position_m).norm(), 1e-12);
  EXPECT_LT((at0.velocity_mps - s.velocity_mps).norm(), 1e-12);
  EXPECT_LT((at0.acceleration_mps2 - s.acceleration_mps2).norm(), 1e-9);
  EXPECT_NEAR(at0.yaw_rad, s.yaw_rad, 1e-12);
  EXPECT_NEAR(at0.yaw_rate_radps, 0.0, 1e-12);

  // The turn sets the duration. Smoothstep: peak rate 35/16 * 2 pi / T, 17.18 s. Ramped: 0.75 s
  // ramps of the rate to and from 0.8 rad/s (sweeping 0.6 rad) and the rest of the circle at
  // 0.8 rad/s: 2 pi / 0.8 + 0.75 = 8.60 s.
  EXPECT_NEAR(t->duration_s(),
              GetParam() == StartupYawProfile::kSmoothstep ? 35.0 / 16.0 * kTwoPi / 0.8
                                                           : kTwoPi / 0.8 + 0.75,
              1e-9);
  const FlatOutput end = t->Evaluate(t->end_time_s());
  EXPECT_NEAR(end.position_m.z(), h, 1e-9);
  EXPECT_NEAR(end.velocity_mps.z(), 0.0, 1e-9);
  EXPECT_NEAR(end.acceleration_mps2.z(), 0.0, 1e-9);
  EXPECT_NEAR(end.yaw_rad - s.yaw_rad, kTwoPi, 1e-9);
  EXPECT_NEAR(end.yaw_rate_radps, 0.0, 1e-9);

  const double at_height_s = CheckLimits(*t, s, h, limits);
  ASSERT_GT(at_height_s, 0.0) << "never at h";
  EXPECT_LT(at_height_s, 3.0) << "the climb must not wait for the turn";
  // ...while the turn goes on: at that time it is not done.
  EXPECT_LT(t->Evaluate(s.time_s + at_height_s).yaw_rad - s.yaw_rad, 0.5 * kTwoPi);

  // The peak yaw rate is the limit (the turn is no slower than it must be).
  double peak = 0.0;
  for (const TrajectorySample& sample : t->Sample(0.001))
    peak = std::max(peak, sample.flat.yaw_rate_radps);
  EXPECT_NEAR(peak, 0.8, 1e-3);

  // Continuous at every knot (the climb's end and the yaw profile's pieces): position to
  // acceleration, yaw and its rate.
  ASSERT_GE(t->num_segments(), GetParam() == StartupYawProfile::kSmoothstep ? 2 : 4);
  double knot = t->start_time_s();
  for (int i = 0; i + 1 < t->num_segments(); ++i) {
    knot += t->segments()[static_cast<size_t>(i)].duration_s;
    const FlatOutput a = t->Evaluate(knot - 1e-7);
    const FlatOutput b = t->Evaluate(knot + 1e-7);
    EXPECT_LT((a.position_m - b.position_m).norm(), 1e-6) << i;
    EXPECT_LT((a.velocity_mps - b.velocity_mps).norm(), 1e-5) << i;
    EXPECT_LT((a.acceleration_mps2 - b.acceleration_mps2).norm(), 1e-4) << i;
    EXPECT_NEAR(a.yaw_rad, b.yaw_rad, 1e-6) << i;
    EXPECT_NEAR(a.yaw_rate_radps, b.yaw_rate_radps, 1e-5) << i;
  }
}

INSTANTIATE_TEST_SUITE_P(Profiles, ClimbingTurn,
                         ::testing::Values(StartupYawProfile::kSmoothstep,
                                           StartupYawProfile::kRamped));

// Tighter limits (0.3 m/s^2, 0.6 m/s, 0.5 rad/s) are respected with both yaw profiles, the
// climb just takes longer.
TEST(StartupTurn, RespectsTighterLimits) {
  const TrajectoryStart s = Climbing();
  for (const StartupYawProfile profile :
       {StartupYawProfile::kRamped, StartupYawProfile::kSmoothstep}) {
    StartupTurnLimits limits;
    limits.max_speed_mps = 0.6;
    limits.max_acceleration_mps2 = 0.3;
    limits.peak_yaw_rate_radps = 0.5;
    limits.yaw_profile = profile;
    const auto t = PlanStartupTurn(s, 1.5, limits, nullptr);
    ASSERT_TRUE(t.has_value());
    EXPECT_GT(CheckLimits(*t, s, 1.5, limits), 0.0);
    const FlatOutput end = t->Evaluate(t->end_time_s());
    EXPECT_NEAR(end.yaw_rad - s.yaw_rad, kTwoPi, 1e-9);
    EXPECT_NEAR(end.position_m.z(), 1.5, 1e-9);
  }
}

// From a hover at h the default (smoothstep) profile is the former turn in place: one piece, z
// constant, the same coefficients.
TEST(StartupTurn, FromHoverAtHeightTurnsInPlace) {
  TrajectoryStart s;
  s.position_m = Eigen::Vector3d(1.0, 2.0, 0.8);
  s.yaw_rad = -2.0;
  const StartupTurnLimits limits;
  const auto t = PlanStartupTurn(s, 0.8, limits, nullptr);
  ASSERT_TRUE(t.has_value());
  ASSERT_EQ(t->num_segments(), 1);
  const double T = 35.0 / 16.0 * kTwoPi / 0.8;
  EXPECT_NEAR(t->duration_s(), T, 1e-9);
  const std::vector<double>& yaw = t->segments()[0].coefficients[3];
  ASSERT_EQ(yaw.size(), 8u);
  const double expected[8] = {-2.0,
                              0,
                              0,
                              0,
                              kTwoPi * 35 / std::pow(T, 4),
                              -kTwoPi * 84 / std::pow(T, 5),
                              kTwoPi * 70 / std::pow(T, 6),
                              -kTwoPi * 20 / std::pow(T, 7)};
  for (size_t k = 0; k < 8; ++k)
    EXPECT_NEAR(yaw[k], expected[k], 1e-12 + 1e-9 * std::abs(expected[k]));
  EXPECT_EQ(t->segments()[0].coefficients[2], std::vector<double>{0.8});
  EXPECT_GT(CheckLimits(*t, s, 0.8, limits), -1.0);
}

// Above h (an operator's take-off higher than h) it descends to h.
TEST(StartupTurn, DescendsToHeight) {
  TrajectoryStart s;
  s.position_m = Eigen::Vector3d(0.0, 0.0, 1.4);
  s.velocity_mps = Eigen::Vector3d(0.0, 0.0, 0.2);  // still climbing a little
  const StartupTurnLimits limits;
  const auto t = PlanStartupTurn(s, 0.8, limits, nullptr);
  ASSERT_TRUE(t.has_value());
  EXPECT_GT(CheckLimits(*t, s, 0.8, limits), 0.0);
  EXPECT_NEAR(t->Evaluate(t->end_time_s()).position_m.z(), 0.8, 1e-9);
}

// A start the limits cannot take (climbing at 3 m/s with a 1 m/s limit) or a non-finite one gives
// no trajectory and says why.
TEST(StartupTurn, RefusesWhatTheLimitsCannotTake) {
  TrajectoryStart s = Climbing();
  s.velocity_mps.z() = 3.0;
  std::string error;
  EXPECT_FALSE(PlanStartupTurn(s, 0.8, StartupTurnLimits{}, &error).has_value());
  EXPECT_NE(error.find("limits"), std::string::npos) << error;
  s = Climbing();
  s.position_m.z() = std::nan("");
  EXPECT_FALSE(PlanStartupTurn(s, 0.8, StartupTurnLimits{}, &error).has_value());
  EXPECT_NE(error.find("non-finite"), std::string::npos) << error;
}

}  // namespace
}  // namespace kestrel
