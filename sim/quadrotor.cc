#include "sim/quadrotor.h"

#include <cmath>
#include <limits>

#include "common/check.h"

namespace kestrel {

void QuadrotorConfig::Validate() const {
  KESTREL_THROW_UNLESS(max_substep_s > 0.0 && max_substep_s <= 0.01,
                       "quadrotor max_substep_s = " << max_substep_s << "; accepted: (0, 0.01]");
  KESTREL_THROW_UNLESS(crash_speed_mps > 0.0 && std::isfinite(crash_speed_mps),
                       "quadrotor crash_speed_mps = " << crash_speed_mps << "; accepted: (0, inf)");
  KESTREL_THROW_UNLESS(gravity_mps2 > 0.0 && gravity_mps2 < 100.0,
                       "quadrotor gravity_mps2 = " << gravity_mps2 << "; accepted: (0, 100)");
}

Quadrotor::Quadrotor(const VehicleConfig& vehicle, const QuadrotorConfig& config,
                     const World& world, const BulletWorld* contacts)
    : vehicle_(vehicle),
      config_(config),
      geometry_(ComputeRotorGeometry(vehicle)),
      contacts_(contacts),
      ground_z_m_(-std::numeric_limits<double>::infinity()) {
  config_.Validate();
  J_ = vehicle_.inertia_kgm2.asDiagonal();
  J_inv_ = vehicle_.inertia_kgm2.cwiseInverse().asDiagonal();
  for (const WorldPlane& p : world.planes) {
    if (p.normal.isApprox(Eigen::Vector3d::UnitZ(), 1e-12)) {
      ground_z_m_ = std::max(ground_z_m_, p.offset_m);
    }
  }
  Reset(world.start_X_WB);
}

void Quadrotor::Reset(const Pose3& X_WB, const Eigen::Vector4d& thrust_N) {
  QuadrotorState s;
  s.p_W = X_WB.p;
  s.q_WB = X_WB.q;
  s.thrust_N = thrust_N;
  SetState(s);
  collision_count_ = 0;
  in_collision_ = false;
  last_collision_.clear();
}

void Quadrotor::SetState(const QuadrotorState& state) {
  state_ = state;
  state_.q_WB.normalize();
  state_.thrust_N =
      state_.thrust_N.cwiseMax(vehicle_.min_rotor_thrust_N).cwiseMin(vehicle_.max_rotor_thrust_N);
  on_ground_ = state_.p_W.z() <= ground_z_m_;
  const Vector17 x = Pack();
  acceleration_W_ = on_ground_ ? Eigen::Vector3d::Zero()
                               : Eigen::Vector3d(Derivative(x, state_.thrust_N).segment<3>(3));
}

Quadrotor::Vector17 Quadrotor::Pack() const {
  Vector17 x;
  x << state_.p_W, state_.v_W, state_.q_WB.w(), state_.q_WB.x(), state_.q_WB.y(), state_.q_WB.z(),
      state_.w_B, state_.thrust_N;
  return x;
}

void Quadrotor::Unpack(const Vector17& x) {
  state_.p_W = x.segment<3>(0);
  state_.v_W = x.segment<3>(3);
  state_.q_WB = Eigen::Quaterniond(x[6], x[7], x[8], x[9]).normalized();
  state_.w_B = x.segment<3>(10);
  state_.thrust_N = x.segment<4>(13);
}

Quadrotor::Vector17 Quadrotor::Derivative(const Vector17& x, const Eigen::Vector4d& command) const {
  const Eigen::Quaterniond q = Eigen::Quaterniond(x[6], x[7], x[8], x[9]).normalized();
  const Eigen::Matrix3d R = q.toRotationMatrix();
  const Eigen::Vector3d v = x.segment<3>(3);
  const Eigen::Vector3d w = x.segment<3>(10);
  const Eigen::Vector4d T = x.segment<4>(13);
  const double m = vehicle_.mass_kg;
  Vector17 d;
  d.segment<3>(0) = v;
  const Eigen::Vector3d drag_W =
      R * (vehicle_.linear_drag_Ns_per_m.asDiagonal() * (R.transpose() * v));
  d.segment<3>(3) = (R * Eigen::Vector3d(0, 0, T.sum()) - drag_W) / m -
                    config_.gravity_mps2 * Eigen::Vector3d::UnitZ();
  // qdot = q (0, w) / 2
  const Eigen::Quaterniond qw = q * Eigen::Quaterniond(0.0, w.x(), w.y(), w.z());
  d[6] = 0.5 * qw.w();
  d[7] = 0.5 * qw.x();
  d[8] = 0.5 * qw.y();
  d[9] = 0.5 * qw.z();
  // Moments from each rotor: r_i x (T_i e3) and the drag reaction -s_i k_m T_i e3.
  Eigen::Vector3d M = Eigen::Vector3d::Zero();
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector3d r = geometry_.position_B_m.col(i);
    M += r.cross(Eigen::Vector3d(0, 0, T[i]));
    M.z() -= geometry_.spin[static_cast<size_t>(i)] * vehicle_.drag_torque_coefficient_m * T[i];
  }
  d.segment<3>(10) = J_inv_ * (M - w.cross(J_ * w));
  const double tau = vehicle_.motor_time_constant_s;
  d.segment<4>(13) = tau > 0.0 ? Eigen::Vector4d((command - T) / tau) : Eigen::Vector4d::Zero();
  return d;
}

