#include "sim/sensors.h"

#include <limits>
#include <thread>

#include "common/check.h"
#include "common/clock.h"

namespace kestrel {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kDegToRad = M_PI / 180.0;

bool InUnit(double p) { return p >= 0.0 && p <= 1.0; }

}  // namespace

// ------------------------------------------------------------------------- depth camera

DepthCameraConfig DepthCameraConfig::WithResolution(int width_px, int height_px) {
  DepthCameraConfig c;
  c.width_px = width_px;
  c.height_px = height_px;
  return c;
}

void DepthCameraConfig::Validate() const {
  KESTREL_THROW_UNLESS(width_px >= 1 && width_px <= 4096,
                       "depth camera width_px = " << width_px << "; accepted: [1, 4096]");
  KESTREL_THROW_UNLESS(height_px >= 1 && height_px <= 4096,
                       "depth camera height_px = " << height_px << "; accepted: [1, 4096]");
  KESTREL_THROW_UNLESS(hfov_deg > 0.0 && hfov_deg < 180.0,
                       "depth camera hfov_deg = " << hfov_deg << "; accepted: (0, 180)");
  KESTREL_THROW_UNLESS(vfov_deg > 0.0 && vfov_deg < 180.0,
                       "depth camera vfov_deg = " << vfov_deg << "; accepted: (0, 180)");
  KESTREL_THROW_UNLESS(
      range_min_m >= 0.0 && range_max_m > range_min_m && std::isfinite(range_max_m),
      "depth camera range [" << range_min_m << ", " << range_max_m
                             << "] m; accepted: 0 <= min < max < inf");
  KESTREL_THROW_UNLESS(sigma_a_m >= 0.0 && sigma_b_per_m >= 0.0 && std::isfinite(sigma_z0_m),
                       "depth camera noise a = " << sigma_a_m << ", b = " << sigma_b_per_m
                                                 << "; accepted: a, b >= 0");
  KESTREL_THROW_UNLESS(depth_scale_m > 0.0 && range_max_m / depth_scale_m <= 65535.0,
                       "depth camera depth_scale_m = " << depth_scale_m
                                                       << "; accepted: > 0 with range_max / scale "
                                                          "<= 65535");
  KESTREL_THROW_UNLESS(
      InUnit(dropout_probability),
      "depth camera dropout_probability = " << dropout_probability << "; accepted: [0, 1]");
  KESTREL_THROW_UNLESS(rate_hz > 0.0 && rate_hz <= 1000.0,
                       "depth camera rate_hz = " << rate_hz << "; accepted: (0, 1000]");
  KESTREL_THROW_UNLESS(num_threads >= 1 && num_threads <= 64,
                       "depth camera num_threads = " << num_threads << "; accepted: [1, 64]");
  KESTREL_THROW_UNLESS(
      disparity_focal_px >= 0.0 && disparity_focal_px <= 10000.0,
      "depth camera disparity_focal_px = " << disparity_focal_px << "; accepted: [0, 10000]");
  KESTREL_THROW_UNLESS(
      disparity_baseline_m > 0.0 && disparity_baseline_m <= 1.0,
      "depth camera disparity_baseline_m = " << disparity_baseline_m << "; accepted: (0, 1]");
  KESTREL_THROW_UNLESS(
      disparity_steps_per_px >= 1 && disparity_steps_per_px <= 64,
      "depth camera disparity_steps_per_px = " << disparity_steps_per_px << "; accepted: [1, 64]");
}

DepthCamera::DepthCamera(const DepthCameraConfig& config) : config_(config) {
  config_.Validate();
  const int w = config_.width_px;
  const int h = config_.height_px;
  fx_ = 0.5 * w / std::tan(0.5 * config_.hfov_deg * kDegToRad);
  fy_ = 0.5 * h / std::tan(0.5 * config_.vfov_deg * kDegToRad);
  cx_ = 0.5 * (w - 1);
  cy_ = 0.5 * (h - 1);
  unit_dir_S_.reserve(static_cast<size_t>(w) * h);
  axial_.reserve(static_cast<size_t>(w) * h);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const Eigen::Vector3d d((u - cx_) / fx_, (v - cy_) / fy_, 1.0);
      const double n = d.norm();
      unit_dir_S_.push_back(d / n);
      axial_.push_back(1.0 / n);
    }
  }
}

