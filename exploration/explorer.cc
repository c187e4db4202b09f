#include "exploration/explorer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>

#include "common/check.h"
#include "exploration/startup_turn.h"

namespace kestrel {
namespace {

// CPU time of the calling thread, s: what a replan costs one core, whatever else the machine runs.
double ThreadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

double SecondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// A goal counts as reached when the vehicle passes this near it (non-stop flight), m.
constexpr double kGoalReachedRadius = 0.3;
// The controller has this long to fly the start-up trajectory, s.
constexpr double kStartupFlownWithin = 1.0;
// After the start-up turn (and the flight home) the vehicle settles this long, s.
constexpr double kSettle = 0.5;

}  // namespace

const char* ToString(ReplanReason reason) {
  switch (reason) {
    case ReplanReason::kStartupDone:
      return "start-up turn done";
    case ReplanReason::kTrajectoryEnded:
      return "trajectory ended";
    case ReplanReason::kReplanPeriod:
      return "replan period";
    case ReplanReason::kPathUnsafe:
      return "remaining path unsafe";
    case ReplanReason::kTooNearPeer:
      return "too near another vehicle ahead";
    case ReplanReason::kControllerHolds:
      return "the controller holds";
    case ReplanReason::kResumed:
      return "resumed after a restart";
    case ReplanReason::kExplorationEnded:
      return "exploration ended";
    case ReplanReason::kRetryHome:
      return "retrying the flight home";
  }
  return "unknown";
}

const char* ToString(ExplorerEvent event) {
  switch (event) {
    case ExplorerEvent::kYielded:
      return "yielded";
    case ExplorerEvent::kReplanKept:
      return "replan_kept";
    case ExplorerEvent::kStartNotMatched:
      return "start_not_matched";
    case ExplorerEvent::kStopped:
      return "stopped";
    case ExplorerEvent::kStopNotClear:
      return "stop_not_clear";
    case ExplorerEvent::kSpliceFailed:
      return "splice_failed";
    case ExplorerEvent::kEndDeferred:
      return "end_deferred";
    case ExplorerEvent::kStartupNotFlown:
      return "startup_not_flown";
    case ExplorerEvent::kStartupFailed:
      return "startup_failed";
    case ExplorerEvent::kControllerHolds:
      return "controller_holds";
    case ExplorerEvent::kPlanFailed:
      return "plan_failed";
  }
  return "unknown";
}

ReplanUse ChooseReplanUse(bool start_matched, bool in_flight, bool periodic_replan,
                          bool remaining_path_clear) {
  if (start_matched || !in_flight) return ReplanUse::kPublish;
  return periodic_replan && remaining_path_clear ? ReplanUse::kKeep : ReplanUse::kStop;
}

namespace {

UnlearnedCellsConfig UnlearnedConfigOf(const ExplorerConfig& config) {
  UnlearnedCellsConfig c;
  c.enabled = config.unlearned_looks > 0 && IsVolumetric(config.planner.mode);
  c.looks = std::max(2, config.unlearned_looks);
  c.min_entropy_drop_nats = config.unlearned_min_entropy_drop_nats;
  c.certain_probability = config.planner.projection.p_min_entropy;
  return c;
}

}  // namespace

Explorer::Explorer(const ExplorerConfig& config, int64_t epoch, PlanningTime planning_time)
    : config_(config),
      epoch_(epoch),
      planning_time_(planning_time),
      planner_(MakePlanner(config.planner)),
      unlearned_(UnlearnedConfigOf(config)) {
  config_.Validate();
  peers_.resize(config_.peers.size());
  for (size_t k = 0; k < peers_.size(); ++k) peers_[k].name = config_.peers[k];
}

// --- Inputs.

bool Explorer::Restore(const ExplorerRecord& record) {
  const bool resumable =
      record.state == ExplorerState::kStartup || record.state == ExplorerState::kExploring ||
      record.state == ExplorerState::kReturning || record.state == ExplorerState::kDone;
  if (!resumable || !record.home_xy_m.allFinite() || !std::isfinite(record.home_yaw_rad) ||
      !std::isfinite(record.lowest_z_m)) {
    return false;
  }
  resume_ = record.state;
  home_xy_ = record.home_xy_m;
  home_yaw_rad_ = record.home_yaw_rad;
  lowest_z_m_ = record.lowest_z_m;
  end_rule_ = record.end_rule;
  return true;
}

ExplorerRecord Explorer::Record() const {
  ExplorerRecord r;
  r.state = state_;
  r.home_xy_m = home_xy_;
  r.home_yaw_rad = home_yaw_rad_;
  r.lowest_z_m = lowest_z_m_;
  r.end_rule = end_rule_;
  return r;
}

bool Explorer::OnPose(double time_s, const Pose3& X_WB) {
  if (!std::isfinite(time_s) || !X_WB.p.allFinite() || !X_WB.q.coeffs().allFinite()) return false;
  pose_ = X_WB;
  have_pose_ = true;
  const bool flying = state_ != ExplorerState::kWaiting && state_ != ExplorerState::kDone;
  if (state_ == ExplorerState::kWaiting) lowest_z_m_ = std::min(lowest_z_m_, X_WB.p.z());
  if (flying && (flown_path_.empty() ||
                 (flown_path_.back() - X_WB.p.head<2>()).norm() >= config_.flown_path_spacing_m)) {
    flown_path_.push_back(X_WB.p.head<2>());
  }
  const double yaw = YawOf(X_WB.q);
  if (flying &&
      (flown_views_.empty() ||
       (flown_views_.back().head<2>() - X_WB.p.head<2>()).norm() >= config_.flown_path_spacing_m ||
       std::abs(std::remainder(yaw - flown_views_.back().z(), 2.0 * M_PI)) >=
           kFlownViewYawStepRad)) {
    flown_views_.emplace_back(X_WB.p.x(), X_WB.p.y(), yaw);
  }
  return true;
}

void Explorer::OnControllerReport(const ControllerReport& report) {
  have_controller_ = true;
  controller_ = report;
  if (report.velocity_mps && report.velocity_mps->allFinite()) velocity_mps_ = *report.velocity_mps;
}

bool Explorer::OnPeerPose(size_t peer, double time_s, const Eigen::Vector3d& position_m) {
  if (peer >= peers_.size() || !position_m.allFinite() || !std::isfinite(time_s)) return false;
  if (peers_[peer].seen && time_s < peers_[peer].position_time_s) return false;  // older
  peers_[peer].position_m = position_m;
  peers_[peer].seen = true;
  peers_[peer].position_time_s = time_s;
  return true;
}

bool Explorer::OnPeerTrajectory(size_t peer, PiecewisePolynomialTrajectory trajectory) {
  if (peer >= peers_.size()) return false;
  peers_[peer].trajectory = std::move(trajectory);
  return true;
}

// --- The state machine.

std::vector<ExplorerAction> Explorer::Step(double time_s, const ExplorerMap& map) {
  actions_.clear();
  if (!std::isfinite(time_s)) return {};
  now_s_ = time_s;
  map_ = map;
  switch (state_) {
    case ExplorerState::kWaiting:
      StepWaiting();
      break;
    case ExplorerState::kStartup:
      StepStartup();
      break;
    case ExplorerState::kExploring:
      StepExploring();
      break;
    case ExplorerState::kReturning:
      StepReturning();
      break;
    case ExplorerState::kDone:
    case ExplorerState::kFailed:
      break;
  }
  return std::move(actions_);
}

void Explorer::StepWaiting() {
  if (!have_pose_ || !have_controller_ || !map_.current || now_s_ < next_attempt_s_) return;
  if (resume_ && Resume()) return;
  const double h = config_.planner.projection.height_m;
  const bool at_height = std::abs(pose_.p.z() - h) < config_.height_tolerance_m;
  const bool risen = pose_.p.z() >= lowest_z_m_ + config_.startup_min_rise_m;
  // The controller flies trajectories in HOLD and, once off the ground, in TAKEOFF
  // (control/safety.h); in the other modes the explorer does nothing.
  const ControllerMode mode = controller_.mode;
  const bool ready = config_.startup_while_climbing
                         ? (mode == ControllerMode::kTakeoff && risen) ||
                               (mode == ControllerMode::kHold && (risen || at_height))
                         : mode == ControllerMode::kHold && at_height;
  if (!ready) return;
  home_xy_ = pose_.p.head<2>();
  home_yaw_rad_ = YawOf(pose_.q);
  if (StartTurn()) {
    state_ = ExplorerState::kStartup;
    startup_flown_ = false;
  } else {
    next_attempt_s_ = now_s_ + config_.retry_period_s;
  }
}

void Explorer::StepStartup() {
  // Our trajectory, not a predecessor's with the same seq (docs/design.md §3.4).
  if (controller_.mode == ControllerMode::kTrack && controller_.trajectory_seq == trajectory_seq_ &&
      controller_.trajectory_epoch == epoch_) {
    startup_flown_ = true;
  }
  if (!startup_flown_ && now_s_ > trajectory_->start_time_s() + kStartupFlownWithin) {
    // Refused or not flown (e.g. a failsafe hold): nothing is commanded; wait and retry.
    Event(ExplorerEvent::kStartupNotFlown,
          "the controller did not fly the start-up trajectory (mode " +
              std::to_string(static_cast<int>(controller_.mode)) + ")");
    state_ = ExplorerState::kWaiting;
    trajectory_.reset();
    next_attempt_s_ = now_s_ + config_.retry_period_s;
  } else if (now_s_ > trajectory_->end_time_s() + kSettle) {
    state_ = ExplorerState::kExploring;
    Plan(ReplanReason::kStartupDone);
  }
}

void Explorer::StepExploring() {
  if (ControllerHoldsWithoutOurTrajectory()) {
    // A controller that took over after a restart, or refused a far-start trajectory, holds:
    // plan again from where the vehicle is (docs/design.md §2.5).
    Event(ExplorerEvent::kControllerHolds,
          "the controller holds without flying the latest trajectory: replanning from the flown "
          "state");
    trajectory_.reset();
    Plan(ReplanReason::kControllerHolds);
    return;
  }
  if (now_s_ < next_attempt_s_) return;
  const bool ended = !trajectory_.has_value() || now_s_ >= trajectory_->end_time_s();
  RememberReachedGoal(ended);
  if (ended) {
    Plan(ReplanReason::kTrajectoryEnded);
  } else if (now_s_ - last_plan_s_ >= config_.replan_period_s &&
             trajectory_->end_time_s() - now_s_ > config_.replan_min_remaining_s) {
    Plan(ReplanReason::kReplanPeriod);
  } else if (now_s_ - last_safety_check_s_ >= config_.safety_check_period_s &&
             map_.seq != safety_checked_map_seq_) {
    last_safety_check_s_ = now_s_;
    safety_checked_map_seq_ = map_.seq;
    if (!RemainingPathSafe()) Plan(ReplanReason::kPathUnsafe);
  } else if (!peers_.empty() &&
             now_s_ - last_separation_check_s_ >= config_.safety_check_period_s) {
    last_separation_check_s_ = now_s_;
    if (!SeparationRefusal(*trajectory_, now_s_).empty()) Plan(ReplanReason::kTooNearPeer);
  }
}

void Explorer::StepReturning() {
  if (home_trajectory_ && ControllerHoldsWithoutOurTrajectory()) {
    Event(ExplorerEvent::kControllerHolds,
          "the controller holds without flying the flight home: planning it again");
    trajectory_.reset();
    home_trajectory_ = false;
    PlanHome(ReplanReason::kControllerHolds);
    return;
  }
  if (!home_trajectory_) {
    if (now_s_ >= next_attempt_s_) PlanHome(ReplanReason::kRetryHome);
    return;
  }
  // The flight home ends in the cell holding the take-off point (or the reachable one nearest
  // to it), or at a landing place elsewhere: land there.
  if (trajectory_.has_value() && now_s_ >= trajectory_->end_time_s() + kSettle) {
    if (landing_.empty()) {  // else: a landing place elsewhere (LandElsewhere)
      landing_ = "returned home (" + std::to_string((pose_.p.head<2>() - home_xy_).norm()) +
                 " m from the take-off point)";
    }
    actions_.push_back(LogLine{LogLevel::kInfo, landing_});
    Land();
    // The status says DONE too: processes watching EXPLORATION_STATUS (kestrel-flight-check,
    // the viewer, an operator) learn that exploration is over from it.
    ++plan_seq_;
    Status(std::make_shared<PlanResult>(), "home: land sent (" + end_rule_ + ", " + landing_ + ")",
           false);
  }
}

bool Explorer::Resume() {
  const bool airborne =
      controller_.mode == ControllerMode::kHold || controller_.mode == ControllerMode::kTrack;
  if (!airborne) {
    if (controller_.mode == ControllerMode::kLand && *resume_ == ExplorerState::kDone) {
      state_ = ExplorerState::kDone;  // landing as asked before the restart
      resume_.reset();
    }
    return false;  // on the ground, taking off or landing: as on a first start
  }
  const ExplorerState was = *resume_;
  resume_.reset();
  trajectory_.reset();
  resume_status_ = std::string("resumed ") + ToString(was) + " from the flown state at (" +
                   std::to_string(pose_.p.x()) + ", " + std::to_string(pose_.p.y()) + ", " +
                   std::to_string(pose_.p.z()) + ") m, controller in " +
                   (controller_.mode == ControllerMode::kHold ? "HOLD" : "TRACK");
  actions_.push_back(LogLine{LogLevel::kWarning, resume_status_});
  if (was == ExplorerState::kDone) {
    Land();
  } else if (was == ExplorerState::kReturning) {
    state_ = ExplorerState::kReturning;
    if (end_rule_.empty()) end_rule_ = "unknown (before a restart)";
    PlanHome(ReplanReason::kResumed);
  } else {
    state_ = ExplorerState::kExploring;
    Plan(ReplanReason::kResumed);
  }
  return true;
}

bool Explorer::ControllerHoldsWithoutOurTrajectory() const {
  return have_controller_ && controller_.mode == ControllerMode::kHold && trajectory_.has_value() &&
         now_s_ < trajectory_->end_time_s() &&
         now_s_ - last_publish_s_ >= config_.controller_hold_replan_s &&
         !(controller_.trajectory_seq == trajectory_seq_ && controller_.trajectory_epoch == epoch_);
}

void Explorer::RememberReachedGoal(bool trajectory_ended) {
  if (!last_plan_ || last_plan_->status != PlanStatus::kGoal || last_plan_->chosen < 0) return;
  // A goal counts as reached when its trajectory ends or, in non-stop flight (where trajectories
  // are replaced before they end), when the vehicle passes within kGoalReachedRadius of it.
  const Candidate& goal = last_plan_->candidates[static_cast<size_t>(last_plan_->chosen)];
  const Eigen::Vector3d g(goal.position_m.x(), goal.position_m.y(), goal.yaw_rad);
  const bool near = (pose_.p.head<2>() - goal.position_m).norm() < kGoalReachedRadius;
  if ((trajectory_ended || near) && (reached_goals_.empty() || reached_goals_.back() != g)) {
    reached_goals_.push_back(g);
    reached_views_.emplace_back(pose_.p.x(), pose_.p.y(), YawOf(pose_.q));
  }
}

// --- Plans.

void Explorer::PlanningTook(double wall_s) {
  if (planning_time_ == PlanningTime::kPasses) now_s_ += wall_s;
}

void Explorer::Plan(ReplanReason reason) {
  const auto t0 = std::chrono::steady_clock::now();
  const double cpu0 = ThreadCpuSeconds();
  PlannerInput input = PlanningInput();
  LookAndSetGainMap(&input);
  auto result = std::make_shared<PlanResult>(planner_->Plan(input));
  if (unlearned_.count() > 0) {
    result->unlearned_cells = static_cast<int64_t>(unlearned_.count());
  }
  PlanningTook(SecondsSince(t0));
  if (result->status == PlanStatus::kGoal && StallRuleApplies(planner_->mode(), config_) &&
      ProgressStalled()) {
    result->status = PlanStatus::kExplorationDone;
    result->end_rule = "progress stall";
    result->reason = "progress stalled: known cells grew by less than " +
                     std::to_string(100.0 * config_.end_stall_min_growth) + "% in " +
                     std::to_string(config_.end_stall_window_s) + " s";
  }
  const double plan_s = SecondsSince(t0);
  total_planning_s_ += plan_s;
  plan_times_s_.push_back(plan_s);
  plan_cpu_times_s_.push_back(ThreadCpuSeconds() - cpu0);
  plan_timings_.push_back(result->timings);
  plan_gain_stats_.push_back(result->volumetric_stats);
  last_plan_s_ = now_s_;
  ++plan_seq_;
  OnPlan(result.get(), reason);
  Status(result, ToString(reason), true);
  const bool returning = state_ == ExplorerState::kReturning;
  last_plan_ = std::move(result);
  if (returning) PlanHome(ReplanReason::kExplorationEnded);
}

void Explorer::OnPlan(PlanResult* result, ReplanReason reason) {
  // Every mode's trajectory is checked against the other vehicles (the volumetric planner has
  // already tried its next candidates).
  if (result->status == PlanStatus::kGoal && result->trajectory.trajectory.has_value()) {
    const std::string refusal = SeparationRefusal(*result->trajectory.trajectory);
    if (!refusal.empty()) {
      result->status = PlanStatus::kFailed;
      result->reason = "the trajectory is refused by the separation check: " + refusal;
      result->refused_trajectories = 1;
    }
  }
  const bool yielded = result->status == PlanStatus::kFailed && result->refused_trajectories > 0 &&
                       Yield(result->reason);
  if (yielded) {
    // Neither a goal nor a failure: plan again after retry_period_s.
  } else if (result->status == PlanStatus::kGoal && result->trajectory.trajectory.has_value()) {
    yielding_since_s_ = -1.0;
    failed_plans_ = 0;
    end_deferrals_ = 0;
    const bool matched = result->trajectory.start_matched;
    const bool in_flight = Splicing();
    const bool periodic = reason == ReplanReason::kReplanPeriod;
    // Evaluated only where it matters (a map check of the whole remaining path).
    const bool clear = !matched && in_flight && periodic && RemainingPathSafe();
    switch (ChooseReplanUse(matched, in_flight, periodic, clear)) {
      case ReplanUse::kKeep:
        // The replan could not start from the flown state (e.g. too close to its goal to stop
        // there at the acceleration limit). The flown trajectory is still clear, so keep it;
        // the next replan starts where it ends, at rest, if nothing better comes first.
        Event(ExplorerEvent::kReplanKept, "the replan could not start from the flown state");
        break;
      case ReplanUse::kStop:
        if (Stop()) break;
        [[fallthrough]];
      case ReplanUse::kPublish:
        if (!matched) {
          Event(ExplorerEvent::kStartNotMatched,
                "the new trajectory starts from a simplified state: a step in the set point");
        }
        PublishFrom(*result->trajectory.trajectory);
        break;
    }
  } else if (result->status == PlanStatus::kExplorationDone &&
             end_deferrals_ < config_.max_end_deferrals &&
             !ReachesWithin(*result, home_xy_, config_.planner.trajectory.vehicle_radius_m)) {
    // The end rules judge the space reachable now; without the take-off point in it, map noise
    // has closed a way the vehicle flew (e.g. a door jamb read a cell wider), and the verdict
    // covers part of the building only. Stop, let the map settle, plan again.
    ++end_deferrals_;
    Event(ExplorerEvent::kEndDeferred, "an end rule held with the take-off point unreachable (" +
                                           result->reason + "): stopping and planning again");
    if (trajectory_ && Splicing()) Stop();
    next_attempt_s_ = now_s_ + config_.retry_period_s;
  } else if (result->status == PlanStatus::kExplorationDone) {
    end_rule_ = result->end_rule.empty() ? "gain rule" : result->end_rule;
    actions_.push_back(
        LogLine{LogLevel::kInfo, "exploration ended by the " + end_rule_ + ": " + result->reason});
    state_ = ExplorerState::kReturning;
  } else {
    ++failed_plans_;
    Event(ExplorerEvent::kPlanFailed, result->reason);
    next_attempt_s_ = now_s_ + config_.retry_period_s;
    if (failed_plans_ >= config_.max_failed_plans) {
      end_rule_ = result->end_rule.empty() ? "planning failures" : result->end_rule;
      actions_.push_back(LogLine{LogLevel::kWarning, std::to_string(failed_plans_) +
                                                         " plans failed in a row (last: " +
                                                         result->reason + "): returning"});
      state_ = ExplorerState::kReturning;
    }
  }
}

bool Explorer::ProgressStalled() {
  if (config_.end_stall_window_s <= 0.0) return false;
  int64_t known = 0;
  const float lo = static_cast<float>(0.5 * config_.p_init);
  const size_t n = static_cast<size_t>(map_.view.dims.prod());
  for (size_t i = 0; i < n; ++i) {
    const float p = map_.view.probability[i];
    known += (p < lo || p > 0.5f) ? 1 : 0;
  }
  known_history_.emplace_back(now_s_, known);
  // The latest entry at least a window old; older ones are no longer needed.
  size_t ref = known_history_.size();
  for (size_t i = 0; i < known_history_.size(); ++i) {
    if (now_s_ - known_history_[i].first >= config_.end_stall_window_s) ref = i;
  }
  if (ref == known_history_.size()) return false;
  known_history_.erase(known_history_.begin(),
                       known_history_.begin() + static_cast<std::ptrdiff_t>(ref));
  const double then = static_cast<double>(known_history_.front().second);
  return static_cast<double>(known) - then < config_.end_stall_min_growth * then;
}

void Explorer::PlanHome(ReplanReason why) {
  const std::string reason = ToString(why);
  if (!config_.return_home) {
    landing_ = "landed where exploration ended (return_home off)";
    Land();
    return;
  }
  // After a first failure, the retries ask for the vehicle's radius only, without the margin,
  // and for the body's own height below h, without the tilt allowance, at half the speed and
  // acceleration (docs/exploration.md, "Ending and the flight home"): new map data (noise at a
  // door jamb or over a table top at the band's lower edge) can close a way the vehicle flew,
  // and a slow, careful flight home beats landing in an unknown place.
  PlannerConfig planner = config_.planner;
  const bool squeeze = home_attempts_ > 0;
  if (squeeze) {
    planner.volumetric.margin_m = 0.0;
    planner.volumetric.passage_margin_m = 0.0;
    planner.volumetric.band_below_m =
        std::min(planner.volumetric.band_below_m, planner.volumetric.band_above_m);
    planner.trajectory.max_speed_mps *= 0.5;
    planner.trajectory.max_acceleration_mps2 *= 0.5;
  }
  auto home =
      std::make_shared<PlanResult>(PlanToPoint(planner, PlanningInput(), home_xy_, home_yaw_rad_));
  PlanningTook(home->timings.total_s);
  ++plan_seq_;
  if (home->status == PlanStatus::kGoal && home->trajectory.trajectory.has_value()) {
    // Home in turn (docs/exploration.md, "Several vehicles"): a flight home that would come too
    // near another vehicle waits for it.
    const std::string refusal = SeparationRefusal(*home->trajectory.trajectory);
    if (!refusal.empty()) {
      home->status = PlanStatus::kFailed;
      home->reason = "the flight home is refused by the separation check: " + refusal;
      if (Yield(home->reason)) {
        next_attempt_s_ = now_s_ + config_.retry_period_s;
        Status(home, reason + " (" + end_rule_ + "): waiting for another vehicle", false);
        return;
      }
    }
  }
  ++home_attempts_;
  if (home->status == PlanStatus::kGoal && home->trajectory.trajectory.has_value()) {
    yielding_since_s_ = -1.0;
    home_trajectory_ = true;
    if (squeeze) {
      actions_.push_back(
          LogLine{LogLevel::kWarning, "path home found without the clearance margin (attempt " +
                                          std::to_string(home_attempts_) + ")"});
    }
    PublishFrom(*home->trajectory.trajectory);
    Status(home,
           reason + " (" + end_rule_ + "): flying home" + (squeeze ? " without the margin" : ""),
           false);
    return;
  }
  // No path home yet: hover (the trajectory being flown ends and the controller holds) and try
  // again, max_home_attempts times in all; then land where the vehicle is, and say why.
  next_attempt_s_ = now_s_ + config_.retry_period_s;
  if (home_attempts_ < config_.max_home_attempts) {
    actions_.push_back(LogLine{LogLevel::kWarning, "no path home (" + home->reason + "), attempt " +
                                                       std::to_string(home_attempts_) + " of " +
                                                       std::to_string(config_.max_home_attempts)});
    Status(home, reason + " (" + end_rule_ + "): no path home yet", false);
    return;
  }
  LandElsewhere(planner, *home, why);
  Status(home, reason + " (" + end_rule_ + "): " + landing_, false);
}

void Explorer::LandElsewhere(const PlannerConfig& planner, const PlanResult& home,
                             ReplanReason why) {
  landing_ = "landed elsewhere: no path home after " + std::to_string(home_attempts_) +
             " attempts (" + home.reason + "), ";
  // Not onto furniture: the nearest reachable place with known-free space under the vehicle's
  // disc from the ground to the flight (LandingCell), reached by the careful flight above.
  const PlannerInput input = PlanningInput();
  const double r = config_.planner.trajectory.vehicle_radius_m;
  const std::optional<int> spot =
      LandingCell(home, input.map, r, lowest_z_m_,
                  config_.planner.projection.height_m - planner.volumetric.band_below_m,
                  config_.planner.projection.collision_threshold);
  if (spot && home.traversability) {
    const GridMap2D& grid = home.traversability->band;
    const Eigen::Vector2d xy = grid.CenterOf(grid.CellAt(*spot));
    const std::optional<Cell2> own = grid.CellOf(pose_.p.head<2>());
    if (!own || grid.IndexOf(*own) != *spot) {
      auto to_spot = std::make_shared<PlanResult>(PlanToPoint(planner, input, xy, YawOf(pose_.q)));
      PlanningTook(to_spot->timings.total_s);
      ++plan_seq_;
      if (to_spot->status == PlanStatus::kGoal && to_spot->trajectory.trajectory.has_value() &&
          SeparationRefusal(*to_spot->trajectory.trajectory).empty()) {
        landing_ += std::to_string((xy - home_xy_).norm()) +
                    " m from the take-off point, on known-free ground " +
                    std::to_string((xy - pose_.p.head<2>()).norm()) + " m from where it stopped";
        actions_.push_back(LogLine{LogLevel::kWarning, landing_ + ": flying there"});
        home_trajectory_ = true;  // the trajectory ends where the vehicle lands
        PublishFrom(*to_spot->trajectory.trajectory);
        Status(to_spot,
               std::string(ToString(why)) + " (" + end_rule_ + "): flying to a landing place",
               false);
        return;
      }
    }
  }
  landing_ += std::to_string((pose_.p.head<2>() - home_xy_).norm()) + " m from the take-off point";
  if (!spot) landing_ += ", no known-free ground within reach: in place";
  actions_.push_back(LogLine{LogLevel::kWarning, landing_});
  Land();
}

bool Explorer::StartTurn() {
  // From the current state (docs/exploration.md, "Start-up: the turn while climbing"): the
  // vertical velocity of the controller's estimate, no horizontal motion (a take-off climbs
  // vertically), zero acceleration (the take-off set point climbs at constant speed).
  const double h = config_.planner.projection.height_m;
  TrajectoryStart start;
  start.position_m = pose_.p;
  start.velocity_mps = Eigen::Vector3d(0.0, 0.0, velocity_mps_.z());
  start.yaw_rad = YawOf(pose_.q);
  start.time_s = now_s_;
  StartupTurnLimits limits;
  limits.max_speed_mps = config_.planner.trajectory.max_speed_mps;
  limits.max_acceleration_mps2 = config_.planner.trajectory.max_acceleration_mps2;
  limits.peak_yaw_rate_radps =
      std::min(config_.startup_yaw_rate_radps, config_.planner.trajectory.max_yaw_rate_radps);
  limits.yaw_profile = config_.startup_yaw_profile;
  std::string error;
  const std::optional<PiecewisePolynomialTrajectory> turn =
      PlanStartupTurn(start, h, limits, &error);
  if (!turn.has_value()) {
    Event(ExplorerEvent::kStartupFailed, error);
    return false;
  }
  Publish(*turn);
  actions_.push_back(LogLine{
      LogLevel::kInfo, "start-up: from z = " + std::to_string(pose_.p.z()) + " m at " +
                           std::to_string(start.velocity_mps.z()) +
                           " m/s to h = " + std::to_string(h) + " m while turning a full circle, " +
                           std::to_string(turn->duration_s()) + " s"});
  return true;
}

// --- Flying: what goes out.

bool Explorer::Yield(const std::string& why) {
  if (yielding_since_s_ < 0.0) yielding_since_s_ = now_s_;
  if (now_s_ - yielding_since_s_ > config_.max_yield_s) return false;  // a failure from now on
  Event(ExplorerEvent::kYielded, why);
  // Keep flying what was checked, if it is still clear of the map and of the others; else stop.
  if (trajectory_ && Splicing() &&
      (!RemainingPathSafe() || !SeparationRefusal(*trajectory_, now_s_).empty())) {
    Stop();
  }
  next_attempt_s_ = now_s_ + config_.retry_period_s;
  return true;
}

bool Explorer::Stop() {
  // From the set point now, not after the splice's lookahead: the flown path ahead is no longer
  // clear, and a replan that steps the velocity there would stop the vehicle harder, later.
  TrajectoryStart now = StateAt(*trajectory_, now_s_);
  now.time_s = now_s_;
  std::optional<PiecewisePolynomialTrajectory> stop = PlanStop(now, config_.planner.trajectory);
  if (!stop) return false;  // not expected: a finite state always has a stop
  // The stop follows the velocity, not the map: where that line leaves the usable cells (into a
  // door jamb when the vehicle enters a door at an angle), the caller flies the checked replan.
  if (!TrajectoryStillClear(config_.planner, Input(), *stop, now.time_s - 0.5)) {
    Event(ExplorerEvent::kStopNotClear,
          "stopping on the line of flight would leave the usable cells: flying the replan");
    return false;
  }
  Event(ExplorerEvent::kStopped,
        "a replan could not start from the flown state and the flown path is no longer clear: "
        "stopping on the line of flight");
  Publish(*stop);
  return true;
}

bool Explorer::RemainingPathSafe() const {
  if (!trajectory_.has_value()) return true;
  if (now_s_ >= trajectory_->end_time_s()) return true;
  // The planner's own rule for the mode (exploration/planner.h, TrajectoryStillClear).
  return TrajectoryStillClear(config_.planner, Input(), *trajectory_, now_s_);
}

std::string Explorer::SeparationRefusal(const PiecewisePolynomialTrajectory& trajectory,
                                        double from_s) const {
  const double from = std::max(from_s, trajectory.start_time_s());
  for (const PeerMotion& peer : peers_) {
    const std::vector<PeerMotion> one{peer};
    const Separation s = ClosestApproach(trajectory, from, one, config_.min_vertical_separation_m);
    if (s.distance_m >= config_.min_separation_m) continue;
    // Already nearer than the minimum (tracking error, a take-off beside another): not nearer.
    const double start_m = SeparationAt(trajectory.Evaluate(from).position_m, peer, from,
                                        config_.min_vertical_separation_m);
    if (s.distance_m >= start_m - 0.02) continue;
    char text[160];
    std::snprintf(text, sizeof(text),
                  "%.2f m from vehicle %s %.1f s after its start (minimum %.2f m)", s.distance_m,
                  peer.name.c_str(), s.time_s - from, config_.min_separation_m);
    return text;
  }
  return "";
}

PlannerInput Explorer::Input() const {
  PlannerInput in;
  in.map = map_.view;
  in.position_m = pose_.p;
  in.velocity_mps = velocity_mps_;
  in.yaw_rad = YawOf(pose_.q);
  in.time_s = now_s_;
  in.startup_center_m = home_xy_;
  in.reached_goals = reached_goals_;
  in.reached_views = reached_views_;
  in.flown_path = flown_path_;
  in.flown_views = flown_views_;
  if (!peers_.empty()) {
    in.peer_goals = PeerGoals(peers_);
    in.trajectory_check = [this](const PiecewisePolynomialTrajectory& t) {
      return SeparationRefusal(t);
    };
  }
  // The goal being flown to (its trajectory has not ended): hysteresis for period replans.
  if (state_ == ExplorerState::kExploring && trajectory_.has_value() &&
      now_s_ < trajectory_->end_time_s() && last_plan_ && last_plan_->status == PlanStatus::kGoal &&
      last_plan_->chosen >= 0) {
    const Candidate& goal = last_plan_->candidates[static_cast<size_t>(last_plan_->chosen)];
    in.current_goal = Eigen::Vector3d(goal.position_m.x(), goal.position_m.y(), goal.yaw_rad);
  }
  return in;
}

void Explorer::LookAndSetGainMap(PlannerInput* input) {
  if (!unlearned_.config().enabled || !map_.view.probability) return;
  const VolumetricGainConfig& gain = config_.planner.volumetric.gain;
  unlearned_.Look(map_.view, CellsInView(map_.view, gain.sensors, pose_.p, YawOf(pose_.q),
                                         config_.unlearned_azimuth_bins, config_.unlearned_rows));
  if (unlearned_.count() == 0) return;
  const size_t n = static_cast<size_t>(map_.view.dims.prod());
  gain_map_.assign(map_.view.probability, map_.view.probability + n);
  unlearned_.ApplyTo(&gain_map_, config_.planner.projection.p_min_entropy);
  input->gain_map = map_.view;
  input->gain_map.probability = gain_map_.data();
}

bool Explorer::Splicing() const {
  return config_.nonstop && trajectory_.has_value() && now_s_ < trajectory_->end_time_s();
}

PlannerInput Explorer::PlanningInput() const {
  PlannerInput in = Input();
  if (!Splicing()) return in;
  // The state the flown trajectory predicts at the splice time: the new trajectory starts there.
  const double t = std::min(now_s_ + config_.replan_lookahead_s, trajectory_->end_time_s());
  in.SetStart(StateAt(*trajectory_, t));
  return in;
}

void Explorer::PublishFrom(const PiecewisePolynomialTrajectory& next) {
  if (trajectory_.has_value() && next.start_time_s() > now_s_) {
    if (std::optional<PiecewisePolynomialTrajectory> spliced = Splice(*trajectory_, now_s_, next)) {
      Publish(*spliced);
      return;
    }
    Event(ExplorerEvent::kSpliceFailed, "could not splice the replan onto the flown trajectory");
  }
  Publish(next);
}

void Explorer::Publish(const PiecewisePolynomialTrajectory& trajectory) {
  trajectory_ = trajectory;
  last_publish_s_ = now_s_;
  actions_.push_back(PublishTrajectory{trajectory, ++trajectory_seq_});
}

void Explorer::Status(std::shared_ptr<const PlanResult> plan, const std::string& reason,
                      bool replan) {
  actions_.push_back(PublishStatus{std::move(plan), reason, state_, plan_seq_, replan});
}

void Explorer::Land() {
  state_ = ExplorerState::kDone;
  if (config_.land_at_end) actions_.push_back(SendLand{});
}

void Explorer::Event(ExplorerEvent event, const std::string& what) {
  ++events_[static_cast<size_t>(event)];
  actions_.push_back(ReportEvent{event, what});
}

}  // namespace kestrel
