#include "exploration/planning_pipeline.h"

#include <algorithm>
#include <chrono>
#include <numeric>
#include <stdexcept>
#include <string>

namespace kestrel {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// The centre of the vehicle is checked against fine traversable cells, whose clearance already
// holds the radius and the margin: the trajectory planner's disc shrinks to (almost) a point.
constexpr double kPointRadius = 1e-3;

// How far the escape from a place short of clearance may lead (AllowEscape), m.
constexpr double kEscapeRadius = 2.0;

// The start-up zone of docs/algorithms.md §8.1 around the take-off point, if the input has one;
// `cell_m` is the view's cell for the radius (alpha_C, or twice the fine clearance).
std::optional<StartupFreeZone> StartupZone(const PlannerConfig& config, const PlannerInput& input,
                                           double cell_m) {
  if (!input.startup_center_m) return std::nullopt;
  return StartupFreeZone{*input.startup_center_m,
                         StartupFreeRadius(cell_m, config.startup_vertical_fov_rad)};
}

// Stage 4 over the goals (GoalChoice): the first whose trajectory passes, at most max_failures
// distinct cells failed and max_refused trajectories refused by the separation check.
void TryGoals(const PlannerInput& input, const SearchSpace& space, const SearchedCells& cells,
              const GoalChoice& choice, PlanResult* result) {
  std::vector<int> tried_cells;
  int failed = 0;
  int refused = 0;
  std::string refusal;
  const bool check = choice.check_separation && static_cast<bool>(input.trajectory_check);
  for (const Goal& goal : choice.goals) {
    if (std::find(tried_cells.begin(), tried_cells.end(), goal.cell) != tried_cells.end()) continue;
    if (failed == choice.max_failures || refused == choice.max_refused) break;
    tried_cells.push_back(goal.cell);
    result->chosen = goal.candidate;
    space.TrajectoryTo(input, cells, goal.cell, goal.yaw_rad, result);
    if (result->status != PlanStatus::kGoal) {
      ++failed;
      continue;
    }
    if (!check) return;
    refusal = input.trajectory_check(*result->trajectory.trajectory);
    if (refusal.empty()) {
      result->refused_trajectories = refused;
      return;
    }
    ++refused;
    result->trajectory = TrajectoryPlan{};
  }
  result->chosen = -1;
  result->refused_trajectories = refused;
  if (refused > 0) {
    result->status = PlanStatus::kFailed;
    result->end_rule.clear();
    result->reason = "every trajectory tried is refused by the separation check (" +
                     std::to_string(refused) + " refused; last: " + refusal + ")";
  }
}

}  // namespace

SearchSpace SearchSpace::Collision(const PlannerConfig& config, bool with_entropy_map) {
  return SearchSpace(config, false, with_entropy_map);
}

SearchSpace SearchSpace::Fine(const PlannerConfig& config) {
  return SearchSpace(config, true, false);
}

SearchSpace SearchSpace::For(const PlannerConfig& config) {
  const bool fine = IsVolumetric(config.mode) || (config.mode == ExplorationMode::kFrontier &&
                                                  config.frontier.fine_traversability);
  return fine ? Fine(config) : Collision(config, config.mode == ExplorationMode::kTwoMap);
}

bool SearchSpace::Search(const PlannerInput& input, PlanResult* result,
                         SearchedCells* cells) const {
  const Clock::time_point t0 = Clock::now();
  if (fine_) {
    const TraversabilityConfig tc = FineTraversabilityConfig(config_);
    try {
      result->traversability = ComputeTraversability(
          input.map, tc, StartupZone(config_, input, 2.0 * tc.required_clearance_m()),
          &input.flown_path);
    } catch (const std::invalid_argument& e) {
      result->reason = std::string("traversability: ") + e.what();
      return false;
    }
    const Traversability& tr = *result->traversability;
    result->collision.collision = tr.band;
    result->collision.combined = GridMap2D{};  // no B in these modes (nothing is published)
    result->collision.collision_factor = 1;
  } else {
    const double alpha_c =
        CollisionFactor(config_.projection, input.map.resolution_m) * input.map.resolution_m;
    try {
      result->collision =
          ProjectCollisionMaps(input.map, config_.projection, StartupZone(config_, input, alpha_c));
      if (with_entropy_map_) result->entropy = ProjectEntropyMap(input.map, config_.projection);
    } catch (const std::invalid_argument& e) {  // e.g. a floor above the whole map
      result->reason = std::string("projection: ") + e.what();
      return false;
    }
  }
  result->timings.projection_s = SecondsSince(t0);

  const Clock::time_point t1 = Clock::now();
  const GridMap2D& grid = result->collision.collision;
  const std::optional<Cell2> start = grid.CellOf(input.position_m.head<2>());
  if (fine_) {
    if (!start) {
      result->reason = "vehicle outside the map";
      return false;
    }
    const Traversability& tr = *result->traversability;
    const TraversabilityConfig tc = FineTraversabilityConfig(config_);
    cells->traversable = tr.traversable;
    AllowPassages(tr, &cells->traversable);  // for paths; goals read tr.traversable
    // A vehicle that new map data left short of the required clearance moves away along space no
    // tighter than where it is (Dijkstra always starts from its own cell).
    AllowEscape(tr, tc, input.position_m.head<2>(), kEscapeRadius, &cells->traversable);
    cells->vehicle_cell = grid.IndexOf(*start);
    result->field = ComputeDistanceField(grid.width, grid.height, cells->traversable, *start,
                                         grid.resolution_m, ClearanceStepWeights(tr, tc));
  } else {
    cells->traversable = TraversableCells(grid, config_.projection.collision_threshold);
    if (!start) {
      result->reason = "vehicle outside the collision map";
      return false;
    }
    cells->vehicle_cell = grid.IndexOf(*start);
    result->field = ComputeDistanceField(grid.width, grid.height, cells->traversable, *start,
                                         grid.resolution_m);
  }
  result->timings.dijkstra_s = SecondsSince(t1);
  return true;
}

