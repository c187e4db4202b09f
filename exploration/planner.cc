#include "exploration/planner.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "exploration/entropy_planner.h"
#include "exploration/fine_frontier_planner.h"
#include "exploration/frontier_planner.h"
#include "exploration/planning_pipeline.h"
#include "exploration/volumetric_planner.h"

namespace kestrel {
namespace {

// The flight to a point: its cell (on the fine traversability, the reachable cell nearest to it
// within the vehicle radius when its own is not reachable).
class PointObjective final : public Objective {
 public:
  PointObjective(const PlannerConfig& config, bool fine, const Eigen::Vector2d& goal_xy,
                 double goal_yaw_rad)
      : config_(config), fine_(fine), goal_xy_(goal_xy), goal_yaw_rad_(goal_yaw_rad) {}

  GoalChoice Choose(const PlannerInput&, const SearchedCells&, PlanResult* result) override {
    const GridMap2D& grid = result->collision.collision;
    const std::optional<Cell2> goal = grid.CellOf(goal_xy_);
    if (!fine_) {
      if (!goal || !result->field.Reachable(grid.IndexOf(*goal))) {
        result->reason = "goal outside the map or unreachable";
        return {};
      }
      return Single(grid.IndexOf(*goal));
    }
    if (!goal) {
      result->reason = "goal outside the map";
      return {};
    }
    int goal_cell = grid.IndexOf(*goal);
    if (!result->field.Reachable(goal_cell)) {
      double best = config_.trajectory.vehicle_radius_m;
      goal_cell = -1;
      const int r = static_cast<int>(std::ceil(best / grid.resolution_m));
      for (int y = std::max(0, goal->y - r); y <= std::min(grid.height - 1, goal->y + r); ++y) {
        for (int x = std::max(0, goal->x - r); x <= std::min(grid.width - 1, goal->x + r); ++x) {
          const int i = grid.IndexOf(x, y);
          const double d = (grid.CenterOf({x, y}) - goal_xy_).norm();
          if (result->field.Reachable(i) && d <= best) {
            best = d;
            goal_cell = i;
          }
        }
      }
    }
    if (goal_cell < 0) {
      result->reason = "goal unreachable: no path over known-free or flown space";
      return {};
    }
    return Single(goal_cell);
  }

 private:
  GoalChoice Single(int cell) const {
    GoalChoice choice;
    choice.goals = {Goal{cell, goal_yaw_rad_, -1}};
    choice.check_separation = false;
    return choice;
  }

