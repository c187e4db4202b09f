#pragma once
/// @file
/// One replan of the explorer (docs/algorithms.md §7-§9) behind one interface, so that every
/// mode is interchangeable: its input (the map, the vehicle's start state, the goal and
/// flown-path memory), its result, the planner interface and the planner of a mode
/// (MakePlanner), the flight to a point (PlanToPoint) and the checks the explorer asks between
/// plans. The stages every mode runs are exploration/planning_pipeline.h. Pure: no LCM, no clock
/// (timings are measured with std::chrono::steady_clock for the status).

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "exploration/dijkstra.h"
#include "exploration/planner_config.h"

namespace kestrel {

/// A flown view is recorded each time the vehicle has turned this far (PlannerInput::flown_views).
inline constexpr double kFlownViewYawStepRad = 0.2;

/// The vehicle and map at replanning time.
struct PlannerInput {
  OccupancyGridView map;  ///< the 3D map (not owned)
  /// The map the volumetric gain reads (not owned; same lattice as `map`): the explorer's
  /// unlearned cells read as certain (exploration/unlearned_cells.h; docs/exploration.md,
  /// "Unlearned cells"). Unset (no probabilities): `map`. Traversability always reads `map`.
  OccupancyGridView gain_map;
  Eigen::Vector3d position_m{Eigen::Vector3d::Zero()};    ///< vehicle position, m, W
  Eigen::Vector3d velocity_mps{Eigen::Vector3d::Zero()};  ///< vehicle velocity, m/s, W
  /// Vehicle acceleration, m/s^2, W (a replan spliced onto the flown trajectory starts from it).
  Eigen::Vector3d acceleration_mps2{Eigen::Vector3d::Zero()};
  double yaw_rad{0.0};         ///< vehicle heading, rad
  double yaw_rate_radps{0.0};  ///< vehicle yaw rate, rad/s
  double time_s{0.0};          ///< start time of the trajectory, s
  /// If set, the start-up rule of section 8 around this (x, y) (the take-off point), m, W.
  std::optional<Eigen::Vector2d> startup_center_m;
  /// Goal poses (x m, y m, yaw rad; W) the vehicle has reached; with
  /// candidates.skip_reached_goals, a candidate in the same collision cell with the same heading
  /// (within half a heading step) is not scored.
  std::vector<Eigen::Vector3d> reached_goals;
  /// The vehicle's own pose (x m, y m, yaw rad; W) at the moment it reached each goal, one per
  /// reached_goals entry: in non-stop flight it can pass a goal before it has turned to the
  /// goal's heading, so what it saw there is judged from this (the fine frontiers' covered cells,
  /// the volumetric mode's skip_viewed_poses).
  std::vector<Eigen::Vector3d> reached_views;
  /// The goal (x m, y m, yaw rad; W) being flown to, if any: kept unless another candidate's
  /// objective exceeds its own by candidates.switch_margin.
  std::optional<Eigen::Vector3d> current_goal;
  /// Points (x, y; W) the vehicle has flown through: the flight home (PlanToPoint, volumetric
  /// traversability) may use them even where the map has since grown uncertain.
  std::vector<Eigen::Vector2d> flown_path;
  /// The vehicle's poses (x m, y m, yaw rad; W) along its flight, one each time it has moved
  /// flown_path_spacing_m or turned kFlownViewYawStepRad since the last: where it has looked from
  /// (the volumetric mode's skip_flown_poses).
  std::vector<Eigen::Vector3d> flown_views;
  /// Several vehicles (docs/exploration.md, "Several vehicles"): the goals (x m, y m, yaw rad; W)
  /// the other vehicles fly to; the volumetric mode discounts candidates in their view
  /// (VolumetricConfig::peer_view_radius_m).
  std::vector<Eigen::Vector3d> peer_goals;
  /// Several vehicles: "" if a trajectory keeps its separation from the other vehicles, else why
  /// not. The volumetric mode tries its next candidates (at most 10 refused) when it refuses the
  /// best one's trajectory, and fails with the reason when every one is refused. Unset: no check.
  std::function<std::string(const PiecewisePolynomialTrajectory&)> trajectory_check;

  /// gain_map if set, else map.
  [[nodiscard]] const OccupancyGridView& GainMap() const {
    return gain_map.probability != nullptr ? gain_map : map;
  }

