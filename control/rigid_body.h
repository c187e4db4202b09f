#pragma once
/// @file
/// A plain 6-DoF rigid-body quadrotor model with first-order motor lag, integrated with RK4, for
/// closed-loop tests of the controller in one process (the Bullet simulator in sim/ may replace
/// it). Frames as in control/vehicle_state.h (z up, thrust along +z_B). No ground, no contact.
///
/// Dynamics (Lee 2010 eqs. (2)-(5), z up, plus rotor lag and linear body drag):
///     xdot = v
///     m vdot = R (sum_i T_i) e3 - m g e3 - R diag(c_drag) R^T v
///     Rdot = R hat(W)                   (unit quaternion: qdot = q (0, W) / 2)
///     J Wdot = M(T) - W x J W           (M(T): rows 2-4 of the mixer, r_i x T_i e3 + drag torque)
///     tau Tdot_i = T_cmd,i - T_i        (tau = motor_time_constant_s; tau = 0: T_i = T_cmd,i)
/// Commands are clamped to [min_rotor_thrust_N, max_rotor_thrust_N] and held over a step.

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "common/vehicle_config.h"
#include "control/vehicle_state.h"

namespace kestrel {

/// The rigid body plus its four rotor thrusts. Not thread-safe.
class RigidBodySimulator {
 public:
  /// @throws std::invalid_argument if vehicle.Validate() throws.
  explicit RigidBodySimulator(const VehicleConfig& vehicle, double gravity_mps2 = kGravity_mps2);

  /// Sets the state; R_WB is re-orthonormalised; rotor thrusts (N) are clamped to the limits.
  void SetState(const VehicleState& state, const Eigen::Vector4d& rotor_thrust_N);

  /// Advances by dt_s (> 0) with `commanded_rotor_thrust_N` held, in RK4 sub-steps of at most
  /// max_substep_s. @throws std::invalid_argument on dt_s <= 0 or a non-finite command.
  void Step(const Eigen::Vector4d& commanded_rotor_thrust_N, double dt_s,
            double max_substep_s = 0.0005);

  /// The current state (R_WB from the unit quaternion).
  [[nodiscard]] VehicleState state() const;
  /// Actual rotor thrusts (after the lag), N.
  [[nodiscard]] Eigen::Vector4d rotor_thrust_N() const { return x_.segment<4>(13); }
  /// Specific force in B (what an accelerometer measures: R^T (vdot + g e3)), m/s^2, at the
  /// current state.
  [[nodiscard]] Eigen::Vector3d specific_force_B_mps2() const;
  /// A flat ground at height z (W): the body cannot sink below it; touching it stops the body
  /// (velocity and angular velocity zeroed) until the thrust lifts it. The accelerometer then
  /// reads R^T g e3. Off by default.
  void EnableGround(double ground_z_m);
  /// True while resting on the ground.
  [[nodiscard]] bool on_ground() const { return on_ground_; }
  /// Simulated time since construction, s.
  [[nodiscard]] double time_s() const { return time_s_; }
  [[nodiscard]] const RotorGeometry& geometry() const { return geometry_; }

 private:
  using StateVector = Eigen::Matrix<double, 17, 1>;  // p(3) v(3) q(w,x,y,z)(4) W(3) T(4)
  [[nodiscard]] StateVector Derivative(const StateVector& x, const Eigen::Vector4d& command) const;

  VehicleConfig vehicle_;
  RotorGeometry geometry_;
  double gravity_mps2_;
  Eigen::Matrix3d J_;
  Eigen::Matrix3d J_inv_;
  StateVector x_;
  double time_s_{0.0};
  bool has_ground_{false};
  double ground_z_m_{0.0};
  bool on_ground_{false};
};

}  // namespace kestrel
