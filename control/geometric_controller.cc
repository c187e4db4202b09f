#include "control/geometric_controller.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "common/check.h"
#include "common/se3.h"

namespace kestrel {

namespace {

// Advances an integral by dt * rate, clamped per component to [-limit, limit]. Returns 1 for
// components that follow the rate, 0 for components held at the clamp (their derivative is zero).
Eigen::Vector3d IntegrateClamped(const Eigen::Vector3d& rate, double dt_s, double limit,
                                 Eigen::Vector3d* integral) {
  Eigen::Vector3d active = Eigen::Vector3d::Ones();
  for (int k = 0; k < 3; ++k) {
    const double next = (*integral)[k] + dt_s * rate[k];
    if (next > limit) {
      (*integral)[k] = limit;
      if (rate[k] > 0.0) active[k] = 0.0;
    } else if (next < -limit) {
      (*integral)[k] = -limit;
      if (rate[k] < 0.0) active[k] = 0.0;
    } else {
      (*integral)[k] = next;
    }
  }
  return active;
}

bool CheckFinitePositive(double value) { return std::isfinite(value) && value > 0.0; }
bool CheckFiniteNonNegative(double value) { return std::isfinite(value) && value >= 0.0; }

}  // namespace

void DeriveUnitVector(const Eigen::Vector3d& q, const Eigen::Vector3d& q_dot,
                      const Eigen::Vector3d& q_ddot, Eigen::Vector3d* u, Eigen::Vector3d* u_dot,
                      Eigen::Vector3d* u_ddot) {
  const double n = q.norm();
  const double n3 = n * n * n;
  const double q_qdot = q.dot(q_dot);
  *u = q / n;
  *u_dot = q_dot / n - q * q_qdot / n3;
  *u_ddot = q_ddot / n - q_dot * (2.0 * q_qdot / n3) -
            q * ((q_dot.squaredNorm() + q.dot(q_ddot)) / n3) +
            q * (3.0 * q_qdot * q_qdot / (n3 * n * n));
}

const char* ToString(AttitudeErrorForm form) {
  switch (form) {
    case AttitudeErrorForm::kCdc2010:
      return "cdc2010";
    case AttitudeErrorForm::kLargeAngle:
      return "large_angle";
  }
  return "unknown";
}

bool ParseAttitudeErrorForm(const std::string& text, AttitudeErrorForm* form) {
  KESTREL_DEMAND(form != nullptr);
  if (text == "cdc2010") {
    *form = AttitudeErrorForm::kCdc2010;
  } else if (text == "large_angle") {
    *form = AttitudeErrorForm::kLargeAngle;
  } else {
    return false;
  }
  return true;
}

double ComputeAttitudeErrorFunction(const Eigen::Matrix3d& R, const Eigen::Matrix3d& R_d,
                                    AttitudeErrorForm form) {
  const double trace = (R_d.transpose() * R).trace();
  if (form == AttitudeErrorForm::kCdc2010) return 0.5 * (3.0 - trace);  // 1/2 tr(I - R_d^T R)
  // 2 (2 - sqrt(1 + tr(R_d^T R))); 1 + tr >= 0 up to rounding.
  return 2.0 * (2.0 - std::sqrt(std::max(0.0, 1.0 + trace)));
}

Eigen::Vector3d ComputeAttitudeError(const Eigen::Matrix3d& R, const Eigen::Matrix3d& R_d,
                                     AttitudeErrorForm form) {
  const Eigen::Matrix3d RdtR = R_d.transpose() * R;
  // vee(R_d^T R - R^T R_d) = 2 sin(theta) a.
  const Eigen::Vector3d vee2(RdtR(2, 1) - RdtR(1, 2), RdtR(0, 2) - RdtR(2, 0),
                             RdtR(1, 0) - RdtR(0, 1));
  if (form == AttitudeErrorForm::kCdc2010) return 0.5 * vee2;  // CDC 2010: sin(theta) a
  // Large-angle form (AttitudeErrorForm::kLargeAngle): vee(.) / sqrt(1 + tr) = 2 sin(theta/2) a.
  const double one_plus_trace = 1.0 + RdtR.trace();  // 4 cos^2(theta/2)
  if (one_plus_trace >= 1e-6) return vee2 / std::sqrt(one_plus_trace);
  // Within 0.06 deg of 180: 2 sign(w) v from the quaternion of R_d^T R (same value, no 0/0).
  const Eigen::Quaterniond q(RdtR);
  return (q.w() >= 0.0 ? 2.0 : -2.0) * q.vec();
}

GeometricControllerConfig GeometricControllerConfig::FromVehicle(const VehicleConfig& vehicle) {
  GeometricControllerConfig config;
  config.mass_kg = vehicle.mass_kg;
  config.inertia_kgm2 = vehicle.inertia_kgm2;
  config.min_thrust_N = 4.0 * vehicle.min_rotor_thrust_N;
  config.max_thrust_N = 4.0 * vehicle.max_rotor_thrust_N;
  return config;
}

void GeometricControllerConfig::Validate() const {
  KESTREL_THROW_UNLESS(attitude_error == AttitudeErrorForm::kCdc2010 ||
                           attitude_error == AttitudeErrorForm::kLargeAngle,
                       "controller.attitude_error = " << static_cast<int>(attitude_error)
                                                      << ", accepted cdc2010 | large_angle");
  KESTREL_THROW_UNLESS(CheckFinitePositive(mass_kg),
                       "controller.mass_kg = " << mass_kg << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(
      inertia_kgm2.allFinite() && (inertia_kgm2.array() > 0.0).all(),
      "controller.inertia_kgm2 = [" << inertia_kgm2.transpose() << "], accepted each in (0, inf)");
  KESTREL_THROW_UNLESS(CheckFinitePositive(gravity_mps2),
                       "controller.gravity_mps2 = " << gravity_mps2 << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(CheckFinitePositive(k_x_per_s2),
                       "controller.k_x_per_s2 = " << k_x_per_s2 << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(CheckFinitePositive(k_v_per_s),
                       "controller.k_v_per_s = " << k_v_per_s << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(CheckFiniteNonNegative(k_i_per_s2),
                       "controller.k_i_per_s2 = " << k_i_per_s2 << ", accepted [0, inf)");
  KESTREL_THROW_UNLESS(CheckFiniteNonNegative(c1_per_s),
                       "controller.c1_per_s = " << c1_per_s << ", accepted [0, inf)");
  KESTREL_THROW_UNLESS(CheckFiniteNonNegative(position_integral_limit_m),
                       "controller.position_integral_limit_m = " << position_integral_limit_m
                                                                 << ", accepted [0, inf)");
  KESTREL_THROW_UNLESS(CheckFinitePositive(k_R_Nm_per_rad),
                       "controller.k_R_Nm_per_rad = " << k_R_Nm_per_rad << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(CheckFinitePositive(k_W_Nms_per_rad),
                       "controller.k_W_Nms_per_rad = " << k_W_Nms_per_rad << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(
      CheckFiniteNonNegative(k_I_Nm_per_rad_s),
      "controller.k_I_Nm_per_rad_s = " << k_I_Nm_per_rad_s << ", accepted [0, inf)");
  KESTREL_THROW_UNLESS(CheckFiniteNonNegative(c2_per_s),
                       "controller.c2_per_s = " << c2_per_s << ", accepted [0, inf)");
  KESTREL_THROW_UNLESS(CheckFiniteNonNegative(attitude_integral_limit_rad_s),
                       "controller.attitude_integral_limit_rad_s = "
                           << attitude_integral_limit_rad_s << ", accepted [0, inf)");
  KESTREL_THROW_UNLESS(std::isfinite(thrust_lag_compensation_s) &&
                           thrust_lag_compensation_s >= 0.0 && thrust_lag_compensation_s <= 0.5,
                       "controller.thrust_lag_compensation_s = " << thrust_lag_compensation_s
                                                                 << ", accepted [0, 0.5]");
  KESTREL_THROW_UNLESS(CheckFiniteNonNegative(min_thrust_N),
                       "controller.min_thrust_N = " << min_thrust_N << ", accepted [0, inf)");
  KESTREL_THROW_UNLESS(std::isfinite(max_thrust_N) && max_thrust_N > min_thrust_N,
                       "controller.max_thrust_N = " << max_thrust_N << ", accepted (min_thrust_N = "
                                                    << min_thrust_N << ", inf)");
  KESTREL_THROW_UNLESS(
      std::isfinite(min_force_z_fraction) && min_force_z_fraction >= 0.0 &&
          min_force_z_fraction < 1.0,
      "controller.min_force_z_fraction = " << min_force_z_fraction << ", accepted [0, 1)");
  KESTREL_THROW_UNLESS(std::isfinite(max_tilt_rad) && max_tilt_rad > 0.0 && max_tilt_rad < 1.5,
                       "controller.max_tilt_rad = " << max_tilt_rad << ", accepted (0, 1.5)");
  KESTREL_THROW_UNLESS(
      max_desired_rate_radps > 0.0,
      "controller.max_desired_rate_radps = " << max_desired_rate_radps << ", accepted (0, inf]");
  KESTREL_THROW_UNLESS(max_desired_angular_acceleration_radps2 > 0.0,
                       "controller.max_desired_angular_acceleration_radps2 = "
                           << max_desired_angular_acceleration_radps2 << ", accepted (0, inf]");
  KESTREL_THROW_UNLESS(
      CheckFinitePositive(min_force_norm_N),
      "controller.min_force_norm_N = " << min_force_norm_N << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(CheckFinitePositive(max_dt_s),
                       "controller.max_dt_s = " << max_dt_s << ", accepted (0, inf)");
}

GeometricController::GeometricController(const GeometricControllerConfig& config)
    : config_(config) {
  config_.Validate();
  J_ = config_.inertia_kgm2.asDiagonal();
}

void GeometricController::ResetIntegrals() {
  e_i_.setZero();
  e_I_.setZero();
}

bool GeometricController::Compute(const VehicleState& state, const FlatOutput& desired, double dt_s,
                                  ControlOutput* out) {
  KESTREL_DEMAND(out != nullptr);
  if (!state.IsValid(1e-6) || !desired.IsFinite() || !std::isfinite(dt_s) || dt_s < 0.0 ||
      dt_s > config_.max_dt_s) {
    return false;
  }
  const double m = config_.mass_kg;
  const double g = config_.gravity_mps2;
  const double k_x = config_.k_x_per_s2 * m;
  const double k_v = config_.k_v_per_s * m;
  const double k_i = config_.k_i_per_s2 * m;
  const Eigen::Vector3d e3 = Eigen::Vector3d::UnitZ();
  const Eigen::Matrix3d& R = state.R_WB;
  const Eigen::Vector3d& W = state.angular_velocity_radps;

  // Translational errors (Lee 2010 eqs. (6)-(7)).
  const Eigen::Vector3d e_x = state.position_m - desired.position_m;
  const Eigen::Vector3d e_v = state.velocity_mps - desired.velocity_mps;

  // Position integral of c1 e_x + e_v, clamped (FDCL); work on a copy until success is certain.
  Eigen::Vector3d e_i = e_i_;
  const Eigen::Vector3d e_i_active =
      IntegrateClamped(config_.c1_per_s * e_x + e_v, dt_s, config_.position_integral_limit_m, &e_i);
  const Eigen::Vector3d e_i_rate = e_i_active.cwiseProduct(config_.c1_per_s * e_x + e_v);

  // A = -k_x e_x - k_v e_v - k_i e_i + m g e3 + m a_d (docs/algorithms.md §11.2, z up).
  Eigen::Vector3d A =
      -k_x * e_x - k_v * e_v - k_i * e_i + m * g * e3 + m * desired.acceleration_mps2;
  // A_z >= min_force_z_fraction m g: R_d never upside down (see the config field); while the
  // bound holds A_z, its derivatives are zero (a choice of ours, not the paper's).
  const double A_z_min = config_.min_force_z_fraction * m * g;
  const bool A_z_bounded = A.z() < A_z_min;
  if (A_z_bounded) A.z() = A_z_min;
  // Tilt of b3d at most max_tilt_rad: |A_xy| <= A_z tan(max_tilt), A_xy keeping its direction u
  // (A_xy = A_z tan(max_tilt) u while limited; derivatives by the chain rule below).
  const double tan_tilt = std::tan(config_.max_tilt_rad);
  const Eigen::Vector3d A_xy_raw(A.x(), A.y(), 0.0);
  const bool tilt_limited = A.z() > 0.0 && A_xy_raw.norm() > A.z() * tan_tilt;
  if (tilt_limited) A.head<2>() = A.z() * tan_tilt * A_xy_raw.head<2>().normalized();
  const double A_norm = A.norm();
  if (!(A_norm >= config_.min_force_norm_N)) return false;

  // f = A . R e3 (eq. (15)); b3 = R e3 and its rate R hat(W) e3.
  const Eigen::Vector3d b3 = R.col(2);
  const Eigen::Vector3d b3_dot = R * W.cross(e3);
  const double f = A.dot(b3);

  // Acceleration estimated from the thrust the rotors can produce (f clamped to
  // [min_thrust_N, max_thrust_N]), and its error: e_a = f R e3 / m - g e3 - a_d.
  const bool f_realisable = f >= config_.min_thrust_N && f <= config_.max_thrust_N;
  const double f_est = std::clamp(f, config_.min_thrust_N, config_.max_thrust_N);
  const Eigen::Vector3d e_a = f_est * b3 / m - g * e3 - desired.acceleration_mps2;
  // Adot = -k_x e_v - k_v e_a - k_i (c1 e_x + e_v) + m jerk_d.
  Eigen::Vector3d A_dot = -k_x * e_v - k_v * e_a - k_i * e_i_rate + m * desired.jerk_mps3;
  if (A_z_bounded) A_dot.z() = 0.0;
  const Eigen::Vector3d A_dot_xy_raw(A_dot.x(), A_dot.y(), 0.0);
  if (tilt_limited) {
    // d/dt (A_z tan u) with u = A_xy/|A_xy|: tan (Adot_z u + A_z udot).
    const double n = A_xy_raw.norm();
    const Eigen::Vector3d u = A_xy_raw / n;
    const Eigen::Vector3d u_dot = A_dot_xy_raw / n - u * (u.dot(A_dot_xy_raw) / n);
    A_dot.head<2>() = (tan_tilt * (A_dot.z() * u + A.z() * u_dot)).head<2>();
  }
  // fdot = Adot . R e3 + A . R hat(W) e3; the estimated jerk follows from differentiating f R e3.
  const double f_dot = A_dot.dot(b3) + A.dot(b3_dot);
  // Estimated jerk d/dt (f_est R e3 / m); a clamped f_est does not change with f.
  const double f_est_dot = f_realisable ? f_dot : 0.0;
  const Eigen::Vector3d e_j = (f_est_dot * b3 + f_est * b3_dot) / m - desired.jerk_mps3;
  // Addot = -k_x e_a - k_v e_j - k_i (c1 e_v + e_a) + m snap_d (integral rate masked at the clamp).
  const Eigen::Vector3d integral_accel = e_i_active.cwiseProduct(config_.c1_per_s * e_v + e_a);
  Eigen::Vector3d A_ddot = -k_x * e_a - k_v * e_j - k_i * integral_accel + m * desired.snap_mps4;
  if (A_z_bounded) A_ddot.z() = 0.0;
  if (tilt_limited) {
    const Eigen::Vector3d A_ddot_xy_raw(A_ddot.x(), A_ddot.y(), 0.0);
    Eigen::Vector3d u, u_dot, u_ddot;
    DeriveUnitVector(A_xy_raw, A_dot_xy_raw, A_ddot_xy_raw, &u, &u_dot, &u_ddot);
    A_ddot.head<2>() =
        (tan_tilt * (A_ddot.z() * u + 2.0 * A_dot.z() * u_dot + A.z() * u_ddot)).head<2>();
  }

  // b3d = A/|A| and its derivatives.
  Eigen::Vector3d b3d, b3d_dot, b3d_ddot;
  DeriveUnitVector(A, A_dot, A_ddot, &b3d, &b3d_dot, &b3d_ddot);

  // Desired heading b1d = (cos psi, sin psi, 0) and its derivatives.
  const double psi = desired.yaw_rad;
  const double psi_dot = desired.yaw_rate_radps;
  const double psi_ddot = desired.yaw_acceleration_radps2;
  Eigen::Vector3d b1d(std::cos(psi), std::sin(psi), 0.0);
  const Eigen::Vector3d b1d_perp(-std::sin(psi), std::cos(psi), 0.0);
  Eigen::Vector3d b1d_dot = psi_dot * b1d_perp;
  Eigen::Vector3d b1d_ddot = psi_ddot * b1d_perp - psi_dot * psi_dot * b1d;
  // Heading parallel to b3d (thrust horizontal along the heading): fall back to the body x axis,
  // then the body y axis, held constant.
  if (b3d.cross(b1d).norm() < 1e-6) {
    b1d =
        b3d.cross(R.col(0)).norm() >= 1e-6 ? Eigen::Vector3d(R.col(0)) : Eigen::Vector3d(R.col(1));
    b1d_dot.setZero();
    b1d_ddot.setZero();
  }

  // Projection of the heading onto the plane normal to b3d: b2d = (b3d x b1d)/|b3d x b1d|,
  // b1c = b2d x b3d (docs/algorithms.md §11.3), with derivatives.
  const Eigen::Vector3d C = b3d.cross(b1d);
  const Eigen::Vector3d C_dot = b3d_dot.cross(b1d) + b3d.cross(b1d_dot);
  const Eigen::Vector3d C_ddot =
      b3d_ddot.cross(b1d) + 2.0 * b3d_dot.cross(b1d_dot) + b3d.cross(b1d_ddot);
  Eigen::Vector3d b2d, b2d_dot, b2d_ddot;
  DeriveUnitVector(C, C_dot, C_ddot, &b2d, &b2d_dot, &b2d_ddot);
  const Eigen::Vector3d b1c = b2d.cross(b3d);
  const Eigen::Vector3d b1c_dot = b2d_dot.cross(b3d) + b2d.cross(b3d_dot);
  const Eigen::Vector3d b1c_ddot =
      b2d_ddot.cross(b3d) + 2.0 * b2d_dot.cross(b3d_dot) + b2d.cross(b3d_ddot);

  Eigen::Matrix3d R_d, R_d_dot, R_d_ddot;
  R_d << b1c, b2d, b3d;
  R_d_dot << b1c_dot, b2d_dot, b3d_dot;
  R_d_ddot << b1c_ddot, b2d_ddot, b3d_ddot;
  // R_d_dot = R_d hat(W_d); R_d_ddot = R_d (hat(W_d)^2 + hat(Wdot_d)).
  Eigen::Vector3d W_d = Vee(R_d.transpose() * R_d_dot);
  const Eigen::Matrix3d W_d_hat = Hat(W_d);
  Eigen::Vector3d Wdot_d = Vee(R_d.transpose() * R_d_ddot - W_d_hat * W_d_hat);
  // Norm bounds on the feed-forward rates (see the config fields; direction kept).
  if (W_d.norm() > config_.max_desired_rate_radps) {
    W_d *= config_.max_desired_rate_radps / W_d.norm();
  }
  if (Wdot_d.norm() > config_.max_desired_angular_acceleration_radps2) {
    Wdot_d *= config_.max_desired_angular_acceleration_radps2 / Wdot_d.norm();
  }

  // Attitude errors (eqs. (10)-(11)): e_R of the configured form (CDC 2010's 1/2 vee(R_d^T R -
  // R^T R_d) or the large-angle one, see AttitudeErrorForm), e_W = W - R^T R_d W_d.
  const Eigen::Matrix3d RtRd = R.transpose() * R_d;
  const Eigen::Vector3d e_R = ComputeAttitudeError(R, R_d, config_.attitude_error);
  const Eigen::Vector3d e_W = W - RtRd * W_d;

  // Attitude integral of c2 e_R + e_W, clamped.
  Eigen::Vector3d e_I = e_I_;
  IntegrateClamped(config_.c2_per_s * e_R + e_W, dt_s, config_.attitude_integral_limit_rad_s, &e_I);

  // M = -k_R e_R - k_W e_W - k_I e_I + W x J W - J (hat(W) R^T R_d W_d - R^T R_d Wdot_d) (eq.
  // (16)).
  const Eigen::Vector3d M = -config_.k_R_Nm_per_rad * e_R - config_.k_W_Nms_per_rad * e_W -
                            config_.k_I_Nm_per_rad_s * e_I + W.cross(J_ * W) -
                            J_ * (W.cross(RtRd * W_d) - RtRd * Wdot_d);

  const double f_command = f + config_.thrust_lag_compensation_s * f_dot;
  if (!std::isfinite(f_command) || !M.allFinite() || !R_d.allFinite() || !W_d.allFinite() ||
      !Wdot_d.allFinite()) {
    return false;
  }

  e_i_ = e_i;
  e_I_ = e_I;
  out->thrust_N = f_command;
  out->moment_Nm = M;
  out->thrust_rate_Nps = f_dot;
  out->e_x_m = e_x;
  out->e_v_mps = e_v;
  out->e_R = e_R;
  out->e_W_radps = e_W;
  out->e_i_m = e_i;
  out->e_I_rad_s = e_I;
  out->force_W_N = A;
  out->R_d = R_d;
  out->W_d_radps = W_d;
  out->Wdot_d_radps2 = Wdot_d;
  return true;
}

}  // namespace kestrel
