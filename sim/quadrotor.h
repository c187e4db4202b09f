#pragma once
/// @file
/// The simulated vehicle: a rigid-body quadrotor integrated with the simulator's own RK4, four
/// rotors from common/vehicle_config.h (positions and spin directions from ComputeRotorGeometry,
/// the same derivation the controller's mixer uses), first-order motor lag on each rotor's
/// thrust, linear body drag, a floor to stand on and Bullet contact detection against the world.
/// Frames (docs/design.md §4): W x east, y north, z up, gravity -z_W; B x forward,
/// y left, z up, thrust along +z_B.
///
/// Equations (state p_W, v_W, q_WB, w_B, rotor thrusts T_i):
///     pdot = v
///     m vdot = R (sum_i T_i) e3 - R diag(c_drag) R^T v - m g e3
///     qdot = q (0, w) / 2
///     J wdot = sum_i r_i x (T_i e3) - sum_i s_i k_m T_i e3 - w x J w
///     tau Tdot_i = T_cmd,i - T_i        (tau = 0: T_i = T_cmd,i at once)
/// with r_i the rotor hub positions, s_i = +1 counter-clockwise seen from above, k_m the drag
/// torque coefficient. Commands are clamped to [min_rotor_thrust_N, max_rotor_thrust_N].
///
/// Floor: the highest half-space with an upward normal (0, 0, 1) is the ground; the body origin
/// cannot go below it. Touching it faster than crash_speed_mps is a collision; while the thrust
/// cannot lift the vehicle it rests (level at its yaw, no motion). Contacts of the vehicle
/// cylinder of the BulletWorld (build it with radius diameter_m/2) with any box or cylinder of
/// the world are collisions; a collision is counted once per contact episode.
/// There is no contact response: the vehicle flies on through obstacles (the run has failed).
/// Kinematic mode: the state follows a trajectory exactly (what the paper's simulation did).

#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "common/se3.h"
#include "common/trajectory.h"
#include "common/vehicle_config.h"
#include "sim/bullet_world.h"
#include "sim/world.h"

namespace kestrel {

/// Simulator-side vehicle options (the physics comes from VehicleConfig).
struct QuadrotorConfig {
  double max_substep_s{0.0005};        ///< longest RK4 step, s, (0, 0.01]
  double crash_speed_mps{1.0};         ///< touching the floor faster than this is a collision, m/s
  double gravity_mps2{kGravity_mps2};  ///< g, m/s^2
  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// The vehicle's true state.
struct QuadrotorState {
  Eigen::Vector3d p_W{Eigen::Vector3d::Zero()};             ///< body origin in W, m
  Eigen::Vector3d v_W{Eigen::Vector3d::Zero()};             ///< velocity in W, m/s
  Eigen::Quaterniond q_WB{Eigen::Quaterniond::Identity()};  ///< attitude R_WB
  Eigen::Vector3d w_B{Eigen::Vector3d::Zero()};             ///< angular velocity in B, rad/s
  Eigen::Vector4d thrust_N{Eigen::Vector4d::Zero()};        ///< actual rotor thrusts T_1..T_4, N
  /// X_WB.
  [[nodiscard]] Pose3 pose() const { return Pose3{p_W, q_WB}; }
};

/// Rigid-body quadrotor. Not thread-safe (it uses the BulletWorld).
class Quadrotor {
 public:
  /// `contacts` (may be nullptr: no collision detection) must outlive the Quadrotor and is used
  /// only from the calling thread. `world` gives the floor height.
  /// @throws std::invalid_argument if vehicle.Validate() or config.Validate() throws.
  Quadrotor(const VehicleConfig& vehicle, const QuadrotorConfig& config, const World& world,
            const BulletWorld* contacts);

  /// Places the vehicle at rest at X_WB with zero rotor thrust (or `thrust_N` if given).
  void Reset(const Pose3& X_WB, const Eigen::Vector4d& thrust_N = Eigen::Vector4d::Zero());
  /// Sets the full state (thrusts clamped to the rotor limits, quaternion normalised).
  void SetState(const QuadrotorState& state);

  /// Advances dt_s (> 0) holding the commanded rotor thrusts (N), in RK4 substeps of at most
  /// max_substep_s, then applies the floor and checks contacts.
  /// @throws std::invalid_argument on dt_s <= 0 or non-finite commands.
  void Step(const Eigen::Vector4d& commanded_thrust_N, double dt_s);

  /// Kinematic mode: puts the vehicle exactly on the trajectory at time t_s: position, velocity
  /// and acceleration from the flat output, attitude with thrust axis along a + g e3 and heading
  /// yaw, angular velocity from the attitude's central difference over +-0.1 ms. Checks contacts.
  void FollowTrajectory(const PiecewisePolynomialTrajectory& trajectory, double t_s);

  /// The true state.
  [[nodiscard]] const QuadrotorState& state() const { return state_; }
  /// Acceleration of the body origin in W at the current state (0 while resting on the floor),
  /// m/s^2: what the IMU's accelerometer integrates.
  [[nodiscard]] const Eigen::Vector3d& acceleration_W() const { return acceleration_W_; }
  /// True while touching the floor.
  [[nodiscard]] bool on_ground() const { return on_ground_; }
  /// Number of collision episodes so far (obstacle contacts and floor crashes).
  [[nodiscard]] int collision_count() const { return collision_count_; }
  /// True while the vehicle touches an obstacle.
  [[nodiscard]] bool in_collision() const { return in_collision_; }
  /// Name of the obstacle of the latest collision ("floor" for a crash), "" if none.
  [[nodiscard]] const std::string& last_collision() const { return last_collision_; }
  /// Rotor positions, spins and mixer derived from the vehicle configuration.
  [[nodiscard]] const RotorGeometry& geometry() const { return geometry_; }
  /// The floor height, m (-infinity when the world has no upward half-space).
  [[nodiscard]] double ground_height_m() const { return ground_z_m_; }

 private:
  using Vector17 = Eigen::Matrix<double, 17, 1>;  // p(3) v(3) q wxyz(4) w(3) T(4)
  [[nodiscard]] Vector17 Derivative(const Vector17& x, const Eigen::Vector4d& command) const;
  [[nodiscard]] Vector17 Pack() const;
  void Unpack(const Vector17& x);
  void ApplyFloor();
  void CheckContacts();

  VehicleConfig vehicle_;
  QuadrotorConfig config_;
  RotorGeometry geometry_;
  const BulletWorld* contacts_;
  Eigen::Matrix3d J_, J_inv_;
  double ground_z_m_;
  QuadrotorState state_;
  Eigen::Vector3d acceleration_W_{Eigen::Vector3d::Zero()};
  bool on_ground_{false};
  bool in_collision_{false};
  int collision_count_{0};
  std::string last_collision_;
};

}  // namespace kestrel
