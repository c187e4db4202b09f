#pragma once
/// @file
/// The whole simulation without I/O: world, exact ray caster, Bullet contacts, one to four
/// quadrotors and their sensors, advanced together in fixed physics steps (lockstep). Each Step()
/// reports, per vehicle, what became due at the new time (motion-capture poses whose latency has
/// passed, IMU samples, depth frames, scans, truth). sim/sim_node.h puts it on LCM, each vehicle
/// on its own channels (its prefix before every channel name). Deterministic: the same config and
/// seed give the same outputs bit for bit (each sensor of each vehicle draws from its own stream
/// derived from the seed; the first vehicle's streams are those of a one-vehicle run).
/// The vehicles do not see each other (their sensors see the world only); their contacts with
/// each other are counted (docs/design.md §7.10).

#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include "common/config.h"
#include "common/trajectory.h"
#include "common/vehicle_config.h"
#include "sim/bullet_world.h"
#include "sim/quadrotor.h"
#include "sim/ray_reach.h"
#include "sim/sensor_errors.h"
#include "sim/sensors.h"
#include "sim/world.h"
#include "sim/world_ray_caster.h"

namespace kestrel {

/// One simulated vehicle: its channels and where it starts.
struct SimVehicleConfig {
  /// Put before every channel name of this vehicle (e.g. "V2_" gives V2_POSE_VICON); "" for a
  /// single vehicle. Letters, digits and '_'.
  std::string prefix;
  /// Start position relative to the world's start pose, W, m (same yaw).
  Eigen::Vector3d start_offset_m{Eigen::Vector3d::Zero()};
};

/// Everything a simulation run needs (config/sim/sim.yaml; loaded by LoadSimConfig).
struct SimConfig {
  World world;                   ///< the world (from world_file)
  VehicleConfig vehicle;         ///< the vehicle (from vehicle_file), extrinsics X_BS included
  int64_t seed{1};               ///< random seed of every sensor stream
  std::string mode{"dynamic"};   ///< "dynamic" (MOTOR_COMMAND drives the rotors) or "kinematic"
  double physics_step_s{0.001};  ///< lockstep period, s, [1e-5, 0.01]
  double speed_factor{0.0};    ///< simulated s per wall s for kestrel-sim; 0 = as fast as possible
  double run_duration_s{0.0};  ///< kestrel-sim stops after this much simulated time; 0 = never
  double vehicle_height_m{0.15};  ///< height of the vehicle's collision cylinder, m, > 0
  /// The ESC watchdog: the last motor command is held this long, then the rotors stop, s. The
  /// sheets' sim configs set 1.5 s, longer than a controller respawn (docs/design.md §2.5).
  double motor_command_timeout_s{0.5};
  double ray_bin_m{0.5};                    ///< ray caster grid bin edge, m, > 0
  QuadrotorConfig quadrotor;                ///< integrator and floor options
  bool depth_enabled{true};                 ///< simulate the depth camera
  std::string depth_sensor_name{"xtion"};   ///< name in depth messages
  DepthCameraConfig depth;                  ///< depth camera model
  bool lidar_enabled{true};                 ///< simulate the planar LIDAR
  std::string lidar_sensor_name{"hokuyo"};  ///< name in scan messages
  PlanarLidarConfig lidar;    ///< LIDAR model (profile urg-04lx or utm-30lx, then overrides)
  bool mocap_enabled{true};   ///< simulate motion capture
  MotionCaptureConfig mocap;  ///< motion-capture model
  /// A scheduled motion-capture loss (docs/design.md §2.4): the poses acquired in
  /// [outage_at_s, outage_at_s + outage_s) of simulated time after the start go out invalid, as
  /// the Vicon bridge publishes a lost body. outage_at_s < 0: none.
  double mocap_outage_at_s{-1.0};
  double mocap_outage_s{1.0};  ///< length of that loss, s, >= 0
  bool imu_enabled{true};      ///< simulate the IMU
  ImuConfig imu;               ///< IMU model
  /// Error sources beyond the sensor noise (docs/design.md §7.13): the profile named by
  /// error_profile (clean: none, the default), then the overrides of the `errors:` section.
  SensorErrorsConfig errors;
  double truth_rate_hz{100.0};                     ///< SIM_TRUTH rate, Hz, (0, 1000]
  std::string pose_channel{"POSE_VICON"};          ///< motion capture out
  std::string imu_channel{"IMU"};                  ///< IMU out
  std::string depth_channel{"DEPTH_XTION"};        ///< depth out
  std::string scan_channel{"SCAN_HOKUYO"};         ///< scans out
  std::string truth_channel{"SIM_TRUTH"};          ///< truth out
  std::string motor_channel{"MOTOR_COMMAND"};      ///< rotor thrusts in (dynamic mode)
  std::string trajectory_channel{"TRAJECTORY"};    ///< trajectory in (kinematic mode)
  std::string heartbeat_channel{"HEARTBEAT_SIM"};  ///< 1 Hz status out (one for the simulator)
  /// "" (default): depth images and scans go out on the driver channels above. Otherwise they go
  /// out on <sensor_device_prefix><channel> (e.g. DEV_DEPTH_XTION), the device side, and a
  /// kestrel-sim-standin per sensor relays them to the driver channel as the real driver would
  /// (docs/design.md §7.11). Letters, digits and '_'.
  std::string sensor_device_prefix;
  /// The vehicles, 1 to 4, all of `vehicle`'s model; each one's channels are its prefix followed
  /// by the channels above (except the heartbeat).
  std::vector<SimVehicleConfig> vehicles{SimVehicleConfig{}};

