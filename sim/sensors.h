#pragma once
/// @file
/// Simulated sensors over the exact ray caster: an Xtion-like depth camera, Hokuyo-like planar
/// LIDARs (URG-04LX, UTM-30LX), motion capture and an IMU. All randomness comes from SimRandom
/// (sim/sim_random.h): the same seed gives the same data bit for bit, whatever the thread count.
/// Frames (docs/design.md §4): W x east, y north, z up; camera S optical
/// (z forward, x right, y down); LIDAR S x forward, z up; body B x forward, y left, z up.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "common/se3.h"
#include "sim/sim_random.h"
#include "sim/world_ray_caster.h"

namespace kestrel {

/// Depth camera (ASUS Xtion-like) parameters.
struct DepthCameraConfig {
  int width_px{640};        ///< columns (VGA 640, QVGA 320, or 80)
  int height_px{480};       ///< rows (VGA 480, QVGA 240, or 60)
  double hfov_deg{58.0};    ///< horizontal field of view, deg, (0, 180)
  double vfov_deg{45.0};    ///< vertical field of view, deg, (0, 180)
  double range_min_m{0.5};  ///< nearest depth returned, m (nearer: 0)
  /// Farthest depth returned, m (farther: 0). The PS1080 in a real Xtion reports depth well past
  /// the 3.5 m of its datasheet, to 8-10 m indoors (noisier: the sigma below gives 0.11 m at
  /// 8 m); the mapper reads a depth beyond its model's z_max as a no-return, which is evidence,
  /// and a 0 as no evidence (docs/algorithms.md §3.4).
  double range_max_m{8.0};
  double sigma_a_m{0.0012};           ///< axial noise sigma = a + b (z - z0)^2: a, m
  double sigma_b_per_m{0.0019};       ///< b, 1/m
  double sigma_z0_m{0.4};             ///< z0, m
  double depth_scale_m{0.001};        ///< metres per count (1 mm quantisation), > 0
  double dropout_probability{0.005};  ///< chance a valid pixel reads 0, [0, 1]
  double rate_hz{30.0};               ///< frame rate, Hz, > 0
  bool noise{true};                   ///< false: exact depth, quantised, no dropouts
  int num_threads{2};                 ///< threads over rows (results independent of it), >= 1
  /// Disparity quantisation (docs/design.md §7.13), off when disparity_focal_px is 0: the
  /// measured depth z (after the noise) becomes z_q = f b / (round(s f b / z) / s), f the native
  /// focal length (whatever width_px), b the baseline, s the disparity steps per pixel; then the
  /// count rounding as before. Set by the simulator from SensorErrorsConfig.
  double disparity_focal_px{0.0};      ///< f, px; 0: no disparity quantisation
  double disparity_baseline_m{0.075};  ///< b, m, > 0
  int disparity_steps_per_px{8};       ///< s, [1, 64]

  /// VGA 640x480, QVGA 320x240, or 80x60 with the Xtion's other defaults.
  [[nodiscard]] static DepthCameraConfig WithResolution(int width_px, int height_px);
  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// Depth camera: pinhole with fx = (w/2)/tan(hfov/2), fy = (h/2)/tan(vfov/2), principal point
/// cx = (w-1)/2, cy = (h-1)/2; pixel (u, v) (column u, row v) looks along
/// d_S = ((u - cx)/fx, (v - cy)/fy, 1) and reads the depth z along the optical axis (not the ray
/// length). Measurement: z_true in [range_min, range_max], else 0; with noise on, dropout with
/// dropout_probability, else z = z_true + sigma(z_true) N(0,1), sigma(z) = a + b (z - z0)^2; the
/// count is round(z / depth_scale) (0 if not positive, at most 65535).
class DepthCamera {
 public:
  /// @throws std::invalid_argument if config.Validate() throws.
  explicit DepthCamera(const DepthCameraConfig& config);

  /// Noise-free depth (m) of every pixel, row-major; +infinity where no surface is within
  /// range_max along the pixel's ray (range limits are not applied otherwise).
  void RenderTrueDepth(const WorldRayCaster& caster, const Pose3& X_WS,
                       std::vector<double>* depth_m) const;

  /// One measured frame from sensor pose X_WS: counts row-major, 0 = no return. Draws one
  /// 64-bit sub-seed from `rng`; row v then uses its own SimRandom seeded from it and v.
  void Render(const WorldRayCaster& caster, const Pose3& X_WS, SimRandom* rng,
              std::vector<uint16_t>* counts) const;