void DepthCamera::RenderRows(const WorldRayCaster& caster, const Pose3& X_WS, int row_begin,
                             int row_end, const uint64_t* frame_seed, std::vector<double>* depth_m,
                             std::vector<uint16_t>* counts) const {
  const Eigen::Matrix3d R_WS = X_WS.rotation();
  const int w = config_.width_px;
  // The farthest ray length that can still give a depth within range_max.
  for (int v = row_begin; v < row_end; ++v) {
    SimRandom rng(frame_seed != nullptr ? MixSeed(*frame_seed ^ MixSeed(static_cast<uint64_t>(v)))
                                        : 0);
    int hit = WorldRayCaster::kNoHit;  // the previous pixel's primitive hints the next search
    for (int u = 0; u < w; ++u) {
      const size_t i = static_cast<size_t>(v) * w + u;
      const double max_length = config_.range_max_m / axial_[i];
      const double t = caster.CastRay(X_WS.p, R_WS * unit_dir_S_[i], max_length, &hit, hit);
      const double z = t * axial_[i];  // depth along the optical axis
      if (depth_m != nullptr) (*depth_m)[i] = z;
      if (counts == nullptr) continue;
      uint16_t count = 0;
      if (z >= config_.range_min_m && z <= config_.range_max_m) {
        double measured = z;
        bool dropped = false;
        if (config_.noise) {
          dropped = rng.Bernoulli(config_.dropout_probability);
          measured = z + SigmaAt(z) * rng.Gaussian();
        }
        if (config_.disparity_focal_px > 0.0 && measured > 0.0) {
          // Disparity quantisation (docs/design.md §7.13): the chip's disparity in 1/s px.
          const double fb = config_.disparity_focal_px * config_.disparity_baseline_m;
          const double s = config_.disparity_steps_per_px;
          const double k = std::round(s * fb / measured);
          measured = k > 0.0 ? fb / (k / s) : 0.0;  // zero disparity: no return
        }
        const double q = std::round(measured / config_.depth_scale_m);
        if (!dropped && q > 0.0) count = static_cast<uint16_t>(std::min(q, 65535.0));
      }
      (*counts)[i] = count;
    }
  }
}

void DepthCamera::RenderTrueDepth(const WorldRayCaster& caster, const Pose3& X_WS,
                                  std::vector<double>* depth_m) const {
  depth_m->assign(unit_dir_S_.size(), kInf);
  RenderRows(caster, X_WS, 0, config_.height_px, nullptr, depth_m, nullptr);
}

void DepthCamera::Render(const WorldRayCaster& caster, const Pose3& X_WS, SimRandom* rng,
                         std::vector<uint16_t>* counts) const {
  counts->assign(unit_dir_S_.size(), 0);
  const uint64_t frame_seed = rng->NextBits();
  const int h = config_.height_px;
  const int threads = std::min(config_.num_threads, std::max(1, h / 8));
  if (threads <= 1) {
    RenderRows(caster, X_WS, 0, h, &frame_seed, nullptr, counts);
    return;
  }
  std::vector<std::thread> pool;
  const int chunk = (h + threads - 1) / threads;
  for (int t = 1; t < threads; ++t) {
    pool.emplace_back([&, t] {
      RenderRows(caster, X_WS, std::min(h, t * chunk), std::min(h, (t + 1) * chunk), &frame_seed,
                 nullptr, counts);
    });
  }
  RenderRows(caster, X_WS, 0, std::min(h, chunk), &frame_seed, nullptr, counts);
  for (std::thread& th : pool) th.join();
}

