#pragma once
/// @file
/// The whole simulation without I/O: world, exact ray caster, Bullet contacts, the quadrotor and
/// its sensors, advanced in fixed physics steps (lockstep). Each Step() reports what became due
/// at the new time (motion-capture poses whose latency has passed, IMU samples, depth frames,
/// scans, truth). sim/sim_node.h puts it on LCM. Deterministic: the same config and seed give the
/// same outputs bit for bit (each sensor draws from its own stream derived from the seed).

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
#include "sim/sensors.h"
#include "sim/world.h"
#include "sim/world_ray_caster.h"

namespace kestrel {

/// Everything a simulation run needs (config/sim/sim.yaml; loaded by LoadSimConfig).
struct SimConfig {
  World world;                   ///< the world (from world_file)
  VehicleConfig vehicle;         ///< the vehicle (from vehicle_file), extrinsics X_BS included
  int64_t seed{1};               ///< random seed of every sensor stream
  std::string mode{"dynamic"};   ///< "dynamic" (MOTOR_COMMAND drives the rotors) or "kinematic"
  double physics_step_s{0.001};  ///< lockstep period, s, [1e-5, 0.01]
  double speed_factor{0.0};    ///< simulated s per wall s for kestrel-sim; 0 = as fast as possible
  double run_duration_s{0.0};  ///< kestrel-sim stops after this much simulated time; 0 = never
  double vehicle_height_m{0.15};            ///< height of the vehicle's collision cylinder, m, > 0
  double motor_command_timeout_s{0.5};      ///< rotors stop this long after the last command, s
  double ray_bin_m{0.5};                    ///< ray caster grid bin edge, m, > 0
  QuadrotorConfig quadrotor;                ///< integrator and floor options
  bool depth_enabled{true};                 ///< simulate the depth camera
  std::string depth_sensor_name{"xtion"};   ///< name in depth messages
  DepthCameraConfig depth;                  ///< depth camera model
  bool lidar_enabled{true};                 ///< simulate the planar LIDAR
  std::string lidar_sensor_name{"hokuyo"};  ///< name in scan messages
  PlanarLidarConfig lidar;      ///< LIDAR model (profile urg-04lx or utm-30lx, then overrides)
  bool mocap_enabled{true};     ///< simulate motion capture
  MotionCaptureConfig mocap;    ///< motion-capture model
  bool imu_enabled{true};       ///< simulate the IMU
  ImuConfig imu;                ///< IMU model
  double truth_rate_hz{100.0};  ///< SIM_TRUTH rate, Hz, (0, 1000]
  std::string pose_channel{"POSE_VICON"};          ///< motion capture out
  std::string imu_channel{"IMU"};                  ///< IMU out
  std::string depth_channel{"DEPTH_XTION"};        ///< depth out
  std::string scan_channel{"SCAN_HOKUYO"};         ///< scans out
  std::string truth_channel{"SIM_TRUTH"};          ///< truth out
  std::string motor_channel{"MOTOR_COMMAND"};      ///< rotor thrusts in (dynamic mode)
  std::string trajectory_channel{"TRAJECTORY"};    ///< trajectory in (kinematic mode)
  std::string heartbeat_channel{"HEARTBEAT_SIM"};  ///< 1 Hz status out

  /// Checks every field and the sub-configs. @throws std::invalid_argument naming the field.
  void Validate() const;
};

/// Reads a SimConfig: world_file and vehicle_file are loaded (relative paths against
/// `base_dir`, e.g. the repository root); absent keys keep their defaults; unknown keys are
/// errors. Sections: quadrotor, depth (resolution "vga" | "qvga" | "80x60" then overrides),
/// lidar (model "urg-04lx" | "utm-30lx" then overrides), mocap, imu, channels.
/// @throws ConfigError naming the file, key, value and accepted range.
[[nodiscard]] SimConfig LoadSimConfig(const ConfigNode& root, const std::string& base_dir);

/// What became due in one Step.
struct SimFrame {
  std::vector<MotionCaptureSample> poses;  ///< poses delivered now (stamped at acquisition)
  std::optional<SimulatedImuSample> imu;   ///< an IMU sample taken now
  bool depth{false};                       ///< a depth frame taken now (Simulator::depth_counts)
  bool scan{false};                        ///< a scan taken now (Simulator::scan_ranges)
  bool truth{false};                       ///< a truth sample is due now
};

/// The lockstep simulation core. Not thread-safe (it uses Bullet).
class Simulator {
 public:
  /// Builds everything; time starts at start_utime with the vehicle at the world's start pose.
  /// @throws std::invalid_argument if config.Validate() throws.
  Simulator(const SimConfig& config, int64_t start_utime);
  Simulator(const Simulator&) = delete;
  Simulator& operator=(const Simulator&) = delete;