  /// Vehicle k's name for `channel` (its prefix + channel).
  [[nodiscard]] std::string ChannelOf(size_t k, const std::string& channel) const {
    return vehicles.at(k).prefix + channel;
  }
  /// Where vehicle k's depth images and scans go out: sensor_device_prefix + ChannelOf(k, channel).
  [[nodiscard]] std::string SensorChannelOf(size_t k, const std::string& channel) const {
    return sensor_device_prefix + ChannelOf(k, channel);
  }

  /// Checks every field and the sub-configs. @throws std::invalid_argument naming the field.
  void Validate() const;
};

/// Reads a SimConfig: world_file and vehicle_file are loaded (relative paths against
/// `base_dir`, e.g. the repository root); absent keys keep their defaults; unknown keys are
/// errors. Sections: quadrotor, depth (resolution "vga" | "qvga" | "80x60" then overrides),
/// lidar (model "urg-04lx" | "utm-30lx" then overrides), mocap (outage_at_s and outage_s: the
/// scheduled loss), imu, channels, vehicles (a list of {prefix, start_offset_m}), errors (the
/// overrides of the profile error_profile: clean | realistic, docs/design.md §7.13);
/// sensor_device_prefix and error_profile at the top level.
/// @throws ConfigError naming the file, key, value and accepted range.
[[nodiscard]] SimConfig LoadSimConfig(const ConfigNode& root, const std::string& base_dir);

/// What became due for one vehicle in one Step.
struct SimFrame {
  std::vector<MotionCaptureSample> poses;  ///< poses delivered now (stamped at acquisition)
  std::optional<SimulatedImuSample> imu;   ///< an IMU sample taken now
  bool depth{false};                       ///< a depth frame taken now (Simulator::depth_counts)
  bool scan{false};                        ///< a scan taken now (Simulator::scan_ranges)
  bool truth{false};                       ///< a truth sample is due now
};

/// The lockstep simulation core. Not thread-safe (it uses Bullet). Vehicle-indexed calls take
/// k in [0, num_vehicles()); k defaults to the first (the only one in a one-vehicle run).
class Simulator {
 public:
  /// Builds everything; time starts at start_utime with each vehicle at the world's start pose
  /// plus its start offset.
  /// @throws std::invalid_argument if config.Validate() throws.
  Simulator(const SimConfig& config, int64_t start_utime);
  Simulator(const Simulator&) = delete;
  Simulator& operator=(const Simulator&) = delete;

  /// Dynamic mode: rotor thrusts (N) of vehicle k to hold from now; `armed` false stops the
  /// rotors. Non-finite commands are ignored (returns false).
  bool SetMotorCommand(const Eigen::Vector4d& thrust_N, bool armed, size_t k = 0);
  /// Kinematic mode: the trajectory of vehicle k to follow from now (times in s = utime / 1e6).
  void SetTrajectory(const PiecewisePolynomialTrajectory& trajectory, size_t k = 0);

  /// Puts vehicle k in `state` now (tests and scenarios: start in the air, at speed...).
  void SetVehicleState(const QuadrotorState& state, size_t k = 0) {
    vehicles_.at(k)->quad->SetState(state);
  }

  /// Advances one physics step and samples every sensor that is due at the new time. Returns
  /// the first vehicle's frame; frame(k) has every vehicle's.
  const SimFrame& Step();

