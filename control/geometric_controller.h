#pragma once
/// @file
/// Geometric tracking control on SE(3): Lee, Leok, McClamroch, "Geometric tracking control of a
/// quadrotor UAV on SE(3)", CDC 2010, in Kestrel's z-UP convention (docs/algorithms.md §11):
/// world W x east, y north, z up, gravity -g e3; body B x forward, y left, z up; thrust f along
/// +b3 = R e3, so m xddot = f R e3 - m g e3 and J Wdot + W x J W = M.
///
/// Symbols (the paper's): x, v, R, W the state; x_d and derivatives, psi_d (heading b1d) the
/// desired flat output; e_x, e_v, e_R, e_W the errors; e_i, e_I the position and attitude
/// integrals (as in the FDCL implementations, each clamped per component); A the desired force;
/// R_d = [b1c, b2d, b3d], W_d, Wdot_d the desired attitude and its rates.
///
/// The desired force's vertical component is bounded below (min_force_z_fraction) and its tilt
/// from vertical above (max_tilt_rad), choices of ours, not the paper's, so that R_d is never
/// upside down or flat.
///
/// W_d and Wdot_d are computed ANALYTICALLY from A, Adot and Addot, and these include the feedback
/// terms (Adot = -k_x e_v - k_v e_a - k_i (c1 e_x + e_v) + m jerk_d, e_a from the acceleration
/// estimated from the thrust, f R e3 / m - g e3, with f clamped to what the rotors can produce);
/// never by finite differences.
///
/// Attitude error (GeometricControllerConfig::attitude_error, AttitudeErrorForm): either CDC 2010's
/// e_R = 1/2 vee(R_d^T R - R^T R_d), |e_R| = sin(angle), which vanishes at 180 deg so the flip
/// from upside down starts slowly, or the large-angle form (ComputeAttitudeError has the
/// equations), |e_R| = 2 sin(angle/2), largest at 180 deg. Both enter M the same way.
///
/// Thrust during a flip: upside down f = A . R e3 < 0 and the mixer (control/mixer.h) raises the
/// collective only to f_min(M_xy), the least that keeps every rotor >= 0 with the flipping
/// moments. That is the bound we keep: while b3 . e3 < 0 any thrust pushes the vehicle towards
/// the ground, so more collective than the moments need would only add to the fall (a floor of
/// m g / 2 while inverted loses more altitude, with either e_R; tests/control/closed_loop_test.cc).
/// Past 90 deg f = A . R e3 grows with the position and velocity errors and saturates; the rest
/// of the altitude lost is braking the descent at full thrust. The flip's figures:
/// docs/STATUS.md, "Controller".
///
/// Motor lag: with thrust_lag_compensation_s = tau > 0 the commanded thrust is f + tau * fdot (fdot
/// analytic); the moment is not lag-compensated. Default 0 (no compensation).

#include <Eigen/Core>
#include <string>

#include "common/trajectory.h"
#include "common/vehicle_config.h"
#include "control/vehicle_state.h"

