#pragma once
/// @file
/// Sensor error sources of the simulator beyond the per-sample noise of sim/sensors.h, selected
/// by the sim config's error_profile (clean | realistic) and overridden key by key in its
/// `errors:` section (docs/design.md §7.13). The clean profile turns every one off and leaves
/// the simulator's outputs bit-identical to a run without them.

#include <string>

#include <Eigen/Core>

#include "common/config.h"
#include "common/se3.h"
#include "sim/sim_random.h"

namespace kestrel {

/// Error sources of one run (docs/design.md §7.13). Each of the random ones is drawn from its own
/// stream derived from the run's seed, so the sensors' noise streams are those of a clean run.
struct SensorErrorsConfig {
  std::string profile{"clean"};  ///< the profile these values started from: clean | realistic

  // 1. Extrinsic calibration error: the sensor's true mount is X_BS * X_err, X_err =
  //    (Exp(rotation), translation), each axis = fixed value + sigma N(0, 1), drawn once per run
  //    and vehicle; the mapper keeps the vehicle file's X_BS. Axes of the sensor frame S.
  double depth_extrinsic_sigma_m{0.0};    ///< per-axis translation sigma, m, [0, 0.1]
  double depth_extrinsic_sigma_rad{0.0};  ///< per-axis rotation sigma, rad, [0, 0.2]
  Eigen::Vector3d depth_extrinsic_error_m{Eigen::Vector3d::Zero()};    ///< fixed part, m
  Eigen::Vector3d depth_extrinsic_error_rad{Eigen::Vector3d::Zero()};  ///< fixed part, rad
  double lidar_extrinsic_sigma_m{0.0};                                 ///< as for depth, m
  double lidar_extrinsic_sigma_rad{0.0};                               ///< as for depth, rad
  Eigen::Vector3d lidar_extrinsic_error_m{Eigen::Vector3d::Zero()};    ///< fixed part, m
  Eigen::Vector3d lidar_extrinsic_error_rad{Eigen::Vector3d::Zero()};  ///< fixed part, rad

  // 2. Sensor time stamps: stamp = capture time + offset + jitter N(0, 1), per frame.
  double depth_time_offset_s{0.0};  ///< depth stamp offset, s, [-1, 1]
  double depth_time_jitter_s{0.0};  ///< depth stamp jitter sigma, s, [0, 0.1]
  double lidar_time_offset_s{0.0};  ///< scan stamp offset, s, [-1, 1]
  double lidar_time_jitter_s{0.0};  ///< scan stamp jitter sigma, s, [0, 0.1]

  // 3. Motion-capture latency the bridge does not remove: a pose acquired at t is stamped
  //    t + residual.
  double mocap_residual_latency_s{0.0};  ///< s, [-0.1, 0.1]

  // 4. Depth quantisation in disparity (PrimeSense/Xtion): see DepthCameraConfig.
  bool depth_disparity_quantisation{false};  ///< quantise depth in disparity steps
  double depth_baseline_m{0.075};            ///< projector-camera baseline b, m, (0, 1]
  double depth_native_focal_px{580.0};       ///< focal length of the native VGA IR image, px
  int depth_disparity_steps_per_px{8};       ///< disparity resolution: 1/8 px, [1, 64]

  // 5. LIDAR mixed pixels: see PlanarLidarConfig.
  bool lidar_mixed_pixels{false};           ///< average ranges across a beam's footprint edge
  double lidar_beam_divergence_rad{0.006};  ///< full footprint angle in the scan plane, rad
  int lidar_mixed_pixel_subrays{5};         ///< sub-rays across the footprint, [2, 15]
  double lidar_mixed_pixel_gap_m{0.05};     ///< sub-ray range spread that mixes, m, > 0

  /// Every source off: the outputs of a simulator without them.
  [[nodiscard]] static SensorErrorsConfig Clean();
  /// Every source on at the values of docs/design.md §7.13.
  [[nodiscard]] static SensorErrorsConfig Realistic();
  /// The named profile. @throws std::invalid_argument on an unknown name.
  [[nodiscard]] static SensorErrorsConfig Profile(const std::string& name);
  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// Reads the overrides of the `errors:` section into *c (absent keys keep their values).
/// @throws ConfigError naming the key, its value and the accepted range.
void ReadSensorErrors(const ConfigNode& n, SensorErrorsConfig* c);

/// One extrinsic error X_err = (Exp(rotation), translation): fixed + sigma N(0, 1) per axis,
/// translation axes drawn first. Always draws six Gaussians from `rng`. Identity (exactly) when
/// every part is zero.
[[nodiscard]] Pose3 DrawExtrinsicError(const Eigen::Vector3d& fixed_m,
                                       const Eigen::Vector3d& fixed_rad, double sigma_m,
                                       double sigma_rad, SimRandom* rng);

/// X_BS * X_err, or X_BS itself (bit for bit) when X_err is the identity.
[[nodiscard]] Pose3 PerturbedMount(const Pose3& X_BS, const Pose3& X_err);

}  // namespace kestrel
