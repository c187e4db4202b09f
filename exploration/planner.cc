#include "exploration/planner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

#include "common/check.h"

namespace kestrel {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Projection of C and B (section 7) and Dijkstra from the vehicle's cell (section 8). Returns
// false with result->reason set when the vehicle is outside C.
bool ProjectAndSearch(const PlannerConfig& config, const PlannerInput& input, PlanResult* result,
                      std::vector<bool>* traversable, int* vehicle_cell) {
  const Clock::time_point t0 = Clock::now();
  std::optional<StartupFreeZone> zone;
  const double alpha_c =
      CollisionFactor(config.projection, input.map.resolution_m) * input.map.resolution_m;
  if (input.startup_center_m) {
    zone = StartupFreeZone{*input.startup_center_m,
                           StartupFreeRadius(alpha_c, config.startup_vertical_fov_rad)};
  }
  try {
    result->collision = ProjectCollisionMaps(input.map, config.projection, zone);
    if (config.mode == ExplorationMode::kTwoMap) {
      result->entropy = ProjectEntropyMap(input.map, config.projection);
    }
  } catch (const std::invalid_argument& e) {  // e.g. a floor above the whole map
    result->reason = std::string("projection: ") + e.what();
    return false;
  }
  result->timings.projection_s = SecondsSince(t0);

  const Clock::time_point t1 = Clock::now();
  const GridMap2D& c = result->collision.collision;
  *traversable = TraversableCells(c, config.projection.collision_threshold);
  const std::optional<Cell2> start = c.CellOf(input.position_m.head<2>());
  if (!start) {
    result->reason = "vehicle outside the collision map";
    return false;
  }
  *vehicle_cell = c.IndexOf(*start);
  result->field = ComputeDistanceField(c.width, c.height, *traversable, *start, c.resolution_m);
  result->timings.dijkstra_s = SecondsSince(t1);
  return true;
}

void PlanTrajectoryTo(const PlannerConfig& config, const PlannerInput& input,
                      const std::vector<bool>& traversable, int goal_cell, double goal_yaw,
                      PlanResult* result) {
  const Clock::time_point t0 = Clock::now();
  result->trajectory =
      PlanTrajectory(result->collision.collision, traversable, result->field, goal_cell,
                     input.position_m, input.velocity_mps, input.yaw_rad, goal_yaw,
                     config.projection.height_m, input.time_s, config.trajectory);
  result->timings.trajectory_s += SecondsSince(t0);
  if (result->trajectory.trajectory) {
    result->status = PlanStatus::kGoal;
  } else {
    result->status = PlanStatus::kFailed;
    result->reason = "trajectory: " + result->trajectory.error;
  }
}

bool ValidInput(const PlannerInput& input, PlanResult* result) {
  result->reason = CheckPlannerInput(input);
  return result->reason.empty();
}

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

const char* ModeName(ExplorationMode mode) {
  switch (mode) {
    case ExplorationMode::kCombined:
      return "combined";
    case ExplorationMode::kTwoMap:
      return "two_map";
    case ExplorationMode::kFrontier:
      return "frontier";
    case ExplorationMode::kVolumetric:
      return "volumetric";
  }
  return "unknown";
}

void PlannerConfig::Validate() const {
  projection.Validate();
  gain.Validate();
  candidates.Validate();
  trajectory.Validate();
  volumetric.Validate();
  KESTREL_THROW_UNLESS(
      frontier.min_distance_m >= 0.0 && std::isfinite(frontier.min_distance_m),
      "frontier.min_distance_m = " << frontier.min_distance_m << ", accepted [0, inf)");
  KESTREL_THROW_UNLESS(
      frontier.view_min_range_m >= 0.0 && frontier.view_max_range_m > frontier.view_min_range_m &&
          std::isfinite(frontier.view_max_range_m),
      "frontier.view_min_range_m = " << frontier.view_min_range_m
                                     << ", view_max_range_m = " << frontier.view_max_range_m
                                     << ", accepted 0 <= min < max < inf");
  KESTREL_THROW_UNLESS(frontier.goal_max_range_m > frontier.view_min_range_m &&
                           frontier.goal_max_range_m <= frontier.view_max_range_m,
                       "frontier.goal_max_range_m = "
                           << frontier.goal_max_range_m
                           << ", accepted (view_min_range_m = " << frontier.view_min_range_m
                           << ", view_max_range_m = " << frontier.view_max_range_m << "]");
  KESTREL_THROW_UNLESS(
      frontier.horizontal_fov_deg > 0.0 && frontier.horizontal_fov_deg <= 360.0,
      "frontier.horizontal_fov_deg = " << frontier.horizontal_fov_deg << ", accepted (0, 360]");
  KESTREL_THROW_UNLESS(
      frontier.min_frontier_cells >= 1,
      "frontier.min_frontier_cells = " << frontier.min_frontier_cells << ", accepted >= 1");
  KESTREL_THROW_UNLESS(
      startup_vertical_fov_rad > 0.0 && startup_vertical_fov_rad < M_PI,
      "startup_vertical_fov_rad = " << startup_vertical_fov_rad << ", accepted (0, pi)");
}

EntropyPlanner::EntropyPlanner(const PlannerConfig& config) : config_(config), gains_(config.gain) {
  config_.Validate();
  KESTREL_THROW_UNLESS(
      config_.mode == ExplorationMode::kCombined || config_.mode == ExplorationMode::kTwoMap,
      "EntropyPlanner: mode " << ModeName(config_.mode) << ", accepted combined or two_map");
}

bool EntropyPlanner::Reached(const PlannerInput& input, const GridMap2D& c, int cell,
                             double yaw_rad) const {
  if (!config_.candidates.skip_reached_goals) return false;
  const double half_step = M_PI / config_.candidates.n_yaw;
  for (const Eigen::Vector3d& g : input.reached_goals) {
    const std::optional<Cell2> gc = c.CellOf(g.head<2>());
    if (!gc || c.IndexOf(*gc) != cell) continue;
    const double d = std::remainder(g.z() - yaw_rad, 2.0 * M_PI);
    if (std::abs(d) < half_step) return true;
  }
  return false;
}

std::optional<GridMap2D> EntropyPlanner::PlanarLayer(const OccupancyGridView& map) const {
  for (const GainSensor& s : config_.gain.sensors) {
    if (!s.planar) continue;
    try {
      return ProjectLayer(map, config_.projection.height_m + s.height_offset_m);
    } catch (const std::invalid_argument&) {
      return std::nullopt;
    }
  }
  return std::nullopt;
}

Choice EntropyPlanner::ScoreCandidates(const PlannerInput& input, const GridMap2D& gain_map,
                                       bool two_map_end_test, PlanResult* result,
                                       const GridMap2D* planar_map) {
  const GridMap2D& c = result->collision.collision;
  const int n_yaw = config_.candidates.n_yaw;
  result->candidates.clear();
  result->end_test_gain_nats = 0.0;
  for (int cell : CandidateCells(result->field, config_.candidates)) {
    const Eigen::Vector2d p = c.CenterOf(c.CellAt(cell));
    std::vector<double> excess;
    const std::vector<double> gains = gains_.HeadingGains(
        gain_map, p, n_yaw, 0.0, &result->gain_stats, config_.projection.p_min_entropy,
        two_map_end_test ? &excess : nullptr, planar_map);
    for (int m = 0; m < n_yaw; ++m) {
      Candidate cand;
      cand.cell = cell;
      cand.position_m = p;
      cand.yaw_rad = 2.0 * M_PI * m / n_yaw;
      if (Reached(input, c, cell, cand.yaw_rad)) continue;
      cand.gain_nats = gains[static_cast<size_t>(m)];
      result->candidates.push_back(cand);
      if (two_map_end_test) {
        result->end_test_gain_nats =
            std::max(result->end_test_gain_nats, excess[static_cast<size_t>(m)]);
      }
    }
  }
  Choice choice = ChooseCandidate(result->field, config_.candidates, &result->candidates);
  if (input.current_goal && choice.index >= 0) {
    // Hysteresis (CandidateConfig::switch_margin): keep flying to the current goal unless the
    // best objective beats it by the margin.
    const double best = result->candidates[static_cast<size_t>(choice.index)].objective();
    const std::optional<Cell2> gc = c.CellOf(input.current_goal->head<2>());
    const double half_step = M_PI / n_yaw;
    for (size_t i = 0; gc && i < result->candidates.size(); ++i) {
      const Candidate& cand = result->candidates[i];
      if (cand.cell != c.IndexOf(*gc) ||
          std::abs(std::remainder(cand.yaw_rad - input.current_goal->z(), 2.0 * M_PI)) >=
              half_step) {
        continue;
      }
      if (cand.objective() > 0.0 &&
          best <= (1.0 + config_.candidates.switch_margin) * cand.objective()) {
        choice.index = static_cast<int>(i);
      }
      break;
    }
  }
  if (two_map_end_test) {
    // The end test on the gain beyond E's P_min_E floor (planner.h).
    choice.exploration_done = result->candidates.empty() ||
                              result->end_test_gain_nats < config_.candidates.end_entropy_gain_nats;
  }
  return choice;
}

PlanResult EntropyPlanner::Plan(const PlannerInput& input) {
  const Clock::time_point t0 = Clock::now();
  PlanResult result;
  std::vector<bool> traversable;
  int vehicle_cell = -1;
  if (!ValidInput(input, &result) ||
      !ProjectAndSearch(config_, input, &result, &traversable, &vehicle_cell)) {
    result.timings.total_s = SecondsSince(t0);
    return result;
  }
  // Candidates: reachable lattice cells x headings; gains on B (combined) or E (two-map).
  const Clock::time_point t1 = Clock::now();
  const bool two_map = config_.mode == ExplorationMode::kTwoMap;
  // A planar scanner is credited against the layer it sees, not E's whole columns.
  const std::optional<GridMap2D> layer = PlanarLayer(input.map);
  Choice choice = ScoreCandidates(input, two_map ? *result.entropy : result.collision.combined,
                                  two_map, &result, two_map && layer ? &*layer : nullptr);
  if (!two_map) {
    result.end_test_gain_nats = choice.best_unweighted_gain_nats;
    if (choice.exploration_done && config_.candidates.end_check_entropy_map) {
      // B says explored; E may disagree (CandidateConfig::end_check_entropy_map).
      PlanResult on_e;
      on_e.collision = result.collision;
      on_e.field = result.field;
      try {
        on_e.entropy = ProjectEntropyMap(input.map, config_.projection);
      } catch (const std::invalid_argument& e) {
        result.reason = std::string("projection: ") + e.what();
        result.timings.total_s = SecondsSince(t0);
        return result;
      }
      const Choice e_choice =
          ScoreCandidates(input, *on_e.entropy, true, &on_e, layer ? &*layer : nullptr);
      if (!e_choice.exploration_done) {
        result.entropy = std::move(on_e.entropy);
        result.candidates = std::move(on_e.candidates);
        result.end_test_gain_nats = on_e.end_test_gain_nats;
        result.gain_stats = on_e.gain_stats;
        result.gains_from_entropy_map = true;
        choice = e_choice;
      }
    }
  }
  result.timings.gain_s = SecondsSince(t1);
  result.volumetric_stats.positions =
      static_cast<long>(result.candidates.size()) / std::max(1, config_.candidates.n_yaw);
  result.best_unweighted_gain_nats = choice.best_unweighted_gain_nats;
  if (choice.exploration_done) {
    result.status = PlanStatus::kExplorationDone;
    result.reason = result.candidates.empty() ? "no reachable candidate"
                                              : "best unweighted gain below end_gain_nats";
  } else {
    // The best candidate; if no trajectory reaches it, the next ones by objective (up to
    // kMaxTrajectoryAttempts different cells).
    std::vector<int> order(result.candidates.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
      return result.candidates[static_cast<size_t>(a)].objective() >
             result.candidates[static_cast<size_t>(b)].objective();
    });
    std::swap(*std::find(order.begin(), order.end(), choice.index), order.front());
    constexpr int kMaxTrajectoryAttempts = 5;
    std::vector<int> tried_cells;
    for (int index : order) {
      const Candidate& goal = result.candidates[static_cast<size_t>(index)];
      if (std::find(tried_cells.begin(), tried_cells.end(), goal.cell) != tried_cells.end()) {
        continue;
      }
      if (static_cast<int>(tried_cells.size()) == kMaxTrajectoryAttempts) break;
      tried_cells.push_back(goal.cell);
      result.chosen = index;
      PlanTrajectoryTo(config_, input, traversable, goal.cell, goal.yaw_rad, &result);
      if (result.status == PlanStatus::kGoal) break;
    }
    if (result.status != PlanStatus::kGoal) result.chosen = -1;
  }
  result.timings.total_s = SecondsSince(t0);
  return result;
}