void SearchSpace::TrajectoryTo(const PlannerInput& input, const SearchedCells& cells, int goal_cell,
                               double goal_yaw_rad, PlanResult* result) const {
  const Clock::time_point t0 = Clock::now();
  TrajectoryConfig tc = config_.trajectory;
  PathClearance room;
  if (fine_) {
    tc.vehicle_radius_m = kPointRadius;
    // Shortcuts keep the room the clearance-weighted search chose (Traversability, step 4).
    if (result->traversability && config_.volumetric.preferred_clearance_m > 0.0 &&
        config_.volumetric.clearance_weight > 0.0) {
      room.clearance = &result->traversability->clearance;
      room.preferred_m = FineTraversabilityConfig(config_).required_clearance_m() +
                         config_.volumetric.preferred_clearance_m;
    }
    if (result->traversability) {
      room.path_points = &result->traversability->passage_points;
      room.path_across = &result->traversability->passage_across;
    }
  }
  result->trajectory =
      PlanTrajectory(result->collision.collision, cells.traversable, result->field, goal_cell,
                     StartOf(input), goal_yaw_rad, config_.projection.height_m, tc, room);
  result->timings.trajectory_s += SecondsSince(t0);
  if (result->trajectory.trajectory) {
    result->status = PlanStatus::kGoal;
  } else {
    result->status = PlanStatus::kFailed;
    result->reason = "trajectory: " + result->trajectory.error;
  }
}

TrajectoryStart SearchSpace::StartOf(const PlannerInput& input) const {
  TrajectoryStart start = input.Start();
  if (!fine_) {  // the paper's modes keep their own start (planning_pipeline.h)
    start.acceleration_mps2.setZero();
    start.yaw_rate_radps = 0.0;
  }
  return start;
}

bool SearchSpace::StillClear(const PlannerInput& input,
                             const PiecewisePolynomialTrajectory& trajectory,
                             double from_time_s) const {
  const Eigen::Vector2d start_xy =
      trajectory.Evaluate(trajectory.start_time_s()).position_m.head<2>();
  GridMap2D grid;
  std::vector<bool> allowed;
  double radius = config_.trajectory.vehicle_radius_m;
  if (fine_) {
    const TraversabilityConfig tc = FineTraversabilityConfig(config_);
    Traversability tr = ComputeTraversability(
        input.map, tc, StartupZone(config_, input, 2.0 * tc.required_clearance_m()),
        &input.flown_path);
    allowed = tr.traversable;
    AllowPassages(tr, &allowed);
    AllowEscape(tr, tc, start_xy, kEscapeRadius, &allowed);
    AllowEscape(tr, tc, input.position_m.head<2>(), kEscapeRadius, &allowed);
    for (const Eigen::Vector2d& p : {start_xy, Eigen::Vector2d(input.position_m.head<2>())}) {
      if (const std::optional<Cell2> c = tr.band.CellOf(p)) {
        allowed[static_cast<size_t>(tr.band.IndexOf(*c))] = true;  // where it is
      }
    }
    grid = std::move(tr.band);
    radius = kPointRadius;
  } else {
    const int k = CollisionFactor(config_.projection, input.map.resolution_m);
    CollisionProjection c = ProjectCollisionMaps(
        input.map, config_.projection, StartupZone(config_, input, k * input.map.resolution_m));
    const std::vector<bool> traversable =
        TraversableCells(c.collision, config_.projection.collision_threshold);
    allowed = AllowedCells(c.collision, traversable, start_xy, radius);
    grid = std::move(c.collision);
  }
  // From half a second ahead (the vehicle's own place) to the end, every 0.05 s.
  for (double s = from_time_s + 0.5; s <= trajectory.end_time_s(); s += 0.05) {
    if (!DiscClear(grid, allowed, trajectory.Evaluate(s).position_m.head<2>(), radius)) {
      return false;
    }
  }
  return true;
}

std::vector<Goal> GoalsByObjective(const std::vector<Candidate>& candidates, int chosen,
                                   double min_gain_nats) {
  std::vector<int> order(candidates.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return candidates[static_cast<size_t>(a)].objective() >
           candidates[static_cast<size_t>(b)].objective();
  });
  const auto it = std::find(order.begin(), order.end(), chosen);
  if (it != order.end()) std::swap(*it, order.front());
  std::vector<Goal> goals;
  for (const int i : order) {
    const Candidate& c = candidates[static_cast<size_t>(i)];
    if (c.gain_nats < min_gain_nats) continue;
    goals.push_back(Goal{c.cell, c.yaw_rad, i});
  }
  return goals;
}

PlanResult RunPlan(const PlannerInput& input, const SearchSpace& space, Objective* objective) {
  const Clock::time_point t0 = Clock::now();
  PlanResult result;
  result.reason = CheckPlannerInput(input);
  SearchedCells cells;
  if (result.reason.empty() && space.Search(input, &result, &cells)) {
    const Clock::time_point t1 = Clock::now();
    const GoalChoice choice = objective->Choose(input, cells, &result);
    result.timings.gain_s = SecondsSince(t1);
    if (!choice.goals.empty()) TryGoals(input, space, cells, choice, &result);
  }
  result.timings.total_s = SecondsSince(t0);
  return result;
}

}  // namespace kestrel
