#include "exploration/explorer_node.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <numeric>

#include "common/check.h"
#include "common/config.h"
#include "common/identity.h"
#include "common/log.h"
#include "common/run_state_file.h"
#include "common/trajectory_message.h"
#include "common/vehicle_prefixes.h"
#include "exploration/planner_config_io.h"
#include "exploration/startup_turn.h"
#include "kestrel/command_t.hpp"
#include "kestrel/grid_map_t.hpp"
#include "mapping/mapping_config.h"

namespace kestrel {
namespace {

// Plan()'s reason for the periodic replan while a trajectory is flown.
constexpr const char* kReplanPeriod = "replan period";

}  // namespace

void ExplorerConfig::Validate() const {
  planner.Validate();
  map.Validate();
  KESTREL_THROW_UNLESS(p_init > 0 && p_init < 1, "map.p_init = " << p_init << " must be in (0, 1)");
  KESTREL_THROW_UNLESS(startup_yaw_rate_radps > 0, "explorer.startup_yaw_rate_radps = "
                                                       << startup_yaw_rate_radps << " must be > 0");
  KESTREL_THROW_UNLESS(startup_min_rise_m > 0,
                       "explorer.startup_min_rise_m = " << startup_min_rise_m << " must be > 0");
  KESTREL_THROW_UNLESS(height_tolerance_m > 0 && replan_period_s > 0 && safety_check_period_s > 0 &&
                           retry_period_s > 0,
                       "explorer periods and tolerances must be > 0");
  KESTREL_THROW_UNLESS(
      end_stall_window_s >= 0 && end_stall_min_growth >= 0 && end_stall_min_growth < 1,
      "explorer.end_stall_window_s = " << end_stall_window_s
                                       << " (accepted >= 0), end_stall_min_growth = "
                                       << end_stall_min_growth << " (accepted [0, 1))");
  KESTREL_THROW_UNLESS(
      replan_lookahead_s > 0 && flown_path_spacing_m > 0 && max_home_attempts >= 1,
      "explorer.replan_lookahead_s = "
          << replan_lookahead_s << ", flown_path_spacing_m = " << flown_path_spacing_m
          << " (accepted > 0), max_home_attempts = " << max_home_attempts << " (accepted >= 1)");
  KESTREL_THROW_UNLESS(max_end_deferrals >= 0,
                       "explorer.max_end_deferrals = " << max_end_deferrals << " must be >= 0");
  KESTREL_THROW_UNLESS(max_failed_plans >= 1,
                       "explorer.max_failed_plans = " << max_failed_plans << " must be >= 1");
  KESTREL_THROW_UNLESS(min_separation_m > 0 && min_vertical_separation_m > 0 && max_yield_s > 0,
                       "explorer.min_separation_m = "
                           << min_separation_m
                           << ", min_vertical_separation_m = " << min_vertical_separation_m
                           << ", max_yield_s = " << max_yield_s << ": accepted > 0");
  for (size_t i = 0; i < peer_prefixes.size(); ++i) {
    KESTREL_THROW_UNLESS(peer_prefixes[i] != vehicle_prefix,
                         "explorer.peers[" << i << "].prefix = '" << peer_prefixes[i]
                                           << "' is this vehicle's own prefix");
    for (size_t j = 0; j < i; ++j) {
      KESTREL_THROW_UNLESS(peer_prefixes[i] != peer_prefixes[j],
                           "explorer.peers[" << j << "] and [" << i << "] share the prefix '"
                                             << peer_prefixes[i] << "'");
    }
  }
  KESTREL_THROW_UNLESS(run_id.empty() || CheckRunId(run_id).empty(),
                       "explorer.run_id = '" << run_id << "': " << CheckRunId(run_id));
  KESTREL_THROW_UNLESS(
      controller_hold_replan_s > 0,
      "explorer.controller_hold_replan_s = " << controller_hold_replan_s << " must be > 0");
  KESTREL_THROW_UNLESS(max_status_candidates >= 1, "explorer.max_status_candidates = "
                                                       << max_status_candidates << " must be >= 1");
}

ExplorerConfig LoadExplorerConfig(const ConfigNode& node) {
  ExplorerConfig c;
  // The planner reads its own keys; the map and explorer sections are ours.
  if (node.Has("map")) {
    const ConfigNode m = node.Child("map");  // the mapper's keys (config/mapper.yaml)
    ReadMapLimits(m, &c.map);
    m.Read("p_init", &c.p_init, Range::Open(0.0, 1.0));
  }
  if (node.Has("explorer")) {
    const ConfigNode e = node.Child("explorer");
    e.Read("map_channel", &c.map_channel);
    e.Read("delta_channel", &c.delta_channel);
    e.Read("pose_channel", &c.pose_channel);
    e.Read("controller_channel", &c.controller_channel);
    e.Read("trajectory_channel", &c.trajectory_channel);
    e.Read("status_channel", &c.status_channel);
    e.Read("command_channel", &c.command_channel);
    e.Read("map2d_prefix", &c.map2d_prefix);
    e.Read("heartbeat_channel", &c.heartbeat_channel);
    e.Read("startup_yaw_rate_radps", &c.startup_yaw_rate_radps, Range::Positive());
    e.Read("height_tolerance_m", &c.height_tolerance_m, Range::Positive());
    e.Read("startup_while_climbing", &c.startup_while_climbing);
    e.Read("startup_min_rise_m", &c.startup_min_rise_m, Range::Positive());
    std::string profile =
        c.startup_yaw_profile == StartupYawProfile::kRamped ? "ramped" : "smoothstep";
    e.Read("startup_yaw_profile", &profile, {"smoothstep", "ramped"});
    c.startup_yaw_profile =
        profile == "ramped" ? StartupYawProfile::kRamped : StartupYawProfile::kSmoothstep;
    e.Read("replan_period_s", &c.replan_period_s, Range::Positive());
    e.Read("replan_min_remaining_s", &c.replan_min_remaining_s, Range::NonNegative());
    e.Read("end_stall_window_s", &c.end_stall_window_s, Range::NonNegative());
    e.Read("end_stall_min_growth", &c.end_stall_min_growth, Range{0.0, 1.0, true, false});
    e.Read("end_stall_in_volumetric", &c.end_stall_in_volumetric);
    e.Read("safety_check_period_s", &c.safety_check_period_s, Range::Positive());
    e.Read("retry_period_s", &c.retry_period_s, Range::Positive());
    e.Read("nonstop", &c.nonstop);
    e.Read("replan_lookahead_s", &c.replan_lookahead_s, Range::Positive());
    e.Read("max_home_attempts", &c.max_home_attempts, Range::Closed(1, 1000));
    e.Read("flown_path_spacing_m", &c.flown_path_spacing_m, Range::Positive());
    e.Read("max_failed_plans", &c.max_failed_plans, Range::Closed(1, 1000));
    e.Read("max_end_deferrals", &c.max_end_deferrals, Range::Closed(0, 1000));
    e.Read("return_home", &c.return_home);
    e.Read("land_at_end", &c.land_at_end);
    e.Read("max_status_candidates", &c.max_status_candidates, Range::Closed(1, 100000));
    e.Read("map2d_period_s", &c.map2d_period_s, Range::NonNegative());
    e.Read("vehicle_prefix", &c.vehicle_prefix);
    ReadVehiclePrefixes(e, "peers", &c.peer_prefixes);
    e.Read("min_separation_m", &c.min_separation_m, Range::Positive());
    e.Read("min_vertical_separation_m", &c.min_vertical_separation_m, Range::Positive());
    e.Read("max_yield_s", &c.max_yield_s, Range::Positive());
    e.Read("state_path", &c.state_path);
    e.Read("run_id", &c.run_id);
    e.Read("controller_hold_replan_s", &c.controller_hold_replan_s, Range::Positive());
  }
  // Last: the planner's reader also checks that no key of the file is left unread.
  c.planner = LoadPlannerConfig(node);
  try {
    c.Validate();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(node.file() + ": " + e.what());
  }
  return c;
}

ExplorerNode::ExplorerNode(lcm::LCM& lcm, const ExplorerConfig& config, const Clock& clock)
    : lcm_(lcm),
      config_(config),
      clock_(clock),
      planner_(MakePlanner(config.planner)),
      replica_(config.map.min_m, config.map.resolution_m,
               GridGeometry::Fixed(config.map).upper().x > 0
                   ? Eigen::Vector3i(GridGeometry::Fixed(config.map).upper().x,
                                     GridGeometry::Fixed(config.map).upper().y,
                                     GridGeometry::Fixed(config.map).upper().z)
                   : Eigen::Vector3i(1, 1, 1),
               config.p_init),
      drops_(clock),
      heartbeat_(lcm, clock, "kestrel-explorer", config.vehicle_prefix + config.heartbeat_channel),
      subscriptions_(lcm),
      epoch_(NewPublisherEpoch()) {
  config_.Validate();
  auto on_error = [this](const std::string& channel, const std::string& reason) {
    drops_.Count("malformed", channel + ": " + reason);
  };
  // The other vehicles read their channels by their prefixes and the unprefixed names; ours get
  // our prefix (docs/exploration.md, "Several vehicles").
  const ExplorerConfig base = config_;
  for (std::string* channel :
       {&config_.pose_channel, &config_.controller_channel, &config_.trajectory_channel,
        &config_.status_channel, &config_.command_channel, &config_.map2d_prefix,
        &config_.heartbeat_channel}) {
    *channel = config_.vehicle_prefix + *channel;
  }
  peers_.resize(config_.peer_prefixes.size());
  for (size_t k = 0; k < peers_.size(); ++k) {
    PeerMotion* peer = &peers_[k];
    peer->name = config_.peer_prefixes[k];
    subscriptions_.Add<pose_t>(
        peer->name + base.pose_channel,
        [this, peer](const std::string&, const pose_t& m) {
          const Eigen::Vector3d p(m.position_m[0], m.position_m[1], m.position_m[2]);
          if (!m.valid) return;
          if (!p.allFinite()) {
            drops_.Count("nan_pose", peer->name + ": non-finite position");
            return;
          }
          peer->position_m = p;
          peer->seen = true;
          peer->position_time_s = now_s();
        },
        on_error);
    subscriptions_.Add<trajectory_t>(
        peer->name + base.trajectory_channel,
        [this, peer](const std::string& channel, const trajectory_t& m) {
          std::string error;
          std::optional<PiecewisePolynomialTrajectory> t = FromMessage(m, &error);
          if (!t) {
            drops_.Count("malformed", channel + ": " + error);
            return;
          }
          peer->trajectory = std::move(t);
        },
        on_error);
  }
  subscriptions_.Add<map3d_chunk_t>(
      config_.map_channel,
      [this](const std::string&, const map3d_chunk_t& m) {
        std::string error;
        if (!replica_.Apply(m, &error)) drops_.Count("map_chunk", error);
      },
      on_error);
  subscriptions_.Add<map3d_delta_t>(
      config_.delta_channel,
      [this](const std::string&, const map3d_delta_t& m) {
        std::string error;
        if (!replica_.Apply(m, &error)) drops_.Count("map_delta", error);
      },
      on_error);
  subscriptions_.Add<pose_t>(
      config_.pose_channel, [this](const std::string&, const pose_t& m) { OnPose(m); }, on_error);
  subscriptions_.Add<controller_status_t>(
      config_.controller_channel,
      [this](const std::string&, const controller_status_t& m) {
        have_controller_ = true;
        controller_mode_ = m.mode;
        controller_trajectory_seq_ = m.trajectory_seq;
        controller_trajectory_epoch_ = m.trajectory_epoch;
        bool finite = true;
        for (double v : m.velocity_mps) finite = finite && std::isfinite(v);
        if (finite)
          velocity_mps_ = Eigen::Vector3d(m.velocity_mps[0], m.velocity_mps[1], m.velocity_mps[2]);
      },
      on_error);
  heartbeat_.SetState(heartbeat_t::STATE_OK);
  run_id_ = config_.run_id.empty() ? NewRunId() : config_.run_id;
  ReadStateFile();
}

namespace {
const char* StateName(int8_t state) {
  switch (state) {
    case exploration_status_t::STATE_WAITING:
      return "WAITING";
    case exploration_status_t::STATE_STARTUP:
      return "STARTUP";
    case exploration_status_t::STATE_EXPLORING:
      return "EXPLORING";
    case exploration_status_t::STATE_RETURNING:
      return "RETURNING";
    case exploration_status_t::STATE_DONE:
      return "DONE";
    default:
      return "FAILED";
  }
}
}  // namespace

void ExplorerNode::ReadStateFile() {
  if (config_.state_path.empty()) return;
  RunStateFile file;
  std::string why;
  const RunStateRead read = ReadRunStateFile(config_.state_path, "explorer", run_id_, &file, &why);
  if (read != RunStateRead::kOk) {
    resume_status_ = why + ": starting as on a first start";
    Log(read == RunStateRead::kCorrupt ? LogLevel::kError : LogLevel::kInfo, resume_status_);
    return;
  }
  const std::string* state = file.Find("state");
  double x = 0, y = 0, yaw = 0, lowest = 0;
  if (state == nullptr || !file.GetDouble("home_x_m", &x) || !file.GetDouble("home_y_m", &y) ||
      !file.GetDouble("home_yaw_rad", &yaw) || !file.GetDouble("lowest_z_m", &lowest)) {
    resume_status_ = "corrupt state file " + config_.state_path +
                     ": no state, home or lowest height; starting as on a first start";
    Log(LogLevel::kError, resume_status_);
    return;
  }
  for (int8_t s : {exploration_status_t::STATE_STARTUP, exploration_status_t::STATE_EXPLORING,
                   exploration_status_t::STATE_RETURNING, exploration_status_t::STATE_DONE}) {
    if (*state == StateName(s)) resume_state_ = s;
  }
  if (resume_state_ < 0) {
    resume_status_ =
        "restarted before exploring (was " + *state + "): starting as on a first start";
    Log(LogLevel::kInfo, resume_status_);
    return;
  }
  home_xy_ = Eigen::Vector2d(x, y);
  home_yaw_rad_ = yaw;
  lowest_z_m_ = lowest;
  if (const std::string* rule = file.Find("end_rule")) {
    end_rule_ = *rule;
    std::replace(end_rule_.begin(), end_rule_.end(), '_', ' ');
  }
  resume_status_ = "restarted within run " + run_id_ + " (was " + *state +
                   "): resuming from the flown state once the vehicle is seen airborne";
  Log(LogLevel::kWarning, resume_status_);
}

void ExplorerNode::WriteStateFile() {
  if (config_.state_path.empty() || state_ == saved_state_) return;
  // Before the start-up nothing is resumable: no take-off point yet.
  if (state_ == exploration_status_t::STATE_WAITING && resume_state_ < 0 && saved_state_ < 0) {
    return;
  }
  RunStateFile file;
  file.kind = "explorer";
  file.run_id = run_id_;
  file.values["state"] = StateName(state_);
  char number[64];
  const auto put = [&](const char* key, double v) {
    std::snprintf(number, sizeof(number), "%.17g", v);
    file.values[key] = number;
  };
  put("home_x_m", home_xy_.x());
  put("home_y_m", home_xy_.y());
  put("home_yaw_rad", home_yaw_rad_);
  put("lowest_z_m", lowest_z_m_);
  if (!end_rule_.empty()) {  // one word in the file: spaces as '_'
    std::string rule = end_rule_;
    std::replace(rule.begin(), rule.end(), ' ', '_');
    file.values["end_rule"] = rule;
  }
  std::string error;
  if (WriteRunStateFile(config_.state_path, file, &error)) {
    saved_state_ = state_;
  } else {
    drops_.Count("state_file", error);
  }
}

bool ExplorerNode::Resume() {
  const bool airborne = controller_mode_ == controller_status_t::MODE_HOLD ||
                        controller_mode_ == controller_status_t::MODE_TRACK;
  if (!airborne) {
    if (controller_mode_ == controller_status_t::MODE_LAND &&
        resume_state_ == exploration_status_t::STATE_DONE) {
      state_ = exploration_status_t::STATE_DONE;  // landing as asked before the restart
      resume_state_ = -1;
    }
    return false;  // on the ground, taking off or landing: as on a first start
  }
  const int8_t was = resume_state_;
  resume_state_ = -1;
  trajectory_.reset();
  resume_status_ = std::string("resumed ") + StateName(was) + " from the flown state at (" +
                   std::to_string(pose_.p.x()) + ", " + std::to_string(pose_.p.y()) + ", " +
                   std::to_string(pose_.p.z()) + ") m, controller in " +
                   (controller_mode_ == controller_status_t::MODE_HOLD ? "HOLD" : "TRACK");
  Log(LogLevel::kWarning, resume_status_);
  if (was == exploration_status_t::STATE_DONE) {
    SendLand();
  } else if (was == exploration_status_t::STATE_RETURNING) {
    state_ = exploration_status_t::STATE_RETURNING;
    if (end_rule_.empty()) end_rule_ = "unknown (before a restart)";
    PlanHome("resumed after a restart");
  } else {
    state_ = exploration_status_t::STATE_EXPLORING;
    Plan("resumed after a restart");
  }
  return true;
}

bool ExplorerNode::ControllerHoldsWithoutOurTrajectory(double t) const {
  return have_controller_ && controller_mode_ == controller_status_t::MODE_HOLD &&
         trajectory_.has_value() && t < trajectory_->end_time_s() &&
         t - last_publish_s_ >= config_.controller_hold_replan_s &&
         !(controller_trajectory_seq_ == trajectory_seq_ && controller_trajectory_epoch_ == epoch_);
}

void ExplorerNode::OnPose(const pose_t& msg) {
  if (!msg.valid) return;
  Pose3 X_WB;
  for (double v : msg.position_m) {
    if (!std::isfinite(v)) {
      drops_.Count("nan_pose", "non-finite position");
      return;
    }
  }
  if (!QuaternionFromWxyz(msg.orientation_wxyz, &X_WB.q)) {
    drops_.Count("nan_pose", "non-unit or non-finite quaternion");
    return;
  }
  X_WB.p = Eigen::Vector3d(msg.position_m[0], msg.position_m[1], msg.position_m[2]);
  pose_ = X_WB;
  have_pose_ = true;
  if (state_ == exploration_status_t::STATE_WAITING)
    lowest_z_m_ = std::min(lowest_z_m_, X_WB.p.z());
  if (state_ != exploration_status_t::STATE_WAITING && state_ != exploration_status_t::STATE_DONE &&
      (flown_path_.empty() ||
       (flown_path_.back() - X_WB.p.head<2>()).norm() >= config_.flown_path_spacing_m)) {
    flown_path_.push_back(X_WB.p.head<2>());
  }
  const double yaw = YawOf(X_WB.q);
  if (state_ != exploration_status_t::STATE_WAITING && state_ != exploration_status_t::STATE_DONE &&
      (flown_views_.empty() ||
       (flown_views_.back().head<2>() - X_WB.p.head<2>()).norm() >= config_.flown_path_spacing_m ||
       std::abs(std::remainder(yaw - flown_views_.back().z(), 2.0 * M_PI)) >=
           kFlownViewYawStepRad)) {
    flown_views_.emplace_back(X_WB.p.x(), X_WB.p.y(), yaw);
  }
}

PlannerInput ExplorerNode::Input() const {
  PlannerInput in;
  in.map.dims = replica_.dims();
  in.map.origin_m = replica_.origin_m();
  in.map.resolution_m = replica_.resolution_m();
  in.map.probability = replica_.probabilities().data();
  in.position_m = pose_.p;
  in.velocity_mps = velocity_mps_;
  in.yaw_rad = YawOf(pose_.q);
  in.time_s = now_s();
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
  if (state_ == exploration_status_t::STATE_EXPLORING && trajectory_.has_value() &&
      now_s() < trajectory_->end_time_s() && last_plan_ &&
      last_plan_->status == PlanStatus::kGoal && last_plan_->chosen >= 0) {
    const Candidate& goal = last_plan_->candidates[static_cast<size_t>(last_plan_->chosen)];
    in.current_goal = Eigen::Vector3d(goal.position_m.x(), goal.position_m.y(), goal.yaw_rad);
  }
  return in;
}

bool ExplorerNode::Splicing(double now) const {
  return config_.nonstop && trajectory_.has_value() && now < trajectory_->end_time_s();
}

PlannerInput ExplorerNode::PlanningInput() const {
  PlannerInput in = Input();
  const double now = now_s();
  if (!Splicing(now)) return in;
  // The state the flown trajectory predicts at the splice time: the new trajectory starts there.
  const double t = std::min(now + config_.replan_lookahead_s, trajectory_->end_time_s());
  in.SetStart(StateAt(*trajectory_, t));
  return in;
}

void ExplorerNode::PublishFrom(const PiecewisePolynomialTrajectory& next) {
  const double now = now_s();
  if (trajectory_.has_value() && next.start_time_s() > now) {
    if (std::optional<PiecewisePolynomialTrajectory> spliced = Splice(*trajectory_, now, next)) {
      Publish(*spliced);
      return;
    }
    drops_.Count("splice_failed", "could not splice the replan onto the flown trajectory");
  }
  Publish(next);
}

void ExplorerNode::Publish(const PiecewisePolynomialTrajectory& trajectory) {
  trajectory_ = trajectory;
  last_publish_s_ = now_s();
  const trajectory_t msg = ToMessage(trajectory, clock_.NowUtime(), ++trajectory_seq_, epoch_);
  lcm_.publish(config_.trajectory_channel, &msg);
}

bool ExplorerNode::StartTurn() {
  // From the current state (docs/exploration.md, "Start-up: the turn while climbing"): the
  // vertical velocity of the controller's estimate, no horizontal motion (a take-off climbs
  // vertically), zero acceleration (the take-off set point climbs at constant speed).
  const double h = config_.planner.projection.height_m;
  TrajectoryStart start;
  start.position_m = pose_.p;
  start.velocity_mps = Eigen::Vector3d(0.0, 0.0, velocity_mps_.z());
  start.yaw_rad = YawOf(pose_.q);
  start.time_s = now_s();
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
    drops_.Count("startup_failed", error);
    return false;
  }
  Publish(*turn);
  Log(LogLevel::kInfo, "start-up: from z = " + std::to_string(pose_.p.z()) + " m at " +
                           std::to_string(start.velocity_mps.z()) +
                           " m/s to h = " + std::to_string(h) + " m while turning a full circle, " +
                           std::to_string(turn->duration_s()) + " s");
  return true;
}

