#pragma once
/// @file
/// The explorer (pure: no LCM, no clock, no files; times come with the inputs): the paper's
/// exploration loop (docs/algorithms.md §8) as a state machine that takes poses, controller
/// reports, the other vehicles' motion and the map, and returns what to publish.
///
///   WAITING   until a map, a valid pose and the vehicle airborne on the commanded take-off
///             (controller in TAKEOFF, startup_min_rise_m above the lowest height seen) or
///             hovering (HOLD); the explorer never takes off by itself;
///   STARTUP   one trajectory from the current state: the rest of the climb to the exploration
///             height h, vertically, while the heading turns a full circle to scan
///             (exploration/startup_turn.h; docs/exploration.md "Start-up: the turn while
///             climbing"); back to WAITING if the controller does not fly it within 1 s;
///   EXPLORING plans (exploration/planner.h) and flies; replans when the trajectory ends, when
///             new map data makes the remaining path unsafe, after replan_period_s, when another
///             vehicle comes too near ahead, or when the controller holds without flying the
///             latest trajectory;
///   RETURNING when an end rule holds (or planning keeps failing): flies back to the take-off
///             point, or lands elsewhere after max_home_attempts failed plans home;
///   DONE      the land command (the only command the explorer may send).
///
/// Where the rules live: when exploration ends (OnPlan: the planner's end rules, the progress
/// stall, the deferral while the take-off point is unreachable), which goal is kept or flown
/// (the goal and flown-path memory handed to the planner in Input(), ChooseReplanUse), when to
/// replan (StepExploring), how to go home (PlanHome) and how to yield to another vehicle
/// (Yield). A restarted explorer of the same run takes up where the last one stopped (Restore,
/// then the first Step that finds the vehicle airborne; docs/design.md §2.5).
///
/// Inputs out of order are defined: a pose before a map, a controller report before a pose, a
/// report naming another explorer's trajectory (another epoch: not ours), a trajectory the
/// controller refused (not flown: STARTUP goes back to WAITING, EXPLORING replans after
/// controller_hold_replan_s), a peer seen long ago (it stays where it was seen) all leave the
/// explorer in a state it names; non-finite inputs are refused (the caller counts them).
/// Not thread-safe.

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "common/log.h"
#include "common/se3.h"
#include "common/trajectory.h"
#include "exploration/explorer_config.h"
#include "exploration/explorer_state.h"
#include "exploration/planner.h"
#include "exploration/separation.h"
#include "exploration/unlearned_cells.h"