  /// Axial noise sigma at depth z, m.
  [[nodiscard]] double SigmaAt(double z_m) const {
    const double e = z_m - config_.sigma_z0_m;
    return config_.sigma_a_m + config_.sigma_b_per_m * e * e;
  }
  /// The validated configuration.
  [[nodiscard]] const DepthCameraConfig& config() const { return config_; }
  /// Focal length along x, pixels.
  [[nodiscard]] double fx_px() const { return fx_; }
  /// Focal length along y, pixels.
  [[nodiscard]] double fy_px() const { return fy_; }
  /// Principal point column, pixels ((w - 1) / 2).
  [[nodiscard]] double cx_px() const { return cx_; }
  /// Principal point row, pixels ((h - 1) / 2).
  [[nodiscard]] double cy_px() const { return cy_; }
  /// The unit direction of pixel i (row-major) in the optical frame S.
  [[nodiscard]] const Eigen::Vector3d& PixelDirection(size_t i) const { return unit_dir_S_[i]; }

 private:
  // Casts rows [row_begin, row_end) into depth_m (if not nullptr) and, with frame_seed, applies
  // the measurement model into counts.
  void RenderRows(const WorldRayCaster& caster, const Pose3& X_WS, int row_begin, int row_end,
                  const uint64_t* frame_seed, std::vector<double>* depth_m,
                  std::vector<uint16_t>* counts) const;

  DepthCameraConfig config_;
  double fx_, fy_, cx_, cy_;
  std::vector<Eigen::Vector3d> unit_dir_S_;  // per pixel, unit
  std::vector<double> axial_;                // per pixel: z component of the unit direction
};

/// Planar LIDAR parameters. Beam i points at angle_min_rad + i * angle_step_rad about +z_S.
struct PlanarLidarConfig {
  std::string model{"urg-04lx"};                     ///< name carried in messages
  int num_beams{682};                                ///< beams per scan, >= 1
  double angle_step_rad{2.0 * M_PI / 1024};          ///< angle between beams, rad, > 0
  double angle_min_rad{-340.5 * 2.0 * M_PI / 1024};  ///< angle of beam 0, rad
  double range_min_m{0.02};         ///< nearer returns carry no information (NaN), m
  double range_max_m{5.6};          ///< nothing within this: "no return" (0), m
  double sigma_m{0.01};             ///< range noise sigma = max(sigma_m, sigma_fraction * r), m
  double sigma_fraction{0.01};      ///< relative part of the noise sigma
  double quantum_m{0.001};          ///< range resolution, m (0: none)
  double dropout_probability{0.0};  ///< chance a beam reads NaN (no information), [0, 1]
  double rate_hz{10.0};             ///< scans per second, Hz
  bool noise{true};                 ///< false: exact ranges (quantised), no dropouts
  /// Mixed pixels (docs/design.md §7.13), off when mixed_pixel_subrays < 2: each beam casts that
  /// many sub-rays evenly across +-beam_divergence_rad/2 in the scan plane; if the returning
  /// sub-rays' ranges spread by more than mixed_pixel_gap_m, the beam's true range is their mean
  /// (an AMCW sensor averages the phases of foreground and background); otherwise the central
  /// ray's. Set by the simulator from SensorErrorsConfig.
  int mixed_pixel_subrays{0};         ///< sub-rays per beam; < 2: off
  double beam_divergence_rad{0.006};  ///< full footprint angle in the scan plane, rad, >= 0
  double mixed_pixel_gap_m{0.05};     ///< range spread that mixes, m, > 0

  /// Hokuyo URG-04LX: 682 beams at 360/1024 deg (240 deg), 0.02-5.6 m, 10 Hz, sigma 10 mm
  /// below 1 m and 1 % of range beyond (datasheet: +-30 mm, +-3 % as 3 sigma).
  [[nodiscard]] static PlanarLidarConfig Urg04lx();
  /// Hokuyo UTM-30LX: 1081 beams at 0.25 deg (270 deg), 0.1-30 m, 40 Hz, sigma 10 mm to 10 m
  /// growing to 16.7 mm at 10 m and beyond (datasheet +-30 mm / +-50 mm as 3 sigma).
  [[nodiscard]] static PlanarLidarConfig Utm30lx();
  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// Planar LIDAR: all beams of a scan from one pose (the simulator stamps the scan at that pose;
/// time_step 0). Ranges: r > 0 a return; 0 no return within range_max; NaN no information
/// (nearer than range_min, or a dropout), as planar_scan_t says.
class PlanarLidar {
 public:
  /// @throws std::invalid_argument if config.Validate() throws.
  explicit PlanarLidar(const PlanarLidarConfig& config);
  /// The true range of beam i (+infinity: nothing within range_max), mixed pixels included.
  [[nodiscard]] double TrueRange(const WorldRayCaster& caster, const Pose3& X_WS, size_t i,
                                 int* hit) const;
  /// One scan from sensor pose X_WS.
  void Scan(const WorldRayCaster& caster, const Pose3& X_WS, SimRandom* rng,
            std::vector<float>* ranges_m) const;
  /// Noise sigma at range r, m.
  [[nodiscard]] double SigmaAt(double r_m) const {
    return std::max(config_.sigma_m, config_.sigma_fraction * r_m);
  }
  /// The validated configuration.
  [[nodiscard]] const PlanarLidarConfig& config() const { return config_; }

