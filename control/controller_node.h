#pragma once
/// @file
/// kestrel-controller's node: subscribes to POSE_VICON, IMU, TRAJECTORY and COMMAND (decoded
/// through the guarded path, bad messages counted and dropped), runs FlightController at the
/// control rate (Tick, called by the process's NodeLoop timer), sends the rotor thrusts through a
/// MotorOutput (LCM MOTOR_COMMAND by default; a hardware backend implements the same interface)
/// and publishes CONTROLLER_STATUS. No YAML or sockets inside. Channel names are configuration.
/// The one file: with state_path set, the flight state (mode, take-off ground height, run id) is
/// written there atomically at every mode change and every half second in flight
/// (common/run_state_file.h). A controller started with the same run id whose file says it was
/// flying sends nothing until a fresh pose comes, however late, then takes the vehicle over where
/// it is (HOLD, or LAND if it was landing) if that pose shows it airborne (control/takeover.h,
/// docs/design.md §2.5); another run, no file or a corrupt one: IDLE, as always.

#include <cstdint>
#include <memory>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/lcm_decode.h"
#include "common/log.h"
#include "control/flight_controller.h"
#include "control/takeover.h"
#include "kestrel/command_t.hpp"
#include "kestrel/imu_t.hpp"
#include "kestrel/pose_t.hpp"
#include "kestrel/trajectory_t.hpp"

namespace kestrel {

class ConfigNode;

/// Where rotor commands go. Called once per control step with the step's output; must not block
/// for long. `armed` false means the motors must stop.
class MotorOutput {
 public:
  virtual ~MotorOutput() = default;
  /// Sends the command of one control step stamped `utime` (us).
  virtual void Send(int64_t utime, const FlightOutput& output) = 0;
};

/// Publishes motor_command_t on an LCM channel (the simulator's input).
class LcmMotorOutput final : public MotorOutput {
 public:
  /// Draws the output's publisher epoch (common/identity.h).
  LcmMotorOutput(lcm::LCM& lcm, std::string channel);
  void Send(int64_t utime, const FlightOutput& output) override;
  /// The publisher epoch stamped on every motor command.
  [[nodiscard]] int64_t epoch() const { return epoch_; }

 private:
  lcm::LCM& lcm_;
  std::string channel_;
  int64_t epoch_;
  int64_t seq_{0};
};

/// The process configuration: the flight logic and the wiring.
struct ControllerConfig {
  FlightControllerConfig flight;                          ///< vehicle, gains, estimator, safety
  double rate_hz{400.0};                                  ///< control rate, Hz (issue: 200-500)
  int status_decimation{4};                               ///< status every N control steps (>= 1)
  std::string pose_channel{"POSE_VICON"};                 ///< motion-capture poses (pose_t)
  std::string imu_channel{"IMU"};                         ///< IMU samples (imu_t)
  std::string trajectory_channel{"TRAJECTORY"};           ///< trajectories (trajectory_t)
  std::string command_channel{"COMMAND"};                 ///< operator commands (command_t)
  std::string motor_channel{"MOTOR_COMMAND"};             ///< rotor commands (motor_command_t)
  std::string status_channel{"CONTROLLER_STATUS"};        ///< status (controller_status_t)
  std::string heartbeat_channel{"HEARTBEAT_CONTROLLER"};  ///< kestrel-controller's heartbeat
  /// The flight-state file ("" = none: a restarted controller always starts IDLE).
  std::string state_path;
  /// The run this controller belongs to (common/identity.h); "" = a fresh id, which takes nothing
  /// over. kestrel-controller fills it from $KESTREL_RUN_ID when unset.
  std::string run_id;
  /// A vehicle is taken over only when its first fresh pose comes at most this long after the
  /// previous controller's last life sign in the state file, s (> 0; control/takeover.h): later,
  /// whatever holds it up is not its rotors.
  double takeover_max_gap_s{10.0};

