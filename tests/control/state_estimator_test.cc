#include "control/state_estimator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <deque>
#include <limits>

namespace kestrel {
namespace {

constexpr double kG = 9.81;

// A known motion: a 1 m circle at 1 rad/s with a vertical bob, and a constant body rate from a
// tilted start, so gyro and accelerometer are known exactly.
struct Truth {
  Eigen::Vector3d w0{0.2, -0.1, 0.5};  // body rate, rad/s
  Eigen::Matrix3d R0 =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, -1, 0.5).normalized()).toRotationMatrix();
  Eigen::Vector3d p(double t) const {
    return {std::cos(t), std::sin(t), 1.0 + 0.2 * std::sin(2 * t)};
  }
  Eigen::Vector3d v(double t) const { return {-std::sin(t), std::cos(t), 0.4 * std::cos(2 * t)}; }
  Eigen::Vector3d a(double t) const { return {-std::cos(t), -std::sin(t), -0.8 * std::sin(2 * t)}; }
  Eigen::Matrix3d R(double t) const {
    return R0 * Eigen::AngleAxisd(w0.norm() * t, w0.normalized()).toRotationMatrix();
  }
  ImuSample Imu(double t, const Eigen::Vector3d& gyro_bias) const {
    ImuSample s;
    s.time_s = t;
    s.angular_velocity_radps = w0 + gyro_bias;
    s.specific_force_mps2 = R(t).transpose() * (a(t) + kG * Eigen::Vector3d::UnitZ());
    return s;
  }
  PoseMeasurement Pose(double t) const {
    PoseMeasurement m;
    m.time_s = t;
    m.position_m = p(t);
    m.q_WB = Eigen::Quaterniond(R(t));
    return m;
  }
};

double AttitudeErrorDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a.transpose() * b).angle() * 180.0 / 3.14159265358979323846;
}

struct Errors {
  double position_m = 0.0;
  double velocity_mps = 0.0;
  double attitude_deg = 0.0;
};

// Runs IMU at 400 Hz and poses at 100 Hz arriving latency_s after their stamps, from t0 to t1;
// poses stamped inside [drop_begin, drop_end) are lost. Returns the errors at t1.
Errors Feed(StateEstimator* estimator, const Truth& truth, double t0, double t1, double latency_s,
            const Eigen::Vector3d& gyro_bias, double drop_begin = 1e9, double drop_end = 1e9) {
  std::deque<PoseMeasurement> in_flight;
  const double imu_dt = 0.0025;
  double next_pose = t0;
  for (double t = t0; t <= t1 + 1e-9; t += imu_dt) {
    while (next_pose <= t + 1e-9) {
      if (!(next_pose >= drop_begin && next_pose < drop_end))
        in_flight.push_back(truth.Pose(next_pose));
      next_pose += 0.01;
    }
    while (!in_flight.empty() && in_flight.front().time_s + latency_s <= t + 1e-9) {
      estimator->AddPose(in_flight.front());
      in_flight.pop_front();
    }
    estimator->AddImu(truth.Imu(t, gyro_bias));
  }
  const VehicleState s = estimator->state();
  const double t = estimator->time_s();
  return {(s.position_m - truth.p(t)).norm(), (s.velocity_mps - truth.v(t)).norm(),
          AttitudeErrorDeg(s.R_WB, truth.R(t))};
}

// Poses arrive 30 ms late while the vehicle moves at over 1 m/s: uncompensated, the estimate
// would trail by 3 cm; with the history replay it matches the truth NOW to millimetres.
TEST(StateEstimator, CompensatesPoseLatency) {
  StateEstimator estimator{StateEstimatorConfig{}};
  const Truth truth;
  const Errors e = Feed(&estimator, truth, 0.0, 6.0, 0.03, Eigen::Vector3d::Zero());
  EXPECT_LT(e.position_m, 0.002);
  EXPECT_LT(e.velocity_mps, 0.01);
  EXPECT_LT(e.attitude_deg, 0.05);
  EXPECT_EQ(estimator.rejected_inputs(), 0);
  EXPECT_NEAR(estimator.time_s(), 6.0, 1e-6);
  // Angular velocity is the gyro's.
  EXPECT_LT((estimator.state().angular_velocity_radps - truth.w0).norm(), 1e-3);
}

