#pragma once
/// @file
/// Mount and clock calibration (docs/algorithms.md §3.7): the correction to a sensor's mount (six
/// degrees of freedom) and its stamp offset that best explain its returns against the world's
/// surfaces. Pure: poses and scans in, the fit out (no files, no LCM).
///
/// Model. A return z along the unit ray (o_S, u_S) of a scan stamped t was taken from
///     X_WS(theta) = X_WB(t - delta) * X_BS * C,   C = (Exp(w), p),   theta = (p, w, delta),
/// with X_WB interpolated in the run's poses exactly as the mapper pairs them (PoseHistory:
/// linear position, slerp, no pairing across a gap of more than max_gap_s), X_BS the vehicle
/// file's mount, C the mount correction in the sensor frame (the form of the simulator's
/// extrinsic error, docs/design.md §7.13) and delta the stamp offset measured in the poses' clock.
/// The predicted range d_i(theta) is the exact cast of the ray from X_WS(theta) against the
/// world (WorldRayCaster). The fit minimises sum_i rho(r_i / s_i), r_i = z_i - d_i(theta), rho
/// Huber's loss, s_i the residuals' robust scale in the return's 0.5 m range band, and returns
/// beyond gate_sigmas s_i left out (edges, mixed pixels, objects missing from the world), by
/// iteratively reweighted Gauss-Newton. The Jacobian of d_i is that of the surface plane at the
/// hit (its normal from two neighbouring casts of the same primitive), through the exact
/// derivatives of X_WS in p and w and a central difference of the pose track in time.
///
/// Observability: the stamp offset is seen only while the vehicle moves or turns, and what it
/// measures is the sensor's stamp delay less the motion capture's residual latency (both shift
/// the pairing the same way). A planar LIDAR facing vertical walls does not see its translation
/// along its scan plane's normal, nor its tilt (to first order): such axes come out with large
/// standard errors. An axis whose standard error exceeds the `determined_*` limit is held at its
/// start value when it is not `required`, and fails the fit when it is.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "common/se3.h"
#include "mapping/pose_history.h"
#include "mapping/scan_integrator.h"
#include "sim/world_ray_caster.h"

namespace kestrel {

/// The seven calibrated values of one sensor: the mount correction C = (Exp(rotation_rad),
/// translation_m) in the sensor frame (the true mount is X_BS * C) and the stamp offset (a scan
/// stamped t was taken when the poses' clock read t - stamp_offset_s).
struct MountCorrection {
  Eigen::Vector3d translation_m{Eigen::Vector3d::Zero()};  ///< p, sensor frame, m
  Eigen::Vector3d rotation_rad{Eigen::Vector3d::Zero()};   ///< w, rotation vector, rad
  double stamp_offset_s{0.0};                              ///< delta, s

