#pragma once
/// @file
/// Geometric tracking control on SE(3): Lee, Leok, McClamroch, "Geometric tracking control of a
/// quadrotor UAV on SE(3)", CDC 2010, in Kestrel's z-UP convention (ALGORITHMS.md section 9):
/// world W x east, y north, z up, gravity -g e3; body B x forward, y left, z up; thrust f along
/// +b3 = R e3, so m xddot = f R e3 - m g e3 and J Wdot + W x J W = M.
///
/// Symbols (the paper's): x, v, R, W the state; x_d and derivatives, psi_d (heading b1d) the
/// desired flat output; e_x, e_v, e_R, e_W the errors; e_i, e_I the position and attitude
/// integrals (as in the FDCL implementations, each clamped per component); A the desired force;
/// R_d = [b1c, b2d, b3d], W_d, Wdot_d the desired attitude and its rates.
///
/// W_d and Wdot_d are computed ANALYTICALLY from A, Adot and Addot, and these include the feedback
/// terms (Adot = -k_x e_v - k_v e_a - k_i (c1 e_x + e_v) + m jerk_d, e_a from the acceleration
/// estimated from the thrust, f R e3 / m - g e3, with f clamped to what the rotors can produce);
/// never by finite differences.
///
/// Motor lag: with thrust_lag_compensation_s = tau > 0 the commanded thrust is f + tau * fdot (fdot
/// analytic); the moment is not lag-compensated. Default 0 (no compensation).

#include <Eigen/Core>

#include "common/trajectory.h"
#include "common/vehicle_config.h"
#include "control/vehicle_state.h"

namespace kestrel {

/// Gains and vehicle constants of the geometric controller. Position gains are given per unit
/// mass (the paper writes k_x = 16 m, k_v = 5.6 m), attitude gains absolutely (paper: k_R = 8.81,
/// k_W = 2.54). The integral gains are ours: measured on the paper's helix with tau = 0.02 s
/// (tests/control/closed_loop_test.cc), k_i/m = 4 gave 39 mm RMS, 0.5 gives 17 mm, 0 gives 16 mm;
/// k_I barely matters there (it is for offsets: centre of mass, rotor mismatch).
struct GeometricControllerConfig {
  double mass_kg{4.34};                                  ///< m, kg
  Eigen::Vector3d inertia_kgm2{0.0820, 0.0845, 0.1377};  ///< diag J, body axes, kg m^2
  double gravity_mps2{kGravity_mps2};                    ///< g, m/s^2
  double k_x_per_s2{16.0};  ///< k_x / m: position gain per unit mass, (N/m)/kg = 1/s^2
  double k_v_per_s{5.6};    ///< k_v / m: velocity gain per unit mass, (N s/m)/kg = 1/s
  double k_i_per_s2{0.5};   ///< k_i / m: position-integral gain per unit mass, 1/s^2 (0: off)
  double c1_per_s{1.0};     ///< c1: e_i integrates c1 e_x + e_v, 1/s
  double position_integral_limit_m{0.5};      ///< per-component clamp of e_i, m
  double k_R_Nm_per_rad{8.81};                ///< k_R: attitude gain, N m/rad
  double k_W_Nms_per_rad{2.54};               ///< k_W: angular-velocity gain, N m s/rad
  double k_I_Nm_per_rad_s{0.1};               ///< k_I: attitude-integral gain, N m/(rad s) (0: off)
  double c2_per_s{1.0};                       ///< c2: e_I integrates c2 e_R + e_W, 1/s
  double attitude_integral_limit_rad_s{0.1};  ///< per-component clamp of e_I, rad s
  /// tau: commanded thrust f + tau * fdot compensates a first-order motor lag, s (0: off).
  double thrust_lag_compensation_s{0.0};
  /// Total thrust the rotors can produce, N: f is clamped to [min_thrust_N, max_thrust_N] ONLY
  /// where the law estimates the acceleration from the thrust (a = f R e3 / m - g e3). Upside down
  /// f = A . R e3 is negative, which no rotor produces; estimating from it would predict a
  /// sideways acceleration and steer b3d away, against the flip.
  double min_thrust_N{0.0};
  double max_thrust_N{100.0};  ///< see min_thrust_N, N
  /// |A| below this (N) leaves no thrust direction: Compute() fails (free fall commanded).
  double min_force_norm_N{1e-3};
  /// Largest dt_s Compute() accepts, s (longer gaps would wind the integrals up).
  double max_dt_s{0.1};