namespace kestrel {

/// Which attitude error function Psi(R, R_d) and error vector e_R (its left-trivialised gradient,
/// d/de Psi(R Exp(e eta), R_d) at e = 0 equals e_R . eta) the law uses. theta is the angle of
/// the rotation R_d^T R, a its axis (in B).
enum class AttitudeErrorForm {
  /// Lee, Leok, McClamroch, CDC 2010 (docs/algorithms.md §11.4):
  /// Psi = 1/2 tr(I - R_d^T R) = 1 - cos theta,
  /// e_R = 1/2 vee(R_d^T R - R^T R_d) = sin(theta) a. Almost-global attractivity, but the
  /// restoring moment vanishes at theta = 180 deg (a saddle at exactly 180 deg).
  kCdc2010,
  /// T. Lee, "Exponential stability of an attitude tracking control system on SO(3) for
  /// large-angle rotational maneuvers", Systems & Control Letters 61(1), 2012, uses
  /// Psi = 2 - sqrt(1 + tr(R_d^T R)) and e_R = vee(R_d^T R - R^T R_d) / (2 sqrt(1 + tr(R_d^T R)))
  /// = sin(theta/2) a (almost-global EXPONENTIAL stability; defined for theta < 180 deg). Kestrel
  /// uses TWICE that pair, Psi = 2 (2 - sqrt(1 + tr(R_d^T R))) = 4 (1 - cos(theta/2)),
  /// e_R = vee(R_d^T R - R^T R_d) / sqrt(1 + tr(R_d^T R)) = 2 sin(theta/2) a, so that to first
  /// order at R = R_d both forms give e_R = theta a and k_R keeps its meaning (N m per rad near
  /// hover): the helix gains carry over. Near 180 deg, 1 + tr -> 0: below 1e-6 (theta within
  /// 0.06 deg of 180) e_R is taken from the quaternion (w, v) of R_d^T R as 2 sign(w) v (equal
  /// to the formula where both are defined; w = 0 picks +), so e_R stays finite, of norm 2.
  /// Formula checked by tests/control/geometric_controller_test.cc (gradient of Psi vs e_R).
  kLargeAngle,
};

/// "cdc2010" or "large_angle" (the YAML values of controller.attitude_error).
[[nodiscard]] const char* ToString(AttitudeErrorForm form);

/// Parses "cdc2010" / "large_angle"; returns false (leaving *form) for anything else.
/// Precondition: form != nullptr.
[[nodiscard]] bool ParseAttitudeErrorForm(const std::string& text, AttitudeErrorForm* form);

/// The attitude error function Psi(R, R_d) of `form` (dimensionless, >= 0, 0 iff R = R_d; see
/// AttitudeErrorForm). R, R_d rotations (R_WB, R_WBd).
[[nodiscard]] double ComputeAttitudeErrorFunction(const Eigen::Matrix3d& R,
                                                  const Eigen::Matrix3d& R_d,
                                                  AttitudeErrorForm form);

/// The attitude error vector e_R (in B, dimensionless) of `form` (see AttitudeErrorForm).
/// R, R_d rotations.
[[nodiscard]] Eigen::Vector3d ComputeAttitudeError(const Eigen::Matrix3d& R,
                                                   const Eigen::Matrix3d& R_d,
                                                   AttitudeErrorForm form);

/// Gains and vehicle constants of the geometric controller. Position gains are given per unit
/// mass (the paper writes k_x = 16 m, k_v = 5.6 m), attitude gains absolutely (paper: k_R = 8.81,
/// k_W = 2.54). The integral gains are ours, chosen on the paper's helix with tau = 0.02 s
/// (tests/control/closed_loop_test.cc; docs/STATUS.md, "Controller"): a small k_i costs the helix
/// almost nothing, a large one worsens it; k_I barely matters there (it is for offsets: centre of
/// mass, rotor mismatch).
struct GeometricControllerConfig {
  double mass_kg{4.34};                                  ///< m, kg
  Eigen::Vector3d inertia_kgm2{0.0820, 0.0845, 0.1377};  ///< diag J, body axes, kg m^2
  double gravity_mps2{kGravity_mps2};                    ///< g, m/s^2
  double k_x_per_s2{16.0};  ///< k_x / m: position gain per unit mass, (N/m)/kg = 1/s^2
  double k_v_per_s{5.6};    ///< k_v / m: velocity gain per unit mass, (N s/m)/kg = 1/s
  double k_i_per_s2{0.5};   ///< k_i / m: position-integral gain per unit mass, 1/s^2 (0: off)
  double c1_per_s{1.0};     ///< c1: e_i integrates c1 e_x + e_v, 1/s
  double position_integral_limit_m{0.5};  ///< per-component clamp of e_i, m
  /// Attitude error function: kLargeAngle (default; the 178 deg flip in tests/control and
  /// tests/system) or kCdc2010 (the paper's). YAML: controller.attitude_error.
  AttitudeErrorForm attitude_error{AttitudeErrorForm::kLargeAngle};
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
  /// Lower bound of the desired force's vertical component, as a fraction of the weight, [0, 1):
  /// A_z >= fraction m g (0: A_z >= 0), with Adot_z = Addot_z = 0 while the bound holds A_z. So
  /// b3d = A/|A| stays in the upper hemisphere and R_d is never upside down: rotors that cannot
  /// reverse give at most g downward (idling); flipping over to push down faster is never worth
  /// it. Needed with kLargeAngle, together with max_tilt_rad and the W_d, Wdot_d bounds below:
  /// after the 178 deg recovery the vehicle overshoots upward, A_z turns negative,
  /// R_d swings by ~180 deg and the large-angle e_R, unlike CDC 2010's (near zero there), rolls
  /// the vehicle over again (tests/control/closed_loop_test.cc). The paper's helix needs A_z >=
  /// m (g - 0.6 pi^2) = 0.40 m g: 0.2 leaves it untouched.
  double min_force_z_fraction{0.2};
  /// Largest tilt of b3d from vertical, rad, (0, 1.5): |A_xy| is scaled down to A_z
  /// tan(max_tilt_rad), keeping its direction (W_d, Wdot_d from the bounded A, exactly). Without
  /// it the bounded A_z above still lets b3d lie almost flat when the horizontal error is large
  /// (as after a flip), and the vehicle rolls over again. The paper's helix needs much less
  /// (docs/STATUS.md, "Controller").
  double max_tilt_rad{1.0};
  /// Bound on |W_d|, rad/s (inf: none). W_d ~ |Adot| / |A| grows without bound when |A| is
  /// small and the feedback part of Adot large (after a flip: a vehicle tilted at full thrust
  /// decelerating sideways while its vertical channel asks for little thrust): tracking that
  /// W_d rolls the vehicle over (in the 178 deg case a second roll followed). W_d is scaled down
  /// to this norm, direction kept. The paper's helix needs less after its transient
  /// (tests/control/closed_loop_test.cc; the figures: docs/STATUS.md, "Controller").
  double max_desired_rate_radps{6.0};
  /// Bound on |Wdot_d|, rad/s^2, likewise (the helix needs less after its transient).
  double max_desired_angular_acceleration_radps2{30.0};
  /// |A| below this (N) leaves no thrust direction: Compute() fails (only reachable with
  /// min_force_z_fraction = 0: free fall commanded).
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
  /// e_R in B (dimensionless; |e_R| = sin angle for kCdc2010, 2 sin(angle/2) for kLargeAngle)
  Eigen::Vector3d e_R{Eigen::Vector3d::Zero()};
  Eigen::Vector3d e_W_radps{Eigen::Vector3d::Zero()};      ///< e_W = W - R^T R_d W_d, B, rad/s
  Eigen::Vector3d e_i_m{Eigen::Vector3d::Zero()};          ///< position integral after this step, m
  Eigen::Vector3d e_I_rad_s{Eigen::Vector3d::Zero()};      ///< attitude integral after this step
  Eigen::Vector3d force_W_N{Eigen::Vector3d::Zero()};      ///< A, the desired force, W, N
  Eigen::Matrix3d R_d{Eigen::Matrix3d::Identity()};        ///< desired attitude [b1c b2d b3d]
  Eigen::Vector3d W_d_radps{Eigen::Vector3d::Zero()};      ///< desired angular velocity, B_d, rad/s
  Eigen::Vector3d Wdot_d_radps2{Eigen::Vector3d::Zero()};  ///< its derivative, rad/s^2
};

/// The control law as a pure object: it holds only its gains and the two integrals; no clock, no
/// I/O. Not thread-safe (Compute mutates the integrals).
class GeometricController {
 public:
  /// @throws std::invalid_argument if config.Validate() throws.
  explicit GeometricController(const GeometricControllerConfig& config);

  /// One control step (docs/algorithms.md §11). `dt_s` (s, in [0, max_dt_s]) is the time since
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