  /// Throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// Reads a ControllerConfig from YAML: keys rate_hz, status_decimation, state_path, run_id,
/// takeover_max_gap_s, channels.{pose, imu, trajectory, command, motor, status, heartbeat},
/// controller.{attitude_error ("large_angle" | "cdc2010"), k_x_per_s2, ...}, estimator.{...},
/// safety.{..., takeoff_track_min_rise_m, geofence_min_m, geofence_max_m,
/// max_trajectory_start_offset_m}; absent keys keep their defaults. The vehicle comes from its own
/// file (LoadVehicleConfigFile). @throws ConfigError naming file, key, range.
[[nodiscard]] ControllerConfig LoadControllerConfig(const ConfigNode& node,
                                                    const VehicleConfig& vehicle);

/// The node. Neither copyable nor movable (LCM subscriptions hold `this`).
class ControllerNode {
 public:
  /// Subscribes to the input channels. `motor_output` (not owned, must outlive the node) replaces
  /// the default LCM output when non-null. @throws std::invalid_argument if config.Validate()
  /// throws.
  ControllerNode(lcm::LCM& lcm, const ControllerConfig& config, Clock& clock,
                 MotorOutput* motor_output = nullptr);
  ControllerNode(const ControllerNode&) = delete;
  ControllerNode& operator=(const ControllerNode&) = delete;

  /// One control step at `utime` (us): FlightController::Step, motor output, status. While a
  /// takeover is pending (takeover_pending()) it only decides it: no motor command, no status.
  void Tick(int64_t utime);

  [[nodiscard]] const FlightController& flight() const { return flight_; }
  [[nodiscard]] const FlightOutput& last_output() const { return last_; }
  [[nodiscard]] const DropCounter& drops() const { return drops_; }
  [[nodiscard]] int64_t trajectory_seq() const { return trajectory_seq_; }
  /// End of the tracked trajectory, s (0 if none).
  [[nodiscard]] double trajectory_end_s() const { return trajectory_end_s_; }
  /// The epoch of the tracked trajectory's publisher (0 if none).
  [[nodiscard]] int64_t trajectory_epoch() const { return trajectory_epoch_; }
  /// The publisher epoch stamped on CONTROLLER_STATUS (common/identity.h).
  [[nodiscard]] int64_t epoch() const { return epoch_; }
  /// The control step at which this controller took a flying vehicle over (-1: none).
  [[nodiscard]] int64_t takeover_utime() const { return takeover_utime_; }
  /// When the first valid pose reached this controller, its clock, us (-1: none yet).
  [[nodiscard]] int64_t first_pose_utime() const { return first_pose_utime_; }
  /// Whether the state file said "flying" and no verdict has come yet (nothing is sent).
  [[nodiscard]] bool takeover_pending() const { return takeover_pending_; }
  /// What the start-up found in the state file and did (for logs and tests).
  [[nodiscard]] const std::string& takeover_status() const { return takeover_status_; }
  /// The stamp of the newest IMU sample the estimator took, us (-1: none yet): a motor command
  /// sent at t acts on inertial data t - last_imu_utime() old (docs/design.md §2.6).
  [[nodiscard]] int64_t last_imu_utime() const { return last_imu_utime_; }
  /// The run id in use (config run_id, or a fresh one).
  [[nodiscard]] const std::string& run_id() const { return run_id_; }

 private:
  void ReadStateFile();
  void TryTakeover(int64_t utime);
  void WriteStateFile(int64_t utime);
  void OnPose(const pose_t& msg);
  void OnImu(const imu_t& msg);
  void OnTrajectory(const trajectory_t& msg);
  void OnCommand(const command_t& msg);
  void PublishStatus(int64_t utime);

  lcm::LCM& lcm_;
  ControllerConfig config_;
  Clock& clock_;
  FlightController flight_;
  LcmMotorOutput lcm_motor_output_;
  MotorOutput* motor_output_;
  DropCounter drops_;
  GuardedSubscriptions subscriptions_;
  int64_t epoch_;
  FlightOutput last_;
  int64_t ticks_{0};
  int64_t status_seq_{0};
  int64_t trajectory_seq_{-1};
  int64_t trajectory_epoch_{0};
  int64_t last_imu_utime_{-1};
  double trajectory_end_s_{0.0};
  std::string run_id_;
  bool takeover_pending_{false};  // the state file says the vehicle was flying; no verdict yet
  PreviousFlight previous_;       // what that file says
  int64_t first_pose_utime_{-1};
  int64_t takeover_utime_{-1};
  std::string takeover_status_;
  int saved_mode_{-1};              // the mode last written to the state file (-1: none)
  int64_t saved_utime_{INT64_MIN};  // when it was written, us
};

}  // namespace kestrel