  /// Copies mass, inertia and the total thrust range (4 x rotor limits) from the vehicle; gains
  /// keep their defaults.
  static GeometricControllerConfig FromVehicle(const VehicleConfig& vehicle);

  /// Throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// Everything Compute() produces: the command and the internals worth logging.
struct ControlOutput {
  double thrust_N{0.0};                                ///< f (commanded, incl. lag compensation), N
  Eigen::Vector3d moment_Nm{Eigen::Vector3d::Zero()};  ///< M in B, N m
  double thrust_rate_Nps{0.0};                         ///< fdot (analytic), N/s
  Eigen::Vector3d e_x_m{Eigen::Vector3d::Zero()};      ///< e_x = x - x_d, W, m
  Eigen::Vector3d e_v_mps{Eigen::Vector3d::Zero()};    ///< e_v = v - v_d, W, m/s
  Eigen::Vector3d e_R{Eigen::Vector3d::Zero()};        ///< e_R (dimensionless, |e_R| = sin angle)
  Eigen::Vector3d e_W_radps{Eigen::Vector3d::Zero()};  ///< e_W = W - R^T R_d W_d, B, rad/s
  Eigen::Vector3d e_i_m{Eigen::Vector3d::Zero()};      ///< position integral after this step, m
  Eigen::Vector3d e_I_rad_s{Eigen::Vector3d::Zero()};  ///< attitude integral after this step
  Eigen::Vector3d force_W_N{Eigen::Vector3d::Zero()};  ///< A, the desired force, W, N
  Eigen::Matrix3d R_d{Eigen::Matrix3d::Identity()};    ///< desired attitude [b1c b2d b3d]
  Eigen::Vector3d W_d_radps{Eigen::Vector3d::Zero()};  ///< desired angular velocity, B_d, rad/s
  Eigen::Vector3d Wdot_d_radps2{Eigen::Vector3d::Zero()};  ///< its derivative, rad/s^2
};

/// The control law as a pure object: it holds only its gains and the two integrals; no clock, no
/// I/O. Not thread-safe (Compute mutates the integrals).
class GeometricController {
 public:
  /// @throws std::invalid_argument if config.Validate() throws.
  explicit GeometricController(const GeometricControllerConfig& config);

  /// One control step (ALGORITHMS.md section 9). `dt_s` (s, in [0, max_dt_s]) is the time since
  /// the previous step, used to integrate e_i and e_I (first the integrals advance with the
  /// current errors and are clamped, then they are used).
  /// Returns false, leaving *out and the integrals untouched, when the state is not finite or R
  /// not a rotation, the desired output is not finite, dt_s is out of range, or |A| <
  /// min_force_norm_N. Precondition: out != nullptr.
  [[nodiscard]] bool Compute(const VehicleState& state, const FlatOutput& desired, double dt_s,
                             ControlOutput* out);

  /// Zeroes both integrals (e.g. on the ground, at take-off).
  void ResetIntegrals();

  [[nodiscard]] const GeometricControllerConfig& config() const { return config_; }
  [[nodiscard]] const Eigen::Vector3d& position_integral_m() const { return e_i_; }
  [[nodiscard]] const Eigen::Vector3d& attitude_integral_rad_s() const { return e_I_; }

 private:
  GeometricControllerConfig config_;
  Eigen::Matrix3d J_;
  Eigen::Vector3d e_i_{Eigen::Vector3d::Zero()};
  Eigen::Vector3d e_I_{Eigen::Vector3d::Zero()};
};

/// u = q/|q| and its first two time derivatives given q, qdot, qddot (|q| > 0).
void DeriveUnitVector(const Eigen::Vector3d& q, const Eigen::Vector3d& q_dot,
                      const Eigen::Vector3d& q_ddot, Eigen::Vector3d* u, Eigen::Vector3d* u_dot,
                      Eigen::Vector3d* u_ddot);

}  // namespace kestrel
