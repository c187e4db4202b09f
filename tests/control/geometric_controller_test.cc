#include "control/geometric_controller.h"

#include <gtest/gtest.h>

#include <algorithm>
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

// The law against a case worked out here step by step, for both attitude error forms: non-identity
// attitude, non-zero W and a desired trajectory with velocity, acceleration, jerk, snap and a
// turning heading, so W_d and Wdot_d are non-zero. W_d and Wdot_d are obtained by finite
// differences of R_d(t) built by Gram-Schmidt from the Taylor expansion of A(t) and psi(t) (the
// library differentiates analytically).
TEST_F(GeometricControllerTest, MatchesHandComputedCase) {
  for (const AttitudeErrorForm form :
       {AttitudeErrorForm::kCdc2010, AttitudeErrorForm::kLargeAngle}) {
    SCOPED_TRACE(ToString(form));
    config_.attitude_error = form;
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

    // CDC 2010: e_R = 1/2 vee(Rd^T R - R^T Rd) = vee of the antisymmetric part of Rd^T R.
    // Large-angle: e_R = 2 sin(theta/2) a from the angle-axis of Rd^T R.
    const Eigen::AngleAxisd error_rotation(Rd.transpose() * R);
    const Eigen::Vector3d eR =
        form == AttitudeErrorForm::kCdc2010
            ? VeeOfAntisymmetricPart(Rd.transpose() * R)
            : Eigen::Vector3d(2.0 * std::sin(error_rotation.angle() / 2.0) * error_rotation.axis());
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
  // Free fall commanded: A = 0 (with the vertical-force bound off).
  d = desired;
  d.position_m = state.position_m;
  d.acceleration_mps2 = Eigen::Vector3d(0, 0, -9.81);
  config_.min_force_z_fraction = 0.0;
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

// The desired force's vertical component is bounded below by min_force_z_fraction m g: a law
// asking to accelerate down faster than the bound allows (here -2 g, which only an inverted
// vehicle could do) gets an upright R_d and A_z = 0.2 m g; requests within the bound are
// untouched.
TEST_F(GeometricControllerTest, BoundsTheVerticalForceSoRdIsNeverUpsideDown) {
  VehicleState state;
  state.position_m = Eigen::Vector3d(0, 0, 2);
  state.velocity_mps = Eigen::Vector3d(0.2, 0, 3.0);  // rising fast
  FlatOutput desired = FlatOutput::Hover(Eigen::Vector3d(0.1, 0, 2.0), 0.3);
  desired.jerk_mps3 = Eigen::Vector3d(0.5, 0.2, 1.0);
  desired.acceleration_mps2 = Eigen::Vector3d(1.0, 0, -2.0 * 9.81);
  ControlOutput bounded;
  ASSERT_TRUE(GeometricController(config_).Compute(state, desired, 0.0, &bounded));
  const double m = config_.mass_kg;
  EXPECT_NEAR(bounded.force_W_N.z(), 0.2 * m * 9.81, 1e-9);
  EXPECT_GT(bounded.R_d(2, 2), 0.0);  // b3d in the upper hemisphere
  // The unbounded A_z would be negative (b3d downwards): -k_v v_z + m g + m a_z < 0.
  ASSERT_LT(-5.6 * m * 3.0 + m * 9.81 - 2.0 * m * 9.81, 0.0);
  // A request inside the bound: identical outputs with and without it.
  desired.acceleration_mps2 = Eigen::Vector3d(1.0, 0, -3.0);
  state.velocity_mps = Eigen::Vector3d(0.2, 0, 0.1);
  config_.min_force_z_fraction = 0.2;
  ControlOutput a;
  ASSERT_TRUE(GeometricController(config_).Compute(state, desired, 0.0, &a));
  config_.min_force_z_fraction = 0.0;
  ControlOutput b;
  ASSERT_TRUE(GeometricController(config_).Compute(state, desired, 0.0, &b));
  EXPECT_EQ(a.thrust_N, b.thrust_N);
  EXPECT_EQ(a.moment_Nm, b.moment_Nm);
  config_.min_force_z_fraction = 1.0;
  EXPECT_THROW(config_.Validate(), std::invalid_argument);
}

// A large horizontal error: b3d tilts by exactly max_tilt_rad towards the unbounded A_xy, and
// the feed-forward rates stay within their bounds.
TEST_F(GeometricControllerTest, BoundsTheTiltAndTheDesiredRates) {
  VehicleState state;
  state.position_m = Eigen::Vector3d(3.0, -4.0, 2.0);
  state.velocity_mps = Eigen::Vector3d(-2.0, 1.0, -1.0);
  state.angular_velocity_radps = Eigen::Vector3d(2.0, -1.0, 0.5);
  state.R_WB = Eigen::AngleAxisd(0.8, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix();
  const FlatOutput desired = FlatOutput::Hover(Eigen::Vector3d(0, 0, 2), 0.0);
  ControlOutput out;
  ASSERT_TRUE(GeometricController(config_).Compute(state, desired, 0.0, &out));
  const double tilt = std::acos(out.R_d(2, 2));
  EXPECT_NEAR(tilt, config_.max_tilt_rad, 1e-12);
  // Direction of the unbounded A_xy = -k_x e_xy - k_v e_v,xy (per unit mass).
  const Eigen::Vector2d A_xy =
      -16.0 * Eigen::Vector2d(3.0, -4.0) - 5.6 * Eigen::Vector2d(-2.0, 1.0);
  EXPECT_NEAR(out.R_d.col(2).head<2>().normalized().dot(A_xy.normalized()), 1.0, 1e-12);
  EXPECT_LE(out.W_d_radps.norm(), config_.max_desired_rate_radps + 1e-12);
  EXPECT_LE(out.Wdot_d_radps2.norm(), config_.max_desired_angular_acceleration_radps2 + 1e-12);
  config_.max_tilt_rad = 1.5;
  EXPECT_THROW(config_.Validate(), std::invalid_argument);
}

// With the tilt and vertical-force bounds holding A, W_d still is the rate of R_d: central
// differences of R_d from Compute() at states moved along the motion the law assumes (x +- v h +
// a h^2/2, v +- a h, a = f R e3 / m - g e3 the acceleration estimated from the realisable
// thrust), hover set point, no integral, rate bounds off.
TEST_F(GeometricControllerTest, DesiredRateIsExactWhileTheBoundsHold) {
  config_.k_i_per_s2 = 0.0;
  config_.k_I_Nm_per_rad_s = 0.0;
  config_.max_desired_rate_radps = 1e9;
  config_.max_desired_angular_acceleration_radps2 = 1e9;
  const FlatOutput desired = FlatOutput::Hover(Eigen::Vector3d(0, 0, 2), 0.4);
  struct Case {
    Eigen::Vector3d position_m, velocity_mps;
    bool expect_z_bounded;
  };
  const Case cases[] = {
      {Eigen::Vector3d(2.0, -1.5, 2.1), Eigen::Vector3d(-0.5, 1.0, 0.3), false},  // tilt only
      {Eigen::Vector3d(1.5, 1.0, 2.4), Eigen::Vector3d(0.3, -0.8, 2.5), true},    // both
  };
  for (const Case& c : cases) {
    VehicleState state;
    state.position_m = c.position_m;
    state.velocity_mps = c.velocity_mps;
    state.R_WB = Eigen::AngleAxisd(0.5, Eigen::Vector3d(1, -1, 0).normalized()).toRotationMatrix();
    state.angular_velocity_radps = Eigen::Vector3d(0.3, 0.2, -0.1);
    ControlOutput out;
    ASSERT_TRUE(GeometricController(config_).Compute(state, desired, 0.0, &out));
    ASSERT_NEAR(std::acos(out.R_d(2, 2)), config_.max_tilt_rad, 1e-12);  // tilt bound holds
    const double A_z_min = config_.min_force_z_fraction * config_.mass_kg * 9.81;
    ASSERT_EQ(std::abs(out.force_W_N.z() - A_z_min) < 1e-9, c.expect_z_bounded);
    const double f = std::clamp(out.force_W_N.dot(state.R_WB.col(2)), 0.0, 100.0);
    const Eigen::Vector3d a = f * state.R_WB.col(2) / config_.mass_kg - Eigen::Vector3d(0, 0, 9.81);
    const double h = 1e-5;
    auto R_d_at = [&](double t) {
      VehicleState moved = state;
      moved.position_m += state.velocity_mps * t + 0.5 * a * t * t;
      moved.velocity_mps += a * t;
      ControlOutput o;
      EXPECT_TRUE(GeometricController(config_).Compute(moved, desired, 0.0, &o));
      return o.R_d;
    };
    const Eigen::Matrix3d R_d_dot = (R_d_at(h) - R_d_at(-h)) / (2 * h);
    const Eigen::Vector3d W_d = VeeOfAntisymmetricPart(out.R_d.transpose() * R_d_dot);
    ASSERT_GT(W_d.norm(), 0.1);
    EXPECT_LT((out.W_d_radps - W_d).norm(), 1e-5 * std::max(1.0, W_d.norm()))
        << out.W_d_radps.transpose() << " vs " << W_d.transpose();
  }
}

// Psi(R Exp(h eta), R_d) rotated by a small h along eta changes by h e_R . eta (e_R is the
// left-trivialised gradient of Psi), for both forms, at small, large and near-180 deg errors;
// central differences of Psi computed here from the angle of R_d^T R alone.
TEST(AttitudeError, IsTheGradientOfItsErrorFunction) {
  const auto psi_of_angle = [](AttitudeErrorForm form, double theta) {
    return form == AttitudeErrorForm::kCdc2010 ? 1.0 - std::cos(theta)
                                               : 4.0 * (1.0 - std::cos(theta / 2.0));
  };
  const auto exp_so3 = [](const Eigen::Vector3d& v) {
    return v.norm() == 0.0 ? Eigen::Matrix3d::Identity()
                           : Eigen::AngleAxisd(v.norm(), v.normalized()).toRotationMatrix();
  };
  const Eigen::Matrix3d R_d =
      Eigen::AngleAxisd(0.9, Eigen::Vector3d(-1, 2, 0.5).normalized()).toRotationMatrix();
  const Eigen::Vector3d axes[] = {Eigen::Vector3d(1, 0.3, 0).normalized(),
                                  Eigen::Vector3d(-0.2, 1, 0.7).normalized(),
                                  Eigen::Vector3d(0, 0, 1)};
  const double angles_deg[] = {0.5, 30.0, 90.0, 150.0, 178.0, 179.5};
  const Eigen::Vector3d eta = Eigen::Vector3d(0.3, -0.8, 0.5).normalized();
  const double h = 1e-6;
  int checked = 0;
  for (const AttitudeErrorForm form :
       {AttitudeErrorForm::kCdc2010, AttitudeErrorForm::kLargeAngle}) {
    for (const Eigen::Vector3d& axis : axes) {
      for (const double angle_deg : angles_deg) {
        // R = R_d Exp(theta a): the error rotation R_d^T R has angle theta about a (in B).
        const Eigen::Matrix3d R = R_d * exp_so3(angle_deg * M_PI / 180.0 * axis);
        const auto psi = [&](const Eigen::Matrix3d& R_) {
          const double c = std::clamp(((R_d.transpose() * R_).trace() - 1.0) / 2.0, -1.0, 1.0);
          return psi_of_angle(form, std::acos(c));
        };
        const double slope = (psi(R * exp_so3(h * eta)) - psi(R * exp_so3(-h * eta))) / (2 * h);
        const Eigen::Vector3d e_R = ComputeAttitudeError(R, R_d, form);
        EXPECT_NEAR(e_R.dot(eta), slope, 2e-6)
            << ToString(form) << " at " << angle_deg << " deg about " << axis.transpose();
        // The library's Psi agrees with the angle formula.
        EXPECT_NEAR(ComputeAttitudeErrorFunction(R, R_d, form),
                    psi_of_angle(form, angle_deg * M_PI / 180.0), 1e-9);
        ++checked;
      }
    }
  }
  EXPECT_EQ(checked, 36);
}

// Both forms agree to first order at R = R_d (e_R = theta a), so k_R keeps its meaning; near 180
// deg CDC 2010's e_R vanishes (sin theta) while the large-angle one tends to 2 a; at and within
// 0.06 deg of 180 (the quaternion branch) it stays finite and equal to 2 sin(theta/2) a up to the
// sign of the axis.
TEST(AttitudeError, LargeAngleFormStaysLargeNear180Degrees) {
  const Eigen::Vector3d a = Eigen::Vector3d(1, 0.3, 0).normalized();
  const Eigen::Matrix3d R_d =
      Eigen::AngleAxisd(-0.4, Eigen::Vector3d(0.2, 0.1, 1).normalized()).toRotationMatrix();
  const auto rotated = [&](double theta) {
    return Eigen::Matrix3d(R_d * Eigen::AngleAxisd(theta, a).toRotationMatrix());
  };
  // First order: theta = 1e-4 rad.
  for (const AttitudeErrorForm form :
       {AttitudeErrorForm::kCdc2010, AttitudeErrorForm::kLargeAngle}) {
    EXPECT_LT((ComputeAttitudeError(rotated(1e-4), R_d, form) - 1e-4 * a).norm(), 1e-12);
  }
  const double theta_178 = 178.0 * M_PI / 180.0;
  EXPECT_NEAR(ComputeAttitudeError(rotated(theta_178), R_d, AttitudeErrorForm::kCdc2010).norm(),
              std::sin(theta_178), 1e-12);
  EXPECT_LT((ComputeAttitudeError(rotated(theta_178), R_d, AttitudeErrorForm::kLargeAngle) -
             2.0 * std::sin(theta_178 / 2.0) * a)
                .norm(),
            1e-9);
  // The quaternion branch (1 + tr < 1e-6) and exactly 180 deg.
  for (const double theta : {M_PI - 1e-4, M_PI - 1e-7, M_PI}) {
    const Eigen::Vector3d e_R =
        ComputeAttitudeError(rotated(theta), R_d, AttitudeErrorForm::kLargeAngle);
    ASSERT_TRUE(e_R.allFinite()) << theta;
    EXPECT_NEAR(e_R.norm(), 2.0 * std::sin(theta / 2.0), 1e-9) << theta;
    EXPECT_NEAR(std::abs(e_R.normalized().dot(a)), 1.0, 1e-6) << theta;
  }
  // Just above the branch threshold the formula and the quaternion give the same vector.
  EXPECT_LT((ComputeAttitudeError(rotated(M_PI - 1.5e-3), R_d, AttitudeErrorForm::kLargeAngle) -
             2.0 * std::sin((M_PI - 1.5e-3) / 2.0) * a)
                .norm(),
            1e-9);
  EXPECT_LT((ComputeAttitudeError(rotated(M_PI - 0.5e-3), R_d, AttitudeErrorForm::kLargeAngle) -
             2.0 * std::sin((M_PI - 0.5e-3) / 2.0) * a)
                .norm(),
            1e-9);
}

TEST(AttitudeError, ParsesAndPrintsItsNames) {
  AttitudeErrorForm form = AttitudeErrorForm::kLargeAngle;
  ASSERT_TRUE(ParseAttitudeErrorForm("cdc2010", &form));
  EXPECT_EQ(form, AttitudeErrorForm::kCdc2010);
  EXPECT_STREQ(ToString(form), "cdc2010");
  ASSERT_TRUE(ParseAttitudeErrorForm("large_angle", &form));
  EXPECT_EQ(form, AttitudeErrorForm::kLargeAngle);
  EXPECT_STREQ(ToString(form), "large_angle");
  EXPECT_FALSE(ParseAttitudeErrorForm("lee", &form));
  EXPECT_EQ(form, AttitudeErrorForm::kLargeAngle);
  GeometricControllerConfig config;
  config.attitude_error = static_cast<AttitudeErrorForm>(7);
  EXPECT_THROW(config.Validate(), std::invalid_argument);
}

// Upside down (178 deg) and at rest at the set point: CDC 2010 asks for a roll/pitch moment of
// k_R sin(178 deg) = 0.31 N m, the large-angle form for k_R 2 sin(89 deg) = 17.6 N m (the mixer
// then scales it to what the rotors give, keeping its direction).
TEST_F(GeometricControllerTest, LargeAngleFormAsksForAFullFlipMoment) {
  VehicleState state;
  state.position_m = Eigen::Vector3d(0, 0, 20);
  state.R_WB = Eigen::AngleAxisd(178.0 * M_PI / 180.0, Eigen::Vector3d(1, 0.3, 0).normalized())
                   .toRotationMatrix();
  const FlatOutput desired = FlatOutput::Hover(state.position_m, 0.0);
  ControlOutput cdc;
  ControlOutput large;
  config_.attitude_error = AttitudeErrorForm::kCdc2010;
  ASSERT_TRUE(GeometricController(config_).Compute(state, desired, 0.0, &cdc));
  config_.attitude_error = AttitudeErrorForm::kLargeAngle;
  ASSERT_TRUE(GeometricController(config_).Compute(state, desired, 0.0, &large));
  const double k_R = config_.k_R_Nm_per_rad;
  EXPECT_NEAR(cdc.moment_Nm.head<2>().norm(), k_R * std::sin(178.0 * M_PI / 180.0), 1e-3);
  EXPECT_NEAR(large.moment_Nm.head<2>().norm(), k_R * 2.0 * std::sin(89.0 * M_PI / 180.0), 1e-3);
  EXPECT_LT(large.thrust_N, 0.0);  // f = A . R e3 < 0 upside down; the mixer handles it
}

}  // namespace
}  // namespace kestrel
