// The frontier baseline on the collision map C (exploration/frontier_planner.h).
#include "exploration/frontier_planner.h"

#include <cmath>
#include <vector>

namespace kestrel {

FrontierPlanner::FrontierPlanner(const PlannerConfig& config)
    : config_(config), gains_(config.gain), space_(SearchSpace::Collision(config, false)) {
  config_.mode = ExplorationMode::kFrontier;
  config_.Validate();
}

PlanResult FrontierPlanner::Plan(const PlannerInput& input) { return RunPlan(input, space_, this); }

GoalChoice FrontierPlanner::Choose(const PlannerInput& input, const SearchedCells& cells,
                                   PlanResult* out) {
  PlanResult& result = *out;
  const std::vector<bool>& traversable = cells.traversable;
  const int vehicle_cell = cells.vehicle_cell;
  const GridMap2D& c = result.collision.collision;
  const double p_init = config_.projection.p_init;
  // Unknown collision cell: not traversable, not known occupied (section 10's "not known").
  const auto unknown = [&](int x, int y) {
    if (!c.Contains(x, y)) return false;
    const double p = c.at(x, y);
    return p >= 0.5 * p_init && p <= 0.5 && !traversable[static_cast<size_t>(c.IndexOf(x, y))];
  };
  int best = -1;
  // Frontier cells already reached are skipped (candidates.skip_reached_goals): a frontier that
  // stays one after the vehicle has been there borders cells its sensors cannot see, and
  // Yamauchi's planner would shuttle between two such cells for ever.
  std::vector<bool> reached(static_cast<size_t>(c.size()), false);
  if (config_.candidates.skip_reached_goals) {
    for (const Eigen::Vector3d& g : input.reached_goals) {
      if (const std::optional<Cell2> gc = c.CellOf(g.head<2>())) {
        reached[static_cast<size_t>(c.IndexOf(*gc))] = true;
      }
    }
  }
  for (int i = 0; i < c.size(); ++i) {
    if (!result.field.Reachable(i) || !traversable[static_cast<size_t>(i)]) continue;
    const double d = result.field.distance_m[static_cast<size_t>(i)];
    if (i == vehicle_cell || d < config_.frontier.min_distance_m) continue;
    if (reached[static_cast<size_t>(i)]) continue;
    const Cell2 cell = c.CellAt(i);
    Eigen::Vector2d towards = Eigen::Vector2d::Zero();
    int count = 0;
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        if ((dx != 0 || dy != 0) && unknown(cell.x + dx, cell.y + dy)) {
          towards += Eigen::Vector2d(dx, dy).normalized();
          ++count;
        }
      }
    }
    if (count == 0) continue;
    Candidate cand;
    cand.cell = i;
    cand.position_m = c.CenterOf(cell);
    // Face the unknown neighbours (their mean direction; opposite ones cancel to heading 0).
    cand.yaw_rad = towards.squaredNorm() > 0.0 ? std::atan2(towards.y(), towards.x()) : 0.0;
    cand.distance_m = d;
    cand.bump = 1.0;
    result.candidates.push_back(cand);
    if (best < 0 || d < result.candidates[static_cast<size_t>(best)]
                            .distance_m) {  // nearest; ties: lowest index
      best = static_cast<int>(result.candidates.size()) - 1;
    }
  }
  if (best < 0) {
    result.status = PlanStatus::kExplorationDone;
    result.reason = "no reachable frontier";
    return {};
  }
  // Keep flying to the current goal while it is still a reachable frontier (a replan on the way
  // would otherwise switch to whichever frontier is nearest from here, back and forth).
  if (input.current_goal) {
    if (const std::optional<Cell2> gc = c.CellOf(input.current_goal->head<2>())) {
      for (size_t i = 0; i < result.candidates.size(); ++i) {
        if (result.candidates[i].cell == c.IndexOf(*gc)) best = static_cast<int>(i);
      }
    }
  }
  Candidate& goal = result.candidates[static_cast<size_t>(best)];
  goal.gain_nats =  // for comparison only
      gains_.PoseGain(result.collision.combined, goal.position_m, goal.yaw_rad);
  result.best_unweighted_gain_nats = goal.gain_nats;
  GoalChoice choice;
  choice.goals = {Goal{goal.cell, goal.yaw_rad, best}};
  return choice;
}

}  // namespace kestrel
