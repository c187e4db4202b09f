#include "sim/simulator.h"

#include <algorithm>
#include <cctype>
#include <cmath>

#include "common/check.h"
#include "common/clock.h"

namespace kestrel {
namespace {

// A sensor stamp's error, us: offset + jitter N(0, 1) (docs/design.md §7.13). Draws one
// Gaussian per frame whatever the values, so a stream's draws do not depend on them.
int64_t StampError(double offset_s, double jitter_s, SimRandom* rng) {
  const double n = rng->Gaussian();
  return SecondsToUtime(offset_s + jitter_s * n);
}

std::string Resolve(const std::string& base_dir, const std::string& path) {
  if (path.empty() || path[0] == '/' || base_dir.empty()) return path;
  return base_dir + "/" + path;
}

void ReadDepth(const ConfigNode& n, DepthCameraConfig* c) {
  if (n.Has("resolution")) {
    std::string resolution;
    n.Read("resolution", &resolution, std::vector<std::string>{"vga", "qvga", "80x60"});
    if (resolution == "vga") {
      c->width_px = 640;
      c->height_px = 480;
    } else if (resolution == "qvga") {
      c->width_px = 320;
      c->height_px = 240;
    } else {
      c->width_px = 80;
      c->height_px = 60;
    }
  }
  n.Read("width_px", &c->width_px, Range::Closed(1, 4096));
  n.Read("height_px", &c->height_px, Range::Closed(1, 4096));
  n.Read("hfov_deg", &c->hfov_deg, Range::Open(0, 180));
  n.Read("vfov_deg", &c->vfov_deg, Range::Open(0, 180));
  n.Read("range_min_m", &c->range_min_m, Range::NonNegative());
  n.Read("range_max_m", &c->range_max_m, Range::Positive());
  n.Read("sigma_a_m", &c->sigma_a_m, Range::NonNegative());
  n.Read("sigma_b_per_m", &c->sigma_b_per_m, Range::NonNegative());
  n.Read("sigma_z0_m", &c->sigma_z0_m);
  n.Read("depth_scale_m", &c->depth_scale_m, Range::Positive());
  n.Read("dropout_probability", &c->dropout_probability, Range::Closed(0, 1));
  n.Read("rate_hz", &c->rate_hz, Range{0, 1000, false, true});
  n.Read("noise", &c->noise);
  n.Read("num_threads", &c->num_threads, Range::Closed(1, 64));
}

void ReadLidar(const ConfigNode& n, PlanarLidarConfig* c) {
  if (n.Has("model")) {
    std::string model;
    n.Read("model", &model, std::vector<std::string>{"urg-04lx", "utm-30lx"});
    *c = model == "utm-30lx" ? PlanarLidarConfig::Utm30lx() : PlanarLidarConfig::Urg04lx();
  }
  n.Read("num_beams", &c->num_beams, Range::Closed(1, 100000));
  n.Read("angle_step_rad", &c->angle_step_rad, Range::Positive());
  n.Read("angle_min_rad", &c->angle_min_rad, Range::Closed(-2 * M_PI, 2 * M_PI));
  n.Read("range_min_m", &c->range_min_m, Range::NonNegative());
  n.Read("range_max_m", &c->range_max_m, Range::Positive());
  n.Read("sigma_m", &c->sigma_m, Range::NonNegative());
  n.Read("sigma_fraction", &c->sigma_fraction, Range::NonNegative());
  n.Read("quantum_m", &c->quantum_m, Range::NonNegative());
  n.Read("dropout_probability", &c->dropout_probability, Range::Closed(0, 1));
  n.Read("rate_hz", &c->rate_hz, Range{0, 1000, false, true});
  n.Read("noise", &c->noise);
}

}  // namespace

void SimConfig::Validate() const {
  world.Validate();
  vehicle.Validate();
  KESTREL_THROW_UNLESS(mode == "dynamic" || mode == "kinematic",
                       "sim mode = \"" << mode << "\"; accepted: dynamic, kinematic");
  KESTREL_THROW_UNLESS(physics_step_s >= 1e-5 && physics_step_s <= 0.01,
                       "sim physics_step_s = " << physics_step_s << "; accepted: [1e-5, 0.01]");
  KESTREL_THROW_UNLESS(speed_factor >= 0.0 && std::isfinite(speed_factor),
                       "sim speed_factor = " << speed_factor << "; accepted: [0, inf)");
  KESTREL_THROW_UNLESS(run_duration_s >= 0.0 && std::isfinite(run_duration_s),
                       "sim run_duration_s = " << run_duration_s << "; accepted: [0, inf)");
  KESTREL_THROW_UNLESS(vehicle_height_m > 0.0 && vehicle_height_m < 5.0,
                       "sim vehicle_height_m = " << vehicle_height_m << "; accepted: (0, 5)");
  KESTREL_THROW_UNLESS(
      motor_command_timeout_s > 0.0,
      "sim motor_command_timeout_s = " << motor_command_timeout_s << "; accepted: (0, inf)");
  KESTREL_THROW_UNLESS(ray_bin_m > 0.0, "sim ray_bin_m = " << ray_bin_m << "; accepted: (0, inf)");
  KESTREL_THROW_UNLESS(truth_rate_hz > 0.0 && truth_rate_hz <= 1000.0,
                       "sim truth_rate_hz = " << truth_rate_hz << "; accepted: (0, 1000]");
  KESTREL_THROW_UNLESS(!vehicles.empty() && vehicles.size() <= 4,
                       "sim vehicles: " << vehicles.size() << " listed; accepted: 1 to 4");
  for (const char c : sensor_device_prefix) {
    KESTREL_THROW_UNLESS(std::isalnum(static_cast<unsigned char>(c)) || c == '_',
                         "sim sensor_device_prefix = \""
                             << sensor_device_prefix << "\"; accepted: letters, digits and '_'");
  }
  KESTREL_THROW_UNLESS(std::isfinite(mocap_outage_at_s),
                       "sim mocap.outage_at_s = " << mocap_outage_at_s << "; accepted: finite");
  KESTREL_THROW_UNLESS(mocap_outage_s >= 0.0 && std::isfinite(mocap_outage_s),
                       "sim mocap.outage_s = " << mocap_outage_s << "; accepted: [0, inf)");
  for (size_t i = 0; i < vehicles.size(); ++i) {
    const SimVehicleConfig& v = vehicles[i];
    for (const char c : v.prefix) {
      KESTREL_THROW_UNLESS(std::isalnum(static_cast<unsigned char>(c)) || c == '_',
                           "sim vehicles[" << i << "].prefix = \"" << v.prefix
                                           << "\"; accepted: letters, digits and '_'");
    }
    KESTREL_THROW_UNLESS(v.start_offset_m.allFinite(),
                         "sim vehicles[" << i << "].start_offset_m is not finite");
    const std::optional<std::string> start_problem =
        StartClearanceProblem(world, v.start_offset_m, 0.5 * vehicle.diameter_m);
    if (start_problem) {
      throw std::invalid_argument(
          (vehicles.size() > 1 ? "sim vehicles[" + std::to_string(i) + "]: " : std::string()) +
          *start_problem);
    }
    for (size_t j = 0; j < i; ++j) {
      KESTREL_THROW_UNLESS(vehicles[j].prefix != v.prefix,
                           "sim vehicles[" << j << "] and [" << i << "] share the prefix \""
                                           << v.prefix << "\"; each vehicle needs its own");
      const Eigen::Vector3d d = v.start_offset_m - vehicles[j].start_offset_m;
      KESTREL_THROW_UNLESS(
          d.head<2>().norm() > vehicle.diameter_m || std::abs(d.z()) > vehicle_height_m,
          "sim vehicles[" << j << "] and [" << i << "] start " << d.head<2>().norm()
                          << " m apart, closer than the " << vehicle.diameter_m
                          << " m vehicle diameter");
    }
  }
  quadrotor.Validate();
  depth.Validate();
  lidar.Validate();
  mocap.Validate();
  imu.Validate();
  errors.Validate();
}

SimConfig LoadSimConfig(const ConfigNode& root, const std::string& base_dir) {
  SimConfig c;
  std::string world_file, vehicle_file;
  root.ReadRequired("world_file", &world_file);
  root.ReadRequired("vehicle_file", &vehicle_file);
  c.world = LoadWorld(Resolve(base_dir, world_file), root);
  c.vehicle = LoadVehicleConfigFile(Resolve(base_dir, vehicle_file), root);
  root.Read("seed", &c.seed, Range::NonNegative());
  root.Read("mode", &c.mode, std::vector<std::string>{"dynamic", "kinematic"});
  root.Read("physics_step_s", &c.physics_step_s, Range::Closed(1e-5, 0.01));
  root.Read("speed_factor", &c.speed_factor, Range::NonNegative());
  root.Read("run_duration_s", &c.run_duration_s, Range::NonNegative());
  root.Read("vehicle_height_m", &c.vehicle_height_m, Range::Open(0, 5));
  root.Read("motor_command_timeout_s", &c.motor_command_timeout_s, Range::Positive());
  root.Read("ray_bin_m", &c.ray_bin_m, Range::Positive());
  root.Read("truth_rate_hz", &c.truth_rate_hz, Range{0, 1000, false, true});
  root.Read("sensor_device_prefix", &c.sensor_device_prefix);
  // The profile first, then the overrides of the `errors:` section (docs/design.md §7.13).
  std::string error_profile = c.errors.profile;
  root.Read("error_profile", &error_profile, std::vector<std::string>{"clean", "realistic"});
  c.errors = SensorErrorsConfig::Profile(error_profile);
  if (root.Has("errors")) ReadSensorErrors(root.Child("errors"), &c.errors);
  if (root.Has("quadrotor")) {
    const ConfigNode q = root.Child("quadrotor");
    q.Read("max_substep_s", &c.quadrotor.max_substep_s, Range{0, 0.01, false, true});
    q.Read("crash_speed_mps", &c.quadrotor.crash_speed_mps, Range::Positive());
  }
  if (root.Has("depth")) {
    const ConfigNode d = root.Child("depth");
    d.Read("enabled", &c.depth_enabled);
    d.Read("sensor_name", &c.depth_sensor_name);
    ReadDepth(d, &c.depth);
  }
  if (root.Has("lidar")) {
    const ConfigNode l = root.Child("lidar");
    l.Read("enabled", &c.lidar_enabled);
    l.Read("sensor_name", &c.lidar_sensor_name);
    ReadLidar(l, &c.lidar);
  }
  if (root.Has("mocap")) {
    const ConfigNode m = root.Child("mocap");
    m.Read("enabled", &c.mocap_enabled);
    m.Read("rate_hz", &c.mocap.rate_hz, Range{0, 1000, false, true});
    m.Read("position_sigma_m", &c.mocap.position_sigma_m, Range::NonNegative());
    m.Read("orientation_sigma_rad", &c.mocap.orientation_sigma_rad, Range::NonNegative());
    m.Read("latency_s", &c.mocap.latency_s, Range::Closed(0, 1));
    m.Read("dropout_probability", &c.mocap.dropout_probability, Range{0, 1, true, false});
    m.Read("mean_dropout_samples", &c.mocap.mean_dropout_samples, Range::AtLeast(1));
    m.Read("outage_at_s", &c.mocap_outage_at_s);
    m.Read("outage_s", &c.mocap_outage_s, Range::NonNegative());
  }
  if (root.Has("imu")) {
    const ConfigNode i = root.Child("imu");
    i.Read("enabled", &c.imu_enabled);
    i.Read("rate_hz", &c.imu.rate_hz, Range::Closed(1, 10000));
    i.Read("gyro_noise_sigma_radps", &c.imu.gyro_noise_sigma_radps, Range::NonNegative());
    i.Read("accel_noise_sigma_mps2", &c.imu.accel_noise_sigma_mps2, Range::NonNegative());
    i.Read("gyro_bias_sigma_radps", &c.imu.gyro_bias_sigma_radps, Range::NonNegative());
    i.Read("accel_bias_sigma_mps2", &c.imu.accel_bias_sigma_mps2, Range::NonNegative());
    i.Read("gyro_bias_walk_radps_sqrt_s", &c.imu.gyro_bias_walk_radps_sqrt_s, Range::NonNegative());
    i.Read("accel_bias_walk_mps2_sqrt_s", &c.imu.accel_bias_walk_mps2_sqrt_s, Range::NonNegative());
  }
  if (root.Has("vehicles")) {
    c.vehicles.clear();
    for (const ConfigNode& v : root.Elements("vehicles")) {
      SimVehicleConfig vehicle;
      v.Read("prefix", &vehicle.prefix);
      v.Read("start_offset_m", &vehicle.start_offset_m);
      c.vehicles.push_back(vehicle);
    }
  }
  if (root.Has("channels")) {
    const ConfigNode ch = root.Child("channels");
    ch.Read("pose", &c.pose_channel);
    ch.Read("imu", &c.imu_channel);
    ch.Read("depth", &c.depth_channel);
    ch.Read("scan", &c.scan_channel);
    ch.Read("truth", &c.truth_channel);
    ch.Read("motor_command", &c.motor_channel);
    ch.Read("trajectory", &c.trajectory_channel);
    ch.Read("heartbeat", &c.heartbeat_channel);
  }
  root.CheckNoUnknownKeys();
  try {
    c.Validate();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(root.file() + ": " + e.what());
  }
  c.imu.gravity_mps2 = c.quadrotor.gravity_mps2;
  return c;
}

Simulator::Vehicle::Vehicle(const SimConfig& config, size_t index)
    : mocap(config.mocap),
      // The first vehicle's streams are a one-vehicle run's; each other one has its own.
      depth_rng(MixSeed(static_cast<uint64_t>(config.seed) * 8 + 1 + (uint64_t{index} << 40))),
      lidar_rng(MixSeed(static_cast<uint64_t>(config.seed) * 8 + 2 + (uint64_t{index} << 40))),
      mocap_rng(MixSeed(static_cast<uint64_t>(config.seed) * 8 + 3 + (uint64_t{index} << 40))),
      imu_rng(MixSeed(static_cast<uint64_t>(config.seed) * 8 + 4 + (uint64_t{index} << 40))),
      // Error streams 5, 6, 7: residues of seed * 8 that the noise streams do not use.
      extrinsic_rng(MixSeed(static_cast<uint64_t>(config.seed) * 8 + 5 + (uint64_t{index} << 40))),
      depth_stamp_rng(
          MixSeed(static_cast<uint64_t>(config.seed) * 8 + 6 + (uint64_t{index} << 40))),
      lidar_stamp_rng(
          MixSeed(static_cast<uint64_t>(config.seed) * 8 + 7 + (uint64_t{index} << 40))),
      imu(config.imu, &imu_rng) {
  // Extrinsic calibration error, drawn once per run and vehicle (docs/design.md §7.13).
  const SensorErrorsConfig& e = config.errors;
  const Pose3 X_err_depth =
      DrawExtrinsicError(e.depth_extrinsic_error_m, e.depth_extrinsic_error_rad,
                         e.depth_extrinsic_sigma_m, e.depth_extrinsic_sigma_rad, &extrinsic_rng);
  const Pose3 X_err_lidar =
      DrawExtrinsicError(e.lidar_extrinsic_error_m, e.lidar_extrinsic_error_rad,
                         e.lidar_extrinsic_sigma_m, e.lidar_extrinsic_sigma_rad, &extrinsic_rng);
  X_BS_depth = PerturbedMount(config.vehicle.X_BS_xtion, X_err_depth);
  X_BS_lidar = PerturbedMount(config.vehicle.X_BS_hokuyo, X_err_lidar);
}

DepthCameraConfig Simulator::CameraConfigOf(const SimConfig& config) {
  DepthCameraConfig c = config.depth;
  if (config.errors.depth_disparity_quantisation) {
    c.disparity_focal_px = config.errors.depth_native_focal_px;
    c.disparity_baseline_m = config.errors.depth_baseline_m;
    c.disparity_steps_per_px = config.errors.depth_disparity_steps_per_px;
  }
  return c;
}

PlanarLidarConfig Simulator::LidarConfigOf(const SimConfig& config) {
  PlanarLidarConfig c = config.lidar;
  if (config.errors.lidar_mixed_pixels) {
    c.mixed_pixel_subrays = config.errors.lidar_mixed_pixel_subrays;
    c.beam_divergence_rad = config.errors.lidar_beam_divergence_rad;
    c.mixed_pixel_gap_m = config.errors.lidar_mixed_pixel_gap_m;
  }
  return c;
}

Simulator::Simulator(const SimConfig& config, int64_t start_utime)
    : config_((config.Validate(), config)),
      start_utime_(start_utime),
      utime_(start_utime),
      step_us_(SecondsToUtime(config.physics_step_s)),
      caster_(config_.world, config_.ray_bin_m),
      bullet_(config_.world, 0.5 * config_.vehicle.diameter_m, config_.vehicle_height_m),
      camera_(CameraConfigOf(config_)),
      lidar_(LidarConfigOf(config_)) {
  KESTREL_THROW_UNLESS(step_us_ >= 1, "physics step " << config_.physics_step_s << " s");
  const size_t n = config_.vehicles.size();
  for (size_t k = 0; k < n; ++k) {
    auto v = std::make_unique<Vehicle>(config_, k);
    v->quad =
        std::make_unique<Quadrotor>(config_.vehicle, config_.quadrotor, config_.world, &bullet_);
    Pose3 start = config_.world.start_X_WB;
    start.p += config_.vehicles[k].start_offset_m;
    v->quad->Reset(start);
    v->last_imu_utime = start_utime;
    vehicles_.push_back(std::move(v));
  }
  pair_in_contact_.assign(n * n, false);
}

bool Simulator::InMocapOutage(int64_t utime) const {
  if (config_.mocap_outage_at_s < 0.0) return false;
  const int64_t begin = start_utime_ + SecondsToUtime(config_.mocap_outage_at_s);
  return utime >= begin && utime < begin + SecondsToUtime(config_.mocap_outage_s);
}

int64_t Simulator::DueUtime(double rate_hz, int64_t k) const {
  return start_utime_ + std::llround(static_cast<double>(k) * 1e6 / rate_hz);
}

bool Simulator::SetMotorCommand(const Eigen::Vector4d& thrust_N, bool armed, size_t k) {
  if (!thrust_N.allFinite()) return false;
  Vehicle& v = *vehicles_.at(k);
  v.command_N = armed ? thrust_N : Eigen::Vector4d::Zero();
  v.command_utime = utime_;
  v.have_command = true;
  return true;
}

void Simulator::SetTrajectory(const PiecewisePolynomialTrajectory& trajectory, size_t k) {
  vehicles_.at(k)->trajectory = trajectory;
}

const SimFrame& Simulator::Step() {
  utime_ += step_us_;
  // Streams due at the new time, each at its own rate from the start time (every vehicle
  // samples together).
  const auto due = [this](bool enabled, double rate_hz, int64_t* k) {
    if (!enabled || utime_ < DueUtime(rate_hz, *k)) return false;
    while (utime_ >= DueUtime(rate_hz, *k)) ++*k;
    return true;
  };
  const bool imu_due = due(config_.imu_enabled, config_.imu.rate_hz, &imu_k_);
  const bool mocap_due = due(config_.mocap_enabled, config_.mocap.rate_hz, &mocap_k_);
  const bool depth_due = due(config_.depth_enabled, config_.depth.rate_hz, &depth_k_);
  const bool scan_due = due(config_.lidar_enabled, config_.lidar.rate_hz, &scan_k_);
  const bool truth_due = due(true, config_.truth_rate_hz, &truth_k_);
  for (const auto& v : vehicles_) {
    StepVehicle(v.get(), imu_due, mocap_due, depth_due, scan_due);
    v->frame.truth = truth_due;
  }
  if (vehicles_.size() > 1) CountVehicleContacts();
  return vehicles_.front()->frame;
}

void Simulator::StepVehicle(Vehicle* v, bool imu_due, bool mocap_due, bool depth_due,
                            bool scan_due) {
  v->frame = SimFrame{};
  Quadrotor& quad = *v->quad;
  const double t_s = UtimeToSeconds(utime_);
  if (config_.mode == "kinematic") {
    if (v->trajectory.has_value()) quad.FollowTrajectory(*v->trajectory, t_s);
  } else {
    const bool fresh = v->have_command &&
                       utime_ - v->command_utime <= SecondsToUtime(config_.motor_command_timeout_s);
    quad.Step(fresh ? v->command_N : Eigen::Vector4d::Zero(), config_.physics_step_s);
  }
  const QuadrotorState& s = quad.state();
  const Pose3 X_WB = s.pose();
  if (imu_due) {
    v->frame.imu = v->imu.Measure(utime_, s.q_WB.toRotationMatrix(), s.w_B, quad.acceleration_W(),
                                  UtimeToSeconds(utime_ - v->last_imu_utime), &v->imu_rng);
    v->last_imu_utime = utime_;
  }
  if (mocap_due) {
    // The sample is drawn in any case, so the noise streams are those of a run without outage.
    MotionCaptureSample sample = v->mocap.Measure(utime_, X_WB, &v->mocap_rng);
    // Latency the bridge does not remove (docs/design.md §7.13).
    sample.utime += SecondsToUtime(config_.errors.mocap_residual_latency_s);
    if (InMocapOutage(utime_)) sample.valid = false;
    v->mocap_queue.push_back(sample);
  }
  while (!v->mocap_queue.empty() && v->mocap_queue.front().deliver_utime <= utime_) {
    v->frame.poses.push_back(v->mocap_queue.front());
    v->mocap_queue.pop_front();
  }
  const double since_start_s = UtimeToSeconds(utime_ - start_utime_);
  if (depth_due) {
    // The true mount and the stamp error (docs/design.md §7.13).
    camera_.Render(caster_, X_WB * v->X_BS_depth, &v->depth_rng, &v->depth_counts);
    if (reach_ != nullptr) {
      const Pose3 X_WS = X_WB * v->X_BS_depth;
      const Eigen::Matrix3d R_WS = X_WS.q.toRotationMatrix();
      for (size_t i = 0; i < v->depth_counts.size(); ++i) {
        const Eigen::Vector3d& d_S = camera_.PixelDirection(i);
        const Eigen::Vector3d u_W = R_WS * d_S;
        const double range_m = camera_.config().range_max_m / d_S.z();
        reach_->AddRay(X_WS.p, u_W, std::min(range_m, caster_.CastRay(X_WS.p, u_W, range_m)),
                       since_start_s);
      }
    }
    v->depth_utime = utime_ + StampError(config_.errors.depth_time_offset_s,
                                         config_.errors.depth_time_jitter_s, &v->depth_stamp_rng);
    v->frame.depth = true;
  }
  if (scan_due) {
    lidar_.Scan(caster_, X_WB * v->X_BS_lidar, &v->lidar_rng, &v->scan_ranges);
    if (reach_ != nullptr) {
      const Pose3 X_WS = X_WB * v->X_BS_lidar;
      const PlanarLidarConfig& c = lidar_.config();
      for (int i = 0; i < c.num_beams; ++i) {
        const double a = c.angle_min_rad + i * c.angle_step_rad;
        const Eigen::Vector3d u_W = X_WS.q * Eigen::Vector3d(std::cos(a), std::sin(a), 0.0);
        reach_->AddRay(X_WS.p, u_W,
                       std::min(c.range_max_m, caster_.CastRay(X_WS.p, u_W, c.range_max_m)),
                       since_start_s);
      }
    }
    v->scan_utime = utime_ + StampError(config_.errors.lidar_time_offset_s,
                                        config_.errors.lidar_time_jitter_s, &v->lidar_stamp_rng);
    v->frame.scan = true;
  }
}

void Simulator::CountVehicleContacts() {
  // Each vehicle is the vertical cylinder of the world contacts (diameter, vehicle_height_m)
  // centred on its body origin: two touch when their axes are at most a diameter apart and
  // their centres at most a height apart vertically.
  const size_t n = vehicles_.size();
  for (const auto& v : vehicles_) v->touching_vehicle = false;
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = i + 1; j < n; ++j) {
      const Eigen::Vector3d d = vehicles_[j]->quad->state().p_W - vehicles_[i]->quad->state().p_W;
      const bool touch = d.head<2>().norm() <= config_.vehicle.diameter_m &&
                         std::abs(d.z()) <= config_.vehicle_height_m;
      if (touch && !pair_in_contact_[i * n + j]) {
        ++inter_vehicle_collisions_;
        ++vehicles_[i]->vehicle_collisions;
        ++vehicles_[j]->vehicle_collisions;
      }
      pair_in_contact_[i * n + j] = touch;
      if (touch) vehicles_[i]->touching_vehicle = vehicles_[j]->touching_vehicle = true;
    }
  }
}

}  // namespace kestrel
