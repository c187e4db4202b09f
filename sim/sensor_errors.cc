#include "sim/sensor_errors.h"

#include <cmath>

#include "common/check.h"

namespace kestrel {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

bool WithinAbs(const Eigen::Vector3d& v, double limit) {
  return v.allFinite() && v.cwiseAbs().maxCoeff() <= limit;
}

}  // namespace

SensorErrorsConfig SensorErrorsConfig::Clean() { return SensorErrorsConfig{}; }

SensorErrorsConfig SensorErrorsConfig::Realistic() {
  // Values and sources: docs/design.md §7.13.
  SensorErrorsConfig c;
  c.profile = "realistic";
  c.depth_extrinsic_sigma_m = 0.005;
  c.depth_extrinsic_sigma_rad = 0.5 * kDegToRad;
  c.lidar_extrinsic_sigma_m = 0.005;
  c.lidar_extrinsic_sigma_rad = 0.5 * kDegToRad;
  c.depth_time_offset_s = 0.020;
  c.depth_time_jitter_s = 0.003;
  c.lidar_time_offset_s = 0.003;
  c.lidar_time_jitter_s = 0.001;
  c.mocap_residual_latency_s = 0.005;
  c.depth_disparity_quantisation = true;
  c.lidar_mixed_pixels = true;
  return c;
}

SensorErrorsConfig SensorErrorsConfig::Profile(const std::string& name) {
  if (name == "clean") return Clean();
  if (name == "realistic") return Realistic();
  KESTREL_THROW_UNLESS(false, "sim error_profile = \"" << name << "\"; accepted: clean, realistic");
  return Clean();
}

void SensorErrorsConfig::Validate() const {
  KESTREL_THROW_UNLESS(profile == "clean" || profile == "realistic",
                       "sim error_profile = \"" << profile << "\"; accepted: clean, realistic");
  const auto check_mount = [](const char* sensor, double sigma_m, double sigma_rad,
                              const Eigen::Vector3d& fixed_m, const Eigen::Vector3d& fixed_rad) {
    KESTREL_THROW_UNLESS(
        sigma_m >= 0.0 && sigma_m <= 0.1,
        "sim errors." << sensor << "_extrinsic_sigma_m = " << sigma_m << "; accepted: [0, 0.1]");
    KESTREL_THROW_UNLESS(sigma_rad >= 0.0 && sigma_rad <= 0.2,
                         "sim errors." << sensor << "_extrinsic_sigma_rad = " << sigma_rad
                                       << "; accepted: [0, 0.2]");
    KESTREL_THROW_UNLESS(WithinAbs(fixed_m, 0.1),
                         "sim errors." << sensor << "_extrinsic_error_m = [" << fixed_m.transpose()
                                       << "]; accepted: each in [-0.1, 0.1]");
    KESTREL_THROW_UNLESS(WithinAbs(fixed_rad, 0.2), "sim errors."
                                                        << sensor << "_extrinsic_error_rad = ["
                                                        << fixed_rad.transpose()
                                                        << "]; accepted: each in [-0.2, 0.2]");
  };
  check_mount("depth", depth_extrinsic_sigma_m, depth_extrinsic_sigma_rad, depth_extrinsic_error_m,
              depth_extrinsic_error_rad);
  check_mount("lidar", lidar_extrinsic_sigma_m, lidar_extrinsic_sigma_rad, lidar_extrinsic_error_m,
              lidar_extrinsic_error_rad);
  const auto check_stamp = [](const char* sensor, double offset_s, double jitter_s) {
    KESTREL_THROW_UNLESS(
        offset_s >= -1.0 && offset_s <= 1.0,
        "sim errors." << sensor << "_time_offset_s = " << offset_s << "; accepted: [-1, 1]");
    KESTREL_THROW_UNLESS(
        jitter_s >= 0.0 && jitter_s <= 0.1,
        "sim errors." << sensor << "_time_jitter_s = " << jitter_s << "; accepted: [0, 0.1]");
  };
  check_stamp("depth", depth_time_offset_s, depth_time_jitter_s);
  check_stamp("lidar", lidar_time_offset_s, lidar_time_jitter_s);
  KESTREL_THROW_UNLESS(mocap_residual_latency_s >= -0.1 && mocap_residual_latency_s <= 0.1,
                       "sim errors.mocap_residual_latency_s = " << mocap_residual_latency_s
                                                                << "; accepted: [-0.1, 0.1]");
  KESTREL_THROW_UNLESS(
      depth_baseline_m > 0.0 && depth_baseline_m <= 1.0,
      "sim errors.depth_baseline_m = " << depth_baseline_m << "; accepted: (0, 1]");
  KESTREL_THROW_UNLESS(
      depth_native_focal_px > 0.0 && depth_native_focal_px <= 10000.0,
      "sim errors.depth_native_focal_px = " << depth_native_focal_px << "; accepted: (0, 10000]");
  KESTREL_THROW_UNLESS(depth_disparity_steps_per_px >= 1 && depth_disparity_steps_per_px <= 64,
                       "sim errors.depth_disparity_steps_per_px = " << depth_disparity_steps_per_px
                                                                    << "; accepted: [1, 64]");
  KESTREL_THROW_UNLESS(lidar_beam_divergence_rad >= 0.0 && lidar_beam_divergence_rad <= 0.1,
                       "sim errors.lidar_beam_divergence_rad = " << lidar_beam_divergence_rad
                                                                 << "; accepted: [0, 0.1]");
  KESTREL_THROW_UNLESS(lidar_mixed_pixel_subrays >= 2 && lidar_mixed_pixel_subrays <= 15,
                       "sim errors.lidar_mixed_pixel_subrays = " << lidar_mixed_pixel_subrays
                                                                 << "; accepted: [2, 15]");
  KESTREL_THROW_UNLESS(
      lidar_mixed_pixel_gap_m > 0.0 && std::isfinite(lidar_mixed_pixel_gap_m),
      "sim errors.lidar_mixed_pixel_gap_m = " << lidar_mixed_pixel_gap_m << "; accepted: (0, inf)");
}