 private:
  PlanarLidarConfig config_;
  std::vector<Eigen::Vector3d> dir_S_;
  std::vector<double> subray_offset_rad_;  // mixed pixels: sub-ray angles about the beam's
};

/// Motion-capture parameters.
struct MotionCaptureConfig {
  double rate_hz{100.0};                ///< pose rate, Hz, (0, 1000]
  double position_sigma_m{0.0005};      ///< position noise per axis, m
  double orientation_sigma_rad{0.002};  ///< rotation noise per body axis, rad
  double latency_s{0.01};               ///< delivery delay after acquisition, s, >= 0
  double dropout_probability{0.0};      ///< long-run fraction of invalid samples, [0, 1)
  double mean_dropout_samples{5.0};     ///< mean length of a dropout burst, samples, >= 1
  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// One motion-capture sample: stamped at acquisition, delivered `latency` later.
struct MotionCaptureSample {
  /// Stamp, us: the acquisition time (the bridge removes the latency) plus the simulator's
  /// residual latency error (docs/design.md §7.13; 0 in the clean profile).
  int64_t utime{0};
  int64_t acquisition_utime{0};  ///< when the pose was acquired, us
  int64_t deliver_utime{0};      ///< when it is published, us
  Pose3 X_WB;                    ///< measured body pose (meaningless when !valid)
  bool valid{false};             ///< false during a dropout (object lost)
};

/// Motion capture with Gaussian pose noise, fixed latency and bursty dropouts (a two-state
/// Markov chain: leave a burst with probability 1/mean_dropout_samples per sample, enter one with
/// the probability that makes the long-run invalid fraction dropout_probability).
class MotionCapture {
 public:
  /// @throws std::invalid_argument if config.Validate() throws.
  explicit MotionCapture(const MotionCaptureConfig& config);
  /// Measures the true pose X_WB at `utime`.
  [[nodiscard]] MotionCaptureSample Measure(int64_t utime, const Pose3& X_WB, SimRandom* rng);
  /// The validated configuration.
  [[nodiscard]] const MotionCaptureConfig& config() const { return config_; }

 private:
  MotionCaptureConfig config_;
  bool in_dropout_{false};
};

/// IMU parameters (discrete-time: sigmas are per sample).
struct ImuConfig {
  double rate_hz{500.0};                     ///< sample rate, Hz, [1, 10000]
  double gyro_noise_sigma_radps{0.002};      ///< white gyro noise per sample, rad/s
  double accel_noise_sigma_mps2{0.02};       ///< white accelerometer noise per sample, m/s^2
  double gyro_bias_sigma_radps{0.003};       ///< initial gyro bias per axis ~ N(0, s^2), rad/s
  double accel_bias_sigma_mps2{0.03};        ///< initial accel bias per axis, m/s^2
  double gyro_bias_walk_radps_sqrt_s{1e-4};  ///< gyro bias random walk, rad/s per sqrt(s)
  double accel_bias_walk_mps2_sqrt_s{1e-3};  ///< accel bias random walk, m/s^2 per sqrt(s)
  double gravity_mps2{9.81};                 ///< g, m/s^2 (gravity along -z_W)
  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// One IMU sample in B.
struct SimulatedImuSample {
  int64_t utime{0};                                                 ///< sample time, us
  Eigen::Vector3d angular_velocity_radps{Eigen::Vector3d::Zero()};  ///< gyro, B, rad/s
  Eigen::Vector3d specific_force_mps2{Eigen::Vector3d::Zero()};     ///< accel, B, m/s^2
};

/// IMU: gyro = w_B + b_g + n_g; accelerometer = R_WB^T (a_W + g e3) + b_a + n_a, the biases
/// drawn at construction and random-walking by sigma_walk sqrt(dt) per sample.
class Imu {
 public:
  /// Draws the initial biases from `rng`. @throws std::invalid_argument on a bad config.
  Imu(const ImuConfig& config, SimRandom* rng);
  /// Measures the true state: attitude R_WB, body angular velocity w_B (rad/s), acceleration a_W
  /// of the body origin in W (m/s^2); dt_s (>= 0) since the previous sample drives the bias walk.
  [[nodiscard]] SimulatedImuSample Measure(int64_t utime, const Eigen::Matrix3d& R_WB,
                                           const Eigen::Vector3d& w_B, const Eigen::Vector3d& a_W,
                                           double dt_s, SimRandom* rng);
  /// Current gyro bias b_g, B, rad/s.
  [[nodiscard]] const Eigen::Vector3d& gyro_bias_radps() const { return gyro_bias_; }
  /// Current accelerometer bias b_a, B, m/s^2.
  [[nodiscard]] const Eigen::Vector3d& accel_bias_mps2() const { return accel_bias_; }
  /// The validated configuration.
  [[nodiscard]] const ImuConfig& config() const { return config_; }

 private:
  ImuConfig config_;
  Eigen::Vector3d gyro_bias_;
  Eigen::Vector3d accel_bias_;
};

}  // namespace kestrel
