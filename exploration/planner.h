#pragma once
/// @file
/// One replan of the explorer (docs/algorithms.md §7-§9) behind one interface, so that the
/// entropy planner (both of the paper's modes) and the frontier baseline are interchangeable:
///   project C (and B or E) from the 3D map -> Dijkstra from the vehicle's collision cell ->
///   candidates and their gains -> choice (or the end of exploration) -> trajectory.
/// Pure: no LCM, no clock (timings are measured with std::chrono::steady_clock for the status).

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "exploration/candidates.h"
#include "exploration/dijkstra.h"
#include "exploration/information_gain.h"
#include "exploration/projected_maps.h"
#include "exploration/trajectory_planner.h"
#include "exploration/traversability.h"
#include "exploration/volumetric_gain.h"

namespace kestrel {

/// Which planner and which map predicts the gain.
enum class ExplorationMode {
  kCombined,  ///< B for the gain, C for traversability (the paper's experiment)
  kTwoMap,    ///< E for the gain, C for traversability (the paper's simulation)
  kFrontier,  ///< nearest reachable frontier (Yamauchi 1997), the baseline
  /// 3D expected information gain on the exact map, fine traversability (docs/exploration.md)
  kVolumetric,
};

/// "combined", "two_map", "frontier" or "volumetric" (the names of exploration_status_t.mode).
[[nodiscard]] const char* ModeName(ExplorationMode mode);

/// Parameters of the frontier baseline.
struct FrontierConfig {
  /// A frontier cell nearer than this (d_cell, m) is not a goal, so the vehicle does not stay in
  /// place; default 0: any cell but the vehicle's own (d_cell > 0).
  double min_distance_m{0.0};
  /// true: frontiers on the fine traversability of the volumetric mode (the fair baseline, same
  /// search and trajectories); false: on the paper's collision map C.
  bool fine_traversability{true};
  // Fine frontiers only (exploration/frontiers.h): what a goal must see.
  double view_min_range_m{0.7};  ///< frontier cells nearer than this are not seen, m
  double view_max_range_m{4.0};  ///< frontier cells farther than this are not seen, m
  /// A goal sees some frontier cell at most this far (view_min_range_m < this <= view_max_range_m),
  /// m: a reached goal covers cells to view_max_range_m, so the next goal on the same stretch of
  /// frontier lies at least the difference farther on (no crawl along it one cell at a time).
  double goal_max_range_m{2.5};
  double horizontal_fov_deg{58.0};  ///< the camera's horizontal field of view, deg
  int min_frontier_cells{1};        ///< a goal sees at least this many frontier cells (>= 1)
};

/// Parameters of the volumetric mode (docs/exploration.md) beyond those it shares: the height,
/// C_thresh and P_init come from `projection`, the vehicle radius from `trajectory`, the bump and
/// switch margin from `candidates`.
struct VolumetricConfig {
  /// Vehicle band below h checked for traversability, m (> 0): the body's half height (0.075 m),
  /// the dip of its rim at 10 deg of tilt (0.44 sin 10 deg = 0.076 m) and one map cell for the
  /// top of a thin or pointed object that the map resolves only below its tip (docs/exploration.md,
  /// "Traversability").
  double band_below_m{0.25};
  double band_above_m{0.15};  ///< vehicle band above h, m (> 0)
  double margin_m{0.10};      ///< clearance beyond the vehicle radius, m (>= 0)
  /// Clearance beyond the vehicle radius at a passage point, the middle of a gap of an even
  /// number of free cells, m (>= 0; docs/exploration.md, "Traversability"
  /// exploration/traversability.h, step 3b).
  double passage_margin_m{0.08};
  /// Paths prefer this much clearance beyond radius + margin where the space allows, m (>= 0;
  /// 0: off): Dijkstra's steps weigh 1 + clearance_weight s^2, s the shortfall's fraction of this
  /// (docs/exploration.md, "Traversability"; exploration/traversability.h, step 4).
  double preferred_clearance_m{0.30};
  double clearance_weight{2.0};      ///< the step weight at the required clearance, minus 1 (>= 0)
  double candidate_spacing_m{0.75};  ///< candidate positions every this many m (>= one cell)
  /// The paper's end rule, working: exploration ends when the best UNWEIGHTED 3D gain of every
  /// reachable candidate pose is below this, nats (> 0).
  double end_gain_nats{4.0};
  /// Local first (docs/exploration.md, "Choosing the next pose"), m (0 = off): the goal is the
  /// best gain x bump with the bump's d_max (eq. 17) at most this, among the poses worth
  /// end_gain_nats, so that a large building does not flatten the bump (d_max grows with the
  /// farthest reachable cell) and the flight does not wander among poses the end rule already
  /// calls explored; only when no pose within it is worth end_gain_nats is the choice made over
  /// every pose with the paper's d_max.
  double local_horizon_m{0.0};
  /// A candidate pose (position within candidate_spacing_m / 2, heading within half a step) that
  /// the vehicle has reached as a goal (PlannerInput::reached_goals) while facing the goal's
  /// heading (within half a step, PlannerInput::reached_views) keeps no gain, in the choice and
  /// in the end rule: a gain the model still predicts after the flight looked from there is one
  /// the sensor does not collect (docs/exploration.md, "Ending and the flight home").
  bool skip_viewed_poses{true};
  /// Likewise for every pose the vehicle has flown through (PlannerInput::flown_views: position
  /// within candidate_spacing_m / 2, its heading in the candidate heading's half-step window):
  /// the camera looked from there on the way, not only at goals.
  bool skip_flown_poses{true};
  /// Several vehicles (docs/exploration.md, "Several vehicles"): a candidate position within this
  /// of another vehicle's goal (PlannerInput::peer_goals), in sight of it over the band, has its
  /// objective discounted by 1 - d / peer_view_radius_m for each such goal (Burgard et al. 2005's
  /// linear visibility discount; at most to 0), m (> 0). The end rule ignores the discount.
  double peer_view_radius_m{3.0};
  VolumetricGainConfig gain;  ///< sensors' 3D rays (gain.sensors' vertical keys), azimuth bins

  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// Everything a replan needs to know, validated as a whole.
struct PlannerConfig {
  ExplorationMode mode{ExplorationMode::kVolumetric};  ///< planner and gain map
  ProjectionConfig projection;                         ///< eqs. (11)-(16)
  GainConfig gain;                                     ///< eq. (10) sensors, rays, weighting
  CandidateConfig candidates;                          ///< lattice, headings, bump, end test
  TrajectoryConfig trajectory;                         ///< limits, order, disc radius
  FrontierConfig frontier;                             ///< baseline only
  VolumetricConfig volumetric;                         ///< volumetric mode (and fine frontiers)
  /// Vertical field of view of the camera for the start-up radius of section 8, rad (Xtion 45 deg).
  double startup_vertical_fov_rad{45.0 * M_PI / 180.0};

  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// A flown view is recorded each time the vehicle has turned this far (PlannerInput::flown_views).
inline constexpr double kFlownViewYawStepRad = 0.2;

/// The vehicle and map at replanning time.
struct PlannerInput {
  OccupancyGridView map;                                  ///< the 3D map (not owned)
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
  TrajectoryPlan trajectory;             ///< to the chosen candidate (status kGoal)
  GainStats gain_stats;                  ///< rays evaluated, rays per candidate
  VolumetricGainStats volumetric_stats;  ///< volumetric mode: 3D rays cast and evaluated
  PlanTimings timings;                   ///< per stage
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
  // With planar_map, planar sensors' rays are cast there (the layer they see).
  Choice ScoreCandidates(const PlannerInput& input, const GridMap2D& gain_map,
                         bool two_map_end_test, PlanResult* result,
                         const GridMap2D* planar_map = nullptr);
  // The layer a planar sensor sees (ProjectLayer at h + its offset), if there is one inside the
  // map; nullopt otherwise (its rays then go through E, as in the paper).
  [[nodiscard]] std::optional<GridMap2D> PlanarLayer(const OccupancyGridView& map) const;
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
/// not known occupied, after docs/algorithms.md §12.2), facing the mean direction of its unknown
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

/// The volumetric planner (docs/exploration.md): fine traversability (exploration/traversability.h)
/// and Dijkstra from the vehicle's cell; candidate positions every candidate_spacing_m on
/// reachable traversable cells x n_yaw headings; each pose's gain from the sensors' 3D rays
/// through the exact map (exploration/volumetric_gain.h, eqs. 7-10 per ray); objective gain x
/// bump(d_cell) (eqs. 9, 17); exploration ends when the best unweighted gain of every reachable
/// candidate is below volumetric.end_gain_nats.
///
/// Exact argmax with less work: a pose's gain is at most the prior entropy of the cells its rays
/// cross (E[H] >= 0), which costs a cast and a sum. Positions are evaluated exactly in decreasing
/// order of bound x bump until the best exact objective reaches the next bound x bump, so the
/// choice is the one evaluating every candidate gives; the end rule likewise evaluates in order of
/// bound until one exact gain passes the threshold or no bound can. Candidates listed in the
/// result are those evaluated exactly. Between replans a position keeps its gains while the map
/// within its rays' reach holds, and a memo per ray (RayMemo) otherwise: a ray that reads the
/// same priors again reuses its exact I_ray, which is also its bound. Not thread-safe.
class VolumetricPlanner final : public ExplorationPlanner {
 public:
  /// @throws std::invalid_argument if config is invalid.
  explicit VolumetricPlanner(const PlannerConfig& config);
  PlanResult Plan(const PlannerInput& input) override;
  [[nodiscard]] ExplorationMode mode() const override { return ExplorationMode::kVolumetric; }

