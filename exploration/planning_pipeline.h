#pragma once
/// @file
/// The one stage sequence every replan runs (docs/algorithms.md §7-§10), whatever the mode:
///   1. check the input (CheckPlannerInput);
///   2. search: the mode's map view (the paper's collision map C with B or E, or the fine
///      traversability) and Dijkstra from the vehicle's cell (SearchSpace::Search);
///   3. choose: the mode's objective scores candidates and picks the goals to try, best first,
///      or ends exploration (Objective::Choose);
///   4. trajectory: the goals in turn, each to a trajectory from the start state
///      (SearchSpace::StartOf: one rule for every mode), checked on the mode's cells
///      (SearchSpace::TrajectoryTo) and against the other vehicles
///      (PlannerInput::trajectory_check), until one passes;
///   5. timing: each stage's wall time (PlanTimings).
/// Each mode supplies its SearchSpace and its Objective (exploration/entropy_planner.h,
/// frontier_planner.h, volumetric_planner.h, fine_frontier_planner.h; the flight home is a point
/// objective, PlanToPoint in exploration/planner.h). Pure: no LCM, no clock (durations are
/// measured with std::chrono::steady_clock for the status).

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "exploration/planner.h"

namespace kestrel {

/// The cells paths may use after a search (the view's own, plus passages and escape cells in the
/// fine view; C's traversable cells in the collision view).
struct SearchedCells {
  std::vector<bool> traversable;  ///< per 2D cell: a path may cross it
  int vehicle_cell{-1};           ///< the vehicle's 2D cell (index)
};

/// The map a mode plans on, and how a trajectory is made and checked there.
class SearchSpace {
 public:
  /// The paper's collision map C (eqs. 11-13) with B (eq. 16), and E (eqs. 14-15) when
  /// `with_entropy_map`: paths over C's traversable cells, the vehicle's disc checked.
  static SearchSpace Collision(const PlannerConfig& config, bool with_entropy_map);
  /// The fine traversability (exploration/traversability.h; the volumetric mode and the fine
  /// frontiers): paths over cells whose clearance holds the vehicle's radius and margin, the
  /// vehicle's centre checked (the clearance already holds its disc), the flown corridor allowed.
  static SearchSpace Fine(const PlannerConfig& config);
  /// The space of config.mode (Fine for the volumetric mode and fine frontiers).
  static SearchSpace For(const PlannerConfig& config);

  /// Stage 2: the map view into result->collision (C and B; the fine band as "collision"),
  /// result->entropy (E, when asked) or result->traversability, and the distance field from the
  /// vehicle's cell into result->field, with timings.projection_s and timings.dijkstra_s. False
  /// with result->reason when the map or the vehicle cannot be used.
  bool Search(const PlannerInput& input, PlanResult* result, SearchedCells* cells) const;

  /// The start state a trajectory of this space leaves from: input.Start(), the full state
  /// (position, velocity, acceleration, yaw, yaw rate; on a spliced replan the flown
  /// trajectory's, docs/exploration.md "Non-stop flight"). On the collision map C the
  /// acceleration and the yaw rate are left out, as the paper's modes always planned: the full
  /// state there changed their flights (lasr, seed 1: the combined mode's disc touched a desk's
  /// corner twice where it had not), and stays off until a wider bench shows it safe
  /// (docs/STATUS.md, Exploration).
  [[nodiscard]] TrajectoryStart StartOf(const PlannerInput& input) const;

  /// Stage 4 for one goal: a trajectory from StartOf(input) to the centre of goal_cell at the
  /// exploration height with heading goal_yaw_rad, into result->trajectory with result->status
  /// kGoal, or kFailed and result->reason; adds its time to timings.trajectory_s.
  void TrajectoryTo(const PlannerInput& input, const SearchedCells& cells, int goal_cell,
                    double goal_yaw_rad, PlanResult* result) const;

  /// Whether the rest of `trajectory` from from_time_s + 0.5 s keeps the vehicle in this space on
  /// input.map (TrajectoryStillClear).
  [[nodiscard]] bool StillClear(const PlannerInput& input,
                                const PiecewisePolynomialTrajectory& trajectory,
                                double from_time_s) const;

  [[nodiscard]] bool fine() const { return fine_; }

 private:
  SearchSpace(const PlannerConfig& config, bool fine, bool with_entropy_map)
      : config_(config), fine_(fine), with_entropy_map_(with_entropy_map) {}

  PlannerConfig config_;
  bool fine_;
  bool with_entropy_map_;
};

/// One goal to try: a 2D cell of the searched view, a heading, and the candidate it stands for.
struct Goal {
  int cell{-1};
  double yaw_rad{0.0};
  int candidate{-1};  ///< index into PlanResult::candidates (-1: a point, not a candidate)
};

/// What an objective chose: the goals in the order to try (the chosen one first), or none (the
/// result then says why: exploration done, or failed).
struct GoalChoice {
  std::vector<Goal> goals;
  /// Goals whose trajectory failed before the plan fails (distinct cells).
  int max_failures{5};
  /// Trajectories the separation check refused before the plan fails (several vehicles).
  int max_refused{10};
  /// Check each trajectory with PlannerInput::trajectory_check (when set) and try the next goal
  /// when it is refused; off for the flight home, which the explorer checks and waits for.
  bool check_separation{true};
};

/// A mode's stage 3.
class Objective {
 public:
  virtual ~Objective() = default;
  /// Scores candidates on the searched view into result->candidates (gains, distances, bumps),
  /// sets result->best_unweighted_gain_nats and the end-test figures, and returns the goals to
  /// try; or returns none with result->status (kExplorationDone, or kFailed), result->end_rule
  /// and result->reason set.
  virtual GoalChoice Choose(const PlannerInput& input, const SearchedCells& cells,
                            PlanResult* result) = 0;
};

/// Runs the stages (file comment) with `space` and `objective`.
[[nodiscard]] PlanResult RunPlan(const PlannerInput& input, const SearchSpace& space,
                                 Objective* objective);

/// Goals in decreasing objective of their candidates (ties: lower index first), with `chosen`
/// swapped to the front, skipping candidates whose gain is below min_gain_nats.
[[nodiscard]] std::vector<Goal> GoalsByObjective(const std::vector<Candidate>& candidates,
                                                 int chosen, double min_gain_nats = -1.0);

}  // namespace kestrel
