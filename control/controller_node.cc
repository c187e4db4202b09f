#include "control/controller_node.h"

#include "common/trajectory_message.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "common/check.h"
#include "common/config.h"
#include "common/identity.h"
#include "common/run_state_file.h"
#include "common/se3.h"
#include "kestrel/controller_status_t.hpp"
#include "kestrel/motor_command_t.hpp"

namespace kestrel {

namespace {

// How often the state file is rewritten in flight, s (its stamp is the life sign).
constexpr double kStateRefreshS = 0.5;

void CopyVector(const Eigen::Vector3d& v, double out[3]) {
  for (int i = 0; i < 3; ++i) out[i] = v[i];
}

}  // namespace

LcmMotorOutput::LcmMotorOutput(lcm::LCM& lcm, std::string channel)
    : lcm_(lcm), channel_(std::move(channel)), epoch_(NewPublisherEpoch()) {}

void LcmMotorOutput::Send(int64_t utime, const FlightOutput& output) {
  motor_command_t msg;
  msg.utime = utime;
  msg.seq = seq_++;
  msg.epoch = epoch_;
  msg.armed = static_cast<int8_t>(output.armed);
  msg.num_motors = 4;
  msg.thrust_N.assign(output.rotor_thrust_N.data(), output.rotor_thrust_N.data() + 4);
  msg.total_thrust_N = output.thrust_N;
  CopyVector(output.moment_Nm, msg.moment_Nm);
  lcm_.publish(channel_, &msg);
}

void ControllerConfig::Validate() const {
  flight.Validate();
  KESTREL_THROW_UNLESS(std::isfinite(rate_hz) && rate_hz >= 50.0 && rate_hz <= 2000.0,
                       "controller.rate_hz = " << rate_hz << ", accepted [50, 2000]");
  KESTREL_THROW_UNLESS(
      status_decimation >= 1 && status_decimation <= 1000,
      "controller.status_decimation = " << status_decimation << ", accepted [1, 1000]");
  for (const std::string* channel :
       {&pose_channel, &imu_channel, &trajectory_channel, &command_channel, &motor_channel,
        &status_channel, &heartbeat_channel}) {
    KESTREL_THROW_UNLESS(!channel->empty(), "controller channels: an empty channel name");
  }
  KESTREL_THROW_UNLESS(run_id.empty() || CheckRunId(run_id).empty(),
                       "controller.run_id = '" << run_id << "': " << CheckRunId(run_id));
  KESTREL_THROW_UNLESS(
      std::isfinite(takeover_max_gap_s) && takeover_max_gap_s > 0.0,
      "controller.takeover_max_gap_s = " << takeover_max_gap_s << ", accepted (0, inf)");
}

ControllerConfig LoadControllerConfig(const ConfigNode& node, const VehicleConfig& vehicle) {
  ControllerConfig config;
  config.flight.vehicle = vehicle;
  node.Read("rate_hz", &config.rate_hz, Range::Closed(50.0, 2000.0));
  node.Read("status_decimation", &config.status_decimation, Range::Closed(1, 1000));
  node.Read("state_path", &config.state_path);
  node.Read("run_id", &config.run_id);
  node.Read("takeover_max_gap_s", &config.takeover_max_gap_s, Range::Positive());
  if (node.Has("channels")) {
    const ConfigNode channels = node.Child("channels");
    channels.Read("pose", &config.pose_channel);
    channels.Read("imu", &config.imu_channel);
    channels.Read("trajectory", &config.trajectory_channel);
    channels.Read("command", &config.command_channel);
    channels.Read("motor", &config.motor_channel);
    channels.Read("status", &config.status_channel);
    channels.Read("heartbeat", &config.heartbeat_channel);
  }
  if (node.Has("controller")) {
    const ConfigNode c = node.Child("controller");
    GeometricControllerConfig& g = config.flight.controller;
    c.Read("k_x_per_s2", &g.k_x_per_s2, Range::Positive());
    c.Read("k_v_per_s", &g.k_v_per_s, Range::Positive());
    c.Read("k_i_per_s2", &g.k_i_per_s2, Range::NonNegative());
    c.Read("c1_per_s", &g.c1_per_s, Range::NonNegative());
    c.Read("position_integral_limit_m", &g.position_integral_limit_m, Range::NonNegative());
    std::string attitude_error = ToString(g.attitude_error);
    c.Read("attitude_error", &attitude_error, {"large_angle", "cdc2010"});
    const bool known = ParseAttitudeErrorForm(attitude_error, &g.attitude_error);
    KESTREL_DEMAND(known);  // Read checked the choices
    c.Read("k_R_Nm_per_rad", &g.k_R_Nm_per_rad, Range::Positive());
    c.Read("k_W_Nms_per_rad", &g.k_W_Nms_per_rad, Range::Positive());
    c.Read("k_I_Nm_per_rad_s", &g.k_I_Nm_per_rad_s, Range::NonNegative());
    c.Read("c2_per_s", &g.c2_per_s, Range::NonNegative());
    c.Read("attitude_integral_limit_rad_s", &g.attitude_integral_limit_rad_s, Range::NonNegative());
    c.Read("thrust_lag_compensation_s", &g.thrust_lag_compensation_s, Range::Closed(0.0, 0.5));
    c.Read("min_force_z_fraction", &g.min_force_z_fraction, Range{0.0, 1.0, true, false});
    c.Read("max_tilt_rad", &g.max_tilt_rad, Range::Open(0.0, 1.5));
    c.Read("max_desired_rate_radps", &g.max_desired_rate_radps, Range::Positive());
    c.Read("max_desired_angular_acceleration_radps2", &g.max_desired_angular_acceleration_radps2,
           Range::Positive());
  }
  if (node.Has("estimator")) {
    const ConfigNode e = node.Child("estimator");
    StateEstimatorConfig& s = config.flight.estimator;
    e.Read("position_bandwidth_radps", &s.position_bandwidth_radps, Range::Positive());
    e.Read("attitude_gain_per_s", &s.attitude_gain_per_s, Range::Positive());
    e.Read("gyro_bias_gain_per_s2", &s.gyro_bias_gain_per_s2, Range::NonNegative());
    e.Read("max_gyro_bias_radps", &s.max_gyro_bias_radps, Range::NonNegative());
    e.Read("history_s", &s.history_s, Range{0.0, 10.0, false, true});
    e.Read("reset_innovation_m", &s.reset_innovation_m, Range::Positive());
  }
  if (node.Has("safety")) {
    const ConfigNode s = node.Child("safety");
    SafetyConfig& c = config.flight.safety;
    s.Read("pose_timeout_s", &c.pose_timeout_s, Range::Positive());
    s.Read("land_timeout_s", &c.land_timeout_s, Range::Positive());
    s.Read("trajectory_timeout_s", &c.trajectory_timeout_s, Range::Positive());
    s.Read("takeoff_height_m", &c.takeoff_height_m, Range{0.0, 10.0, false, true});
    s.Read("takeoff_speed_mps", &c.takeoff_speed_mps, Range{0.0, 5.0, false, true});
    s.Read("takeoff_track_min_rise_m", &c.takeoff_track_min_rise_m, Range::NonNegative());
    s.Read("land_speed_mps", &c.land_speed_mps, Range{0.0, 5.0, false, true});
    s.Read("landed_height_m", &c.landed_height_m, Range::Positive());
    s.Read("blind_land_depth_m", &c.blind_land_depth_m, Range{0.0, 10.0, false, true});
    s.Read("blind_landed_gap_m", &c.blind_landed_gap_m, Range::Positive());
    s.Read("geofence_min_m", &c.geofence_min_m);
    s.Read("geofence_max_m", &c.geofence_max_m);
    s.Read("geofence_margin_m", &c.geofence_margin_m, Range::NonNegative());
    s.Read("max_trajectory_start_offset_m", &c.max_trajectory_start_offset_m, Range::Positive());
  }
  node.CheckNoUnknownKeys();
  try {
    config.Validate();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(node.file() + ": " + e.what());
  }
  return config;
}

ControllerNode::ControllerNode(lcm::LCM& lcm, const ControllerConfig& config, Clock& clock,
                               MotorOutput* motor_output)
    : lcm_(lcm),
      config_(config),
      clock_(clock),
      flight_(config.flight),
      lcm_motor_output_(lcm, config.motor_channel),
      motor_output_(motor_output != nullptr ? motor_output : &lcm_motor_output_),
      drops_(clock),
      subscriptions_(lcm),
      epoch_(NewPublisherEpoch()),
      run_id_(config.run_id.empty() ? NewRunId() : config.run_id) {
  config_.Validate();
  ReadStateFile();
  auto on_error = [this](const std::string& channel, const std::string& reason) {
    drops_.Count("malformed", channel + ": " + reason);
  };
  subscriptions_.Add<pose_t>(
      config_.pose_channel, [this](const std::string&, const pose_t& msg) { OnPose(msg); },
      on_error);
  subscriptions_.Add<imu_t>(
      config_.imu_channel, [this](const std::string&, const imu_t& msg) { OnImu(msg); }, on_error);
  subscriptions_.Add<trajectory_t>(
      config_.trajectory_channel,
      [this](const std::string&, const trajectory_t& msg) { OnTrajectory(msg); }, on_error);
  subscriptions_.Add<command_t>(
      config_.command_channel, [this](const std::string&, const command_t& msg) { OnCommand(msg); },
      on_error);
}

void ControllerNode::ReadStateFile() {
  if (config_.state_path.empty()) return;
  RunStateFile file;
  std::string why;
  const RunStateRead read =
      ReadRunStateFile(config_.state_path, "controller", run_id_, &file, &why);
  const std::string* mode = file.Find("mode");
  double alive_utime = 0;
  if (read == RunStateRead::kAbsent) {
    takeover_status_ = "no state file: starting IDLE";
  } else if (read == RunStateRead::kCorrupt) {
    takeover_status_ = "state file refused (" + why + "): starting IDLE";
    Log(LogLevel::kError, takeover_status_);
  } else if (read == RunStateRead::kOtherRun) {
    takeover_status_ = why + ": starting IDLE (a new run never arms itself)";
    Log(LogLevel::kInfo, takeover_status_);
  } else if (mode == nullptr || !file.GetDouble("ground_z_m", &previous_.ground_z_m) ||
             !file.GetDouble("utime", &alive_utime)) {
    takeover_status_ = "state file refused (corrupt state file " + config_.state_path +
                       ": no mode, ground_z_m or utime): starting IDLE";
    Log(LogLevel::kError, takeover_status_);
  } else if (*mode == "TAKEOFF" || *mode == "HOLD" || *mode == "TRACK" || *mode == "LAND") {
    takeover_pending_ = true;
    previous_.landing = *mode == "LAND";
    previous_.alive_s = alive_utime * 1e-6;
    takeover_status_ = "controller restarted in flight (run " + run_id_ + ", was " + *mode +
                       "): no motor command until a fresh pose shows whether it flies; then " +
                       (previous_.landing ? "LAND" : "HOLD") + " if airborne";
    Log(LogLevel::kWarning, takeover_status_);
  } else if (*mode == "ESTOP") {
    // The e-stop stays latched across the restart (docs/design.md §2.3).
    flight_.HandleCommand(FlightCommand::kEstop, UtimeToSeconds(clock_.NowUtime()));
    takeover_status_ = "restarted after an e-stop (run " + run_id_ + "): ESTOP stays latched";
    Log(LogLevel::kWarning, takeover_status_);
  } else {
    takeover_status_ =
        "restarted on the ground (run " + run_id_ + ", was " + *mode + "): starting IDLE";
    Log(LogLevel::kInfo, takeover_status_);
  }
}

void ControllerNode::TryTakeover(int64_t utime) {
  const double t = UtimeToSeconds(utime);
  const StateEstimator& estimator = flight_.estimator();
  const VehicleState state = estimator.initialized() ? estimator.state() : VehicleState{};
  const TakeoverDecision decision = DecideTakeover(
      previous_, t, estimator.initialized() ? &state : nullptr, estimator.last_pose_time_s(),
      config_.flight.safety, config_.takeover_max_gap_s);
  if (decision.verdict == TakeoverVerdict::kWait) {
    takeover_status_ = "takeover pending: " + decision.reason;
    return;
  }
  if (decision.verdict == TakeoverVerdict::kStayIdle) {
    takeover_pending_ = false;
    takeover_status_ = decision.reason + "; staying IDLE";
    Log(LogLevel::kError, takeover_status_);
    return;
  }
  std::string why;
  if (!flight_.Takeover(t, previous_.ground_z_m, decision.verdict == TakeoverVerdict::kLand,
                        &why)) {
    takeover_status_ = "takeover pending: " + why;  // the same freshness rule: not expected
    return;
  }
  takeover_pending_ = false;
  takeover_utime_ = utime;
  const Eigen::Vector3d& p = estimator.state().position_m;
  char text[240];
  std::snprintf(text, sizeof(text),
                "TAKEOVER: the flying vehicle taken over in %s at (%.2f, %.2f, %.2f) m, %.3f s "
                "after the first pose reached this controller (",
                ToString(decision.verdict), p.x(), p.y(), p.z(),
                UtimeToSeconds(utime - first_pose_utime_));
  takeover_status_ = text + decision.reason + ")";
  Log(LogLevel::kWarning, takeover_status_);
}

void ControllerNode::WriteStateFile(int64_t utime) {
  RunStateFile file;
  file.kind = "controller";
  file.run_id = run_id_;
  file.values["mode"] = ToString(last_.decision.mode);
  file.values["ground_z_m"] = std::to_string(flight_.supervisor().ground_z_m());
  file.values["utime"] = std::to_string(utime);
  std::string error;
  if (!WriteRunStateFile(config_.state_path, file, &error)) drops_.Count("state file", error);
}

void ControllerNode::OnPose(const pose_t& msg) {
  if (!msg.valid) {
    drops_.Count("invalid pose", "pose_t.valid is false (motion capture lost the object)");
    return;
  }
  PoseMeasurement pose;
  pose.time_s = UtimeToSeconds(msg.utime);
  pose.position_m = Eigen::Vector3d(msg.position_m[0], msg.position_m[1], msg.position_m[2]);
  if (!QuaternionFromWxyz(msg.orientation_wxyz, &pose.q_WB) || !flight_.AddPose(pose)) {
    drops_.Count("rejected pose", "non-finite, non-unit or older than the estimator history");
  } else if (first_pose_utime_ < 0) {
    first_pose_utime_ = clock_.NowUtime();
  }
}

void ControllerNode::OnImu(const imu_t& msg) {
  ImuSample sample;
  sample.time_s = UtimeToSeconds(msg.utime);
  sample.angular_velocity_radps = Eigen::Vector3d(
      msg.angular_velocity_radps[0], msg.angular_velocity_radps[1], msg.angular_velocity_radps[2]);
  sample.specific_force_mps2 = Eigen::Vector3d(
      msg.specific_force_mps2[0], msg.specific_force_mps2[1], msg.specific_force_mps2[2]);
  if (flight_.AddImu(sample)) {
    last_imu_utime_ = std::max(last_imu_utime_, msg.utime);
  } else if (flight_.estimator().initialized()) {
    drops_.Count("rejected imu", "non-finite or out-of-order IMU sample");
  }
}

void ControllerNode::OnTrajectory(const trajectory_t& msg) {
  std::string error;
  const auto trajectory = FromMessage(msg, &error);
  if (!trajectory.has_value()) {
    drops_.Count("invalid trajectory", error);
    return;
  }
  if (!flight_.AcceptTrajectory(*trajectory, UtimeToSeconds(clock_.NowUtime()), &error)) {
    // Far starts are counted apart; the explorer replans (docs/design.md §2.5).
    drops_.Count(error.rfind(kFarStartReason, 0) == 0 ? "refused trajectory (far start)"
                                                      : "refused trajectory",
                 error);
    return;
  }
  trajectory_seq_ = msg.seq;
  trajectory_epoch_ = msg.epoch;
  trajectory_end_s_ = trajectory->end_time_s();
}

void ControllerNode::OnCommand(const command_t& msg) {
  if (msg.command < command_t::COMMAND_IDLE || msg.command > command_t::COMMAND_ESTOP) {
    drops_.Count("invalid command", "command_t.command = " + std::to_string(msg.command));
    return;
  }
  const auto command = static_cast<FlightCommand>(msg.command);
  if (takeover_pending_ && command != FlightCommand::kEstop) {
    // The vehicle may be flying on the previous controller's last command: only an e-stop acts
    // before the verdict; a land order is kept for the takeover.
    if (command == FlightCommand::kLand) {
      previous_.landing = true;
      Log(LogLevel::kWarning, "land command from " + msg.source +
                                  " while a takeover is pending: the takeover will land");
    } else {
      drops_.Count("refused command", "command " + std::to_string(msg.command) + " from " +
                                          msg.source + " refused: a takeover is pending");
    }
    return;
  }
  if (takeover_pending_) {
    takeover_pending_ = false;
    takeover_status_ = "e-stop from " + msg.source + " while a takeover was pending: ESTOP";
    Log(LogLevel::kWarning, takeover_status_);
  }
  if (!flight_.HandleCommand(command, UtimeToSeconds(clock_.NowUtime()), msg.height_m)) {
    drops_.Count("refused command", "command " + std::to_string(msg.command) + " from " +
                                        msg.source + " refused in mode " +
                                        ToString(flight_.supervisor().mode()));
  }
}

void ControllerNode::Tick(int64_t utime) {
  if (takeover_pending_) {
    TryTakeover(utime);
    // Undecided: nothing goes out, so the ESC hold keeps the previous controller's last command
    // (a disarmed command would stop the rotors of a flying vehicle), and no status claims a
    // mode (docs/design.md §2.5).
    if (takeover_pending_) return;
  }
  last_ = flight_.Step(UtimeToSeconds(utime));
  motor_output_->Send(utime, last_);
  // At every mode change, and every kStateRefreshS in flight: the file's stamp is the last life
  // sign a respawned controller judges its evidence by (control/takeover.h).
  const FlightMode mode = last_.decision.mode;
  const bool flying = mode == FlightMode::kTakeoff || mode == FlightMode::kHold ||
                      mode == FlightMode::kTrack || mode == FlightMode::kLand;
  if (!config_.state_path.empty() &&
      (static_cast<int>(mode) != saved_mode_ ||
       (flying && utime - saved_utime_ >= SecondsToUtime(kStateRefreshS)))) {
    saved_mode_ = static_cast<int>(mode);
    saved_utime_ = utime;
    WriteStateFile(utime);
  }
  if (ticks_++ % config_.status_decimation == 0) PublishStatus(utime);
}

void ControllerNode::PublishStatus(int64_t utime) {
  controller_status_t msg;
  msg.utime = utime;
  msg.seq = status_seq_++;
  msg.epoch = epoch_;
  msg.mode = static_cast<int8_t>(last_.decision.mode);
  msg.reason = last_.decision.reason;
  CopyVector(last_.state.position_m, msg.position_m);
  CopyVector(last_.state.velocity_mps, msg.velocity_mps);
  const Eigen::Quaterniond q(last_.state.R_WB);
  msg.orientation_wxyz[0] = q.w();
  msg.orientation_wxyz[1] = q.x();
  msg.orientation_wxyz[2] = q.y();
  msg.orientation_wxyz[3] = q.z();
  const ControlOutput& c = last_.control;
  CopyVector(c.e_x_m, msg.e_x_m);
  CopyVector(c.e_v_mps, msg.e_v_mps);
  CopyVector(c.e_R, msg.e_R);
  CopyVector(c.e_W_radps, msg.e_W_radps);
  msg.thrust_N = last_.thrust_N;
  CopyVector(last_.moment_Nm, msg.moment_Nm);
  msg.pose_age_s = std::isfinite(last_.pose_age_s) ? last_.pose_age_s : 1e9;
  msg.trajectory_seq = trajectory_seq_;
  msg.trajectory_epoch = trajectory_epoch_;
  msg.trajectory_done =
      static_cast<int8_t>(trajectory_seq_ >= 0 && UtimeToSeconds(utime) > trajectory_end_s_);
  lcm_.publish(config_.status_channel, &msg);
}

}  // namespace kestrel