  /// Parameter k of (p_x, p_y, p_z, w_x, w_y, w_z, delta).
  [[nodiscard]] double operator[](int k) const {
    return k < 3 ? translation_m[k] : k < 6 ? rotation_rad[k - 3] : stamp_offset_s;
  }
  double& operator[](int k) {
    return k < 3 ? translation_m[k] : k < 6 ? rotation_rad[k - 3] : stamp_offset_s;
  }
  /// C as a transform (Exp(w), p).
  [[nodiscard]] Pose3 Transform() const;
};

/// The parameters' count and names ("translation x", ..., "rotation z", "stamp offset"), and the
/// printable value of parameter k with its unit (mm, deg, ms).
constexpr int kMountParameters = 7;
[[nodiscard]] const char* MountParameterName(int k);
[[nodiscard]] std::string FormatMountParameter(int k, double value);

struct MountCalibrationOptions {
  int rays_per_scan{24};     ///< returns kept per scan at most, evenly spread (>= 1)
  int min_returns{500};      ///< fewer returns paired with poses: no fit
  int max_iterations{30};    ///< Gauss-Newton steps at most
  double huber_k{1.345};     ///< Huber's threshold, in scales
  double gate_sigmas{4.0};   ///< residuals beyond this many scales are left out
  double start_gate_m{0.3};  ///< before any scale is known, residuals beyond this
  /// Smallest |n . u| (the cosine of the ray's incidence on the surface) kept.
  double min_incidence_cosine{0.15};
  /// The standard error (clustered by scan) above which an axis counts as not determined.
  double determined_translation_m{0.001};
  double determined_rotation_rad{0.05 * M_PI / 180.0};
  double determined_offset_s{0.001};
  /// A fitted correction beyond these is implausible (the world, the log and the configured
  /// mount do not belong together): no values.
  double max_translation_m{0.05};
  double max_rotation_rad{5.0 * M_PI / 180.0};
  double max_offset_s{0.1};
  /// Fewer of the returns than this fraction within the gate at the end: no values.
  double min_inlier_fraction{0.5};

  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// The fit of one sensor. When `ok` is false, `why` names the reason and there are no values.
struct MountFit {
  bool ok{false};
  std::string why;
  MountCorrection value;                      ///< the fitted values (held axes: their start values)
  MountCorrection standard_error;             ///< per parameter, clustered by scan (held axes: 0)
  std::array<bool, kMountParameters> held{};  ///< held at the start value, not determined
  /// Each axis's standard error when every axis was free (large for the ones not seen).
  MountCorrection free_standard_error;
  int iterations{0};          ///< Gauss-Newton steps, every pass
  int64_t scans{0};           ///< scans offered
  int64_t returns{0};         ///< returns kept (rays_per_scan) from them
  int64_t returns_used{0};    ///< returns that entered the final step (gated, differentiable)
  double scale_start_m{0.0};  ///< robust residual scale (1.4826 median |r|) at the start, m
  double scale_end_m{0.0};    ///< and at the fit, m
};

/// Accumulates one sensor's scans and its vehicle's poses; fits theta to them.
class MountCalibrator {
 public:
  /// `caster` (the world's exact surfaces) must outlive this. X_BS: the vehicle file's mount;
  /// [z_min, z_max): the returns the mapper's model accepts; `pairing`: the mapper's
  /// pose_history (its max_gap_s is used; every pose is kept).
  /// @throws std::invalid_argument on bad limits or options.
  MountCalibrator(const WorldRayCaster& caster, const Pose3& X_BS, double z_min_m, double z_max_m,
                  const PoseHistoryConfig& pairing, const MountCalibrationOptions& options = {});

  /// A pose of the vehicle, stamped utime (us); not newer than the last: ignored (as the mapper).
  void AddPose(int64_t utime, const Pose3& X_WB);
  /// A scan stamped stamp_us, its rays in the sensor frame (origin_W, direction_W are o_S, u_S):
  /// its returns (ReadingKind::kReturn) are kept, at most rays_per_scan of them, evenly spread
  /// with a start that moves from scan to scan.
  void AddScan(int64_t stamp_us, const std::vector<SensorRay>& rays_S);

  [[nodiscard]] int64_t scans() const { return static_cast<int64_t>(scans_.size()); }
  [[nodiscard]] int64_t returns() const { return static_cast<int64_t>(rays_.size()); }

  /// Fits theta from `start` (also the value a held axis keeps); `required[k]`: parameter k must
  /// be determined (else no values). Deterministic.
  [[nodiscard]] MountFit Fit(const MountCorrection& start,
                             const std::array<bool, kMountParameters>& required) const;

 private:
  struct Ray {
    Eigen::Vector3d origin_S, direction_S;
    double z_m;
    int32_t scan;
  };
  struct Linearisation;
  // Residuals and Jacobians of every ray at theta (rays not usable there have weight 0).
  void Linearise(const MountCorrection& theta, Linearisation* out) const;

  const WorldRayCaster& caster_;
  Pose3 X_BS_;
  double z_min_, z_max_;
  MountCalibrationOptions options_;
  PoseHistory poses_;
  std::vector<int64_t> scans_;  // stamps
  std::vector<Ray> rays_;
};

}  // namespace kestrel
