#pragma once
/// @file
/// The explorer node (kestrel-explorer): keeps a copy of the mapper's 3D map (MAP3D snapshots and
/// deltas, mapping/map_replica.h), and runs the paper's exploration loop (docs/algorithms.md §8):
///
///   WAITING   until a map, a valid pose and the vehicle airborne on the commanded take-off
///             (controller in TAKEOFF, startup_min_rise_m above the lowest height seen) or
///             hovering (HOLD); the explorer never takes off by itself;
///   STARTUP   one trajectory from the current state: the rest of the climb to the exploration
///             height h, vertically, while the heading turns a full circle to scan
///             (exploration/startup_turn.h; docs/exploration.md "Start-up: the turn while
///             climbing"); back to WAITING if the controller does not fly it;
///   EXPLORING plans (exploration/planner.h) and publishes TRAJECTORY; replans when the
///             trajectory ends, when new map data makes the remaining path unsafe (the vehicle's
///             disc over non-traversable collision cells), or after replan_period_s;
///   RETURNING when the best unweighted gain falls below the threshold (or planning keeps
///             failing): flies back to the take-off point;
///   DONE      sends a land command on COMMAND (the only command the explorer may send).
///
/// Restarts (docs/design.md §2.5): with state_path set, the state and the take-off point are
/// written there (common/run_state_file.h) at every change of state; an explorer started with
/// the same run id whose file says it had started exploring, and that finds the vehicle airborne
/// (controller in HOLD or TRACK), resumes from the flown state without a start-up turn: EXPLORING
/// plans at once from the current pose (the map from the mapper's next snapshot), RETURNING
/// plans home, DONE sends the land command again. While exploring or returning, a controller
/// that holds without flying the explorer's latest trajectory (a takeover after a controller
/// restart, or a refused far-start trajectory) makes it replan from the flown state.
///
/// Publishes EXPLORATION_STATUS after every plan, the 2D maps (MAP2D_COLLISION, MAP2D_COMBINED,
/// MAP2D_ENTROPY in two-map mode) and a heartbeat. Step() does the work; it is cheap when
/// nothing is due, so a lockstep simulation may call it every step.

#include <cstdint>
#include <optional>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/heartbeat.h"
#include "common/lcm_decode.h"
#include "common/log.h"
#include "common/se3.h"
#include "common/trajectory.h"
#include "exploration/planner.h"
#include "exploration/separation.h"
#include "exploration/startup_turn.h"
#include "kestrel/controller_status_t.hpp"
#include "kestrel/exploration_status_t.hpp"
#include "kestrel/map3d_chunk_t.hpp"
#include "kestrel/map3d_delta_t.hpp"
#include "kestrel/pose_t.hpp"
#include "mapping/grid.h"
#include "mapping/map_replica.h"

namespace kestrel {

class ConfigNode;

struct ExplorerConfig {
  PlannerConfig planner;  ///< config/exploration/explorer.yaml (planning)
  MapLimits map;          ///< the mapper's lattice (limits, resolution)
  double p_init{0.1};     ///< the mapper's P_init

  std::string map_channel{"MAP3D"};
  std::string delta_channel{"MAP3D_DELTA"};
  std::string pose_channel{"POSE_VICON"};
  std::string controller_channel{"CONTROLLER_STATUS"};
  std::string trajectory_channel{"TRAJECTORY"};
  std::string status_channel{"EXPLORATION_STATUS"};
  std::string command_channel{"COMMAND"};
  std::string map2d_prefix{"MAP2D_"};  ///< + COLLISION, COMBINED, ENTROPY
  std::string heartbeat_channel{"HEARTBEAT_EXPLORER"};

