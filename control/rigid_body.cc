#include "control/rigid_body.h"

#include <cmath>

#include "common/check.h"
#include "common/se3.h"

namespace kestrel {

RigidBodySimulator::RigidBodySimulator(const VehicleConfig& vehicle, double gravity_mps2)
    : vehicle_(vehicle), geometry_(ComputeRotorGeometry(vehicle)), gravity_mps2_(gravity_mps2) {
  KESTREL_THROW_UNLESS(std::isfinite(gravity_mps2) && gravity_mps2 >= 0.0,
                       "gravity_mps2 = " << gravity_mps2 << ", accepted [0, inf)");
  J_ = vehicle_.inertia_kgm2.asDiagonal();
  J_inv_ = vehicle_.inertia_kgm2.cwiseInverse().asDiagonal();
  SetState(VehicleState{}, Eigen::Vector4d::Zero());
}

void RigidBodySimulator::SetState(const VehicleState& state,
                                  const Eigen::Vector4d& rotor_thrust_N) {
  KESTREL_THROW_UNLESS(state.position_m.allFinite() && state.velocity_mps.allFinite() &&
                           state.R_WB.allFinite() && state.angular_velocity_radps.allFinite() &&
                           rotor_thrust_N.allFinite(),
                       "SetState: non-finite state");
  const Eigen::Quaterniond q = QuaternionFromRotation(state.R_WB);
  x_.segment<3>(0) = state.position_m;
  x_.segment<3>(3) = state.velocity_mps;
  x_.segment<4>(6) << q.w(), q.x(), q.y(), q.z();
  x_.segment<3>(10) = state.angular_velocity_radps;
  x_.segment<4>(13) =
      rotor_thrust_N.cwiseMax(vehicle_.min_rotor_thrust_N).cwiseMin(vehicle_.max_rotor_thrust_N);
}

VehicleState RigidBodySimulator::state() const {
  VehicleState state;
  state.position_m = x_.segment<3>(0);
  state.velocity_mps = x_.segment<3>(3);
  state.R_WB = Eigen::Quaterniond(x_[6], x_[7], x_[8], x_[9]).normalized().toRotationMatrix();
  state.angular_velocity_radps = x_.segment<3>(10);
  return state;
}

RigidBodySimulator::StateVector RigidBodySimulator::Derivative(
    const StateVector& x, const Eigen::Vector4d& command) const {
  StateVector dx;
  const Eigen::Vector3d v = x.segment<3>(3);
  const Eigen::Quaterniond q(x[6], x[7], x[8], x[9]);
  const Eigen::Matrix3d R = q.normalized().toRotationMatrix();
  const Eigen::Vector3d W = x.segment<3>(10);
  const Eigen::Vector4d T = x.segment<4>(13);
  const Eigen::Vector4d wrench = geometry_.mixer * T;  // [f; M]
  const Eigen::Vector3d drag_B = -vehicle_.linear_drag_Ns_per_m.cwiseProduct(R.transpose() * v);
  dx.segment<3>(0) = v;
  dx.segment<3>(3) = (R * (Eigen::Vector3d::UnitZ() * wrench[0] + drag_B)) / vehicle_.mass_kg -
                     gravity_mps2_ * Eigen::Vector3d::UnitZ();
  // qdot = 1/2 q (0, W).
  const Eigen::Quaterniond omega(0.0, W.x(), W.y(), W.z());
  const Eigen::Quaterniond q_dot = q * omega;
  dx.segment<4>(6) << 0.5 * q_dot.w(), 0.5 * q_dot.x(), 0.5 * q_dot.y(), 0.5 * q_dot.z();
  dx.segment<3>(10) = J_inv_ * (wrench.tail<3>() - W.cross(J_ * W));
  if (vehicle_.motor_time_constant_s > 0.0) {
    dx.segment<4>(13) = (command - T) / vehicle_.motor_time_constant_s;
  } else {
    dx.segment<4>(13).setZero();
  }
  return dx;
}

void RigidBodySimulator::Step(const Eigen::Vector4d& commanded_rotor_thrust_N, double dt_s,
                              double max_substep_s) {
  KESTREL_THROW_UNLESS(std::isfinite(dt_s) && dt_s > 0.0, "Step: dt_s = " << dt_s);
  KESTREL_THROW_UNLESS(commanded_rotor_thrust_N.allFinite(), "Step: non-finite rotor command");
  KESTREL_THROW_UNLESS(max_substep_s > 0.0, "Step: max_substep_s = " << max_substep_s);
  const Eigen::Vector4d command = commanded_rotor_thrust_N.cwiseMax(vehicle_.min_rotor_thrust_N)
                                      .cwiseMin(vehicle_.max_rotor_thrust_N);
  if (vehicle_.motor_time_constant_s <= 0.0) x_.segment<4>(13) = command;
  const int n = static_cast<int>(std::ceil(dt_s / max_substep_s - 1e-9));
  const double h = dt_s / static_cast<double>(n);
  for (int k = 0; k < n; ++k) {
    const StateVector k1 = Derivative(x_, command);
    const StateVector k2 = Derivative(x_ + 0.5 * h * k1, command);
    const StateVector k3 = Derivative(x_ + 0.5 * h * k2, command);
    const StateVector k4 = Derivative(x_ + h * k3, command);
    x_ += (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    x_.segment<4>(6).normalize();
    if (has_ground_) {
      if (x_[2] <= ground_z_m_) {
        // Contact: rest on the ground (no bounce, no sliding, no tipping).
        x_[2] = ground_z_m_;
        x_.segment<3>(3).setZero();
        x_.segment<3>(10).setZero();
        on_ground_ = true;
      } else {
        on_ground_ = false;
      }
    }
  }
  time_s_ += dt_s;
}

void RigidBodySimulator::EnableGround(double ground_z_m) {
  KESTREL_THROW_UNLESS(std::isfinite(ground_z_m), "EnableGround: ground_z_m = " << ground_z_m);
  has_ground_ = true;
  ground_z_m_ = ground_z_m;
  if (x_[2] <= ground_z_m_) {
    x_[2] = ground_z_m_;
    on_ground_ = true;
  }
}

Eigen::Vector3d RigidBodySimulator::specific_force_B_mps2() const {
  if (on_ground_) {
    return state().R_WB.transpose() * (gravity_mps2_ * Eigen::Vector3d::UnitZ());
  }
  const StateVector dx = Derivative(x_, x_.segment<4>(13));
  const VehicleState s = state();
  return s.R_WB.transpose() * (dx.segment<3>(3) + gravity_mps2_ * Eigen::Vector3d::UnitZ());
}

}  // namespace kestrel