namespace kestrel {

/// Why a plan was made (the start of the status message's reason).
enum class ReplanReason {
  kStartupDone,       ///< "start-up turn done"
  kTrajectoryEnded,   ///< "trajectory ended"
  kReplanPeriod,      ///< "replan period" (replan_period_s while a trajectory is flown)
  kPathUnsafe,        ///< "remaining path unsafe" (new map data)
  kTooNearPeer,       ///< "too near another vehicle ahead"
  kControllerHolds,   ///< "the controller holds" (without flying the latest trajectory)
  kResumed,           ///< "resumed after a restart"
  kExplorationEnded,  ///< "exploration ended" (the first plan home)
  kRetryHome,         ///< "retrying the flight home"
};

/// The reason's words in the status message.
[[nodiscard]] const char* ToString(ReplanReason reason);

/// The controller's mode as the explorer reads it (values as controller_status_t MODE_*).
enum class ControllerMode : int8_t {
  kIdle = 0,
  kTakeoff = 1,
  kTrack = 2,
  kHold = 3,
  kLand = 4,
  kEstop = 5,
};

/// What the controller last reported (CONTROLLER_STATUS).
struct ControllerReport {
  ControllerMode mode{ControllerMode::kIdle};  ///< its flight mode
  int64_t trajectory_seq{-1};                  ///< the trajectory it last accepted (-1: none)
  int64_t trajectory_epoch{0};  ///< that trajectory's publisher epoch (ours, or another's)
  /// Its estimate's velocity, m/s, W; nullopt (or not finite): the last finite one is kept.
  std::optional<Eigen::Vector3d> velocity_mps;
};

/// The map the explorer plans on (the node's copy of the mapper's map).
struct ExplorerMap {
  OccupancyGridView view;  ///< the cells (not owned; valid during the call)
  int64_t seq{-1};         ///< map updates reflected (a change triggers the path re-check)
  bool current{false};     ///< a whole snapshot arrived and no delta was missed since
};

/// Things that happened that are not errors (the node counts and logs them; they are not drops).
enum class ExplorerEvent {
  kYielded,          ///< a plan refused by the separation check: the vehicle yields
  kReplanKept,       ///< a replan not from the flown state: the flown trajectory kept
  kStartNotMatched,  ///< a trajectory from a simplified start state: a set-point step
  kStopped,          ///< a replan not from the flown state, the flown path not clear: stop
  kStopNotClear,     ///< the stop would leave the usable cells: the replan flown instead
  kSpliceFailed,     ///< the replan could not be spliced onto the flown trajectory
  kEndDeferred,      ///< an end rule with the take-off point unreachable: deferred
  kStartupNotFlown,  ///< the controller did not fly the start-up trajectory
  kStartupFailed,    ///< no start-up trajectory from the current state
  kControllerHolds,  ///< the controller held without flying the latest trajectory
  kPlanFailed,       ///< a plan without a usable trajectory
};
inline constexpr int kExplorerEventCount = 11;

/// "yielded", "replan_kept", "start_not_matched", "stopped", "stop_not_clear", "splice_failed",
/// "end_deferred", "startup_not_flown", "startup_failed", "controller_holds", "plan_failed".
[[nodiscard]] const char* ToString(ExplorerEvent event);

/// Publish this trajectory (TRAJECTORY).
struct PublishTrajectory {
  PiecewisePolynomialTrajectory trajectory;
  int64_t seq{0};  ///< its sequence number (1, 2, ...), which the controller reports back
};

/// Publish a status (EXPLORATION_STATUS): what a plan decided and why.
struct PublishStatus {
  std::shared_ptr<const PlanResult> plan;        ///< never null (an empty result for "land sent")
  std::string reason;                            ///< why, before the plan's own reason
  ExplorerState state{ExplorerState::kWaiting};  ///< the state after the decision
  int64_t seq{0};                                ///< the plan number (plans())
  bool replan{false};  ///< an exploration replan (its 2D maps may go out), not a flight home
};

/// Send the land command (COMMAND).
struct SendLand {};

/// Log a line (what the explorer decided, in words).
struct LogLine {
  LogLevel level{LogLevel::kInfo};
  std::string text;
};

/// Count and log an event.
struct ReportEvent {
  ExplorerEvent event{ExplorerEvent::kPlanFailed};
  std::string what;  ///< why, in words
};

/// One thing to do, in order.
using ExplorerAction =
    std::variant<PublishTrajectory, PublishStatus, SendLand, ReportEvent, LogLine>;

/// What the state file keeps so that a restarted explorer of the same run resumes
/// (docs/design.md §2.5).
struct ExplorerRecord {
  ExplorerState state{ExplorerState::kWaiting};
  Eigen::Vector2d home_xy_m{Eigen::Vector2d::Zero()};  ///< the take-off point, m, W
  double home_yaw_rad{0.0};                            ///< the heading at the take-off, rad
  double lowest_z_m{0.0};                              ///< lowest pose height seen while waiting, m
  std::string end_rule;  ///< what ended exploration ("" while exploring)
};

/// What a replan that has a trajectory becomes (docs/exploration.md, "Non-stop flight",
/// section 1).
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

/// How time passes while the planner runs.
enum class PlanningTime {
  kStandsStill,  ///< simulated time: a step happens at one instant (lockstep, SimTruthClock)
  kPasses,       ///< a wall clock: the time after a plan is the step's plus the plan's wall time
};

class Explorer {
 public:
  /// `epoch`: the publisher epoch the node stamps on this explorer's trajectories (the controller
  /// reports it back). @throws std::invalid_argument if config.Validate() throws.
  Explorer(const ExplorerConfig& config, int64_t epoch,
           PlanningTime planning_time = PlanningTime::kStandsStill);