  /// Several vehicles (docs/exploration.md, "Several vehicles"): this vehicle's prefix, put
  /// before the pose, controller, trajectory, status, command, 2D map and heartbeat channels above
  /// ("" for one vehicle; the map channels are shared).
  std::string vehicle_prefix;
  /// The other vehicles' prefixes: the explorer reads each one's pose and trajectory (prefix +
  /// pose_channel, prefix + trajectory_channel), discounts the candidates in view of its goal
  /// (VolumetricConfig::peer_view_radius_m) and publishes no trajectory that comes nearer to it
  /// than min_separation_m (a vehicle yields: it keeps or stops its flight and plans again).
  std::vector<std::string> peer_prefixes;
  /// Smallest horizontal distance to another vehicle a published trajectory may plan, m
  /// (> 0; docs/exploration.md, "Several vehicles"). Where two vehicles are already nearer, a
  /// trajectory may not bring them nearer still.
  double min_separation_m{1.2};
  /// Two vehicles whose heights differ by this much are clear of each other whatever their
  /// horizontal distance (one flies over a landed one), m (> 0).
  double min_vertical_separation_m{0.6};
  /// Yielding to another vehicle is not a failed plan for this long in a row, s (> 0); after it,
  /// each refused plan counts as a failure (max_failed_plans, max_home_attempts).
  double max_yield_s{60.0};

