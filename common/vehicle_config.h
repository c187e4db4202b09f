#pragma once
/// @file
/// The vehicle: mass, inertia, rotor layout, motor and sensor parameters, shared by the simulator,
/// the controller and the mapper (docs/design.md §4).
///
/// Frames: body B is x forward, y left, z up; thrust along +z_B. Rotors are numbered 1..4
/// counter-clockwise seen from above, starting front-right (layout "x", rotors at 45 deg between
/// the axes) or front (layout "plus", rotors on the axes). Rotor 1 spins clockwise seen from
/// above, then the directions alternate (2 counter-clockwise, 3 clockwise, 4 counter-clockwise).
/// A rotor spinning with angular velocity s * omega * z_B (s = +1 counter-clockwise from above,
/// -1 clockwise) exerts the reaction (drag) torque -s * k_m * T_i * z_B on the body, T_i its
/// thrust (N) and k_m the drag-torque coefficient (m). So a clockwise rotor yaws the body
/// counter-clockwise (+z), and vice versa.
///
/// The rotor geometry and the mixer are derived from the layout ONCE, in ComputeRotorGeometry();
/// simulator and controller both use it (rotor index i in code = rotor i+1 in the text).

#include <Eigen/Core>
#include <array>
#include <string>

#include "common/se3.h"

namespace kestrel {

class ConfigNode;

/// Standard gravity used by the simulator and the controller, m/s^2 (g along -z_W).
inline constexpr double kGravity_mps2 = 9.81;

/// Physical vehicle parameters. Defaults are the paper-sized vehicle (config/vehicle/paper.yaml).
/// The ESCs' static thrust map (kestrel-motors and its emulator; docs/protocols.md §6.3): a rotor's
/// thrust at the normalised ESC command u in [0, 1] (set point / full scale) is
/// T(u) = full_command_thrust_N u^2 (static thrust grows with the square of the rotor speed, and
/// the speed of a sensorless ESC with its duty cycle, i.e. u).
struct EscMap {
  double full_command_thrust_N{25.0};  ///< T(1), N; at least the vehicle's max_rotor_thrust_N
  /// Armed with no thrust asked, the command keeps this much (0..0.3 of full scale): the rotors
  /// turn at idle instead of stopping and restarting. 0: they stop.
  double idle_command{0.05};
};

struct VehicleConfig {
  double mass_kg{4.34};  ///< total mass m, kg
  /// Diagonal of the inertia J about the centre of mass in body axes, kg m^2.
  Eigen::Vector3d inertia_kgm2{0.0820, 0.0845, 0.1377};
  double arm_length_m{0.315};  ///< distance from the centre of mass to each rotor axis, m
  std::string layout{"x"};     ///< "x" (rotor 1 front-right) or "plus" (rotor 1 front)
  /// Rotor thrust coefficient k_f: thrust T = k_f * omega^2, N/(rad/s)^2 (simulator only).
  double thrust_coefficient_N_per_radps2{8.5e-6};
  /// Drag-torque coefficient k_m: rotor reaction torque = k_m * thrust, m. 0.016 is typical of
  /// 10-12 in propellers; it sets the yaw authority (at the top of the paper's helix the thrust is
  /// 40% of hover and yaw saturates: a smaller k_m tracks the helix worse, docs/STATUS.md,
  /// "Controller").
  double drag_torque_coefficient_m{0.016};
  double motor_time_constant_s{0.02};  ///< first-order lag of rotor thrust, s (0: no lag)
  double max_rotor_thrust_N{25.0};     ///< per-rotor thrust ceiling, N
  double min_rotor_thrust_N{0.0};      ///< per-rotor thrust floor (>= 0, rotors do not reverse), N
  /// Linear body drag, force = -diag(c) v_B in body axes, N/(m/s) per body axis.
  Eigen::Vector3d linear_drag_Ns_per_m{0.1, 0.1, 0.2};
  double diameter_m{0.88};  ///< vehicle diameter incl. propellers (collision footprint), m
  /// Depth camera (Xtion) in the body: optical convention z forward, x right, y down.
  Pose3 X_BS_xtion{Eigen::Vector3d(0.15, 0.0, 0.05), Eigen::Quaterniond(0.5, -0.5, 0.5, -0.5)};
  /// 2D LIDAR (Hokuyo) in the body: x forward, z up.
  Pose3 X_BS_hokuyo{Eigen::Vector3d(0.10, 0.0, 0.12), Eigen::Quaterniond::Identity()};
  EscMap esc;  ///< the ESCs' thrust map (esc: in the file)

  /// Throws std::invalid_argument naming the field, its value and the accepted range when a field
  /// is out of range or the fields disagree (e.g. 4 * max_rotor_thrust_N cannot lift mass_kg,
  /// min >= max thrust, an unknown layout, a non-unit extrinsic quaternion).
  void Validate() const;
};

/// Rotor geometry derived from a VehicleConfig (docs/design.md §4).
struct RotorGeometry {
  /// Column i: position of rotor i+1's hub in B (z = 0), m.
  Eigen::Matrix<double, 3, 4> position_B_m{Eigen::Matrix<double, 3, 4>::Zero()};
  /// s_i: +1 counter-clockwise seen from above, -1 clockwise (rotor 1 clockwise).
  std::array<double, 4> spin{{-1.0, 1.0, -1.0, 1.0}};
  /// Mixer B: [f; M_x; M_y; M_z] = B * [T_1..T_4] with rows [1 1 1 1], r_y,i, -r_x,i and
  /// -s_i k_m (the z-component of r_i x T_i z_B and of the drag torque), N and N m.
  Eigen::Matrix4d mixer{Eigen::Matrix4d::Zero()};
  Eigen::Matrix4d mixer_inverse{Eigen::Matrix4d::Zero()};  ///< B^-1: [f; M] -> rotor thrusts
};

/// Derives rotor positions, spin directions and the mixer and its inverse from the layout.
/// @throws std::invalid_argument if `config` does not validate.
[[nodiscard]] RotorGeometry ComputeRotorGeometry(const VehicleConfig& config);

/// Reads a VehicleConfig from a YAML node (keys as in config/vehicle/paper.yaml; absent keys keep
/// their defaults, unknown keys are errors), then validates it.
/// @throws ConfigError naming the file, the key, the value and the accepted range.
[[nodiscard]] VehicleConfig LoadVehicleConfig(const ConfigNode& node);

/// LoadVehicleConfig(ConfigNode::LoadFile(path)). @throws ConfigError.
[[nodiscard]] VehicleConfig LoadVehicleConfigFile(const std::string& path);
/// LoadVehicleConfig(including.Include(path)): the vehicle file named by the configuration
/// `including` becomes part of its effective configuration. @throws ConfigError.
[[nodiscard]] VehicleConfig LoadVehicleConfigFile(const std::string& path,
                                                  const ConfigNode& including);

}  // namespace kestrel