// ------------------------------------------------------------------------- planar LIDAR

PlanarLidarConfig PlanarLidarConfig::Urg04lx() { return PlanarLidarConfig{}; }

PlanarLidarConfig PlanarLidarConfig::Utm30lx() {
  PlanarLidarConfig c;
  c.model = "utm-30lx";
  c.num_beams = 1081;
  c.angle_step_rad = 0.25 * kDegToRad;
  c.angle_min_rad = -135.0 * kDegToRad;
  c.range_min_m = 0.1;
  c.range_max_m = 30.0;
  c.sigma_m = 0.01;
  c.sigma_fraction = 0.00167;
  c.rate_hz = 40.0;
  return c;
}

void PlanarLidarConfig::Validate() const {
  KESTREL_THROW_UNLESS(num_beams >= 1 && num_beams <= 100000,
                       "lidar num_beams = " << num_beams << "; accepted: [1, 100000]");
  KESTREL_THROW_UNLESS(
      angle_step_rad > 0.0 && angle_step_rad * (num_beams - 1) <= 2.0 * M_PI,
      "lidar angle_step_rad = " << angle_step_rad << "; accepted: > 0, all beams within 2 pi");
  KESTREL_THROW_UNLESS(std::isfinite(angle_min_rad),
                       "lidar angle_min_rad = " << angle_min_rad << "; accepted: finite");
  KESTREL_THROW_UNLESS(
      range_min_m >= 0.0 && range_max_m > range_min_m && std::isfinite(range_max_m),
      "lidar range [" << range_min_m << ", " << range_max_m
                      << "] m; accepted: 0 <= min < max < inf");
  KESTREL_THROW_UNLESS(sigma_m >= 0.0 && sigma_fraction >= 0.0 && quantum_m >= 0.0,
                       "lidar sigma_m = " << sigma_m << ", sigma_fraction = " << sigma_fraction
                                          << ", quantum_m = " << quantum_m << "; accepted: >= 0");
  KESTREL_THROW_UNLESS(
      InUnit(dropout_probability),
      "lidar dropout_probability = " << dropout_probability << "; accepted: [0, 1]");
  KESTREL_THROW_UNLESS(rate_hz > 0.0 && rate_hz <= 1000.0,
                       "lidar rate_hz = " << rate_hz << "; accepted: (0, 1000]");
  KESTREL_THROW_UNLESS(
      mixed_pixel_subrays <= 15,
      "lidar mixed_pixel_subrays = " << mixed_pixel_subrays << "; accepted: <= 15 (< 2: off)");
  KESTREL_THROW_UNLESS(
      beam_divergence_rad >= 0.0 && beam_divergence_rad <= 0.1,
      "lidar beam_divergence_rad = " << beam_divergence_rad << "; accepted: [0, 0.1]");
  KESTREL_THROW_UNLESS(mixed_pixel_gap_m > 0.0 && std::isfinite(mixed_pixel_gap_m),
                       "lidar mixed_pixel_gap_m = " << mixed_pixel_gap_m << "; accepted: (0, inf)");
}

PlanarLidar::PlanarLidar(const PlanarLidarConfig& config) : config_(config) {
  config_.Validate();
  for (int i = 0; i < config_.num_beams; ++i) {
    const double a = config_.angle_min_rad + i * config_.angle_step_rad;
    dir_S_.emplace_back(std::cos(a), std::sin(a), 0.0);
  }
  if (config_.mixed_pixel_subrays >= 2) {
    const int n = config_.mixed_pixel_subrays;
    for (int j = 0; j < n; ++j) {
      subray_offset_rad_.push_back((static_cast<double>(j) / (n - 1) - 0.5) *
                                   config_.beam_divergence_rad);
    }
  }
}