namespace {
// CPU time of the calling thread, s: what a replan costs one core, whatever else the machine runs.
double ThreadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}
}  // namespace

bool StallRuleApplies(ExplorationMode mode, const ExplorerConfig& config) {
  if (config.end_stall_window_s <= 0.0) return false;
  return mode != ExplorationMode::kVolumetric || config.end_stall_in_volumetric;
}

void ExplorerNode::Plan(const std::string& reason) {
  const auto t0 = std::chrono::steady_clock::now();
  const double cpu0 = ThreadCpuSeconds();
  PlanResult result = planner_->Plan(PlanningInput());
  if (result.status == PlanStatus::kGoal && StallRuleApplies(planner_->mode(), config_) &&
      ProgressStalled()) {
    result.status = PlanStatus::kExplorationDone;
    result.end_rule = "progress stall";
    result.reason = "progress stalled: known cells grew by less than " +
                    std::to_string(100.0 * config_.end_stall_min_growth) + "% in " +
                    std::to_string(config_.end_stall_window_s) + " s";
  }
  const double plan_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  total_planning_s_ += plan_s;
  plan_times_s_.push_back(plan_s);
  plan_cpu_times_s_.push_back(ThreadCpuSeconds() - cpu0);
  plan_timings_.push_back(result.timings);
  plan_gain_stats_.push_back(result.volumetric_stats);
  last_plan_s_ = now_s();
  ++plan_seq_;
  // Every mode's trajectory is checked against the other vehicles (the volumetric planner has
  // already tried its next candidates).
  if (result.status == PlanStatus::kGoal && result.trajectory.trajectory.has_value()) {
    const std::string refusal = SeparationRefusal(*result.trajectory.trajectory);
    if (!refusal.empty()) {
      result.status = PlanStatus::kFailed;
      result.reason = "the trajectory is refused by the separation check: " + refusal;
      result.refused_trajectories = 1;
    }
  }
  const bool yielded = result.status == PlanStatus::kFailed && result.refused_trajectories > 0 &&
                       Yield(result.reason);
  if (yielded) {
    // Neither a goal nor a failure: plan again after retry_period_s.
  } else if (result.status == PlanStatus::kGoal && result.trajectory.trajectory.has_value()) {
    yielding_since_s_ = -1.0;
    failed_plans_ = 0;
    end_deferrals_ = 0;
    const bool matched = result.trajectory.start_matched;
    const bool in_flight = Splicing(now_s());
    // Evaluated only where it matters (a map check of the whole remaining path).
    const bool clear = !matched && in_flight && reason == kReplanPeriod && RemainingPathSafe();
    switch (ChooseReplanUse(matched, in_flight, reason == kReplanPeriod, clear)) {
      case ReplanUse::kKeep:
        // The replan could not start from the flown state (e.g. too close to its goal to stop
        // there at the acceleration limit). The flown trajectory is still clear, so keep it;
        // the next replan starts where it ends, at rest, if nothing better comes first.
        drops_.Count("replan_kept", "the replan could not start from the flown state");
        break;
      case ReplanUse::kStop:
        if (Stop()) break;
        [[fallthrough]];
      case ReplanUse::kPublish:
        if (!matched) {
          drops_.Count(
              "start_not_matched",
              "the new trajectory starts from a simplified state: a step in the set point");
        }
        PublishFrom(*result.trajectory.trajectory);
        break;
    }
  } else if (result.status == PlanStatus::kExplorationDone &&
             end_deferrals_ < config_.max_end_deferrals &&
             !ReachesWithin(result, home_xy_, config_.planner.trajectory.vehicle_radius_m)) {
    // The end rules judge the space reachable now; without the take-off point in it, map noise
    // has closed a way the vehicle flew (e.g. a door jamb read a cell wider), and the verdict
    // covers part of the building only. Stop, let the map settle, plan again.
    ++end_deferrals_;
    drops_.Count("end_deferred", "an end rule held with the take-off point unreachable (" +
                                     result.reason + "): stopping and planning again");
    if (trajectory_ && Splicing(now_s())) Stop();
    next_attempt_s_ = now_s() + config_.retry_period_s;
  } else if (result.status == PlanStatus::kExplorationDone) {
    end_rule_ = result.end_rule.empty() ? "gain rule" : result.end_rule;
    Log(LogLevel::kInfo, "exploration ended by the " + end_rule_ + ": " + result.reason);
    state_ = exploration_status_t::STATE_RETURNING;
  } else {
    ++failed_plans_;
    drops_.Count("plan_failed", result.reason);
    next_attempt_s_ = now_s() + config_.retry_period_s;
    if (failed_plans_ >= config_.max_failed_plans) {
      end_rule_ = result.end_rule.empty() ? "planning failures" : result.end_rule;
      Log(LogLevel::kWarning, std::to_string(failed_plans_) + " plans failed in a row (last: " +
                                  result.reason + "): returning");
      state_ = exploration_status_t::STATE_RETURNING;
    }
  }
  PublishStatus(result, reason);
  if (now_s() - last_map2d_s_ >= config_.map2d_period_s) {
    last_map2d_s_ = now_s();
    PublishMaps(result);
  }
  const bool returning = state_ == exploration_status_t::STATE_RETURNING;
  last_plan_ = std::move(result);
  if (returning) PlanHome("exploration ended");
}