  double startup_yaw_rate_radps{0.8};  ///< peak yaw rate of the start-up full circle, rad/s
  double height_tolerance_m{0.25};     ///< hovering within this of h counts as "at height", m
  /// true: the start-up turn overlaps the climb (docs/exploration.md, "Start-up: the turn while
  /// climbing"): it starts once the controller is in TAKEOFF and the vehicle is
  /// startup_min_rise_m above the lowest height seen while waiting. false (default): the turn
  /// starts in HOLD within height_tolerance_m of h, after the climb; the overlap saves little
  /// time and, seen from below h, can leave the band around the take-off unseen, so that the gain
  /// rule ends exploration early (measured in docs/exploration.md, same section).
  bool startup_while_climbing{false};
  double startup_min_rise_m{0.3};  ///< see startup_while_climbing, m (> 0)
  /// How the heading turns (exploration/startup_turn.h): smoothstep (the former turn, one
  /// degree-7 smoothstep, 17.2 s at 0.8 rad/s) or ramped (0.75 s ramps of the rate and a cruise
  /// at the peak, 8.6 s: an earlier first plan, but not an earlier 95% known; measured in
  /// docs/exploration.md, "Start-up: the turn while climbing").
  StartupYawProfile startup_yaw_profile{StartupYawProfile::kSmoothstep};
  double replan_period_s{1.0};  ///< replan at least this often while flying, s...
  /// ...unless the trajectory ends within this, s: a replan near the goal (often while the
  /// vehicle turns to the goal's heading in the goal's cell, which is no candidate) would pick
  /// another goal before this one is reached, again and again.
  double replan_min_remaining_s{0.0};
  /// Progress stall (Kestrel's addition; 0 disables): exploration also ends when the number of
  /// known 3D cells (P < P_init / 2 or P > 0.5, docs/algorithms.md §12.2's rule on the
  /// explorer's own map) grew by less than end_stall_min_growth of itself over this window, s.
  /// The gain-based tests alone may never end in a cluttered world: cells no sensor can see keep
  /// a little predicted gain that the vehicle chases round the rooms.
  double end_stall_window_s{120.0};
  double end_stall_min_growth{0.005};  ///< see end_stall_window_s, fraction in [0, 1)
  /// Whether the progress-stall rule also ends the volumetric mode. Off: its own end rule does
  /// (docs/exploration.md, "Ending and the flight home": a reached pose keeps no gain, so the
  /// poses it can chase are finite); in a large world the stall rule ended it while whole rooms
  /// were left (hall: 96.6% known at 1269 s; 99% a hundred seconds later without it).
  bool end_stall_in_volumetric{false};
  double safety_check_period_s{0.5};  ///< how often the remaining path is re-checked, s
  /// Non-stop flight (docs/exploration.md, "Non-stop flight"): a replan while a trajectory is
  /// flown starts from the state the trajectory predicts replan_lookahead_s ahead, and the
  /// published trajectory is the flown one up to then, spliced to the new one (continuous in
  /// position, velocity and acceleration): the vehicle never stops to replan.
  bool nonstop{true};
  double replan_lookahead_s{1.0};     ///< s (> 0; longer than the slowest replan)
  int max_home_attempts{5};           ///< failed plans home before landing where the vehicle is
  double flown_path_spacing_m{0.25};  ///< the flown corridor keeps a point every this many m
  double retry_period_s{1.0};         ///< wait after a failed plan, s
  int max_failed_plans{5};            ///< consecutive failures before returning home
  /// An end rule that holds while the take-off point is unreachable (fine modes) is deferred this
  /// many times in a row, retry_period_s apart, the vehicle stopped (docs/exploration.md, "Ending
  /// and the flight home"): map noise closed a way the vehicle flew, and the verdict covers only
  /// part of the building. 0: never deferred.
  int max_end_deferrals{5};
  bool return_home{true};          ///< fly back to the take-off point at the end
  bool land_at_end{true};          ///< then send a land command
  int max_status_candidates{512};  ///< candidates listed in EXPLORATION_STATUS (best first)
  /// The 2D maps go out at most this often, s (0: with every plan). The volumetric mode's band is
  /// at the map's resolution (lasr: 165 kB per message); at 1 Hz replans that traffic crowded the
  /// receive buffers of every process on the multicast group.
  double map2d_period_s{5.0};
  /// The explorer's state file ("" = none: a restarted explorer starts WAITING, as on a first
  /// start); see the file comment.
  std::string state_path;
  /// The run this explorer belongs to; "" = a fresh id, which resumes nothing. kestrel-explorer
  /// fills it from $KESTREL_RUN_ID when unset.
  std::string run_id;
  /// While exploring or returning: the controller holding this long after the latest trajectory
  /// was sent without flying it makes the explorer replan from the flown state, s (> 0).
  double controller_hold_replan_s{0.5};

  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// Reads an ExplorerConfig: the planner keys of config/exploration/explorer.yaml, its `map:`
/// section (the mapper's lattice) and its `explorer:` section. @throws ConfigError
[[nodiscard]] ExplorerConfig LoadExplorerConfig(const ConfigNode& node);

/// Whether the progress-stall rule may end exploration in `mode` (ExplorerConfig::
/// end_stall_window_s, end_stall_in_volumetric).
[[nodiscard]] bool StallRuleApplies(ExplorationMode mode, const ExplorerConfig& config);

/// What the explorer does with a replan that has a trajectory (docs/exploration.md, "Non-stop
/// flight", section 1).
enum class ReplanUse {
  kPublish,  ///< fly it (spliced onto the flown trajectory where that is being flown)
  kKeep,     ///< keep flying the flown trajectory: the replan would step the set point, and the
             ///< flown path is still clear
  kStop,     ///< stop now (PlanStop): the replan would step the set point after the splice, and
             ///< the flown path is no longer clear (or the replan was asked for another reason)
};

/// The choice: a replan that starts from the flown state is flown; one that does not (its start
/// velocity simplified, a step at the splice) is flown only when nothing is being flown (the
/// vehicle is at rest, so nothing steps); in flight the flown trajectory is kept when this was
/// the periodic replan and its remaining path is still clear, and otherwise the vehicle stops.
[[nodiscard]] ReplanUse ChooseReplanUse(bool start_matched, bool in_flight, bool periodic_replan,
                                        bool remaining_path_clear);

class ExplorerNode {
 public:
  /// @throws std::invalid_argument if the configuration is invalid.
  ExplorerNode(lcm::LCM& lcm, const ExplorerConfig& config, const Clock& clock);
  ExplorerNode(const ExplorerNode&) = delete;
  ExplorerNode& operator=(const ExplorerNode&) = delete;

  /// Advances the exploration at the clock's time (file comment).
  void Step();