// A constant gyro bias is learnt from the attitude corrections.
TEST(StateEstimator, EstimatesGyroBias) {
  StateEstimator estimator{StateEstimatorConfig{}};
  const Truth truth;
  const Eigen::Vector3d bias(0.03, -0.02, 0.015);
  const Errors e = Feed(&estimator, truth, 0.0, 30.0, 0.02, bias);
  EXPECT_LT((estimator.gyro_bias_radps() - bias).norm(), 1e-3)
      << estimator.gyro_bias_radps().transpose();
  EXPECT_LT(e.attitude_deg, 0.1);
  EXPECT_LT(e.position_m, 0.005);
}

// Motion capture lost for 1 s: the IMU carries attitude (and, drifting, position); when poses
// return the estimate converges again.
TEST(StateEstimator, FliesThroughOneSecondDropout) {
  StateEstimator estimator{StateEstimatorConfig{}};
  const Truth truth;
  const Eigen::Vector3d bias(0.01, 0.0, -0.01);
  Feed(&estimator, truth, 0.0, 20.0, 0.02, bias);
  // The dropout: poses stamped in [20, 21) never arrive.
  const Errors during = Feed(&estimator, truth, 20.0025, 21.0, 0.02, bias, 20.0, 21.0);
  EXPECT_LT(during.attitude_deg, 0.2);
  EXPECT_LT(during.position_m, 0.05);
  EXPECT_LT(estimator.last_pose_time_s(), 20.0);
  const Errors after = Feed(&estimator, truth, 21.0025, 23.0, 0.02, bias);
  EXPECT_LT(after.position_m, 0.003);
  EXPECT_LT(after.attitude_deg, 0.1);
  std::printf("1 s dropout: position error %.1f mm, attitude %.3f deg at its end\n",
              during.position_m * 1e3, during.attitude_deg);
}

TEST(StateEstimator, RejectsNonFiniteAndOutOfOrderInput) {
  StateEstimator estimator{StateEstimatorConfig{}};
  const Truth truth;
  EXPECT_FALSE(estimator.AddImu(truth.Imu(0.0, Eigen::Vector3d::Zero())));  // before any pose
  ASSERT_TRUE(estimator.AddPose(truth.Pose(0.0)));
  ASSERT_TRUE(estimator.AddImu(truth.Imu(0.01, Eigen::Vector3d::Zero())));
  const VehicleState before = estimator.state();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  ImuSample bad_imu = truth.Imu(0.02, Eigen::Vector3d::Zero());
  bad_imu.specific_force_mps2.y() = nan;
  EXPECT_FALSE(estimator.AddImu(bad_imu));
  EXPECT_FALSE(estimator.AddImu(truth.Imu(0.005, Eigen::Vector3d::Zero())));  // out of order
  PoseMeasurement bad_pose = truth.Pose(0.01);
  bad_pose.position_m.x() = nan;
  EXPECT_FALSE(estimator.AddPose(bad_pose));
  bad_pose = truth.Pose(0.01);
  bad_pose.q_WB.coeffs() *= 1.5;  // not unit
  EXPECT_FALSE(estimator.AddPose(bad_pose));
  EXPECT_EQ(estimator.rejected_inputs(), 4);
  EXPECT_EQ(estimator.state().position_m, before.position_m);
  EXPECT_EQ(estimator.state().R_WB, before.R_WB);
  // Older than the history (0.5 s): rejected.
  for (double t = 0.0125; t < 1.0; t += 0.0025)
    ASSERT_TRUE(estimator.AddImu(truth.Imu(t, Eigen::Vector3d::Zero())));
  EXPECT_FALSE(estimator.AddPose(truth.Pose(0.2)));
}

// A pose far from the estimate (after a long loss) snaps the estimate to it.
TEST(StateEstimator, SnapsOnLargeInnovation) {
  StateEstimator estimator{StateEstimatorConfig{}};
  PoseMeasurement pose;
  ASSERT_TRUE(estimator.AddPose(pose));
  pose.time_s = 0.01;
  pose.position_m = Eigen::Vector3d(3.0, 0.0, 0.0);
  ASSERT_TRUE(estimator.AddPose(pose));
  EXPECT_EQ(estimator.resets(), 1);
  EXPECT_EQ(estimator.state().position_m, pose.position_m);
}

TEST(StateEstimator, ValidateNamesFieldAndRange) {
  StateEstimatorConfig config;
  config.history_s = 0.0;
  EXPECT_THROW(config.Validate(), std::invalid_argument);
  config = StateEstimatorConfig{};
  config.position_bandwidth_radps = 50.0;  // 2 w dt = 5 > 1
  try {
    config.Validate();
    ADD_FAILURE();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("estimator.position_bandwidth_radps = 50"),
              std::string::npos);
  }
}

}  // namespace
}  // namespace kestrel
