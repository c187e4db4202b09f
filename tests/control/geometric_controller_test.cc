#include "control/geometric_controller.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace kestrel {
namespace {

// Helpers written here, independently of common/se3 and the controller.
Eigen::Vector3d VeeOfAntisymmetricPart(const Eigen::Matrix3d& S) {
  const Eigen::Matrix3d A = 0.5 * (S - S.transpose());
  return Eigen::Vector3d(A(2, 1), A(0, 2), A(1, 0));
}

// R_d from a desired force A and heading psi by Gram-Schmidt: b3 = A/|A|, b1 = the heading with its
// b3 component removed, normalised, b2 = b3 x b1. (The controller uses cross products instead.)
Eigen::Matrix3d DesiredAttitudeByGramSchmidt(const Eigen::Vector3d& A, double psi) {
  const Eigen::Vector3d b3 = A.normalized();
  const Eigen::Vector3d heading(std::cos(psi), std::sin(psi), 0.0);
  const Eigen::Vector3d b1 = (heading - heading.dot(b3) * b3).normalized();
  Eigen::Matrix3d R_d;
  R_d.col(0) = b1;
  R_d.col(1) = b3.cross(b1);
  R_d.col(2) = b3;
  return R_d;
}

class GeometricControllerTest : public ::testing::Test {
 protected:
  GeometricControllerConfig config_;  // the paper's gains, m = 4.34 kg
};

// The law against a case worked out here step by step: non-identity attitude, non-zero W and a
// desired trajectory with velocity, acceleration, jerk, snap and a turning heading, so W_d and
// Wdot_d are non-zero. W_d and Wdot_d are obtained by finite differences of R_d(t) built by
// Gram-Schmidt from the Taylor expansion of A(t) and psi(t) (the library differentiates
// analytically).
TEST_F(GeometricControllerTest, MatchesHandComputedCase) {
  // Given a state and a desired flat output.
  VehicleState state;
  state.position_m = Eigen::Vector3d(0.3, -0.2, 1.1);
  state.velocity_mps = Eigen::Vector3d(0.5, 0.1, -0.3);
  state.R_WB = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  state.angular_velocity_radps = Eigen::Vector3d(0.4, -0.3, 0.2);
  FlatOutput desired;
  desired.position_m = Eigen::Vector3d(0.1, 0.05, 1.0);
  desired.velocity_mps = Eigen::Vector3d(0.2, 0.3, 0.0);
  desired.acceleration_mps2 = Eigen::Vector3d(0.5, -0.4, 0.3);
  desired.jerk_mps3 = Eigen::Vector3d(1.0, 0.5, -0.2);
  desired.snap_mps4 = Eigen::Vector3d(-2.0, 1.0, 0.5);
  desired.yaw_rad = 0.4;
  desired.yaw_rate_radps = 0.3;
  desired.yaw_acceleration_radps2 = -0.2;
  const double dt = 0.01;

  // Gains away from their defaults, so the case does not depend on them.
  config_.k_i_per_s2 = 2.0;
  config_.c1_per_s = 1.5;
  config_.k_I_Nm_per_rad_s = 0.7;
  config_.c2_per_s = 0.8;

  // When the controller computes one step from zero integrals.
  GeometricController controller(config_);
  ControlOutput out;
  ASSERT_TRUE(controller.Compute(state, desired, dt, &out));

  // Then every quantity equals the hand computation.
  const double m = 4.34;
  const double g = 9.81;
  const double kx = 16.0 * m;
  const double kv = 5.6 * m;
  const double ki = 2.0 * m;
  const double c1 = 1.5;
  const double kR = 8.81;
  const double kW = 2.54;
  const double kI = 0.7;
  const double c2 = 0.8;
  Eigen::Matrix3d J = Eigen::Matrix3d::Zero();
  J(0, 0) = 0.0820;
  J(1, 1) = 0.0845;
  J(2, 2) = 0.1377;
  const Eigen::Matrix3d& R = state.R_WB;
  const Eigen::Vector3d& W = state.angular_velocity_radps;
  const Eigen::Vector3d e3(0, 0, 1);

  const Eigen::Vector3d ex = state.position_m - desired.position_m;
  const Eigen::Vector3d ev = state.velocity_mps - desired.velocity_mps;
  const Eigen::Vector3d ei = dt * (c1 * ex + ev);  // first step from zero, far from the clamp
  const Eigen::Vector3d A =
      -kx * ex - kv * ev - ki * ei + m * g * e3 + m * desired.acceleration_mps2;
  const Eigen::Vector3d Re3 = R * e3;
  const double f = A.dot(Re3);
  ASSERT_GT(f, 0.0);  // realisable: the acceleration estimate uses f unclamped
  ASSERT_LT(f, 100.0);
  // Rotating b3: d/dt (R e3) = R (W x e3).
  const Eigen::Vector3d Re3_dot = R * W.cross(e3);
  const Eigen::Vector3d ea = f / m * Re3 - g * e3 - desired.acceleration_mps2;
  const Eigen::Vector3d A_dot = -kx * ev - kv * ea - ki * (c1 * ex + ev) + m * desired.jerk_mps3;
  const double f_dot = A_dot.dot(Re3) + A.dot(Re3_dot);
  const Eigen::Vector3d ej = (f_dot * Re3 + f * Re3_dot) / m - desired.jerk_mps3;
  const Eigen::Vector3d A_ddot = -kx * ea - kv * ej - ki * (c1 * ev + ea) + m * desired.snap_mps4;

  auto R_d_at = [&](double t) {
    const Eigen::Vector3d A_t = A + A_dot * t + 0.5 * A_ddot * t * t;
    const double psi_t = desired.yaw_rad + desired.yaw_rate_radps * t +
                         0.5 * desired.yaw_acceleration_radps2 * t * t;
    return DesiredAttitudeByGramSchmidt(A_t, psi_t);
  };
  const double h = 1e-4;
  const Eigen::Matrix3d Rd = R_d_at(0.0);
  const Eigen::Matrix3d Rd_dot = (R_d_at(h) - R_d_at(-h)) / (2 * h);
  const Eigen::Matrix3d Rd_ddot = (R_d_at(h) - 2 * Rd + R_d_at(-h)) / (h * h);
  const Eigen::Vector3d Wd = VeeOfAntisymmetricPart(Rd.transpose() * Rd_dot);
  const Eigen::Vector3d Wd_dot = VeeOfAntisymmetricPart(Rd.transpose() * Rd_ddot);

  // e_R = 1/2 vee(Rd^T R - R^T Rd) = vee of the antisymmetric part of Rd^T R.
  const Eigen::Vector3d eR = VeeOfAntisymmetricPart(Rd.transpose() * R);
  const Eigen::Vector3d eW = W - R.transpose() * Rd * Wd;
  const Eigen::Vector3d eI = dt * (c2 * eR + eW);
  const Eigen::Vector3d Wd_in_B = R.transpose() * Rd * Wd;
  const Eigen::Vector3d Wd_dot_in_B = R.transpose() * Rd * Wd_dot;
  const Eigen::Vector3d M =
      -kR * eR - kW * eW - kI * eI + W.cross(J * W) - J * (W.cross(Wd_in_B) - Wd_dot_in_B);

  // The case is not degenerate.
  ASSERT_GT(Wd.norm(), 0.1);
  ASSERT_GT(Wd_dot.norm(), 0.5);
  ASSERT_GT(eR.norm(), 0.1);

  EXPECT_NEAR(out.thrust_N, f, 1e-9);
  EXPECT_NEAR(out.thrust_rate_Nps, f_dot, 1e-9);
  EXPECT_LT((out.force_W_N - A).norm(), 1e-9);
  EXPECT_LT((out.e_x_m - ex).norm(), 1e-12);
  EXPECT_LT((out.e_v_mps - ev).norm(), 1e-12);
  EXPECT_LT((out.e_i_m - ei).norm(), 1e-12);
  EXPECT_LT((out.R_d - Rd).norm(), 1e-9);
  EXPECT_LT((out.W_d_radps - Wd).norm(), 1e-6)
      << out.W_d_radps.transpose() << " vs " << Wd.transpose();
  EXPECT_LT((out.Wdot_d_radps2 - Wd_dot).norm(), 1e-4)
      << out.Wdot_d_radps2.transpose() << " vs " << Wd_dot.transpose();
  EXPECT_LT((out.e_R - eR).norm(), 1e-9);
  EXPECT_LT((out.e_W_radps - eW).norm(), 1e-6);
  EXPECT_LT((out.e_I_rad_s - eI).norm(), 1e-8);
  EXPECT_LT((out.moment_Nm - M).norm(), 1e-5)
      << out.moment_Nm.transpose() << " vs " << M.transpose();
}

// The desired b1 is the heading projected onto the plane normal to b3d: orthogonal to b3d, in
// the plane spanned by b3d and the heading, on the heading's side.
TEST_F(GeometricControllerTest, ProjectsHeadingOntoPlaneNormalToThrust) {
  GeometricController controller(config_);
  VehicleState state;
  FlatOutput desired;
  desired.acceleration_mps2 = Eigen::Vector3d(3.0, -2.0, 1.0);  // strongly tilted b3d
  desired.yaw_rad = 2.5;
  ControlOutput out;
  ASSERT_TRUE(controller.Compute(state, desired, 0.0, &out));
  const Eigen::Vector3d b3d = out.force_W_N.normalized();
  const Eigen::Vector3d heading(std::cos(2.5), std::sin(2.5), 0.0);
  const Eigen::Vector3d b1c = out.R_d.col(0);
  EXPECT_NEAR(b1c.dot(b3d), 0.0, 1e-12);
  EXPECT_NEAR(b1c.dot(b3d.cross(heading)), 0.0, 1e-12);
  EXPECT_GT(b1c.dot(heading), 0.0);
  EXPECT_LT((out.R_d.col(2) - b3d).norm(), 1e-12);
  EXPECT_LT((out.R_d.transpose() * out.R_d - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  EXPECT_NEAR(out.R_d.determinant(), 1.0, 1e-12);
}

// At the setpoint, level, at rest: thrust = weight, no moment, R_d = the heading rotation.
TEST_F(GeometricControllerTest, HoverAtSetpointNeedsWeightAndNoMoment) {
  GeometricController controller(config_);
  VehicleState state;
  state.position_m = Eigen::Vector3d(1, 2, 3);
  state.R_WB = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const FlatOutput desired = FlatOutput::Hover(state.position_m, 0.3);
  ControlOutput out;
  ASSERT_TRUE(controller.Compute(state, desired, 0.005, &out));
  EXPECT_NEAR(out.thrust_N, 4.34 * 9.81, 1e-9);
  EXPECT_LT(out.moment_Nm.norm(), 1e-12);
  EXPECT_LT((out.R_d - state.R_WB).norm(), 1e-12);
  EXPECT_LT(out.W_d_radps.norm(), 1e-12);
}

// NaN anywhere in the input, or a bad dt, fails the step and leaves output and integrals alone.
TEST_F(GeometricControllerTest, RejectsNonFiniteInputAndBadDt) {
  GeometricController controller(config_);
  VehicleState state;
  FlatOutput desired = FlatOutput::Hover(Eigen::Vector3d(1, 0, 0), 0.0);
  ControlOutput out;
  ASSERT_TRUE(controller.Compute(state, desired, 0.01, &out));
  const Eigen::Vector3d integral = controller.position_integral_m();
  ASSERT_GT(integral.norm(), 0.0);
  const double nan = std::numeric_limits<double>::quiet_NaN();

  ControlOutput untouched;
  untouched.thrust_N = 123.0;
  auto expect_rejected = [&](const VehicleState& s, const FlatOutput& d, double dt) {
    ControlOutput o = untouched;
    EXPECT_FALSE(controller.Compute(s, d, dt, &o));
    EXPECT_EQ(o.thrust_N, 123.0);
    EXPECT_EQ(controller.position_integral_m(), integral);
  };
  for (int k = 0; k < 3; ++k) {
    VehicleState s = state;
    s.position_m[k] = nan;
    expect_rejected(s, desired, 0.01);
    s = state;
    s.velocity_mps[k] = nan;
    expect_rejected(s, desired, 0.01);
    s = state;
    s.angular_velocity_radps[k] = nan;
    expect_rejected(s, desired, 0.01);
    s = state;
    s.R_WB(k, 1) = nan;
    expect_rejected(s, desired, 0.01);
    FlatOutput d = desired;
    d.snap_mps4[k] = nan;
    expect_rejected(state, d, 0.01);
    d = desired;
    d.jerk_mps3[k] = std::numeric_limits<double>::infinity();
    expect_rejected(state, d, 0.01);
  }
  FlatOutput d = desired;
  d.yaw_acceleration_radps2 = nan;
  expect_rejected(state, d, 0.01);
  VehicleState not_rotation = state;
  not_rotation.R_WB(0, 0) = 1.1;
  expect_rejected(not_rotation, desired, 0.01);
  expect_rejected(state, desired, -0.01);
  expect_rejected(state, desired, nan);
  expect_rejected(state, desired, 1.0);  // > max_dt_s
  // Free fall commanded: A = 0.
  d = desired;
  d.position_m = state.position_m;
  d.acceleration_mps2 = Eigen::Vector3d(0, 0, -9.81);
  GeometricController fresh(config_);
  ControlOutput o;
  EXPECT_FALSE(fresh.Compute(state, d, 0.0, &o));
}

// A constant error winds the position integral up to its clamp and no further.
TEST_F(GeometricControllerTest, ClampsIntegrals) {
  GeometricController controller(config_);
  VehicleState state;
  const FlatOutput desired = FlatOutput::Hover(Eigen::Vector3d(-1.0, 2.0, 0.0), 0.0);
  ControlOutput out;
  for (int k = 0; k < 1000; ++k) ASSERT_TRUE(controller.Compute(state, desired, 0.01, &out));
  EXPECT_NEAR(out.e_i_m.x(), 0.5, 1e-15);
  EXPECT_NEAR(out.e_i_m.y(), -0.5, 1e-15);
  EXPECT_EQ(out.e_i_m.z(), 0.0);
  // The clamped components no longer feed Adot: fdot has no integral term left.
  controller.ResetIntegrals();
  EXPECT_TRUE(controller.position_integral_m().isZero());
  EXPECT_TRUE(controller.attitude_integral_rad_s().isZero());
}

TEST_F(GeometricControllerTest, ValidateNamesFieldAndRange) {
  config_.k_R_Nm_per_rad = -1.0;
  try {
    config_.Validate();
    ADD_FAILURE() << "no throw";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("controller.k_R_Nm_per_rad = -1, accepted (0, inf)"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(GeometricController{config_}, std::invalid_argument);
}

// The thrust lag compensation adds tau * fdot, nothing else.
TEST_F(GeometricControllerTest, LagCompensationAddsTauTimesThrustRate) {
  VehicleState state;
  state.velocity_mps = Eigen::Vector3d(0.3, 0.0, -0.5);
  state.angular_velocity_radps = Eigen::Vector3d(0.2, 0.1, 0.0);
  const FlatOutput desired = FlatOutput::Hover(Eigen::Vector3d(0.2, 0.1, 0.3), 0.0);
  GeometricController plain(config_);
  config_.thrust_lag_compensation_s = 0.02;
  GeometricController compensated(config_);
  ControlOutput a;
  ControlOutput b;
  ASSERT_TRUE(plain.Compute(state, desired, 0.0, &a));
  ASSERT_TRUE(compensated.Compute(state, desired, 0.0, &b));
  ASSERT_GT(std::abs(a.thrust_rate_Nps), 1.0);
  EXPECT_NEAR(b.thrust_N, a.thrust_N + 0.02 * a.thrust_rate_Nps, 1e-9);
  EXPECT_LT((a.moment_Nm - b.moment_Nm).norm(), 1e-12);
}

}  // namespace
}  // namespace kestrel
