// The frontier baseline on the fine traversability (exploration/fine_frontier_planner.h).
#include "exploration/fine_frontier_planner.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "exploration/frontiers.h"
#include "exploration/volumetric_planner.h"

namespace kestrel {

FineFrontierPlanner::FineFrontierPlanner(const PlannerConfig& config)
    : config_(config), gains_(config.volumetric.gain), space_(SearchSpace::Fine(config)) {
  config_.mode = ExplorationMode::kFrontier;
  config_.Validate();
}

PlanResult FineFrontierPlanner::Plan(const PlannerInput& input) {
  return RunPlan(input, space_, this);
}

GoalChoice FineFrontierPlanner::Choose(const PlannerInput& input, const SearchedCells&,
                                       PlanResult* out) {
  PlanResult& result = *out;
  const Traversability& tr = *result.traversability;
  const GridMap2D& grid = tr.band;
  const double alpha = grid.resolution_m;
  const double free = FineTraversabilityConfig(config_).free_threshold;
  const FrontierConfig& fc = config_.frontier;
  // What a reached goal covers (to the camera's range), and what a goal must see (nearer).
  const FrontierView view{fc.view_min_range_m, fc.view_max_range_m,
                          fc.horizontal_fov_deg * M_PI / 180.0};
  const FrontierView goal_view{fc.view_min_range_m, fc.goal_max_range_m, view.horizontal_fov_rad};
  std::vector<bool> frontier = FrontierCells(tr, free);
  const long found = std::count(frontier.begin(), frontier.end(), true);
  const int cleared = config_.candidates.skip_reached_goals
                          ? ClearCoveredFrontiers(grid, input.reached_views, view, &frontier)
                          : 0;
  // Cells within the view's range of some frontier cell, nearest first (the current goal's cell
  // first while it still sees enough); the first that sees enough at some heading is the goal.
  const std::vector<double> d2 = SquaredDistanceTransform(grid.width, grid.height, frontier);
  const double reach_cells = goal_view.max_range_m / alpha + 0.5;
  std::vector<int> order;
  for (int i = 0; i < grid.size(); ++i) {
    if (!tr.traversable[static_cast<size_t>(i)] || !result.field.Reachable(i)) continue;
    if (i == result.field.start) continue;
    if (result.field.distance_m[static_cast<size_t>(i)] < fc.min_distance_m) continue;
    if (d2[static_cast<size_t>(i)] > reach_cells * reach_cells) continue;
    order.push_back(i);
  }
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return result.field.distance_m[static_cast<size_t>(a)] <
           result.field.distance_m[static_cast<size_t>(b)];
  });
  if (input.current_goal) {
    const std::optional<Cell2> c = grid.CellOf(input.current_goal->head<2>());
    const auto it = c ? std::find(order.begin(), order.end(), grid.IndexOf(*c)) : order.end();
    if (it != order.end()) std::rotate(order.begin(), it, it + 1);
  }
  constexpr int kHeadingBins = 36;
  int best = -1;
  for (const int i : order) {
    int seen = 0;
    const Eigen::Vector2d xy = grid.CenterOf(grid.CellAt(i));
    const double yaw =
        BestFrontierHeading(grid, frontier, xy, goal_view, free, kHeadingBins, &seen);
    Candidate c;
    c.cell = i;
    c.position_m = xy;
    c.yaw_rad = yaw;
    c.distance_m = result.field.distance_m[static_cast<size_t>(i)];
    c.bump = 1.0;
    result.candidates.push_back(c);
    if (seen >= fc.min_frontier_cells) {
      best = static_cast<int>(result.candidates.size()) - 1;
      break;
    }
  }
  result.volumetric_stats.positions = static_cast<long>(result.candidates.size());
  if (best < 0) {
    result.status = PlanStatus::kExplorationDone;
    result.end_rule = "no reachable frontier";
    result.reason = "no reachable frontier (" + std::to_string(found) + " frontier cells, " +
                    std::to_string(cleared) + " of them seen from reached goals; " +
                    std::to_string(order.size()) + " reachable cells within " +
                    std::to_string(goal_view.max_range_m) + " m of the rest, none sees " +
                    std::to_string(fc.min_frontier_cells) + ")";
    return {};
  }
  Candidate& goal = result.candidates[static_cast<size_t>(best)];
  const PoseGains g = gains_.Evaluate(input.map,
                                      Eigen::Vector3d(goal.position_m.x(), goal.position_m.y(),
                                                      VolumetricGainHeight(config_, input.map)),
                                      1, true, &result.volumetric_stats);
  goal.gain_nats = g.gain_nats.empty() ? 0.0 : g.gain_nats[0];  // heading 0: for the status only
  result.best_unweighted_gain_nats = goal.gain_nats;
  GoalChoice choice;
  choice.goals = {Goal{goal.cell, goal.yaw_rad, best}};
  return choice;
}

}  // namespace kestrel
