#pragma once
/// @file
/// Mixer: total thrust f (N, along +z_B) and moment M (N m, body frame) to the four rotor thrusts,
/// for the "x" and "plus" layouts (geometry from common/vehicle_config.h, docs/design.md §4),
/// with the saturation priority of docs/algorithms.md §11.7:
///   1. roll and pitch moments first: if their rotor differential alone spans more than
///      [T_min, T_max], (M_x, M_y) is scaled down as a vector (its direction is kept);
///   2. then the collective: f is clamped to [f_min(M_xy), f_max(M_xy)], f_min being the least
///      total thrust keeping every rotor >= T_min with those moments (so a negative f, as an
///      upside-down vehicle computes, still yields the flipping moments), f_max the largest
///      keeping every rotor <= T_max;
///   3. then yaw: M_z is scaled by the largest factor in [0, 1] that keeps every rotor within
///      limits.
/// Outputs are always finite and within [T_min, T_max]; a non-finite input gives every rotor
/// T_min and sets input_rejected.

#include <Eigen/Core>

#include "common/vehicle_config.h"

namespace kestrel {

/// The result of one Mix() call: rotor thrusts and what they actually produce.
struct MixerOutput {
  Eigen::Vector4d rotor_thrust_N{Eigen::Vector4d::Zero()};  ///< T_1..T_4, N, within limits
  double thrust_N{0.0};                                     ///< achieved f = sum T_i, N
  Eigen::Vector3d moment_Nm{Eigen::Vector3d::Zero()};       ///< achieved M in B, N m
  bool roll_pitch_saturated{false};                         ///< (M_x, M_y) had to be scaled down
  bool thrust_saturated{false};                             ///< f had to be clamped
  bool yaw_saturated{false};                                ///< M_z had to be scaled down
  bool input_rejected{false};  ///< f or M was not finite; rotors at T_min
};

/// Maps (f, M) to rotor thrusts with saturation priority. Immutable, thread-safe.
class Mixer {
 public:
  /// @throws std::invalid_argument if vehicle.Validate() throws.
  explicit Mixer(const VehicleConfig& vehicle);

  /// Rotor thrusts for the requested total thrust f (N) and body moment M (N m), see the file
  /// comment for the saturation rules.
  [[nodiscard]] MixerOutput Mix(double thrust_N, const Eigen::Vector3d& moment_Nm) const;

  [[nodiscard]] const RotorGeometry& geometry() const { return geometry_; }
  [[nodiscard]] double min_rotor_thrust_N() const { return min_rotor_thrust_N_; }
  [[nodiscard]] double max_rotor_thrust_N() const { return max_rotor_thrust_N_; }

 private:
  RotorGeometry geometry_;
  double min_rotor_thrust_N_;
  double max_rotor_thrust_N_;
};

}  // namespace kestrel
