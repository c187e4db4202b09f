#include "control/safety.h"

#include <algorithm>
#include <cmath>

#include "common/check.h"

namespace kestrel {

namespace {

bool CheckPositive(double value) { return std::isfinite(value) && value > 0.0; }

double YawOfRotation(const Eigen::Matrix3d& R) { return std::atan2(R(1, 0), R(0, 0)); }

}  // namespace

const char* ToString(FlightMode mode) {
  switch (mode) {
    case FlightMode::kIdle:
      return "IDLE";
    case FlightMode::kTakeoff:
      return "TAKEOFF";
    case FlightMode::kHold:
      return "HOLD";
    case FlightMode::kTrack:
      return "TRACK";
    case FlightMode::kLand:
      return "LAND";
    case FlightMode::kEstop:
      return "ESTOP";
  }
  return "UNKNOWN";
}

void SafetyConfig::Validate() const {
  KESTREL_THROW_UNLESS(CheckPositive(pose_timeout_s),
                       "safety.pose_timeout_s = " << pose_timeout_s << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(
      std::isfinite(land_timeout_s) && land_timeout_s > pose_timeout_s,
      "safety.land_timeout_s = " << land_timeout_s
                                 << ", accepted (pose_timeout_s = " << pose_timeout_s << ", inf)");
  KESTREL_THROW_UNLESS(
      CheckPositive(trajectory_timeout_s),
      "safety.trajectory_timeout_s = " << trajectory_timeout_s << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(CheckPositive(takeoff_height_m) && takeoff_height_m <= 10.0,
                       "safety.takeoff_height_m = " << takeoff_height_m << ", accepted (0, 10]");
  KESTREL_THROW_UNLESS(CheckPositive(takeoff_speed_mps) && takeoff_speed_mps <= 5.0,
                       "safety.takeoff_speed_mps = " << takeoff_speed_mps << ", accepted (0, 5]");
  KESTREL_THROW_UNLESS(
      CheckPositive(takeoff_done_tolerance_m),
      "safety.takeoff_done_tolerance_m = " << takeoff_done_tolerance_m << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(
      std::isfinite(takeoff_track_min_rise_m) && takeoff_track_min_rise_m >= 0.0,
      "safety.takeoff_track_min_rise_m = " << takeoff_track_min_rise_m << ", accepted [0, inf)");
  KESTREL_THROW_UNLESS(CheckPositive(land_speed_mps) && land_speed_mps <= 5.0,
                       "safety.land_speed_mps = " << land_speed_mps << ", accepted (0, 5]");
  KESTREL_THROW_UNLESS(CheckPositive(landed_height_m),
                       "safety.landed_height_m = " << landed_height_m << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(CheckPositive(landed_speed_mps),
                       "safety.landed_speed_mps = " << landed_speed_mps << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(
      CheckPositive(blind_land_depth_m) && blind_land_depth_m <= 10.0,
      "safety.blind_land_depth_m = " << blind_land_depth_m << ", accepted (0, 10]");
  KESTREL_THROW_UNLESS(CheckPositive(blind_landed_gap_m) && blind_landed_gap_m < blind_land_depth_m,
                       "safety.blind_landed_gap_m = " << blind_landed_gap_m
                                                      << ", accepted (0, blind_land_depth_m = "
                                                      << blind_land_depth_m << ")");
  KESTREL_THROW_UNLESS(std::isfinite(default_ground_z_m),
                       "safety.default_ground_z_m = " << default_ground_z_m << ", accepted finite");
  KESTREL_THROW_UNLESS(geofence_min_m.allFinite() && geofence_max_m.allFinite() &&
                           (geofence_min_m.array() < geofence_max_m.array()).all(),
                       "safety.geofence_min_m = ["
                           << geofence_min_m.transpose() << "], geofence_max_m = ["
                           << geofence_max_m.transpose() << "]: accepted finite with min < max");
  KESTREL_THROW_UNLESS(std::isfinite(geofence_margin_m) && geofence_margin_m >= 0.0,
                       "safety.geofence_margin_m = " << geofence_margin_m << ", accepted [0, inf)");
  KESTREL_THROW_UNLESS(CheckPositive(max_trajectory_start_offset_m),
                       "safety.max_trajectory_start_offset_m = " << max_trajectory_start_offset_m
                                                                 << ", accepted (0, inf)");
}

SafetySupervisor::SafetySupervisor(const SafetyConfig& config)
    : config_(config),
      ground_z_m_(config.default_ground_z_m),
      takeoff_height_m_(config.takeoff_height_m) {
  config_.Validate();
  decision_.reason = "start";
}

bool SafetySupervisor::PoseFresh(double time_s, double last_pose_time_s, double limit_s) const {
  return std::isfinite(last_pose_time_s) && time_s - last_pose_time_s <= limit_s;
}

FlatOutput SafetySupervisor::Clamp(FlatOutput setpoint) const {
  if (!setpoint.IsFinite()) {
    return FlatOutput::Hover(mode_start_setpoint_.position_m, mode_start_setpoint_.yaw_rad);
  }
  const Eigen::Vector3d clamped =
      setpoint.position_m.cwiseMax(config_.geofence_min_m).cwiseMin(config_.geofence_max_m);
  if (clamped != setpoint.position_m) return FlatOutput::Hover(clamped, setpoint.yaw_rad);
  return setpoint;
}

void SafetySupervisor::Enter(FlightMode mode, double time_s, const std::string& reason) {
  decision_.mode = mode;
  decision_.reason = reason;
  mode_start_time_s_ = time_s;
  mode_start_setpoint_ =
      FlatOutput::Hover(decision_.setpoint.position_m, decision_.setpoint.yaw_rad);
  if (mode != FlightMode::kHold) failsafe_hold_ = false;
}

bool SafetySupervisor::HandleCommand(FlightCommand command, double time_s,
                                     const VehicleState* state, double last_pose_time_s,
                                     double takeoff_height_m) {
  if (!std::isfinite(time_s)) return false;
  const FlightMode mode = decision_.mode;
  const bool flying = mode == FlightMode::kTakeoff || mode == FlightMode::kHold ||
                      mode == FlightMode::kTrack || mode == FlightMode::kLand;
  switch (command) {
    case FlightCommand::kEstop:
      Enter(FlightMode::kEstop, time_s, "ESTOP command");
      decision_.motors_enabled = false;
      return true;
    case FlightCommand::kIdle:
      if (mode == FlightMode::kEstop || mode == FlightMode::kIdle) {
        Enter(FlightMode::kIdle, time_s, "IDLE command");
        return true;
      }
      return false;  // motors off in flight only through ESTOP
    case FlightCommand::kTakeoff:
      if (mode != FlightMode::kIdle || state == nullptr || !state->IsValid(1e-3) ||
          !PoseFresh(time_s, last_pose_time_s, config_.pose_timeout_s)) {
        return false;
      }
      ground_z_m_ = state->position_m.z();
      takeoff_height_m_ = (std::isfinite(takeoff_height_m) && takeoff_height_m > 0.0)
                              ? std::min(takeoff_height_m, 10.0)
                              : config_.takeoff_height_m;
      decision_.setpoint = Clamp(FlatOutput::Hover(state->position_m, YawOfRotation(state->R_WB)));
      Enter(FlightMode::kTakeoff, time_s, "TAKEOFF command");
      return true;
    case FlightCommand::kHold:
      if (!flying) return false;
      Enter(FlightMode::kHold, time_s, "HOLD command");
      return true;
    case FlightCommand::kLand:
      if (mode == FlightMode::kIdle || mode == FlightMode::kLand) return true;
      if (!flying) return false;
      Enter(FlightMode::kLand, time_s, "LAND command");
      return true;
    case FlightCommand::kTrack:
      if ((mode != FlightMode::kHold && mode != FlightMode::kTrack) || !trajectory_.has_value() ||
          time_s > trajectory_->end_time_s() + config_.trajectory_timeout_s) {
        return false;
      }
      Enter(FlightMode::kTrack, time_s, "TRACK command");
      return true;
  }
  return false;  // not a valid enumerator
}

bool SafetySupervisor::AcceptTrajectory(const PiecewisePolynomialTrajectory& trajectory,
                                        double time_s, std::string* reason) {
  const double margin = 1e-9;
  for (const TrajectorySample& sample : trajectory.Sample(0.05)) {
    const Eigen::Vector3d& p = sample.flat.position_m;
    if ((p.array() < config_.geofence_min_m.array() - margin).any() ||
        (p.array() > config_.geofence_max_m.array() + margin).any()) {
      if (reason != nullptr) {
        *reason = "trajectory leaves the geofence at t = " + std::to_string(sample.time_s) +
                  " s, p = (" + std::to_string(p.x()) + ", " + std::to_string(p.y()) + ", " +
                  std::to_string(p.z()) + ")";
      }
      return false;
    }
  }
  if (decision_.mode == FlightMode::kTakeoff) {
    // The same rise as the take-off set point's (Update): off the ground, a trajectory (the
    // explorer's climb and start-up turn) takes over the climb.
    const double rise = std::min(
        config_.takeoff_speed_mps * std::max(0.0, time_s - mode_start_time_s_), takeoff_height_m_);
    if (!(rise >= config_.takeoff_track_min_rise_m)) {
      if (reason != nullptr) {
        *reason = "TAKEOFF: the set point has risen " + std::to_string(rise) +
                  " m, less than takeoff_track_min_rise_m = " +
                  std::to_string(config_.takeoff_track_min_rise_m) + " m";
      }
      return false;
    }
  }
  const bool flown_now = (decision_.mode == FlightMode::kHold && !failsafe_hold_) ||
                         decision_.mode == FlightMode::kTrack;
  if (flown_now) {
    // No set-point step (docs/design.md §2.5): the trajectory must start near the set point.
    const FlatOutput next = trajectory.Evaluate(std::max(time_s, trajectory.start_time_s()));
    const double offset = (next.position_m - decision_.setpoint.position_m).norm();
    if (!(offset <= config_.max_trajectory_start_offset_m)) {
      if (reason != nullptr) {
        *reason = std::string(kFarStartReason) + ": its set point now is " +
                  std::to_string(offset) +
                  " m from the current one (max_trajectory_start_offset_m = " +
                  std::to_string(config_.max_trajectory_start_offset_m) + " m)";
      }
      return false;
    }
  }
  trajectory_ = trajectory;
  if ((decision_.mode == FlightMode::kHold && !failsafe_hold_) ||
      decision_.mode == FlightMode::kTrack || decision_.mode == FlightMode::kTakeoff) {
    Enter(FlightMode::kTrack, time_s, "new trajectory");
  }
  if (reason != nullptr) reason->clear();
  return true;
}

bool SafetySupervisor::Takeover(double time_s, const VehicleState& state, double last_pose_time_s,
                                double ground_z_m, bool landing, std::string* reason) {
  std::string why;
  if (decision_.mode != FlightMode::kIdle) {
    why = std::string("takeover refused in mode ") + ToString(decision_.mode);
  } else if (!std::isfinite(time_s) || !state.IsValid(1e-3)) {
    why = "takeover refused: no valid state estimate";
  } else if (!PoseFresh(time_s, last_pose_time_s, config_.pose_timeout_s)) {
    why = "takeover refused: no fresh pose";
  } else if (!std::isfinite(ground_z_m)) {
    why = "takeover refused: non-finite ground height";
  }
  if (!why.empty()) {
    if (reason != nullptr) *reason = why;
    return false;
  }
  ground_z_m_ = ground_z_m;
  trajectory_.reset();
  // Where the vehicle is, at rest: no set-point step (the law brakes what motion there is).
  decision_.setpoint = Clamp(FlatOutput::Hover(state.position_m, YawOfRotation(state.R_WB)));
  Enter(landing ? FlightMode::kLand : FlightMode::kHold, time_s,
        landing ? "takeover after a controller restart: landing resumed"
                : "takeover after a controller restart: holding");
  decision_.motors_enabled = true;
  decision_.reset_integrals = true;
  if (reason != nullptr) reason->clear();
  return true;
}

SafetyDecision SafetySupervisor::Update(double time_s, const VehicleState* state,
                                        double last_pose_time_s) {
  if (!std::isfinite(time_s)) return decision_;
  const auto flying = [this] {
    const FlightMode m = decision_.mode;
    return m == FlightMode::kTakeoff || m == FlightMode::kHold || m == FlightMode::kTrack ||
           m == FlightMode::kLand;
  };
  const bool state_ok = state != nullptr && state->IsValid(1e-3);

  // Failsafes (see the file comment for the order).
  if (flying() && !state_ok) {
    Enter(FlightMode::kEstop, time_s, "non-finite or missing state estimate in flight");
  } else if (flying() && decision_.mode != FlightMode::kLand &&
             !PoseFresh(time_s, last_pose_time_s, config_.land_timeout_s)) {
    Enter(FlightMode::kLand, time_s, "pose lost longer than land_timeout_s");
  } else if (flying() && !PoseFresh(time_s, last_pose_time_s, config_.pose_timeout_s)) {
    if (decision_.mode == FlightMode::kTrack || decision_.mode == FlightMode::kTakeoff) {
      resume_mode_ = decision_.mode;
      Enter(FlightMode::kHold, time_s, "pose stale: holding on the IMU-propagated state");
      failsafe_hold_ = true;
    }
  } else if (failsafe_hold_ && decision_.mode == FlightMode::kHold) {
    failsafe_hold_ = false;
    if (resume_mode_ == FlightMode::kTrack && trajectory_.has_value() &&
        time_s <= trajectory_->end_time_s() + config_.trajectory_timeout_s) {
      Enter(FlightMode::kTrack, time_s, "poses returned: tracking resumed");
    } else {
      decision_.reason = "poses returned";
    }
  }
  if (flying() && state_ok && decision_.mode != FlightMode::kLand) {
    const Eigen::Vector3d& p = state->position_m;
    const double m = config_.geofence_margin_m;
    if ((p.array() < config_.geofence_min_m.array() - m).any() ||
        (p.array() > config_.geofence_max_m.array() + m).any()) {
      Enter(FlightMode::kLand, time_s, "vehicle outside the geofence");
    }
  }

  // Progress of the current mode and its set point.
  const double t_mode = std::max(0.0, time_s - mode_start_time_s_);
  FlatOutput setpoint = mode_start_setpoint_;
  decision_.reset_integrals = false;
  bool blind_land = false;
  switch (decision_.mode) {
    case FlightMode::kIdle:
    case FlightMode::kEstop:
      if (state_ok) setpoint = FlatOutput::Hover(state->position_m, YawOfRotation(state->R_WB));
      decision_.reset_integrals = true;
      break;
    case FlightMode::kTakeoff: {
      const double rise = std::min(config_.takeoff_speed_mps * t_mode, takeoff_height_m_);
      setpoint.position_m.z() += rise;
      if (rise < takeoff_height_m_) setpoint.velocity_mps.z() = config_.takeoff_speed_mps;
      decision_.reset_integrals = true;  // no wind-up against the ground
      if (rise >= takeoff_height_m_ && state_ok &&
          (state->position_m - setpoint.position_m).norm() < config_.takeoff_done_tolerance_m) {
        decision_.setpoint = setpoint;
        Enter(FlightMode::kHold, time_s, "take-off complete");
      }
      break;
    }
    case FlightMode::kHold:
      break;
    case FlightMode::kTrack:
      if (!trajectory_.has_value() ||
          time_s > trajectory_->end_time_s() + config_.trajectory_timeout_s) {
        decision_.setpoint =
            trajectory_.has_value() ? Clamp(trajectory_->Evaluate(time_s)) : decision_.setpoint;
        Enter(FlightMode::kHold, time_s, "trajectory stale");
        setpoint = mode_start_setpoint_;
      } else {
        setpoint = trajectory_->Evaluate(time_s);
      }
      break;
    case FlightMode::kLand: {
      // Blind (no fresh pose): the estimated height drifts, so descend deeper and detect the
      // touchdown by the vehicle no longer following the set point down (see SafetyConfig).
      blind_land = !PoseFresh(time_s, last_pose_time_s, config_.pose_timeout_s);
      const double floor_z =  // aim below the ground
          ground_z_m_ - (blind_land ? config_.blind_land_depth_m : 0.2);
      const double z = mode_start_setpoint_.position_m.z() - config_.land_speed_mps * t_mode;
      setpoint.position_m.z() = std::max(z, floor_z);
      if (z > floor_z) setpoint.velocity_mps.z() = -config_.land_speed_mps;
      const bool slow = state_ok && state->velocity_mps.norm() < config_.landed_speed_mps;
      // Blind: the vehicle stopped following the set point down (the IMU saw the touchdown), or
      // the set point reached its deepest point (the IMU need not see a soft touchdown: resting
      // on the floor with about its weight in thrust it reads what it read while descending at
      // constant speed, so the estimate keeps descending with the set point; stopping the set
      // point there would lift the vehicle off).
      const bool landed =
          blind_land ? (slow && setpoint.position_m.z() <
                                    state->position_m.z() - config_.blind_landed_gap_m) ||
                           z <= floor_z
                     : slow && state->position_m.z() <= ground_z_m_ + config_.landed_height_m;
      if (landed) {
        decision_.setpoint = Clamp(setpoint);
        Enter(FlightMode::kIdle, time_s,
              blind_land ? "landed (no poses: the vehicle stopped following the set point down)"
                         : "landed");
        decision_.reset_integrals = true;
        blind_land = false;
      }
      break;
    }
  }
  decision_.setpoint = Clamp(setpoint);
  // A blind landing set point may go below the geofence floor (the real floor stops the vehicle).
  if (blind_land) {
    decision_.setpoint.position_m.z() =
        std::min(decision_.setpoint.position_m.z(), setpoint.position_m.z());
    decision_.setpoint.velocity_mps.z() = setpoint.velocity_mps.z();
  }
  decision_.motors_enabled = flying();
  return decision_;
}

}  // namespace kestrel