  /// exploration_status_t::STATE_*.
  [[nodiscard]] int8_t state() const { return state_; }
  [[nodiscard]] int64_t plans() const { return plan_seq_; }
  [[nodiscard]] const std::optional<PlanResult>& last_plan() const { return last_plan_; }
  [[nodiscard]] const MapReplica& replica() const { return replica_; }
  [[nodiscard]] const DropCounter& drops() const { return drops_; }
  /// The publisher epoch stamped on every message but the heartbeat (common/identity.h).
  [[nodiscard]] int64_t epoch() const { return epoch_; }
  /// Sum of planning wall time over all plans, s.
  [[nodiscard]] double total_planning_s() const { return total_planning_s_; }
  /// Wall time of every exploration replan, s (not the flights home).
  [[nodiscard]] const std::vector<double>& plan_times_s() const { return plan_times_s_; }
  /// CPU time of the planning thread for every exploration replan, s (plan_times_s() order).
  [[nodiscard]] const std::vector<double>& plan_cpu_times_s() const { return plan_cpu_times_s_; }
  /// The planner's own stage timings of every exploration replan, in plan_times_s() order.
  [[nodiscard]] const std::vector<PlanTimings>& plan_timings() const { return plan_timings_; }
  /// The volumetric gain's counters of every exploration replan, in plan_times_s() order.
  [[nodiscard]] const std::vector<VolumetricGainStats>& plan_gain_stats() const {
    return plan_gain_stats_;
  }
  /// What ended exploration ("" while exploring): "gain rule", "progress stall", "planning
  /// failures", "no reachable candidate", "no reachable frontier".
  [[nodiscard]] const std::string& end_rule() const { return end_rule_; }
  /// How the flight ended ("" until the land command): "returned home" or "landed elsewhere: ...".
  [[nodiscard]] const std::string& landing() const { return landing_; }
  /// What the start-up found in the state file ("" without one) and, once resumed, how.
  [[nodiscard]] const std::string& resume_status() const { return resume_status_; }
  /// Times the controller held without flying the latest trajectory (a replan followed).
  [[nodiscard]] int64_t controller_holds() const { return controller_holds_; }
  /// Plans whose trajectory the separation check refused (the vehicle yielded).
  [[nodiscard]] int64_t yields() const { return yields_; }
  /// "" if `trajectory` keeps min_separation_m from every other vehicle from from_s (or its start,
  /// if later) on, or does not come nearer to one that is already nearer; else which vehicle, how
  /// near and when.
  [[nodiscard]] std::string SeparationRefusal(const PiecewisePolynomialTrajectory& trajectory,
                                              double from_s = -1e300) const;

 private:
  void OnPose(const pose_t& msg);
  void ReadStateFile();
  void WriteStateFile();
  // WAITING with a resumable state file and the vehicle airborne: takes up where it stopped.
  bool Resume();
  // The controller holds without flying our latest trajectory (controller_hold_replan_s).
  [[nodiscard]] bool ControllerHoldsWithoutOurTrajectory(double t) const;
  // A refused plan (the separation check): true if it is still a yield (max_yield_s), false once
  // it counts as a failure. Keeps or stops the flight.
  bool Yield(const std::string& why);
  void Plan(const std::string& reason);
  void PlanHome(const std::string& reason);
  // Publishes the start-up trajectory from the current state; false (counted) if none is found.
  bool StartTurn();
  bool RemainingPathSafe();
  /// Publishes PlanStop from the flown trajectory's state now (ReplanUse::kStop); false if none.
  bool Stop();
  void Publish(const PiecewisePolynomialTrajectory& trajectory);
  void PublishStatus(const PlanResult& result, const std::string& reason);
  void PublishMaps(const PlanResult& result);
  void SendLand();
  [[nodiscard]] PlannerInput Input() const;
  // Input() from the state predicted at now + lookahead on the flown trajectory, when splicing.
  [[nodiscard]] PlannerInput PlanningInput() const;
  // Publishes `next`, spliced onto the flown trajectory when it starts later than now.
  void PublishFrom(const PiecewisePolynomialTrajectory& next);
  [[nodiscard]] double now_s() const { return UtimeToSeconds(clock_.NowUtime()); }