  /// A restarted explorer of the same run: takes up `record` once the vehicle is seen airborne.
  /// False (nothing changes) when its state is not one to resume (WAITING, FAILED, or a
  /// non-finite take-off point).
  bool Restore(const ExplorerRecord& record);

  /// A pose of this vehicle at time_s (s). False, and ignored, when not finite.
  bool OnPose(double time_s, const Pose3& X_WB);
  /// The controller's report.
  void OnControllerReport(const ControllerReport& report);
  /// Another vehicle's position seen at time_s (config.peers[peer] order). False, and ignored,
  /// for an unknown peer, a non-finite position or one seen before the position it holds.
  bool OnPeerPose(size_t peer, double time_s, const Eigen::Vector3d& position_m);
  /// Another vehicle's latest trajectory. False, and ignored, for an unknown peer.
  bool OnPeerTrajectory(size_t peer, PiecewisePolynomialTrajectory trajectory);

  /// Advances the exploration at time_s on `map`; cheap when nothing is due. Returns what to
  /// publish, in order.
  std::vector<ExplorerAction> Step(double time_s, const ExplorerMap& map);

  [[nodiscard]] ExplorerState state() const { return state_; }
  [[nodiscard]] const ExplorerConfig& config() const { return config_; }
  /// Plans made (each status carries its number).
  [[nodiscard]] int64_t plans() const { return plan_seq_; }
  /// The last exploration replan's result (null before the first).
  [[nodiscard]] const std::shared_ptr<const PlanResult>& last_plan() const { return last_plan_; }
  /// What the state file keeps now.
  [[nodiscard]] ExplorerRecord Record() const;
  /// A restored record waits for the vehicle to be seen airborne.
  [[nodiscard]] bool resume_pending() const { return resume_.has_value(); }
  /// Once resumed, how ("" before).
  [[nodiscard]] const std::string& resume_status() const { return resume_status_; }
  /// What ended exploration ("" while exploring): "gain rule", "progress stall", "planning
  /// failures", "no reachable candidate", "no reachable frontier".
  [[nodiscard]] const std::string& end_rule() const { return end_rule_; }
  /// How the flight ended ("" until the land command): "returned home" or "landed elsewhere: ...".
  [[nodiscard]] const std::string& landing() const { return landing_; }
  /// Times each event happened.
  [[nodiscard]] int64_t count(ExplorerEvent event) const {
    return events_[static_cast<size_t>(event)];
  }
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
  /// The cells looked at again and again without learning (ExplorerConfig::unlearned_looks).
  [[nodiscard]] const UnlearnedCells& unlearned() const { return unlearned_; }
  /// What the next plan is given now (at the last step's time, on its map): the vehicle, the
  /// take-off point, the goal and flown-path memory (reached goals and the views there, the flown
  /// corridor and views), the goal being flown to, the other vehicles' goals and the separation
  /// check.
  [[nodiscard]] PlannerInput Input() const;
  /// "" if `trajectory` keeps min_separation_m from every other vehicle from from_s (or its start,
  /// if later) on, or does not come nearer to one that is already nearer; else which vehicle, how
  /// near and when.
  [[nodiscard]] std::string SeparationRefusal(const PiecewisePolynomialTrajectory& trajectory,
                                              double from_s = -1e300) const;