ReplanUse ChooseReplanUse(bool start_matched, bool in_flight, bool periodic_replan,
                          bool remaining_path_clear) {
  if (start_matched || !in_flight) return ReplanUse::kPublish;
  return periodic_replan && remaining_path_clear ? ReplanUse::kKeep : ReplanUse::kStop;
}

bool ExplorerNode::Stop() {
  // From the set point now, not after the splice's lookahead: the flown path ahead is no longer
  // clear, and a replan that steps the velocity there would stop the vehicle harder, later.
  TrajectoryStart now = StateAt(*trajectory_, now_s());
  now.time_s = now_s();
  std::optional<PiecewisePolynomialTrajectory> stop = PlanStop(now, config_.planner.trajectory);
  if (!stop) return false;  // not expected: a finite state always has a stop
  // The stop follows the velocity, not the map: where that line leaves the usable cells (into a
  // door jamb when the vehicle enters a door at an angle), the caller flies the checked replan.
  if (!TrajectoryStillClear(config_.planner, Input(), *stop, now.time_s - 0.5)) {
    drops_.Count("stop_not_clear",
                 "stopping on the line of flight would leave the usable cells: flying the replan");
    return false;
  }
  drops_.Count("stopped",
               "a replan could not start from the flown state and the flown path is no longer "
               "clear: stopping on the line of flight");
  Publish(*stop);
  return true;
}

