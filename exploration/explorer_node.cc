#include "exploration/explorer_node.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>

#include "common/identity.h"
#include "common/run_state_file.h"
#include "common/trajectory_message.h"
#include "exploration/status_message.h"
#include "kestrel/command_t.hpp"
#include "kestrel/controller_status_t.hpp"
#include "kestrel/exploration_status_t.hpp"
#include "kestrel/grid_map_t.hpp"
#include "kestrel/map3d_chunk_t.hpp"
#include "kestrel/map3d_delta_t.hpp"
#include "kestrel/trajectory_t.hpp"

namespace kestrel {
namespace {

// The Explorer's enums carry the messages' values (as control/safety.h's FlightMode does).
static_assert(static_cast<int8_t>(ExplorerState::kWaiting) == exploration_status_t::STATE_WAITING);
static_assert(static_cast<int8_t>(ExplorerState::kStartup) == exploration_status_t::STATE_STARTUP);
static_assert(static_cast<int8_t>(ExplorerState::kExploring) ==
              exploration_status_t::STATE_EXPLORING);
static_assert(static_cast<int8_t>(ExplorerState::kReturning) ==
              exploration_status_t::STATE_RETURNING);
static_assert(static_cast<int8_t>(ExplorerState::kDone) == exploration_status_t::STATE_DONE);
static_assert(static_cast<int8_t>(ExplorerState::kFailed) == exploration_status_t::STATE_FAILED);
static_assert(static_cast<int8_t>(ControllerMode::kIdle) == controller_status_t::MODE_IDLE);
static_assert(static_cast<int8_t>(ControllerMode::kTakeoff) == controller_status_t::MODE_TAKEOFF);
static_assert(static_cast<int8_t>(ControllerMode::kTrack) == controller_status_t::MODE_TRACK);
static_assert(static_cast<int8_t>(ControllerMode::kHold) == controller_status_t::MODE_HOLD);
static_assert(static_cast<int8_t>(ControllerMode::kLand) == controller_status_t::MODE_LAND);
static_assert(static_cast<int8_t>(ControllerMode::kEstop) == controller_status_t::MODE_ESTOP);

// How far the mapper's P_init may be from the explorer's (map_prior): float cells and log-odds
// read back differ from the configured double by 1e-8 at most.
constexpr double kPriorTolerance = 1e-6;

// The replica's lattice: the configured map's, at least one cell.
Eigen::Vector3i ReplicaDims(const MapLimits& map) {
  const GridGeometry geometry = GridGeometry::Fixed(map);
  return geometry.upper().x > 0
             ? Eigen::Vector3i(geometry.upper().x, geometry.upper().y, geometry.upper().z)
             : Eigen::Vector3i(1, 1, 1);
}

// This vehicle's channels get its prefix (docs/exploration.md, "Several vehicles").
ExplorerNodeConfig Prefixed(ExplorerNodeConfig c) {
  for (std::string* channel :
       {&c.pose_channel, &c.controller_channel, &c.trajectory_channel, &c.status_channel,
        &c.command_channel, &c.map2d_prefix, &c.heartbeat_channel}) {
    *channel = c.vehicle_prefix + *channel;
  }
  return c;
}

}  // namespace

ExplorerNode::ExplorerNode(lcm::LCM& lcm, const ExplorerNodeConfig& config, const Clock& clock)
    : lcm_(lcm),
      config_(Prefixed(config)),
      clock_(clock),
      replica_(config.explorer.map.min_m, config.explorer.map.resolution_m,
               ReplicaDims(config.explorer.map), config.explorer.p_init),
      drops_(clock),
      events_(clock, 5.0, "event", LogLevel::kInfo),
      heartbeat_(lcm, clock, "kestrel-explorer", config_.heartbeat_channel),
      subscriptions_(lcm),
      epoch_(NewPublisherEpoch()),
      explorer_(config.explorer, epoch_,
                clock.is_simulated() ? PlanningTime::kStandsStill : PlanningTime::kPasses) {
  config.Validate();
  auto on_error = [this](const std::string& channel, const std::string& reason) {
    drops_.Count("malformed", channel + ": " + reason);
  };
  // The other vehicles' channels: their prefixes before the unprefixed names.
  SubscribePeers(config.pose_channel, config.trajectory_channel);
  subscriptions_.Add<map3d_chunk_t>(
      config_.map_channel,
      [this](const std::string&, const map3d_chunk_t& m) {
        // The explorer's P_init (its projections, its known cells) must be the mapper's, to the
        // precision of the mapper's cells (float probabilities, or log-odds read back).
        if (std::abs(m.p_init - config_.explorer.p_init) > kPriorTolerance) {
          drops_.Count("map_prior", "the mapper's P_init " + std::to_string(m.p_init) +
                                        " is not the explorer's map.p_init " +
                                        std::to_string(config_.explorer.p_init));
          return;
        }
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
        ControllerReport report;
        report.mode = static_cast<ControllerMode>(m.mode);
        report.trajectory_seq = m.trajectory_seq;
        report.trajectory_epoch = m.trajectory_epoch;
        report.velocity_mps = Eigen::Vector3d(m.velocity_mps[0], m.velocity_mps[1],
                                              m.velocity_mps[2]);  // not finite: ignored
        explorer_.OnControllerReport(report);
      },
      on_error);
  heartbeat_.SetState(heartbeat_t::STATE_OK);
  run_id_ = config_.run_id.empty() ? NewRunId() : config_.run_id;
  ReadStateFile();
}

void ExplorerNode::SubscribePeers(const std::string& pose_channel,
                                  const std::string& trajectory_channel) {
  auto on_error = [this](const std::string& channel, const std::string& reason) {
    drops_.Count("malformed", channel + ": " + reason);
  };
  const std::vector<std::string>& peers = config_.explorer.peers;
  for (size_t k = 0; k < peers.size(); ++k) {
    subscriptions_.Add<pose_t>(
        peers[k] + pose_channel,
        [this, k](const std::string&, const pose_t& m) {
          if (!m.valid) return;
          const Eigen::Vector3d p(m.position_m[0], m.position_m[1], m.position_m[2]);
          if (!p.allFinite()) {
            drops_.Count("nan_pose", config_.explorer.peers[k] + ": non-finite position");
          } else if (!explorer_.OnPeerPose(k, now_s(), p)) {
            drops_.Count("stale_pose", config_.explorer.peers[k] + ": older than the one held");
          }
        },
        on_error);
    subscriptions_.Add<trajectory_t>(
        peers[k] + trajectory_channel,
        [this, k](const std::string& channel, const trajectory_t& m) {
          std::string error;
          std::optional<PiecewisePolynomialTrajectory> t = FromMessage(m, &error);
          if (!t) {
            drops_.Count("malformed", channel + ": " + error);
            return;
          }
          explorer_.OnPeerTrajectory(k, std::move(*t));
        },
        on_error);
  }
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
  explorer_.OnPose(now_s(), X_WB);
}

ExplorerMap ExplorerNode::Map() const {
  ExplorerMap map;
  map.view.dims = replica_.dims();
  map.view.origin_m = replica_.origin_m();
  map.view.resolution_m = replica_.resolution_m();
  map.view.probability = replica_.probabilities().data();
  map.seq = replica_.seq();
  map.current = replica_.current();
  return map;
}

const std::string& ExplorerNode::resume_status() const {
  return explorer_.resume_status().empty() ? file_status_ : explorer_.resume_status();
}

void ExplorerNode::ReadStateFile() {
  if (config_.state_path.empty()) return;
  RunStateFile file;
  std::string why;
  const RunStateRead read = ReadRunStateFile(config_.state_path, "explorer", run_id_, &file, &why);
  if (read != RunStateRead::kOk) {
    file_status_ = why + ": starting as on a first start";
    Log(read == RunStateRead::kCorrupt ? LogLevel::kError : LogLevel::kInfo, file_status_);
    return;
  }
  const std::string* state = file.Find("state");
  ExplorerRecord record;
  double x = 0, y = 0;
  if (state == nullptr || !file.GetDouble("home_x_m", &x) || !file.GetDouble("home_y_m", &y) ||
      !file.GetDouble("home_yaw_rad", &record.home_yaw_rad) ||
      !file.GetDouble("lowest_z_m", &record.lowest_z_m)) {
    file_status_ = "corrupt state file " + config_.state_path +
                   ": no state, home or lowest height; starting as on a first start";
    Log(LogLevel::kError, file_status_);
    return;
  }
  record.home_xy_m = Eigen::Vector2d(x, y);
  std::string name = *state;  // the table's names (older files: upper case)
  std::transform(name.begin(), name.end(), name.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  record.state = ExplorerStateFromName(name).value_or(ExplorerState::kWaiting);
  if (const std::string* rule = file.Find("end_rule")) {
    record.end_rule = *rule;
    std::replace(record.end_rule.begin(), record.end_rule.end(), '_', ' ');
  }
  if (!explorer_.Restore(record)) {
    file_status_ = "restarted before exploring (was " + *state + "): starting as on a first start";
    Log(LogLevel::kInfo, file_status_);
    return;
  }
  file_status_ = "restarted within run " + run_id_ + " (was " + *state +
                 "): resuming from the flown state once the vehicle is seen airborne";
  Log(LogLevel::kWarning, file_status_);
}

void ExplorerNode::WriteStateFile() {
  const int state = static_cast<int>(explorer_.state());
  if (config_.state_path.empty() || state == saved_state_) return;
  // Before the start-up nothing is resumable: no take-off point yet.
  if (explorer_.state() == ExplorerState::kWaiting && !explorer_.resume_pending() &&
      saved_state_ < 0) {
    return;
  }
  const ExplorerRecord record = explorer_.Record();
  RunStateFile file;
  file.kind = "explorer";
  file.run_id = run_id_;
  file.values["state"] = ToString(record.state);
  char number[64];
  const auto put = [&](const char* key, double v) {
    std::snprintf(number, sizeof(number), "%.17g", v);
    file.values[key] = number;
  };
  put("home_x_m", record.home_xy_m.x());
  put("home_y_m", record.home_xy_m.y());
  put("home_yaw_rad", record.home_yaw_rad);
  put("lowest_z_m", record.lowest_z_m);
  if (!record.end_rule.empty()) {  // one word in the file: spaces as '_'
    std::string rule = record.end_rule;
    std::replace(rule.begin(), rule.end(), ' ', '_');
    file.values["end_rule"] = rule;
  }
  std::string error;
  if (WriteRunStateFile(config_.state_path, file, &error)) {
    saved_state_ = state;
  } else {
    drops_.Count("state_file", error);
  }
}

void ExplorerNode::Heartbeat(double t) {
  if (t - last_heartbeat_s_ < 1.0) return;
  last_heartbeat_s_ = t;
  heartbeat_.SetValue("state", static_cast<int>(explorer_.state()));
  heartbeat_.SetValue("plans", static_cast<double>(explorer_.plans()));
  heartbeat_.SetValue("map_seq", static_cast<double>(replica_.seq()));
  heartbeat_.SetValue("drops", static_cast<double>(drops_.total()));
  heartbeat_.SetDropValues(drops_);
  for (const auto& [kind, count] : events_.counts()) {
    heartbeat_.SetValue("event." + kind, static_cast<double>(count));
  }
  if (!drops_.last_reason().empty()) heartbeat_.SetLastError(drops_.last_reason());
  heartbeat_.Publish();
}

void ExplorerNode::Step() {
  Heartbeat(now_s());
  for (const ExplorerAction& action : explorer_.Step(now_s(), Map())) Execute(action);
  WriteStateFile();
}

void ExplorerNode::Execute(const ExplorerAction& action) {
  if (const auto* t = std::get_if<PublishTrajectory>(&action)) {
    const trajectory_t msg = ToMessage(t->trajectory, clock_.NowUtime(), t->seq, epoch_);
    lcm_.publish(config_.trajectory_channel, &msg);
  } else if (const auto* s = std::get_if<kestrel::PublishStatus>(&action)) {
    PublishStatus(*s);
  } else if (std::holds_alternative<SendLand>(action)) {
    PublishLand();
  } else if (const auto* e = std::get_if<ReportEvent>(&action)) {
    events_.Count(ToString(e->event), e->what);
  } else if (const auto* line = std::get_if<LogLine>(&action)) {
    Log(line->level, line->text);
  }
}

void ExplorerNode::PublishStatus(const kestrel::PublishStatus& status) {
  StatusContext context;
  context.utime = clock_.NowUtime();
  context.seq = status.seq;
  context.epoch = epoch_;
  context.mode = config_.explorer.planner.mode;
  context.state = status.state;
  context.reason = status.reason;
  context.map_entropy_nats = MapEntropyNats(Map().view);  // the explorer's view of the map
  context.height_m = config_.explorer.planner.projection.height_m;
  context.max_candidates = config_.max_status_candidates;
  const exploration_status_t msg = ToStatusMessage(*status.plan, context);
  lcm_.publish(config_.status_channel, &msg);
  if (status.replan && now_s() - last_map2d_s_ >= config_.map2d_period_s) {
    last_map2d_s_ = now_s();
    PublishMaps(*status.plan, status.seq);
  }
}

void ExplorerNode::PublishMaps(const PlanResult& result, int64_t seq) {
  auto publish = [&](const GridMap2D& g, const std::string& name) {
    std::string channel = name;
    std::transform(channel.begin(), channel.end(), channel.begin(), ::toupper);
    const grid_map_t msg = ToGridMapMessage(g, name, replica_.utime(), seq, epoch_);
    lcm_.publish(config_.map2d_prefix + channel, &msg);
  };
  // The volumetric mode and the fine frontiers publish their fine band as "collision" (P, the
  // largest over the vehicle's band) and have no combined map B.
  if (result.collision.collision.size() > 0) publish(result.collision.collision, "collision");
  if (result.collision.combined.size() > 0) publish(result.collision.combined, "combined");
  if (result.entropy.has_value()) publish(*result.entropy, "entropy");
}

void ExplorerNode::PublishLand() {
  command_t cmd{};
  cmd.utime = clock_.NowUtime();
  cmd.seq = ++command_seq_;
  cmd.epoch = epoch_;
  cmd.source = "explorer";
  cmd.command = command_t::COMMAND_LAND;
  lcm_.publish(config_.command_channel, &cmd);
  Log(LogLevel::kInfo, "sent land");
}

}  // namespace kestrel