void ReadSensorErrors(const ConfigNode& n, SensorErrorsConfig* c) {
  n.Read("depth_extrinsic_sigma_m", &c->depth_extrinsic_sigma_m, Range::Closed(0, 0.1));
  n.Read("depth_extrinsic_sigma_rad", &c->depth_extrinsic_sigma_rad, Range::Closed(0, 0.2));
  n.Read("depth_extrinsic_error_m", &c->depth_extrinsic_error_m, Range::Closed(-0.1, 0.1));
  n.Read("depth_extrinsic_error_rad", &c->depth_extrinsic_error_rad, Range::Closed(-0.2, 0.2));
  n.Read("lidar_extrinsic_sigma_m", &c->lidar_extrinsic_sigma_m, Range::Closed(0, 0.1));
  n.Read("lidar_extrinsic_sigma_rad", &c->lidar_extrinsic_sigma_rad, Range::Closed(0, 0.2));
  n.Read("lidar_extrinsic_error_m", &c->lidar_extrinsic_error_m, Range::Closed(-0.1, 0.1));
  n.Read("lidar_extrinsic_error_rad", &c->lidar_extrinsic_error_rad, Range::Closed(-0.2, 0.2));
  n.Read("depth_time_offset_s", &c->depth_time_offset_s, Range::Closed(-1, 1));
  n.Read("depth_time_jitter_s", &c->depth_time_jitter_s, Range::Closed(0, 0.1));
  n.Read("lidar_time_offset_s", &c->lidar_time_offset_s, Range::Closed(-1, 1));
  n.Read("lidar_time_jitter_s", &c->lidar_time_jitter_s, Range::Closed(0, 0.1));
  n.Read("mocap_residual_latency_s", &c->mocap_residual_latency_s, Range::Closed(-0.1, 0.1));
  n.Read("depth_disparity_quantisation", &c->depth_disparity_quantisation);
  n.Read("depth_baseline_m", &c->depth_baseline_m, Range{0, 1, false, true});
  n.Read("depth_native_focal_px", &c->depth_native_focal_px, Range{0, 10000, false, true});
  n.Read("depth_disparity_steps_per_px", &c->depth_disparity_steps_per_px, Range::Closed(1, 64));
  n.Read("lidar_mixed_pixels", &c->lidar_mixed_pixels);
  n.Read("lidar_beam_divergence_rad", &c->lidar_beam_divergence_rad, Range::Closed(0, 0.1));
  n.Read("lidar_mixed_pixel_subrays", &c->lidar_mixed_pixel_subrays, Range::Closed(2, 15));
  n.Read("lidar_mixed_pixel_gap_m", &c->lidar_mixed_pixel_gap_m, Range::Positive());
}

Pose3 DrawExtrinsicError(const Eigen::Vector3d& fixed_m, const Eigen::Vector3d& fixed_rad,
                         double sigma_m, double sigma_rad, SimRandom* rng) {
  Eigen::Vector3d dp, dr;
  for (int a = 0; a < 3; ++a) dp[a] = rng->Gaussian();
  for (int a = 0; a < 3; ++a) dr[a] = rng->Gaussian();
  const Eigen::Vector3d t = fixed_m + sigma_m * dp;
  const Eigen::Vector3d w = fixed_rad + sigma_rad * dr;
  Pose3 X_err;
  X_err.p = t;
  X_err.q = QuaternionFromRotationVector(w);
  return X_err;
}

Pose3 PerturbedMount(const Pose3& X_BS, const Pose3& X_err) {
  const bool identity = X_err.p.isZero(0.0) && X_err.q.w() == 1.0 && X_err.q.vec().isZero(0.0);
  return identity ? X_BS : X_BS * X_err;
}

}  // namespace kestrel