  lcm::LCM& lcm_;
  ExplorerConfig config_;
  const Clock& clock_;
  std::unique_ptr<ExplorationPlanner> planner_;
  MapReplica replica_;
  DropCounter drops_;
  Heartbeat heartbeat_;
  GuardedSubscriptions subscriptions_;
  int64_t epoch_;

  int8_t state_{exploration_status_t::STATE_WAITING};
  bool have_pose_{false};
  Pose3 pose_;
  Eigen::Vector3d velocity_mps_{Eigen::Vector3d::Zero()};
  bool have_controller_{false};
  int8_t controller_mode_{0};
  int64_t controller_trajectory_seq_{-1};   // the trajectory the controller last accepted
  int64_t controller_trajectory_epoch_{0};  // and its publisher's epoch: ours, or not ours
  double lowest_z_m_{1e300};                // lowest pose height seen while waiting, m
  bool startup_flown_{false};               // the controller tracks the start-up trajectory
  Eigen::Vector2d home_xy_{Eigen::Vector2d::Zero()};
  double home_yaw_rad_{0.0};
  std::optional<PiecewisePolynomialTrajectory> trajectory_;
  int64_t trajectory_seq_{0};
  int64_t plan_seq_{0};
  int64_t command_seq_{0};
  int failed_plans_{0};
  int end_deferrals_{0};  ///< consecutive end rules deferred (max_end_deferrals)
  double last_plan_s_{-1e300};
  double next_attempt_s_{-1e300};
  double last_safety_check_s_{-1e300};
  int64_t safety_checked_map_seq_{-1};
  double last_heartbeat_s_{-1e300};
  double total_planning_s_{0.0};
  double last_map2d_s_{-1e300};
  std::optional<PlanResult> last_plan_;
  // Goals (x, y, yaw) whose trajectory ran to its end (PlannerInput::reached_goals).
  std::vector<Eigen::Vector3d> reached_goals_;
  std::vector<Eigen::Vector3d> reached_views_;  // the vehicle's pose when it reached each goal
  // (time s, known cells) at each plan while exploring: the progress-stall test.
  std::vector<std::pair<double, int64_t>> known_history_;
  // The flown corridor (PlannerInput::flown_path), a point every flown_path_spacing_m.
  std::vector<Eigen::Vector2d> flown_path_;
  // Where the vehicle looked from (PlannerInput::flown_views).
  std::vector<Eigen::Vector3d> flown_views_;
  std::vector<double> plan_times_s_;
  std::vector<double> plan_cpu_times_s_;
  std::vector<PlanTimings> plan_timings_;
  std::vector<VolumetricGainStats> plan_gain_stats_;
  std::string end_rule_;
  std::string landing_;
  int home_attempts_{0};
  bool home_trajectory_{false};    // the trajectory being flown goes home
  std::vector<PeerMotion> peers_;  // the other vehicles (peer_prefixes order)
  int64_t yields_{0};
  double yielding_since_s_{-1.0};  // start of the current run of yields (-1: not yielding)
  double last_separation_check_s_{-1e300};
  double last_publish_s_{-1e300};
  std::string run_id_;
  int8_t resume_state_{-1};  // the state file's state to resume (-1: none)
  std::string resume_status_;
  int8_t saved_state_{-1};  // the state last written to the state file
  int64_t controller_holds_{0};
  // Starts a spliced replan from `trajectory_` at now + lookahead, if one is being flown.
  [[nodiscard]] bool Splicing(double now) const;
  // True when the known cells grew by less than end_stall_min_growth over the stall window.
  bool ProgressStalled();
};

}  // namespace kestrel