 private:
  // The steps of each state.
  void StepWaiting();
  void StepStartup();
  void StepExploring();
  void StepReturning();
  // WAITING with a restored record and the vehicle airborne: takes up where it stopped.
  bool Resume();
  // The controller holds without flying our latest trajectory (controller_hold_replan_s).
  [[nodiscard]] bool ControllerHoldsWithoutOurTrajectory() const;
  // A refused plan (the separation check): true if it is still a yield (max_yield_s), false once
  // it counts as a failure. Keeps or stops the flight.
  bool Yield(const std::string& why);
  // A replan and what follows from it (OnPlan).
  void Plan(ReplanReason reason);
  // The decisions on a replan's result: fly, keep, stop, yield, defer, end or fail.
  void OnPlan(PlanResult* result, ReplanReason reason);
  void PlanHome(ReplanReason reason);
  // No path home after max_home_attempts: a landing place elsewhere (reached with `planner`, the
  // last attempt's), or in place.
  void LandElsewhere(const PlannerConfig& planner, const PlanResult& home, ReplanReason reason);
  // The start-up trajectory from the current state; false (counted) if none is found.
  bool StartTurn();
  // Records a reached goal (the trajectory ended, or the vehicle passed within 0.3 m of it).
  void RememberReachedGoal(bool trajectory_ended);
  bool RemainingPathSafe() const;
  // Publishes PlanStop from the flown trajectory's state now (ReplanUse::kStop); false if none.
  bool Stop();
  void Publish(const PiecewisePolynomialTrajectory& trajectory);
  // Publishes `next`, spliced onto the flown trajectory when it starts later than now.
  void PublishFrom(const PiecewisePolynomialTrajectory& next);
  void Status(std::shared_ptr<const PlanResult> plan, const std::string& reason, bool replan);
  void Land();
  void Event(ExplorerEvent event, const std::string& what);
  // Input() from the state predicted at now + lookahead on the flown trajectory, when splicing.
  [[nodiscard]] PlannerInput PlanningInput() const;
  // A replan spliced onto the flown trajectory starts at now + lookahead, if one is being flown.
  [[nodiscard]] bool Splicing() const;
  // True when the known cells grew by less than end_stall_min_growth over the stall window.
  bool ProgressStalled();
  // After a plan that took wall_s: time passes (PlanningTime::kPasses) or not.
  void PlanningTook(double wall_s);
  // The volumetric mode with unlearned_looks: one look from the vehicle's pose
  // (UnlearnedCells::Look), and `input`'s gain map with the unlearned cells read as certain.
  void LookAndSetGainMap(PlannerInput* input);

  ExplorerConfig config_;
  int64_t epoch_;
  PlanningTime planning_time_;
  std::unique_ptr<ExplorationPlanner> planner_;
  std::vector<ExplorerAction> actions_;  // of the current call
  double now_s_{0.0};                    // the current time, s
  ExplorerMap map_;                      // the map of the current step

  ExplorerState state_{ExplorerState::kWaiting};
  bool have_pose_{false};
  Pose3 pose_;
  Eigen::Vector3d velocity_mps_{Eigen::Vector3d::Zero()};
  bool have_controller_{false};
  ControllerReport controller_;
  double lowest_z_m_{1e300};   // lowest pose height seen while waiting, m
  bool startup_flown_{false};  // the controller tracks the start-up trajectory
  Eigen::Vector2d home_xy_{Eigen::Vector2d::Zero()};
  double home_yaw_rad_{0.0};
  std::optional<PiecewisePolynomialTrajectory> trajectory_;
  int64_t trajectory_seq_{0};
  int64_t plan_seq_{0};
  int failed_plans_{0};
  int end_deferrals_{0};  // consecutive end rules deferred (max_end_deferrals)
  double last_plan_s_{-1e300};
  double next_attempt_s_{-1e300};
  double last_safety_check_s_{-1e300};
  int64_t safety_checked_map_seq_{-1};
  double total_planning_s_{0.0};
  std::shared_ptr<const PlanResult> last_plan_;
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
  std::vector<PeerMotion> peers_;  // the other vehicles (config.peers order)
  double yielding_since_s_{-1.0};  // start of the current run of yields (-1: not yielding)
  double last_separation_check_s_{-1e300};
  double last_publish_s_{-1e300};
  std::optional<ExplorerState> resume_;  // the restored state to resume
  std::string resume_status_;
  std::array<int64_t, kExplorerEventCount> events_{};
  UnlearnedCells unlearned_;
  std::vector<float> gain_map_;  // the map with unlearned cells read as certain (gain_map)
};

}  // namespace kestrel