void Quadrotor::Step(const Eigen::Vector4d& commanded_thrust_N, double dt_s) {
  KESTREL_THROW_UNLESS(dt_s > 0.0 && std::isfinite(dt_s), "quadrotor step dt_s = " << dt_s);
  KESTREL_THROW_UNLESS(commanded_thrust_N.allFinite(),
                       "quadrotor command " << commanded_thrust_N.transpose() << " not finite");
  const Eigen::Vector4d command = commanded_thrust_N.cwiseMax(vehicle_.min_rotor_thrust_N)
                                      .cwiseMin(vehicle_.max_rotor_thrust_N);
  if (vehicle_.motor_time_constant_s <= 0.0) state_.thrust_N = command;
  const int n = std::max(1, static_cast<int>(std::ceil(dt_s / config_.max_substep_s - 1e-9)));
  const double h = dt_s / n;
  Vector17 x = Pack();
  for (int k = 0; k < n; ++k) {
    const Vector17 k1 = Derivative(x, command);
    const Vector17 k2 = Derivative(x + 0.5 * h * k1, command);
    const Vector17 k3 = Derivative(x + 0.5 * h * k2, command);
    const Vector17 k4 = Derivative(x + h * k3, command);
    x += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    x.segment<4>(6).normalize();
  }
  Unpack(x);
  acceleration_W_ = Derivative(x, command).segment<3>(3);
  ApplyFloor();
  CheckContacts();
}

void Quadrotor::ApplyFloor() {
  on_ground_ = false;
  if (!(state_.p_W.z() <= ground_z_m_)) return;
  on_ground_ = true;
  if (state_.v_W.z() < -config_.crash_speed_mps) {
    ++collision_count_;
    last_collision_ = "floor";
  }
  state_.p_W.z() = ground_z_m_;
  const double lift = (state_.q_WB * Eigen::Vector3d(0, 0, state_.thrust_N.sum())).z();
  if (lift <= vehicle_.mass_kg * config_.gravity_mps2) {
    // Resting: level at its yaw, no motion.
    state_.v_W.setZero();
    state_.w_B.setZero();
    state_.q_WB = QuaternionFromYaw(YawOf(state_.q_WB));
    acceleration_W_.setZero();
  } else {
    state_.v_W.z() = std::max(0.0, state_.v_W.z());
    acceleration_W_.z() = std::max(0.0, acceleration_W_.z());
  }
}

void Quadrotor::CheckContacts() {
  if (contacts_ == nullptr) return;
  std::string name;
  const bool touching = contacts_->CountVehicleContacts(state_.pose(), false, &name) > 0;
  if (touching && !in_collision_) {
    ++collision_count_;
    last_collision_ = name;
  }
  in_collision_ = touching;
}

void Quadrotor::FollowTrajectory(const PiecewisePolynomialTrajectory& trajectory, double t_s) {
  auto attitude = [&](double t) {
    const FlatOutput f = trajectory.Evaluate(t);
    Eigen::Vector3d b3 = f.acceleration_mps2 + config_.gravity_mps2 * Eigen::Vector3d::UnitZ();
    b3.normalize();
    const Eigen::Vector3d heading(std::cos(f.yaw_rad), std::sin(f.yaw_rad), 0.0);
    const Eigen::Vector3d b2 = b3.cross(heading).normalized();
    Eigen::Matrix3d R;
    R.col(0) = b2.cross(b3);
    R.col(1) = b2;
    R.col(2) = b3;
    return R;
  };
  const FlatOutput f = trajectory.Evaluate(t_s);
  constexpr double kDelta = 1e-4;
  const Eigen::Matrix3d R = attitude(t_s);
  const Eigen::AngleAxisd change(attitude(t_s - kDelta).transpose() * attitude(t_s + kDelta));
  state_.p_W = f.position_m;
  state_.v_W = f.velocity_mps;
  state_.q_WB = Eigen::Quaterniond(R).normalized();
  state_.w_B = change.angle() * change.axis() / (2.0 * kDelta);
  state_.thrust_N.setConstant(
      0.25 * vehicle_.mass_kg *
      (f.acceleration_mps2 + config_.gravity_mps2 * Eigen::Vector3d::UnitZ()).norm());
  acceleration_W_ = f.acceleration_mps2;
  on_ground_ = state_.p_W.z() <= ground_z_m_;
  CheckContacts();
}

}  // namespace kestrel