  /// Positions whose gains were reused from an earlier replan in the last Plan (the map did not
  /// change within their rays' reach: exact reuse, same numbers).
  [[nodiscard]] int reused_positions() const { return reused_positions_; }

 private:
  // A position's bounds and (if evaluated) gains, valid while the map within its reach holds.
  struct CachedPose {
    std::vector<double> bounds;
    std::vector<double> gains;  // empty until evaluated exactly
    RayMemo memo;               // each ray's exact I_ray and the priors it was evaluated on
  };
  // Compares the map with the copy of the last Plan in tiles of kTile x kTile columns and marks
  // the tiles within the rays' reach of a changed one (affected_); copies the map. All tiles are
  // affected when the lattice changed or on the first call.
  void UpdateAffectedTiles(const OccupancyGridView& map);
  [[nodiscard]] bool Affected(const Cell2& cell) const;

  static constexpr int kTile = 8;
  PlannerConfig config_;
  VolumetricGainEvaluator gains_;
  std::vector<float> previous_map_;
  Eigen::Vector3i previous_dims_{Eigen::Vector3i::Zero()};
  Eigen::Vector3d previous_origin_m_{Eigen::Vector3d::Zero()};
  double previous_resolution_m_{0.0};
  int tiles_x_{0};
  std::vector<bool> affected_;                 // per tile
  std::unordered_map<int, CachedPose> cache_;  // by 2D cell index
  int reused_positions_{0};
};

/// The frontier baseline on the volumetric mode's fine traversability, search and trajectories
/// (frontier.fine_traversability; docs/exploration.md, "The frontier baseline"): the nearest
/// (d_cell) reachable traversable cell from which, at some heading, the camera sees at least
/// frontier.min_frontier_cells frontier cells (exploration/frontiers.h: within the view's
/// ranges, inside its field of view, in sight over known free cells), facing the heading that
/// sees the most. Frontier cells that a reached goal saw (candidates.skip_reached_goals) are no
/// longer frontiers. The current goal is kept while it still sees enough; done ("no reachable
/// frontier") when no reachable cell does. Not thread-safe.
class FineFrontierPlanner final : public ExplorationPlanner {
 public:
  /// @throws std::invalid_argument if config is invalid.
  explicit FineFrontierPlanner(const PlannerConfig& config);
  PlanResult Plan(const PlannerInput& input) override;
  [[nodiscard]] ExplorationMode mode() const override { return ExplorationMode::kFrontier; }

 private:
  PlannerConfig config_;
  VolumetricGainEvaluator gains_;  // the chosen frontier's 3D gain, for the status
};

/// The fine traversability parameters of `config` (volumetric keys, height, C_thresh, P_init,
/// vehicle radius).
[[nodiscard]] TraversabilityConfig FineTraversabilityConfig(const PlannerConfig& config);

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

/// PlanToPoint on the fine traversability, with the flown corridor (input.flown_path) allowed:
/// the goal's cell, or the reachable cell nearest to it within the vehicle radius.
[[nodiscard]] PlanResult PlanToPointFine(const PlannerConfig& config, const PlannerInput& input,
                                         const Eigen::Vector2d& goal_xy, double goal_yaw_rad);

/// A trajectory from the vehicle to the collision cell containing goal_xy with heading
/// goal_yaw_rad (the flight home at the end of exploration), with the same projection, search
/// and checks as a replan. Status kGoal on success. In volumetric mode and for fine frontiers:
/// PlanToPointFine.
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