  /// The start state this input describes (position, velocity, acceleration, yaw, yaw rate, time).
  [[nodiscard]] TrajectoryStart Start() const;
  /// Sets the start state (a point of the flown trajectory, for a spliced replan).
  void SetStart(const TrajectoryStart& start);
};

/// Wall-clock time of each stage of one replan, s.
struct PlanTimings {
  double projection_s{0.0};  ///< C, B and E
  double gain_s{0.0};        ///< every candidate's gain (frontier: the search for frontiers)
  double dijkstra_s{0.0};    ///< distance field
  double trajectory_s{0.0};  ///< waypoints, pruning, KKT, checks
  double total_s{0.0};       ///< the whole replan
};

/// What a replan decided.
enum class PlanStatus {
  kGoal,             ///< a candidate was chosen and a trajectory to it planned
  kExplorationDone,  ///< best unweighted gain below threshold (or no frontier): go home
  kFailed,           ///< no usable plan (see reason)
};

/// The outcome of one replan, with what the status message reports.
struct PlanResult {
  PlanStatus status{PlanStatus::kFailed};  ///< see PlanStatus
  std::string reason;                      ///< why it failed, or what ended exploration
  CollisionProjection collision;           ///< C and B
  std::optional<GridMap2D> entropy;        ///< E (two-map mode only)
  DistanceField field;                     ///< Dijkstra from the vehicle's cell
  std::vector<Candidate> candidates;       ///< every candidate with gain, distance, bump
  int chosen{-1};                          ///< index into candidates, -1 if none
  double best_unweighted_gain_nats{0.0};   ///< max I(X_c): the end-of-exploration test
  /// What the end test compared (EntropyPlanner): the best unweighted gain on B in combined mode
  /// (with end_gain_nats), the best gain beyond the P_min_E floor on E in two-map mode or after
  /// combined's check on E (with end_entropy_gain_nats), nats.
  double end_test_gain_nats{0.0};
  /// Combined mode: B's end test said "done" and E's did not, so the candidates were scored on
  /// E (candidates.end_check_entropy_map).
  bool gains_from_entropy_map{false};
  /// Volumetric mode and fine frontiers: the fine traversability (its band is also `collision`).
  std::optional<Traversability> traversability;
  /// What ended exploration (status kExplorationDone): "gain rule", "no reachable candidate",
  /// "no reachable frontier".
  std::string end_rule;
  /// Several vehicles: trajectories PlannerInput::trajectory_check refused in this plan; a plan
  /// that fails with some refused failed because of the other vehicles (the explorer yields).
  int refused_trajectories{0};
  /// Cells the explorer reads as certain because looking at them again and again taught nothing
  /// (exploration/unlearned_cells.h; set by the explorer, not the planner).
  int64_t unlearned_cells{0};
  TrajectoryPlan trajectory;             ///< to the chosen candidate (status kGoal)
  GainStats gain_stats;                  ///< rays evaluated, rays per candidate
  VolumetricGainStats volumetric_stats;  ///< volumetric mode: 3D rays cast and evaluated
  PlanTimings timings;                   ///< per stage
};

/// The interface every mode's planner implements (exploration/entropy_planner.h,
/// frontier_planner.h, volumetric_planner.h, fine_frontier_planner.h), each on the one stage
/// sequence of exploration/planning_pipeline.h.
class ExplorationPlanner {
 public:
  virtual ~ExplorationPlanner() = default;
  /// One full replan. Never throws on a map or pose it cannot use: status kFailed with a reason.
  virtual PlanResult Plan(const PlannerInput& input) = 0;
  /// The mode it implements.
  [[nodiscard]] virtual ExplorationMode mode() const = 0;
};

/// Whether the rest of `trajectory` from from_time_s (+ 0.5 s: the vehicle's own place) keeps the
/// vehicle in allowed space on the current map, by the mode's own rule: the disc over C's
/// traversable cells (paper modes, coarse frontier), or the centre over fine traversable cells
/// (volumetric, fine frontier), with the cells around the trajectory's start allowed.
[[nodiscard]] bool TrajectoryStillClear(const PlannerConfig& config, const PlannerInput& input,
                                        const PiecewisePolynomialTrajectory& trajectory,
                                        double from_time_s);

/// The planner for config.mode. @throws std::invalid_argument if config is invalid.
[[nodiscard]] std::unique_ptr<ExplorationPlanner> MakePlanner(const PlannerConfig& config);

/// "" if the input is usable (finite pose, velocity, acceleration, yaw, time; valid map), else why.
[[nodiscard]] std::string CheckPlannerInput(const PlannerInput& input);

/// A trajectory from the vehicle to the cell containing goal_xy with heading goal_yaw_rad (the
/// flight home at the end of exploration), with the same map view, search and checks as a replan
/// of config.mode (planning_pipeline.h). On the fine traversability the flown corridor
/// (input.flown_path) is allowed and, when the goal's cell is not reachable, the reachable cell
/// nearest to it within the vehicle radius is the goal. Status kGoal on success. The separation
/// check is left to the caller (the explorer waits for the other vehicle).
[[nodiscard]] PlanResult PlanToPoint(const PlannerConfig& config, const PlannerInput& input,
                                     const Eigen::Vector2d& goal_xy, double goal_yaw_rad);

/// Whether a fine-mode plan's distance field reaches a cell whose centre lies within radius_m of
/// xy_m (the explorer asks it of the take-off point before it ends exploration). True for plans
/// without a fine traversability (the paper's modes, on C).
[[nodiscard]] bool ReachesWithin(const PlanResult& result, const Eigen::Vector2d& xy_m,
                                 double radius_m);

/// Where to land when no path home exists (docs/exploration.md, "Ending and the flight home"):
/// of the cells a fine-mode plan's distance field reaches (nearest first), the first whose
/// vehicle disc (radius_m) has nothing below the flight to land on: every 3D cell whose column
/// centre lies within radius_m + alpha/sqrt(2) of the cell's centre and whose z extent lies in
/// [ground_z_m + alpha, top_z_m] is known free (P <= free_threshold; one layer above the ground is
/// left out: the floor's own cells and what no landing gear notices). nullopt if there is none
/// or the plan has no fine traversability.
[[nodiscard]] std::optional<int> LandingCell(const PlanResult& result, const OccupancyGridView& map,
                                             double radius_m, double ground_z_m, double top_z_m,
                                             double free_threshold);

}  // namespace kestrel
