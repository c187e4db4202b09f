#pragma once
/// @file
/// Piecewise-polynomial trajectories of the flat outputs (position and yaw) of a quadrotor, as
/// carried by the TRAJECTORY message (docs/design.md §3.1): segments with durations and,
/// per segment, polynomial coefficients for x, y, z (m, world frame W, z up) and yaw (rad) in the
/// segment's local time tau in [0, duration_s]:
///     x(tau) = c[0] + c[1] tau + c[2] tau^2 + ... + c[n] tau^n      (ascending powers)
/// Evaluate() gives exact derivatives up to snap (the controller feeds them forward,
/// docs/algorithms.md §11.5); Sample() is the paper's "path interpreter" for display (every
/// 0.01 s).

#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>
#include <vector>

namespace kestrel {

/// The flat output of a quadrotor at one instant: position and yaw with their derivatives. All in
/// the world frame W (x east, y north, z up). Yaw is the heading of the desired body x axis
/// (rad, not wrapped: polynomials are continuous).
struct FlatOutput {
  Eigen::Vector3d position_m{Eigen::Vector3d::Zero()};         ///< x_d, m
  Eigen::Vector3d velocity_mps{Eigen::Vector3d::Zero()};       ///< dx_d/dt, m/s
  Eigen::Vector3d acceleration_mps2{Eigen::Vector3d::Zero()};  ///< d2x_d/dt2, m/s^2
  Eigen::Vector3d jerk_mps3{Eigen::Vector3d::Zero()};          ///< d3x_d/dt3, m/s^3
  Eigen::Vector3d snap_mps4{Eigen::Vector3d::Zero()};          ///< d4x_d/dt4, m/s^4
  double yaw_rad{0.0};                                         ///< psi_d, rad
  double yaw_rate_radps{0.0};                                  ///< dpsi_d/dt, rad/s
  double yaw_acceleration_radps2{0.0};                         ///< d2psi_d/dt2, rad/s^2

  /// A hover (all derivatives zero) at `position_m` with heading `yaw_rad`.
  static FlatOutput Hover(const Eigen::Vector3d& position_m, double yaw_rad);
  /// True when every member is finite.
  [[nodiscard]] bool IsFinite() const;
};

/// One polynomial piece. coefficients[axis] for axis 0..3 = x, y, z, yaw, ascending powers of
/// the local time tau (s) in [0, duration_s].
struct PolynomialSegment {
  double duration_s{0.0};                             ///< > 0, s
  std::array<std::vector<double>, 4> coefficients{};  ///< x, y, z (m), yaw (rad); 1..kMax each
};

/// One display sample: absolute time (s, same time base as the trajectory's start) and the flat
/// output there.
struct TrajectorySample {
  double time_s{0.0};  ///< s
  FlatOutput flat;     ///< flat output at time_s
};

/// The flat (message) layout of a trajectory: segment i's coefficients of an axis at
/// [i * num_coefficients, (i + 1) * num_coefficients), ascending powers.
struct FlatTrajectory {
  double start_time_s{0.0};          ///< s
  std::vector<double> durations_s;   ///< per segment, s
  int num_coefficients{0};           ///< per axis and segment
  std::vector<double> x, y, z, yaw;  ///< m, m, m, rad
};

/// A validated, immutable piecewise-polynomial trajectory starting at start_time_s (seconds in the
/// caller's time base, e.g. the message utime / 1e6).
///
/// Outside [start_time_s, end_time_s] the trajectory is clamped: before the start it returns the
/// start position and yaw, after the end the end position and yaw, with velocity, acceleration,
/// jerk, snap, yaw rate and yaw acceleration all ZERO (a hover at the end point), whatever the
/// polynomials' derivatives at the ends are. At exactly end_time_s the last segment is evaluated
/// at its full duration (true derivatives). At an interior knot the later segment is used.
class PiecewisePolynomialTrajectory {
 public:
  /// Largest number of coefficients per axis and segment (degree 15); the paper's minimum-snap
  /// trajectories use degree 7 to 9.
  static constexpr int kMaxCoefficients = 16;

  /// Checks segments: at least one; durations finite and > 0; each axis 1..kMaxCoefficients
  /// coefficients, all finite; total duration finite. Returns "" when valid, else a sentence
  /// naming the segment, axis and offending value.
  [[nodiscard]] static std::string CheckSegments(const std::vector<PolynomialSegment>& segments);

  /// Builds a trajectory; returns std::nullopt and sets *error (if non-null) when CheckSegments
  /// fails or start_time_s is not finite. Never throws on bad input.
  [[nodiscard]] static std::optional<PiecewisePolynomialTrajectory> Create(
      double start_time_s, std::vector<PolynomialSegment> segments, std::string* error);

  /// Builds from the flat layout of a message: durations_s[i] for segment i and, per axis, a flat
  /// array with num_coefficients entries per segment (segment i's coefficients at
  /// [i * num_coefficients, (i + 1) * num_coefficients)). Sizes must be consistent
  /// (coefficients.size() == durations_s.size() * num_coefficients); otherwise std::nullopt and
  /// *error is set.
  [[nodiscard]] static std::optional<PiecewisePolynomialTrajectory> CreateFromFlat(
      double start_time_s, const std::vector<double>& durations_s, int num_coefficients,
      const std::vector<double>& x, const std::vector<double>& y, const std::vector<double>& z,
      const std::vector<double>& yaw, std::string* error);

