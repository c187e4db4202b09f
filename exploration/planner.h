#pragma once
/// @file
/// One replan of the explorer (ALGORITHMS.md sections 7 and 8) behind one interface, so that the
/// entropy planner (both of the paper's modes) and the frontier baseline are interchangeable:
///   project C (and B or E) from the 3D map -> Dijkstra from the vehicle's collision cell ->
///   candidates and their gains -> choice (or the end of exploration) -> trajectory.
/// Pure: no LCM, no clock (timings are measured with std::chrono::steady_clock for the status).

#include <Eigen/Core>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "exploration/candidates.h"
#include "exploration/dijkstra.h"
#include "exploration/information_gain.h"
#include "exploration/projected_maps.h"
#include "exploration/trajectory_planner.h"

namespace kestrel {

/// Which planner and which map predicts the gain.
enum class ExplorationMode {
  kCombined,  ///< B for the gain, C for traversability (the paper's experiment)
  kTwoMap,    ///< E for the gain, C for traversability (the paper's simulation)
  kFrontier,  ///< nearest reachable frontier (Yamauchi 1997), the baseline
};

/// "combined", "two_map" or "frontier" (the names of exploration_status_t.mode).
[[nodiscard]] const char* ModeName(ExplorationMode mode);

/// Parameters of the frontier baseline.
struct FrontierConfig {
  /// A frontier cell nearer than this (d_cell, m) is not a goal, so the vehicle does not stay in
  /// place; default 0: any cell but the vehicle's own (d_cell > 0).
  double min_distance_m{0.0};
};

/// Everything a replan needs to know, validated as a whole.
struct PlannerConfig {
  ExplorationMode mode{ExplorationMode::kCombined};  ///< planner and gain map
  ProjectionConfig projection;                       ///< eqs. (11)-(16)
  GainConfig gain;                                   ///< eq. (10) sensors, rays, weighting
  CandidateConfig candidates;                        ///< lattice, headings, bump, end test
  TrajectoryConfig trajectory;                       ///< limits, order, disc radius
  FrontierConfig frontier;                           ///< baseline only
  /// Vertical field of view of the camera for the start-up radius of section 8, rad (Xtion 45 deg).
  double startup_vertical_fov_rad{45.0 * M_PI / 180.0};

  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// The vehicle and map at replanning time.
struct PlannerInput {
  OccupancyGridView map;                                  ///< the 3D map (not owned)
  Eigen::Vector3d position_m{Eigen::Vector3d::Zero()};    ///< vehicle position, m, W
  Eigen::Vector3d velocity_mps{Eigen::Vector3d::Zero()};  ///< vehicle velocity, m/s, W
  double yaw_rad{0.0};                                    ///< vehicle heading, rad
  double time_s{0.0};                                     ///< start time of the trajectory, s
  /// If set, the start-up rule of section 8 around this (x, y) (the take-off point), m, W.
  std::optional<Eigen::Vector2d> startup_center_m;
  /// Goal poses (x m, y m, yaw rad; W) the vehicle has reached; with
  /// candidates.skip_reached_goals, a candidate in the same collision cell with the same heading
  /// (within half a heading step) is not scored.
  std::vector<Eigen::Vector3d> reached_goals;
  /// The goal (x m, y m, yaw rad; W) being flown to, if any: kept unless another candidate's
  /// objective exceeds its own by candidates.switch_margin.
  std::optional<Eigen::Vector3d> current_goal;
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
  TrajectoryPlan trajectory;  ///< to the chosen candidate (status kGoal)
  GainStats gain_stats;       ///< rays evaluated, rays per candidate
  PlanTimings timings;        ///< per stage
};

/// The planner interface shared by the entropy planner and the frontier baseline.
class ExplorationPlanner {
 public:
  virtual ~ExplorationPlanner() = default;
  /// One full replan. Never throws on a map or pose it cannot use: status kFailed with a reason.
  virtual PlanResult Plan(const PlannerInput& input) = 0;
  /// The mode it implements.
  [[nodiscard]] virtual ExplorationMode mode() const = 0;
};

/// The paper's planner: gains by eq. (10) on B (combined) or E (two-map), objective eq. (9)
/// weighted by eq. (17), end test on the unweighted gain. Not thread-safe.
///
/// Two-map end test: E's P_min_E correction (eq. 15) keeps every well-known cell at P_min_E or
/// 1 - P_min_E, whose entropy a measurement can still reduce, so a pose's E-gain never falls to
/// zero (about 1 nat per ray in open known space). In two-map mode the end test therefore uses,
/// per candidate, its gain minus the gain of the same pose on the saturated E (every cell at
/// P_min_E or 1 - P_min_E): exploration ends when the largest such excess is below
/// end_entropy_gain_nats.
class EntropyPlanner final : public ExplorationPlanner {
 public:
  /// @throws std::invalid_argument if config is invalid or its mode is kFrontier.
  explicit EntropyPlanner(const PlannerConfig& config);
  PlanResult Plan(const PlannerInput& input) override;
  [[nodiscard]] ExplorationMode mode() const override { return config_.mode; }

 private:
  // Scores the candidates' gains on gain_map into result->candidates (without reached goals)
  // and chooses; with two_map_end_test, the end test on the excess over E's P_min_E floor.
  Choice ScoreCandidates(const PlannerInput& input, const GridMap2D& gain_map,
                         bool two_map_end_test, PlanResult* result);
  // True if (cell, yaw) is a reached goal and candidates.skip_reached_goals is on.
  [[nodiscard]] bool Reached(const PlannerInput& input, const GridMap2D& c, int cell,
                             double yaw_rad) const;

  PlannerConfig config_;
  GainEvaluator gains_;
};

/// Yamauchi-style baseline: the nearest (by d_cell) reachable traversable collision cell, not
/// already reached (PlannerInput::reached_goals, with candidates.skip_reached_goals; the current
/// goal is kept while it is still a reachable frontier), with an
/// unknown 8-neighbour in C (not traversable and P_init/2 <= P(C) <= 0.5: not yet known free,
/// not known occupied, after ALGORITHMS.md section 10), facing the mean direction of its unknown
/// neighbours; done when no such cell is reachable. Its gain (on B, for the status) is computed
/// for the chosen pose only. Not thread-safe.
class FrontierPlanner final : public ExplorationPlanner {
 public:
  /// @throws std::invalid_argument if config is invalid.
  explicit FrontierPlanner(const PlannerConfig& config);
  PlanResult Plan(const PlannerInput& input) override;
  [[nodiscard]] ExplorationMode mode() const override { return ExplorationMode::kFrontier; }

 private:
  PlannerConfig config_;
  GainEvaluator gains_;  // reports the chosen frontier's gain in nats for comparison
};

/// The planner for config.mode. @throws std::invalid_argument if config is invalid.
[[nodiscard]] std::unique_ptr<ExplorationPlanner> MakePlanner(const PlannerConfig& config);

/// A trajectory from the vehicle to the collision cell containing goal_xy with heading
/// goal_yaw_rad (the flight home at the end of exploration), with the same projection, search
/// and checks as a replan. Status kGoal on success.
[[nodiscard]] PlanResult PlanToPoint(const PlannerConfig& config, const PlannerInput& input,
                                     const Eigen::Vector2d& goal_xy, double goal_yaw_rad);

}  // namespace kestrel