  [[nodiscard]] size_t num_vehicles() const { return vehicles_.size(); }
  /// What became due for vehicle k in the last Step.
  [[nodiscard]] const SimFrame& frame(size_t k) const { return vehicles_.at(k)->frame; }
  /// Simulated time now, us.
  [[nodiscard]] int64_t utime() const { return utime_; }
  /// The validated configuration.
  [[nodiscard]] const SimConfig& config() const { return config_; }
  /// Vehicle k (true state, collisions with the world).
  [[nodiscard]] const Quadrotor& vehicle(size_t k = 0) const { return *vehicles_.at(k)->quad; }
  /// Contacts between vehicles so far (onsets, each pair counted once per contact episode), those
  /// of vehicle k, and whether vehicle k touches another now.
  [[nodiscard]] int inter_vehicle_collision_count() const { return inter_vehicle_collisions_; }
  [[nodiscard]] int vehicle_collision_count(size_t k) const {
    return vehicles_.at(k)->vehicle_collisions;
  }
  [[nodiscard]] bool touches_another_vehicle(size_t k) const {
    return vehicles_.at(k)->touching_vehicle;
  }
  /// The exact ray caster over the world.
  [[nodiscard]] const WorldRayCaster& caster() const { return caster_; }
  /// Vehicle k's true depth camera and LIDAR mounts X_BS: the vehicle file's composed with the
  /// run's extrinsic calibration error (docs/design.md §7.13); the vehicle file's when clean.
  [[nodiscard]] const Pose3& true_X_BS_depth(size_t k = 0) const {
    return vehicles_.at(k)->X_BS_depth;
  }
  [[nodiscard]] const Pose3& true_X_BS_lidar(size_t k = 0) const {
    return vehicles_.at(k)->X_BS_lidar;
  }
  /// The depth camera model (intrinsics).
  [[nodiscard]] const DepthCamera& camera() const { return camera_; }
  /// The LIDAR model.
  [[nodiscard]] const PlanarLidar& lidar() const { return lidar_; }
  /// Vehicle k's latest depth frame (counts, row-major, 0 = no return) and its stamp (the
  /// capture time plus the stamp error of docs/design.md §7.13).
  [[nodiscard]] const std::vector<uint16_t>& depth_counts(size_t k = 0) const {
    return vehicles_.at(k)->depth_counts;
  }
  [[nodiscard]] int64_t depth_utime(size_t k = 0) const {  ///< us
    return vehicles_.at(k)->depth_utime;
  }
  /// Vehicle k's latest scan (ranges as in planar_scan_t) and its stamp (as the depth's).
  [[nodiscard]] const std::vector<float>& scan_ranges(size_t k = 0) const {
    return vehicles_.at(k)->scan_ranges;
  }
  [[nodiscard]] int64_t scan_utime(size_t k = 0) const {  ///< us
    return vehicles_.at(k)->scan_utime;
  }

  /// Records into `reach` (not owned; nullptr: none) the cells every depth pixel and LIDAR beam of
  /// every vehicle reaches from its true pose from now on (sim/ray_reach.h), timed in seconds
  /// after the simulator's start; the central ray of each beam, to the first hit or the sensor's
  /// range (the camera's along the pixel's ray for its axial range). Costs one more cast per ray.
  void SetRayReach(RayReach* reach) { reach_ = reach; }

 private:
  /// One vehicle's dynamics, sensor state and latest outputs.
  struct Vehicle {
    Vehicle(const SimConfig& config, size_t index);
    std::unique_ptr<Quadrotor> quad;
    MotionCapture mocap;
    SimRandom depth_rng, lidar_rng, mocap_rng, imu_rng;
    // Error streams (docs/design.md §7.13), apart from the noise streams above.
    SimRandom extrinsic_rng, depth_stamp_rng, lidar_stamp_rng;
    Imu imu;
    Pose3 X_BS_depth, X_BS_lidar;  // true mounts
    Eigen::Vector4d command_N{Eigen::Vector4d::Zero()};
    int64_t command_utime{0};
    bool have_command{false};
    std::optional<PiecewisePolynomialTrajectory> trajectory;
    int64_t last_imu_utime{0};
    std::deque<MotionCaptureSample> mocap_queue;
    std::vector<uint16_t> depth_counts;
    int64_t depth_utime{0};
    std::vector<float> scan_ranges;
    int64_t scan_utime{0};
    bool touching_vehicle{false};
    int vehicle_collisions{0};
    SimFrame frame;
  };

  // The camera and LIDAR models with the error sources of config.errors.
  [[nodiscard]] static DepthCameraConfig CameraConfigOf(const SimConfig& config);
  [[nodiscard]] static PlanarLidarConfig LidarConfigOf(const SimConfig& config);
  // Whether a pose acquired at utime falls in the scheduled motion-capture outage.
  [[nodiscard]] bool InMocapOutage(int64_t utime) const;
  // Time of the k-th sample of a stream at rate_hz (no drift: rounded from the exact time).
  [[nodiscard]] int64_t DueUtime(double rate_hz, int64_t k) const;
  void StepVehicle(Vehicle* v, bool imu_due, bool mocap_due, bool depth_due, bool scan_due);
  void CountVehicleContacts();

  SimConfig config_;
  int64_t start_utime_;
  int64_t utime_;
  int64_t step_us_;
  WorldRayCaster caster_;
  BulletWorld bullet_;
  DepthCamera camera_;
  PlanarLidar lidar_;
  std::vector<std::unique_ptr<Vehicle>> vehicles_;
  // Index of the next sample of each stream (shared by the vehicles: they sample together); the
  // first is one period after the start.
  int64_t depth_k_{1}, scan_k_{1}, mocap_k_{1}, imu_k_{1}, truth_k_{1};
  std::vector<bool> pair_in_contact_;  // by pair (i < j), i * N + j
  RayReach* reach_{nullptr};
  int inter_vehicle_collisions_{0};
};

}  // namespace kestrel