FrontierPlanner::FrontierPlanner(const PlannerConfig& config)
    : config_(config), gains_(config.gain) {
  config_.mode = ExplorationMode::kFrontier;
  config_.Validate();
}

PlanResult FrontierPlanner::Plan(const PlannerInput& input) {
  const Clock::time_point t0 = Clock::now();
  PlanResult result;
  std::vector<bool> traversable;
  int vehicle_cell = -1;
  if (!ValidInput(input, &result) ||
      !ProjectAndSearch(config_, input, &result, &traversable, &vehicle_cell)) {
    result.timings.total_s = SecondsSince(t0);
    return result;
  }
  const Clock::time_point t1 = Clock::now();
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
    result.timings.gain_s = SecondsSince(t1);
    result.status = PlanStatus::kExplorationDone;
    result.reason = "no reachable frontier";
    result.timings.total_s = SecondsSince(t0);
    return result;
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
  result.timings.gain_s = SecondsSince(t1);
  result.chosen = best;
  PlanTrajectoryTo(config_, input, traversable, goal.cell, goal.yaw_rad, &result);
  result.timings.total_s = SecondsSince(t0);
  return result;
}

std::unique_ptr<ExplorationPlanner> MakePlanner(const PlannerConfig& config) {
  if (config.mode == ExplorationMode::kVolumetric) {
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
  if (config.mode == ExplorationMode::kVolumetric ||
      (config.mode == ExplorationMode::kFrontier && config.frontier.fine_traversability)) {
    return PlanToPointFine(config, input, goal_xy, goal_yaw_rad);
  }
  const Clock::time_point t0 = Clock::now();
  PlanResult result;
  std::vector<bool> traversable;
  int vehicle_cell = -1;
  PlannerConfig c2 = config;
  c2.mode = ExplorationMode::kCombined;  // E is not needed
  if (!ValidInput(input, &result) ||
      !ProjectAndSearch(c2, input, &result, &traversable, &vehicle_cell)) {
    result.timings.total_s = SecondsSince(t0);
    return result;
  }
  const std::optional<Cell2> goal = result.collision.collision.CellOf(goal_xy);
  if (!goal || !result.field.Reachable(result.collision.collision.IndexOf(*goal))) {
    result.reason = "goal outside the map or unreachable";
  } else {
    PlanTrajectoryTo(config, input, traversable, result.collision.collision.IndexOf(*goal),
                     goal_yaw_rad, &result);
  }
  result.timings.total_s = SecondsSince(t0);
  return result;
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