double PlanarLidar::TrueRange(const WorldRayCaster& caster, const Pose3& X_WS, size_t i,
                              int* hit) const {
  const Eigen::Matrix3d R_WS = X_WS.rotation();
  const double r = caster.CastRay(X_WS.p, R_WS * dir_S_[i], config_.range_max_m, hit, *hit);
  if (subray_offset_rad_.empty()) return r;
  // Mixed pixels (docs/design.md §7.13): the sub-rays across the footprint, equal weights.
  const double a = config_.angle_min_rad + static_cast<double>(i) * config_.angle_step_rad;
  double lo = kInf, hi = -kInf, sum = 0.0;
  int returns = 0;
  int sub_hit = WorldRayCaster::kNoHit;
  for (const double da : subray_offset_rad_) {
    const Eigen::Vector3d d_S(std::cos(a + da), std::sin(a + da), 0.0);
    const double rj = caster.CastRay(X_WS.p, R_WS * d_S, config_.range_max_m, &sub_hit, sub_hit);
    if (!std::isfinite(rj)) continue;
    lo = std::min(lo, rj);
    hi = std::max(hi, rj);
    sum += rj;
    ++returns;
  }
  if (returns >= 2 && hi - lo > config_.mixed_pixel_gap_m) return sum / returns;
  return r;
}

void PlanarLidar::Scan(const WorldRayCaster& caster, const Pose3& X_WS, SimRandom* rng,
                       std::vector<float>* ranges_m) const {
  ranges_m->assign(dir_S_.size(), 0.0f);
  int hit = WorldRayCaster::kNoHit;
  for (size_t i = 0; i < dir_S_.size(); ++i) {
    const double r = TrueRange(caster, X_WS, i, &hit);
    float out = 0.0f;  // no return
    if (std::isfinite(r)) {
      if (r < config_.range_min_m) {
        out = std::numeric_limits<float>::quiet_NaN();
      } else {
        double measured = r;
        bool dropped = false;
        if (config_.noise) {
          dropped = rng->Bernoulli(config_.dropout_probability);
          measured = r + SigmaAt(r) * rng->Gaussian();
        }
        if (config_.quantum_m > 0.0) {
          measured = std::round(measured / config_.quantum_m) * config_.quantum_m;
        }
        if (dropped) {
          out = std::numeric_limits<float>::quiet_NaN();
        } else {
          // Noise cannot turn a return into "no return" or a negative range.
          out = static_cast<float>(std::clamp(measured, config_.range_min_m, config_.range_max_m));
        }
      }
    }
    (*ranges_m)[i] = out;
  }
}

// ------------------------------------------------------------------------- motion capture

void MotionCaptureConfig::Validate() const {
  KESTREL_THROW_UNLESS(rate_hz > 0.0 && rate_hz <= 1000.0,
                       "motion capture rate_hz = " << rate_hz << "; accepted: (0, 1000]");
  KESTREL_THROW_UNLESS(position_sigma_m >= 0.0 && orientation_sigma_rad >= 0.0,
                       "motion capture sigmas " << position_sigma_m << " m, "
                                                << orientation_sigma_rad << " rad; accepted: >= 0");
  KESTREL_THROW_UNLESS(latency_s >= 0.0 && latency_s <= 1.0,
                       "motion capture latency_s = " << latency_s << "; accepted: [0, 1]");
  KESTREL_THROW_UNLESS(
      dropout_probability >= 0.0 && dropout_probability < 1.0,
      "motion capture dropout_probability = " << dropout_probability << "; accepted: [0, 1)");
  KESTREL_THROW_UNLESS(
      mean_dropout_samples >= 1.0,
      "motion capture mean_dropout_samples = " << mean_dropout_samples << "; accepted: >= 1");
}

MotionCapture::MotionCapture(const MotionCaptureConfig& config) : config_(config) {
  config_.Validate();
}