  /// The flat layout (for trajectory_t): every axis padded with zero coefficients to the largest
  /// count of any axis and segment. CreateFromFlat of the result gives the same trajectory.
  [[nodiscard]] FlatTrajectory ToFlat() const;

  /// The flat output at absolute time t_s (clamped outside the trajectory, see the class comment).
  /// Precondition: t_s finite (a NaN time returns the start hover).
  [[nodiscard]] FlatOutput Evaluate(double t_s) const;

  /// Samples every dt_s from start_time_s, the last sample exactly at end_time_s. Precondition:
  /// dt_s > 0 (@throws std::invalid_argument otherwise).
  [[nodiscard]] std::vector<TrajectorySample> Sample(double dt_s = 0.01) const;

  [[nodiscard]] double start_time_s() const { return start_time_s_; }
  [[nodiscard]] double end_time_s() const { return start_time_s_ + knots_s_.back(); }
  [[nodiscard]] double duration_s() const { return knots_s_.back(); }
  [[nodiscard]] int num_segments() const { return static_cast<int>(segments_.size()); }
  [[nodiscard]] const std::vector<PolynomialSegment>& segments() const { return segments_; }

 private:
  PiecewisePolynomialTrajectory(double start_time_s, std::vector<PolynomialSegment> segments);
  // Evaluates segment i at local time tau with all derivatives.
  [[nodiscard]] FlatOutput EvaluateSegment(int i, double tau_s) const;

  double start_time_s_{0.0};
  std::vector<PolynomialSegment> segments_;
  std::vector<double> knots_s_;  // cumulative durations, knots_s_[0] = 0, size segments + 1
};

/// Value and first four derivatives of sum_k c[k] tau^k at tau (Horner per derivative).
/// out[d] = d-th derivative, d = 0..4.
void EvaluatePolynomial(const std::vector<double>& c, double tau, double out[5]);

/// Taylor shift: the coefficients d of the same polynomial about a new origin,
/// sum_k d[k] s^k == sum_k c[k] (s + shift)^k, i.e. d[m] = sum_{k>=m} c[k] C(k, m) shift^(k-m).
[[nodiscard]] std::vector<double> TaylorShift(const std::vector<double>& c, double shift);

/// The state a trajectory is planned from (exploration/trajectory_planner.h): where the vehicle is,
/// or where its current trajectory will be, at time_s. World frame W, yaw not wrapped.
struct TrajectoryStart {
  Eigen::Vector3d position_m{Eigen::Vector3d::Zero()};         ///< m
  Eigen::Vector3d velocity_mps{Eigen::Vector3d::Zero()};       ///< m/s
  Eigen::Vector3d acceleration_mps2{Eigen::Vector3d::Zero()};  ///< m/s^2
  double yaw_rad{0.0};                                         ///< rad
  double yaw_rate_radps{0.0};                                  ///< rad/s
  double time_s{0.0};  ///< s, the trajectory's start time (same time base as the trajectories)
};

/// The flat output of `trajectory` at t_s (clamped as Evaluate() is) as a start state at t_s:
/// position, velocity, acceleration, yaw and yaw rate.
[[nodiscard]] TrajectoryStart StateAt(const PiecewisePolynomialTrajectory& trajectory, double t_s);

/// Replanning without a jump of the set point (docs/exploration.md, section "Non-stop flight"):
/// the controller replaces its trajectory as soon as a new one arrives and holds the START
/// position before a trajectory's start time, so a replan planned from StateAt(old, t_splice)
/// (next.start_time_s() == t_splice, a little in the future) must be published as a trajectory
/// that starts NOW. The result starts at now_s, equals `old` on [now_s, next.start_time_s()) and
/// `next` from next.start_time_s() on (exactly as Evaluate() of each, clamped parts of `old`
/// included, to rounding): the piece of `old` containing now_s is re-expanded about the new local
/// time origin (TaylorShift), the piece containing the splice time is cut there, and next's
/// pieces follow unchanged. Position, velocity and acceleration are continuous at the splice when
/// `next` starts with StateAt(old, next.start_time_s()); higher derivatives in general are not.
/// Returns std::nullopt when now_s is not finite or next starts before now_s.
[[nodiscard]] std::optional<PiecewisePolynomialTrajectory> Splice(
    const PiecewisePolynomialTrajectory& old, double now_s,
    const PiecewisePolynomialTrajectory& next);

/// A straight rest-to-rest move from `from_m` to `to_m` in `duration_s` (> 0) at constant yaw: one
/// degree-7 segment x(tau) = from + (to - from) (35 s^4 - 84 s^5 + 70 s^6 - 20 s^7), s = tau / T,
/// whose velocity, acceleration and jerk are zero at both ends (the operator's go-to,
/// kestrel-cmd goto). std::nullopt and *error for a non-finite input or a duration <= 0.
[[nodiscard]] std::optional<PiecewisePolynomialTrajectory> RestToRest(
    double start_time_s, const Eigen::Vector3d& from_m, const Eigen::Vector3d& to_m, double yaw_rad,
    double duration_s, std::string* error);

}  // namespace kestrel