bool ExplorerNode::ProgressStalled() {
  if (config_.end_stall_window_s <= 0.0) return false;
  const double t = now_s();
  int64_t known = 0;
  const float lo = static_cast<float>(0.5 * config_.p_init);
  for (float p : replica_.probabilities()) known += (p < lo || p > 0.5f) ? 1 : 0;
  known_history_.emplace_back(t, known);
  // The latest entry at least a window old; older ones are no longer needed.
  size_t ref = known_history_.size();
  for (size_t i = 0; i < known_history_.size(); ++i) {
    if (t - known_history_[i].first >= config_.end_stall_window_s) ref = i;
  }
  if (ref == known_history_.size()) return false;
  known_history_.erase(known_history_.begin(),
                       known_history_.begin() + static_cast<std::ptrdiff_t>(ref));
  const double then = static_cast<double>(known_history_.front().second);
  return static_cast<double>(known) - then < config_.end_stall_min_growth * then;
}

void ExplorerNode::PlanHome(const std::string& reason) {
  if (!config_.return_home) {
    landing_ = "landed where exploration ended (return_home off)";
    SendLand();
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
  PlanResult home = PlanToPoint(planner, PlanningInput(), home_xy_, home_yaw_rad_);
  ++plan_seq_;
  if (home.status == PlanStatus::kGoal && home.trajectory.trajectory.has_value()) {
    // Home in turn (docs/exploration.md, "Several vehicles"): a flight home that would come too
    // near another vehicle waits for it.
    const std::string refusal = SeparationRefusal(*home.trajectory.trajectory);
    if (!refusal.empty()) {
      home.status = PlanStatus::kFailed;
      home.reason = "the flight home is refused by the separation check: " + refusal;
      if (Yield(home.reason)) {
        next_attempt_s_ = now_s() + config_.retry_period_s;
        PublishStatus(home, reason + " (" + end_rule_ + "): waiting for another vehicle");
        return;
      }
    }
  }
  ++home_attempts_;
  if (home.status == PlanStatus::kGoal && home.trajectory.trajectory.has_value()) {
    yielding_since_s_ = -1.0;
    home_trajectory_ = true;
    if (squeeze) {
      Log(LogLevel::kWarning, "path home found without the clearance margin (attempt " +
                                  std::to_string(home_attempts_) + ")");
    }
    PublishFrom(*home.trajectory.trajectory);
    PublishStatus(home, reason + " (" + end_rule_ + "): flying home" +
                            (squeeze ? " without the margin" : ""));
    return;
  }
  // No path home yet: hover (the trajectory being flown ends and the controller holds) and try
  // again, max_home_attempts times in all; then land where the vehicle is, and say why.
  next_attempt_s_ = now_s() + config_.retry_period_s;
  if (home_attempts_ < config_.max_home_attempts) {
    Log(LogLevel::kWarning, "no path home (" + home.reason + "), attempt " +
                                std::to_string(home_attempts_) + " of " +
                                std::to_string(config_.max_home_attempts));
    PublishStatus(home, reason + " (" + end_rule_ + "): no path home yet");
    return;
  }
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
      PlanResult to_spot = PlanToPoint(planner, input, xy, YawOf(pose_.q));
      ++plan_seq_;
      if (to_spot.status == PlanStatus::kGoal && to_spot.trajectory.trajectory.has_value() &&
          SeparationRefusal(*to_spot.trajectory.trajectory).empty()) {
        landing_ += std::to_string((xy - home_xy_).norm()) +
                    " m from the take-off point, on known-free ground " +
                    std::to_string((xy - pose_.p.head<2>()).norm()) + " m from where it stopped";
        Log(LogLevel::kWarning, landing_ + ": flying there");
        home_trajectory_ = true;  // the trajectory ends where the vehicle lands
        PublishFrom(*to_spot.trajectory.trajectory);
        PublishStatus(to_spot, reason + " (" + end_rule_ + "): flying to a landing place");
        return;
      }
    }
  }
  landing_ += std::to_string((pose_.p.head<2>() - home_xy_).norm()) + " m from the take-off point";
  if (!spot) landing_ += ", no known-free ground within reach: in place";
  Log(LogLevel::kWarning, landing_);
  SendLand();
  PublishStatus(home, reason + " (" + end_rule_ + "): " + landing_);
}