MotionCaptureSample MotionCapture::Measure(int64_t utime, const Pose3& X_WB, SimRandom* rng) {
  // Two-state chain with stationary invalid fraction p: exit 1/L, enter p/(1-p) * 1/L.
  const double p_exit = 1.0 / config_.mean_dropout_samples;
  const double p_enter = config_.dropout_probability / (1.0 - config_.dropout_probability) * p_exit;
  const double u = rng->Uniform();
  in_dropout_ = in_dropout_ ? !(u < p_exit) : (u < p_enter);
  MotionCaptureSample s;
  s.utime = utime;
  s.acquisition_utime = utime;
  s.deliver_utime = utime + SecondsToUtime(config_.latency_s);
  s.valid = !in_dropout_;
  const Eigen::Vector3d dp(rng->Gaussian(), rng->Gaussian(), rng->Gaussian());
  const Eigen::Vector3d dr(rng->Gaussian(), rng->Gaussian(), rng->Gaussian());
  s.X_WB.p = X_WB.p + config_.position_sigma_m * dp;
  s.X_WB.q =
      (X_WB.q * QuaternionFromRotationVector(config_.orientation_sigma_rad * dr)).normalized();
  return s;
}

// ------------------------------------------------------------------------- IMU

void ImuConfig::Validate() const {
  KESTREL_THROW_UNLESS(rate_hz >= 1.0 && rate_hz <= 10000.0,
                       "imu rate_hz = " << rate_hz << "; accepted: [1, 10000]");
  KESTREL_THROW_UNLESS(gyro_noise_sigma_radps >= 0.0 && accel_noise_sigma_mps2 >= 0.0 &&
                           gyro_bias_sigma_radps >= 0.0 && accel_bias_sigma_mps2 >= 0.0 &&
                           gyro_bias_walk_radps_sqrt_s >= 0.0 && accel_bias_walk_mps2_sqrt_s >= 0.0,
                       "imu noise and bias sigmas must be >= 0");
  KESTREL_THROW_UNLESS(gravity_mps2 > 0.0 && gravity_mps2 < 100.0,
                       "imu gravity_mps2 = " << gravity_mps2 << "; accepted: (0, 100)");
}

Imu::Imu(const ImuConfig& config, SimRandom* rng) : config_(config) {
  config_.Validate();
  for (int a = 0; a < 3; ++a) gyro_bias_[a] = config_.gyro_bias_sigma_radps * rng->Gaussian();
  for (int a = 0; a < 3; ++a) accel_bias_[a] = config_.accel_bias_sigma_mps2 * rng->Gaussian();
}

SimulatedImuSample Imu::Measure(int64_t utime, const Eigen::Matrix3d& R_WB,
                                const Eigen::Vector3d& w_B, const Eigen::Vector3d& a_W, double dt_s,
                                SimRandom* rng) {
  KESTREL_THROW_UNLESS(dt_s >= 0.0 && std::isfinite(dt_s), "imu dt_s = " << dt_s);
  const double root_dt = std::sqrt(dt_s);
  for (int a = 0; a < 3; ++a) {
    gyro_bias_[a] += config_.gyro_bias_walk_radps_sqrt_s * root_dt * rng->Gaussian();
  }
  for (int a = 0; a < 3; ++a) {
    accel_bias_[a] += config_.accel_bias_walk_mps2_sqrt_s * root_dt * rng->Gaussian();
  }
  SimulatedImuSample s;
  s.utime = utime;
  const Eigen::Vector3d specific_force_W = a_W + config_.gravity_mps2 * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d n_g(rng->Gaussian(), rng->Gaussian(), rng->Gaussian());
  const Eigen::Vector3d n_a(rng->Gaussian(), rng->Gaussian(), rng->Gaussian());
  s.angular_velocity_radps = w_B + gyro_bias_ + config_.gyro_noise_sigma_radps * n_g;
  s.specific_force_mps2 =
      R_WB.transpose() * specific_force_W + accel_bias_ + config_.accel_noise_sigma_mps2 * n_a;
  return s;
}

}  // namespace kestrel