  const PlannerConfig& config_;
  bool fine_;
  Eigen::Vector2d goal_xy_;
  double goal_yaw_rad_;
};

}  // namespace

TrajectoryStart PlannerInput::Start() const {
  TrajectoryStart s;
  s.position_m = position_m;
  s.velocity_mps = velocity_mps;
  s.acceleration_mps2 = acceleration_mps2;
  s.yaw_rad = yaw_rad;
  s.yaw_rate_radps = yaw_rate_radps;
  s.time_s = time_s;
  return s;
}

void PlannerInput::SetStart(const TrajectoryStart& start) {
  position_m = start.position_m;
  velocity_mps = start.velocity_mps;
  acceleration_mps2 = start.acceleration_mps2;
  yaw_rad = start.yaw_rad;
  yaw_rate_radps = start.yaw_rate_radps;
  time_s = start.time_s;
}

std::string CheckPlannerInput(const PlannerInput& input) {
  if (!input.position_m.allFinite() || !input.velocity_mps.allFinite() ||
      !input.acceleration_mps2.allFinite() || !std::isfinite(input.yaw_rad) ||
      !std::isfinite(input.yaw_rate_radps) || !std::isfinite(input.time_s)) {
    return "pose, velocity or time not finite";
  }
  try {
    input.map.Validate();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

std::unique_ptr<ExplorationPlanner> MakePlanner(const PlannerConfig& config) {
  if (IsVolumetric(config.mode)) {
    return std::make_unique<VolumetricPlanner>(config);
  }
  if (config.mode == ExplorationMode::kFrontier) {
    if (config.frontier.fine_traversability) return std::make_unique<FineFrontierPlanner>(config);
    return std::make_unique<FrontierPlanner>(config);
  }
  return std::make_unique<EntropyPlanner>(config);
}

PlanResult PlanToPoint(const PlannerConfig& config, const PlannerInput& input,
                       const Eigen::Vector2d& goal_xy, double goal_yaw_rad) {
  config.Validate();
  // The paper's modes fly home on C alone (E is not needed).
  const SearchSpace space = config.mode == ExplorationMode::kTwoMap
                                ? SearchSpace::Collision(config, false)
                                : SearchSpace::For(config);
  PointObjective point(config, space.fine(), goal_xy, goal_yaw_rad);
  return RunPlan(input, space, &point);
}

bool TrajectoryStillClear(const PlannerConfig& config, const PlannerInput& input,
                          const PiecewisePolynomialTrajectory& trajectory, double from_time_s) {
  return SearchSpace::For(config).StillClear(input, trajectory, from_time_s);
}

bool ReachesWithin(const PlanResult& result, const Eigen::Vector2d& xy_m, double radius_m) {
  if (!result.traversability) return true;
  const GridMap2D& grid = result.traversability->band;
  const std::optional<Cell2> c = grid.CellOf(xy_m);
  if (!c || grid.size() != static_cast<int>(result.field.distance_m.size())) return false;
  const int reach = static_cast<int>(std::ceil(radius_m / grid.resolution_m));
  for (int y = std::max(0, c->y - reach); y <= std::min(grid.height - 1, c->y + reach); ++y) {
    for (int x = std::max(0, c->x - reach); x <= std::min(grid.width - 1, c->x + reach); ++x) {
      if ((grid.CenterOf({x, y}) - xy_m).norm() <= radius_m &&
          result.field.Reachable(grid.IndexOf(x, y))) {
        return true;
      }
    }
  }
  return false;
}

std::optional<int> LandingCell(const PlanResult& result, const OccupancyGridView& map,
                               double radius_m, double ground_z_m, double top_z_m,
                               double free_threshold) {
  if (!result.traversability) return std::nullopt;
  const GridMap2D& grid = result.traversability->band;
  const double alpha = map.resolution_m;
  if (grid.width != map.dims.x() || grid.height != map.dims.y() ||
      grid.size() != static_cast<int>(result.field.distance_m.size())) {
    return std::nullopt;
  }
  // The layers between the ground (plus a cell) and the flight.
  const int k0 =
      static_cast<int>(std::ceil((ground_z_m + alpha - map.origin_m.z()) / alpha - 1e-9));
  const int k1 = static_cast<int>(std::floor((top_z_m - map.origin_m.z()) / alpha + 1e-9)) - 1;
  std::vector<int> order;
  for (int i = 0; i < grid.size(); ++i) {
    if (result.field.Reachable(i)) order.push_back(i);
  }
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return result.field.distance_m[static_cast<size_t>(a)] <
           result.field.distance_m[static_cast<size_t>(b)];
  });
  const double reach_m = radius_m + alpha * std::sqrt(0.5);
  const int reach = static_cast<int>(std::ceil(reach_m / alpha));
  for (const int i : order) {
    const Cell2 c = grid.CellAt(i);
    const Eigen::Vector2d centre = grid.CenterOf(c);
    bool clear = true;
    for (int y = c.y - reach; clear && y <= c.y + reach; ++y) {
      for (int x = c.x - reach; clear && x <= c.x + reach; ++x) {
        if ((grid.CenterOf({x, y}) - centre).norm() > reach_m) continue;
        if (!grid.Contains(x, y)) {
          clear = false;
          break;
        }
        for (int k = std::max(0, k0); k <= std::min(map.dims.z() - 1, k1); ++k) {
          if (!(map.At(x, y, k) <= free_threshold)) {
            clear = false;
            break;
          }
        }
      }
    }
    if (clear && k0 >= 0 && k1 < map.dims.z()) return i;
  }
  return std::nullopt;
}

}  // namespace kestrel