void ExplorerNode::SendLand() {
  state_ = exploration_status_t::STATE_DONE;
  if (!config_.land_at_end) return;
  command_t cmd{};
  cmd.utime = clock_.NowUtime();
  cmd.seq = ++command_seq_;
  cmd.epoch = epoch_;
  cmd.source = "explorer";
  cmd.command = command_t::COMMAND_LAND;
  lcm_.publish(config_.command_channel, &cmd);
  Log(LogLevel::kInfo, "sent land");
}

bool ExplorerNode::RemainingPathSafe() {
  if (!trajectory_.has_value()) return true;
  const double t = now_s();
  if (t >= trajectory_->end_time_s()) return true;
  // The planner's own rule for the mode (exploration/planner.h, TrajectoryStillClear).
  return TrajectoryStillClear(config_.planner, Input(), *trajectory_, t);
}

std::string ExplorerNode::SeparationRefusal(const PiecewisePolynomialTrajectory& trajectory,
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

bool ExplorerNode::Yield(const std::string& why) {
  const double t = now_s();
  if (yielding_since_s_ < 0.0) yielding_since_s_ = t;
  if (t - yielding_since_s_ > config_.max_yield_s) return false;  // a failure from now on
  ++yields_;
  drops_.Count("yielded", why);
  // Keep flying what was checked, if it is still clear of the map and of the others; else stop.
  if (trajectory_ && Splicing(t) &&
      (!RemainingPathSafe() || !SeparationRefusal(*trajectory_, t).empty())) {
    Stop();
  }
  next_attempt_s_ = t + config_.retry_period_s;
  return true;
}

void ExplorerNode::Step() {
  const double t = now_s();
  if (t - last_heartbeat_s_ >= 1.0) {
    last_heartbeat_s_ = t;
    heartbeat_.SetValue("state", state_);
    heartbeat_.SetValue("plans", static_cast<double>(plan_seq_));
    heartbeat_.SetValue("map_seq", static_cast<double>(replica_.seq()));
    heartbeat_.SetValue("drops", static_cast<double>(drops_.total()));
    heartbeat_.SetDropValues(drops_);
    if (!drops_.last_reason().empty()) heartbeat_.SetLastError(drops_.last_reason());
    heartbeat_.Publish();
  }
  const double h = config_.planner.projection.height_m;
  switch (state_) {
    case exploration_status_t::STATE_WAITING: {
      if (!have_pose_ || !have_controller_ || !replica_.current() || t < next_attempt_s_) break;
      if (resume_state_ >= 0 && Resume()) break;
      const bool at_height = std::abs(pose_.p.z() - h) < config_.height_tolerance_m;
      const bool risen = pose_.p.z() >= lowest_z_m_ + config_.startup_min_rise_m;
      // The controller flies trajectories in HOLD and, once off the ground, in TAKEOFF
      // (control/safety.h); in the other modes the explorer does nothing.
      const bool ready =
          config_.startup_while_climbing
              ? (controller_mode_ == controller_status_t::MODE_TAKEOFF && risen) ||
                    (controller_mode_ == controller_status_t::MODE_HOLD && (risen || at_height))
              : controller_mode_ == controller_status_t::MODE_HOLD && at_height;
      if (!ready) break;
      home_xy_ = pose_.p.head<2>();
      home_yaw_rad_ = YawOf(pose_.q);
      if (StartTurn()) {
        state_ = exploration_status_t::STATE_STARTUP;
        startup_flown_ = false;
      } else {
        next_attempt_s_ = t + config_.retry_period_s;
      }
      break;
    }
    case exploration_status_t::STATE_STARTUP:
      // Our trajectory, not a predecessor's with the same seq (docs/design.md §3.4).
      if (controller_mode_ == controller_status_t::MODE_TRACK &&
          controller_trajectory_seq_ == trajectory_seq_ && controller_trajectory_epoch_ == epoch_) {
        startup_flown_ = true;
      }
      if (!startup_flown_ && t > trajectory_->start_time_s() + 1.0) {
        // Refused or not flown (e.g. a failsafe hold): nothing is commanded; wait and retry.
        drops_.Count("startup_not_flown",
                     "the controller did not fly the start-up trajectory (mode " +
                         std::to_string(controller_mode_) + ")");
        state_ = exploration_status_t::STATE_WAITING;
        trajectory_.reset();
        next_attempt_s_ = t + config_.retry_period_s;
      } else if (t > trajectory_->end_time_s() + 0.5) {
        state_ = exploration_status_t::STATE_EXPLORING;
        Plan("start-up turn done");
      }
      break;
    case exploration_status_t::STATE_EXPLORING: {
      if (ControllerHoldsWithoutOurTrajectory(t)) {
        // A controller that took over after a restart, or refused a far-start trajectory, holds:
        // plan again from where the vehicle is (docs/design.md §2.5).
        ++controller_holds_;
        drops_.Count("controller_holds",
                     "the controller holds without flying the latest trajectory: replanning from "
                     "the flown state");
        trajectory_.reset();
        Plan("the controller holds");
        break;
      }
      if (t < next_attempt_s_) break;
      const bool ended = !trajectory_.has_value() || t >= trajectory_->end_time_s();
      if (last_plan_ && last_plan_->status == PlanStatus::kGoal && last_plan_->chosen >= 0) {
        // A goal counts as reached when its trajectory ends or, in non-stop flight (where
        // trajectories are replaced before they end), when the vehicle passes within 0.3 m of it.
        const Candidate& goal = last_plan_->candidates[static_cast<size_t>(last_plan_->chosen)];
        const Eigen::Vector3d g(goal.position_m.x(), goal.position_m.y(), goal.yaw_rad);
        const bool near = (pose_.p.head<2>() - goal.position_m).norm() < 0.3;
        if ((ended || near) && (reached_goals_.empty() || reached_goals_.back() != g)) {
          reached_goals_.push_back(g);
          reached_views_.emplace_back(pose_.p.x(), pose_.p.y(), YawOf(pose_.q));
        }
      }
      if (ended) {
        Plan("trajectory ended");
      } else if (t - last_plan_s_ >= config_.replan_period_s &&
                 trajectory_->end_time_s() - t > config_.replan_min_remaining_s) {
        Plan(kReplanPeriod);
      } else if (t - last_safety_check_s_ >= config_.safety_check_period_s &&
                 replica_.seq() != safety_checked_map_seq_) {
        last_safety_check_s_ = t;
        safety_checked_map_seq_ = replica_.seq();
        if (!RemainingPathSafe()) Plan("remaining path unsafe");
      } else if (!peers_.empty() && !ended &&
                 t - last_separation_check_s_ >= config_.safety_check_period_s) {
        last_separation_check_s_ = t;
        if (!SeparationRefusal(*trajectory_, t).empty()) Plan("too near another vehicle ahead");
      }
      break;
    }
    case exploration_status_t::STATE_RETURNING:
      if (home_trajectory_ && ControllerHoldsWithoutOurTrajectory(t)) {
        ++controller_holds_;
        drops_.Count("controller_holds",
                     "the controller holds without flying the flight home: planning it again");
        trajectory_.reset();
        home_trajectory_ = false;
        PlanHome("the controller holds");
        break;
      }
      if (!home_trajectory_) {
        if (t >= next_attempt_s_) PlanHome("retrying the flight home");
        break;
      }
      // The flight home ends in the cell holding the take-off point (or the reachable one nearest
      // to it), or at a landing place elsewhere: land there.
      if (trajectory_.has_value() && t >= trajectory_->end_time_s() + 0.5) {
        if (landing_.empty()) {  // else: a landing place elsewhere (PlanHome)
          landing_ = "returned home (" + std::to_string((pose_.p.head<2>() - home_xy_).norm()) +
                     " m from the take-off point)";
        }
        Log(LogLevel::kInfo, landing_);
        SendLand();
        // The status says DONE too: processes watching EXPLORATION_STATUS (kestrel-flight-check,
        // the viewer, an operator) learn that exploration is over from it.
        ++plan_seq_;
        PublishStatus(PlanResult{}, "home: land sent (" + end_rule_ + ", " + landing_ + ")");
      }
      break;
    default:
      break;
  }
  WriteStateFile();
}

void ExplorerNode::PublishStatus(const PlanResult& result, const std::string& reason) {
  exploration_status_t msg{};
  msg.utime = clock_.NowUtime();
  msg.seq = plan_seq_;
  msg.epoch = epoch_;
  msg.mode = ModeName(config_.planner.mode);
  msg.state = state_;
  msg.reason = result.reason.empty() ? reason : reason + ": " + result.reason;
  double entropy = 0.0;  // H of the replica (eq. 6), the explorer's view of the map
  for (float p : replica_.probabilities()) {
    const double q = p;
    if (q > 0 && q < 1) entropy += -q * std::log(q) - (1 - q) * std::log(1 - q);
  }
  msg.map_entropy_nats = entropy;
  msg.best_unweighted_gain_nats = result.best_unweighted_gain_nats;
  std::vector<int> order(result.candidates.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return result.candidates[a].objective() > result.candidates[b].objective();
  });
  if (static_cast<int>(order.size()) > config_.max_status_candidates)
    order.resize(config_.max_status_candidates);
  msg.chosen_index = -1;
  for (size_t i = 0; i < order.size(); ++i) {
    const Candidate& c = result.candidates[order[i]];
    candidate_t m{};
    m.position_m[0] = c.position_m.x();
    m.position_m[1] = c.position_m.y();
    m.position_m[2] = config_.planner.projection.height_m;
    m.yaw_rad = c.yaw_rad;
    m.gain_nats = c.gain_nats;
    m.distance_m = c.distance_m;
    m.bump = c.bump;
    m.objective = c.objective();
    msg.candidates.push_back(m);
    if (order[i] == result.chosen) msg.chosen_index = static_cast<int32_t>(i);
  }
  msg.num_candidates = static_cast<int32_t>(msg.candidates.size());
  if (result.chosen >= 0 && result.chosen < static_cast<int>(result.candidates.size())) {
    const Candidate& c = result.candidates[result.chosen];
    msg.goal_position_m[0] = c.position_m.x();
    msg.goal_position_m[1] = c.position_m.y();
    msg.goal_position_m[2] = config_.planner.projection.height_m;
    msg.goal_yaw_rad = c.yaw_rad;
  }
  msg.projection_time_s = result.timings.projection_s;
  msg.gain_time_s = result.timings.gain_s;
  msg.dijkstra_time_s = result.timings.dijkstra_s;
  msg.trajectory_time_s = result.timings.trajectory_s;
  msg.total_time_s = result.timings.total_s;
  lcm_.publish(config_.status_channel, &msg);
}

void ExplorerNode::PublishMaps(const PlanResult& result) {
  auto publish = [&](const GridMap2D& g, const std::string& name) {
    grid_map_t msg{};
    msg.utime = replica_.utime();
    msg.seq = plan_seq_;
    msg.epoch = epoch_;
    msg.name = name;
    msg.origin_m[0] = g.origin_m.x();
    msg.origin_m[1] = g.origin_m.y();
    msg.height_m = g.height_m;
    msg.resolution_m = g.resolution_m;
    msg.width = g.width;
    msg.height = g.height;
    msg.values.assign(g.values.begin(), g.values.end());
    msg.num_values = static_cast<int32_t>(msg.values.size());
    std::string channel = name;
    std::transform(channel.begin(), channel.end(), channel.begin(), ::toupper);
    lcm_.publish(config_.map2d_prefix + channel, &msg);
  };
  // The volumetric mode and the fine frontiers publish their fine band as "collision" (P, the
  // largest over the vehicle's band) and have no combined map B.
  if (result.collision.collision.size() > 0) publish(result.collision.collision, "collision");
  if (result.collision.combined.size() > 0) publish(result.collision.combined, "combined");
  if (result.entropy.has_value()) publish(*result.entropy, "entropy");
}

}  // namespace kestrel