  /// Dynamic mode: rotor thrusts (N) to hold from now; `armed` false stops the rotors.
  /// Non-finite commands are ignored (returns false).
  bool SetMotorCommand(const Eigen::Vector4d& thrust_N, bool armed);
  /// Kinematic mode: the trajectory to follow from now (times in seconds = utime / 1e6).
  void SetTrajectory(const PiecewisePolynomialTrajectory& trajectory);

  /// Puts the vehicle in `state` now (tests and scenarios: start in the air, at speed...).
  void SetVehicleState(const QuadrotorState& state) { quad_->SetState(state); }

  /// Advances one physics step and samples every sensor that is due at the new time.
  const SimFrame& Step();

  /// Simulated time now, us.
  [[nodiscard]] int64_t utime() const { return utime_; }
  /// The validated configuration.
  [[nodiscard]] const SimConfig& config() const { return config_; }
  /// The vehicle (true state, collisions).
  [[nodiscard]] const Quadrotor& vehicle() const { return *quad_; }
  /// The exact ray caster over the world.
  [[nodiscard]] const WorldRayCaster& caster() const { return caster_; }
  /// The depth camera model (intrinsics).
  [[nodiscard]] const DepthCamera& camera() const { return camera_; }
  /// The LIDAR model.
  [[nodiscard]] const PlanarLidar& lidar() const { return lidar_; }
  /// The latest depth frame (counts, row-major, 0 = no return) and its time.
  [[nodiscard]] const std::vector<uint16_t>& depth_counts() const { return depth_counts_; }
  [[nodiscard]] int64_t depth_utime() const { return depth_utime_; }  ///< us
  /// The latest scan (ranges as in planar_scan_t) and its time.
  [[nodiscard]] const std::vector<float>& scan_ranges() const { return scan_ranges_; }
  [[nodiscard]] int64_t scan_utime() const { return scan_utime_; }  ///< us

 private:
  // Time of the k-th sample of a stream at rate_hz (no drift: rounded from the exact time).
  [[nodiscard]] int64_t DueUtime(double rate_hz, int64_t k) const;

  SimConfig config_;
  int64_t start_utime_;
  int64_t utime_;
  int64_t step_us_;
  WorldRayCaster caster_;
  BulletWorld bullet_;
  std::unique_ptr<Quadrotor> quad_;
  DepthCamera camera_;
  PlanarLidar lidar_;
  MotionCapture mocap_;
  SimRandom depth_rng_, lidar_rng_, mocap_rng_, imu_rng_;
  Imu imu_;
  Eigen::Vector4d command_N_{Eigen::Vector4d::Zero()};
  int64_t command_utime_{0};
  bool have_command_{false};
  std::optional<PiecewisePolynomialTrajectory> trajectory_;
  // Index of the next sample of each stream: the first is one period after the start.
  int64_t depth_k_{1}, scan_k_{1}, mocap_k_{1}, imu_k_{1}, truth_k_{1};
  int64_t last_imu_utime_{0};
  std::deque<MotionCaptureSample> mocap_queue_;
  std::vector<uint16_t> depth_counts_;
  int64_t depth_utime_{0};
  std::vector<float> scan_ranges_;
  int64_t scan_utime_{0};
  SimFrame frame_;
};

}  // namespace kestrel
