// The volumetric planner and the fine frontier baseline (exploration/planner.h;
// docs/exploration.md, sections "Volumetric gain", "Traversability" and "Choosing the next pose").
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>

#include "common/check.h"
#include "exploration/frontiers.h"
#include "exploration/planner.h"

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

// One candidate position of the volumetric planner.
struct Position {
  int cell{-1};
  Eigen::Vector2d xy{Eigen::Vector2d::Zero()};
  double bump{0.0};
  double discount{1.0};  // the other vehicles' goals in view (PlannerInput::peer_goals)
  double distance_m{0.0};
  double max_bound{0.0};
  bool evaluated{false};
  std::vector<double> gains;
  std::vector<bool> viewed;  // per heading: looked from (skip_viewed_poses, skip_flown_poses)
};

// The flown views (x, y, yaw) by square bins of `edge_m`, for the poses near a position.
class FlownViewBins {
 public:
  FlownViewBins(const std::vector<Eigen::Vector3d>& views, double edge_m) : edge_m_(edge_m) {
    for (const Eigen::Vector3d& v : views) bins_[Key(v.x(), v.y())].push_back(v);
  }
  // Calls f(view) for every view within radius_m (<= edge_m) of xy.
  template <typename F>
  void ForNear(const Eigen::Vector2d& xy, double radius_m, F f) const {
    const auto [bx, by] = Bin(xy.x(), xy.y());
    for (int64_t dy = -1; dy <= 1; ++dy) {
      for (int64_t dx = -1; dx <= 1; ++dx) {
        const auto it = bins_.find(Pack(bx + dx, by + dy));
        if (it == bins_.end()) continue;
        for (const Eigen::Vector3d& v : it->second) {
          if ((v.head<2>() - xy).norm() < radius_m) f(v);
        }
      }
    }
  }

 private:
  std::pair<int64_t, int64_t> Bin(double x, double y) const {
    return {static_cast<int64_t>(std::floor(x / edge_m_)),
            static_cast<int64_t>(std::floor(y / edge_m_))};
  }
  static int64_t Pack(int64_t bx, int64_t by) { return bx * 1'000'003 + by; }
  int64_t Key(double x, double y) const {
    const auto [bx, by] = Bin(x, y);
    return Pack(bx, by);
  }
  double edge_m_;
  std::unordered_map<int64_t, std::vector<Eigen::Vector3d>> bins_;
};

// Fine traversability, the escape cells around the vehicle and Dijkstra from its cell. False with
// result->reason when the map or the vehicle cannot be used.
bool FineSearch(const PlannerConfig& config, const PlannerInput& input, bool with_flown_path,
                PlanResult* result, std::vector<bool>* traversable) {
  result->reason = CheckPlannerInput(input);
  if (!result->reason.empty()) return false;
  const Clock::time_point t0 = Clock::now();
  const TraversabilityConfig tc = FineTraversabilityConfig(config);
  std::optional<StartupFreeZone> zone;
  if (input.startup_center_m) {
    zone = StartupFreeZone{
        *input.startup_center_m,
        StartupFreeRadius(2.0 * tc.required_clearance_m(), config.startup_vertical_fov_rad)};
  }
  try {
    result->traversability =
        ComputeTraversability(input.map, tc, zone, with_flown_path ? &input.flown_path : nullptr);
  } catch (const std::invalid_argument& e) {
    result->reason = std::string("traversability: ") + e.what();
    return false;
  }
  const Traversability& tr = *result->traversability;
  result->collision.collision = tr.band;
  result->collision.combined = GridMap2D{};  // no B in these modes (nothing is published)
  result->collision.collision_factor = 1;
  result->timings.projection_s = SecondsSince(t0);

  const Clock::time_point t1 = Clock::now();
  const std::optional<Cell2> start = tr.band.CellOf(input.position_m.head<2>());
  if (!start) {
    result->reason = "vehicle outside the map";
    return false;
  }
  *traversable = tr.traversable;
  AllowPassages(tr, traversable);  // for paths; goals read tr.traversable
  // A vehicle that new map data left short of the required clearance moves away along space no
  // tighter than where it is (Dijkstra always starts from its own cell).
  AllowEscape(tr, tc, input.position_m.head<2>(), kEscapeRadius, traversable);
  result->field = ComputeDistanceField(tr.band.width, tr.band.height, *traversable, *start,
                                       tr.band.resolution_m, ClearanceStepWeights(tr, tc));
  result->timings.dijkstra_s = SecondsSince(t1);
  return true;
}

void FineTrajectoryTo(const PlannerConfig& config, const PlannerInput& input,
                      const std::vector<bool>& traversable, int goal_cell, double goal_yaw,
                      PlanResult* result) {
  const Clock::time_point t0 = Clock::now();
  TrajectoryConfig tc = config.trajectory;
  tc.vehicle_radius_m = kPointRadius;
  // Shortcuts keep the room the clearance-weighted search chose (Traversability, step 4).
  PathClearance room;
  if (result->traversability && config.volumetric.preferred_clearance_m > 0.0 &&
      config.volumetric.clearance_weight > 0.0) {
    room.clearance = &result->traversability->clearance;
    room.preferred_m = FineTraversabilityConfig(config).required_clearance_m() +
                       config.volumetric.preferred_clearance_m;
  }
  if (result->traversability) room.path_points = &result->traversability->passage_points;
  result->trajectory =
      PlanTrajectory(result->collision.collision, traversable, result->field, goal_cell,
                     input.Start(), goal_yaw, config.projection.height_m, tc, room);
  result->timings.trajectory_s += SecondsSince(t0);
  if (result->trajectory.trajectory) {
    result->status = PlanStatus::kGoal;
  } else {
    result->status = PlanStatus::kFailed;
    result->reason = "trajectory: " + result->trajectory.error;
  }
}

// Tries the candidates in decreasing objective (at most kMaxTrajectoryAttempts distinct cells),
// the chosen one first.
void TrajectoryToBest(const PlannerConfig& config, const PlannerInput& input,
                      const std::vector<bool>& traversable, int chosen, double min_goal_gain,
                      PlanResult* result) {
  std::vector<int> order(result->candidates.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return result->candidates[static_cast<size_t>(a)].objective() >
           result->candidates[static_cast<size_t>(b)].objective();
  });
  std::swap(*std::find(order.begin(), order.end(), chosen), order.front());
  constexpr int kMaxTrajectoryAttempts = 5;
  // Several vehicles: trajectories the separation check refuses do not count as attempts.
  constexpr int kMaxRefused = 10;
  std::vector<int> tried_cells;
  int failed = 0;
  int refused = 0;
  std::string refusal;
  for (int index : order) {
    const Candidate& goal = result->candidates[static_cast<size_t>(index)];
    if (goal.gain_nats < min_goal_gain) continue;  // not a goal (Plan)
    if (std::find(tried_cells.begin(), tried_cells.end(), goal.cell) != tried_cells.end()) continue;
    if (failed == kMaxTrajectoryAttempts || refused == kMaxRefused) break;
    tried_cells.push_back(goal.cell);
    result->chosen = index;
    FineTrajectoryTo(config, input, traversable, goal.cell, goal.yaw_rad, result);
    if (result->status != PlanStatus::kGoal) {
      ++failed;
      continue;
    }
    if (!input.trajectory_check) return;
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

// Whether the segment from a to b stays off the band's occupied cells (P > 0.5), sampled every
// half cell: a wall between two places hides one from the other.
bool InSight(const GridMap2D& band, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const double length = (b - a).norm();
  const int steps = std::max(1, static_cast<int>(std::ceil(length / (0.5 * band.resolution_m))));
  for (int i = 0; i <= steps; ++i) {
    const std::optional<Cell2> c = band.CellOf(a + (b - a) * (static_cast<double>(i) / steps));
    if (c && band.at(c->x, c->y) > 0.5) return false;
  }
  return true;
}

// Burgard et al. (2005)'s linear visibility discount (VolumetricConfig::peer_view_radius_m): 1
// minus, for each other vehicle's goal within the radius and in sight, 1 - d / radius; at least 0.
double PeerDiscount(const GridMap2D& band, const Eigen::Vector2d& xy,
                    const std::vector<Eigen::Vector3d>& peer_goals, double radius_m) {
  double discount = 1.0;
  for (const Eigen::Vector3d& g : peer_goals) {
    const double d = (g.head<2>() - xy).norm();
    if (d >= radius_m || !InSight(band, xy, g.head<2>())) continue;
    discount -= 1.0 - d / radius_m;
  }
  return std::max(0.0, discount);
}

// The height at which poses' gains are predicted: h, or h + 1 mm when a sensor's origin would lie
// on a cell boundary (within 1e-6 m), where every ray's first crossing ties with its start and
// has to be cast at each position instead of following a shared template.
double GainHeight(const PlannerConfig& config, const OccupancyGridView& map) {
  const double h = config.projection.height_m;
  for (const VolumetricSensor& s : config.volumetric.gain.sensors) {
    const double cells = (h + s.height_offset_m - map.origin_m.z()) / map.resolution_m;
    if (std::abs(cells - std::round(cells)) * map.resolution_m < 1e-6) return h + 1e-3;
  }
  return h;
}

}  // namespace

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

void VolumetricConfig::Validate() const {
  KESTREL_THROW_UNLESS(std::isfinite(band_below_m) && band_below_m > 0.0,
                       "volumetric.band_below_m = " << band_below_m << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(std::isfinite(band_above_m) && band_above_m > 0.0,
                       "volumetric.band_above_m = " << band_above_m << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(std::isfinite(margin_m) && margin_m >= 0.0,
                       "volumetric.margin_m = " << margin_m << ", accepted [0, inf)");
  KESTREL_THROW_UNLESS(
      std::isfinite(passage_margin_m) && passage_margin_m >= 0.0,
      "volumetric.passage_margin_m = " << passage_margin_m << ", accepted [0, inf)");
  KESTREL_THROW_UNLESS(
      std::isfinite(candidate_spacing_m) && candidate_spacing_m > 0.0,
      "volumetric.candidate_spacing_m = " << candidate_spacing_m << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(std::isfinite(end_gain_nats) && end_gain_nats > 0.0,
                       "volumetric.end_gain_nats = " << end_gain_nats << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(
      std::isfinite(local_horizon_m) && local_horizon_m >= 0.0,
      "volumetric.local_horizon_m = " << local_horizon_m << ", accepted [0, inf) (0: off)");
  KESTREL_THROW_UNLESS(
      std::isfinite(peer_view_radius_m) && peer_view_radius_m > 0.0,
      "volumetric.peer_view_radius_m = " << peer_view_radius_m << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(std::isfinite(preferred_clearance_m) && preferred_clearance_m >= 0.0,
                       "volumetric.preferred_clearance_m = " << preferred_clearance_m
                                                             << ", accepted [0, inf) (0: off)");
  KESTREL_THROW_UNLESS(
      std::isfinite(clearance_weight) && clearance_weight >= 0.0,
      "volumetric.clearance_weight = " << clearance_weight << ", accepted [0, inf) (0: off)");
  gain.Validate();
}

TraversabilityConfig FineTraversabilityConfig(const PlannerConfig& config) {
  TraversabilityConfig t;
  t.height_m = config.projection.height_m;
  t.band_below_m = config.volumetric.band_below_m;
  t.band_above_m = config.volumetric.band_above_m;
  t.vehicle_radius_m = config.trajectory.vehicle_radius_m;
  t.margin_m = config.volumetric.margin_m;
  t.passage_margin_m = config.volumetric.passage_margin_m;
  t.free_threshold = config.projection.collision_threshold;
  t.p_init = config.projection.p_init;
  t.preferred_extra_m = config.volumetric.preferred_clearance_m;
  t.clearance_weight = config.volumetric.clearance_weight;
  return t;
}

VolumetricPlanner::VolumetricPlanner(const PlannerConfig& config)
    : config_(config), gains_(config.volumetric.gain) {
  config_.mode = ExplorationMode::kVolumetric;
  config_.Validate();
}

void VolumetricPlanner::UpdateAffectedTiles(const OccupancyGridView& map) {
  const Eigen::Vector3i d = map.dims;
  const size_t n = static_cast<size_t>(d.prod());
  tiles_x_ = (d.x() + kTile - 1) / kTile;
  const int tiles_y = (d.y() + kTile - 1) / kTile;
  const bool same_lattice = previous_map_.size() == n && previous_dims_ == d &&
                            previous_origin_m_ == map.origin_m &&
                            previous_resolution_m_ == map.resolution_m;
  std::vector<bool> changed(static_cast<size_t>(tiles_x_) * static_cast<size_t>(tiles_y),
                            !same_lattice);
  if (same_lattice) {
    for (int k = 0; k < d.z(); ++k) {
      for (int j = 0; j < d.y(); ++j) {
        const size_t row =
            static_cast<size_t>(d.x()) * (static_cast<size_t>(j) + static_cast<size_t>(d.y()) * k);
        for (int t = 0; t < tiles_x_; ++t) {
          const size_t tile = static_cast<size_t>(t + tiles_x_ * (j / kTile));
          if (changed[tile]) continue;
          const int x0 = t * kTile;
          const int count = std::min(kTile, d.x() - x0);
          changed[tile] = std::memcmp(&previous_map_[row + static_cast<size_t>(x0)],
                                      map.probability + row + static_cast<size_t>(x0),
                                      sizeof(float) * static_cast<size_t>(count)) != 0;
        }
      }
    }
  } else {
    cache_.clear();
  }
  previous_map_.assign(map.probability, map.probability + n);
  previous_dims_ = d;
  previous_origin_m_ = map.origin_m;
  previous_resolution_m_ = map.resolution_m;
  // A position's rays reach z_max (plus the sensor's height and a cell) around it.
  double reach = 0.0;
  for (const VolumetricSensor& s : config_.volumetric.gain.sensors) {
    reach = std::max(reach, std::hypot(s.model.z_max_m, s.height_offset_m));
  }
  const int r =
      static_cast<int>(std::ceil((reach + 2.0 * map.resolution_m) / (kTile * map.resolution_m))) +
      1;
  affected_.assign(changed.size(), false);
  for (int ty = 0; ty < tiles_y; ++ty) {
    for (int tx = 0; tx < tiles_x_; ++tx) {
      if (!changed[static_cast<size_t>(tx + tiles_x_ * ty)]) continue;
      for (int y = std::max(0, ty - r); y <= std::min(tiles_y - 1, ty + r); ++y) {
        for (int x = std::max(0, tx - r); x <= std::min(tiles_x_ - 1, tx + r); ++x) {
          affected_[static_cast<size_t>(x + tiles_x_ * y)] = true;
        }
      }
    }
  }
}

bool VolumetricPlanner::Affected(const Cell2& cell) const {
  return affected_[static_cast<size_t>(cell.x / kTile + tiles_x_ * (cell.y / kTile))];
}

PlanResult VolumetricPlanner::Plan(const PlannerInput& input) {
  const Clock::time_point t0 = Clock::now();
  PlanResult result;
  std::vector<bool> traversable;
  if (!FineSearch(config_, input, true, &result, &traversable)) {
    result.timings.total_s = SecondsSince(t0);
    return result;
  }
  const Clock::time_point t1 = Clock::now();
  const Traversability& tr = *result.traversability;
  const GridMap2D& grid = tr.band;
  const int n_yaw = config_.candidates.n_yaw;
  UpdateAffectedTiles(input.map);
  reused_positions_ = 0;
  const double z = GainHeight(config_, input.map);
  CandidateConfig cc = config_.candidates;
  cc.lattice_step = std::max(
      1, static_cast<int>(std::lround(config_.volumetric.candidate_spacing_m / grid.resolution_m)));
  cc.exclude_vehicle_cell = true;
  const double d_max = DMax(cc, result.field.MaxDistance());

  // Positions and the bound of each first.
  std::vector<Position> positions;
  // A pose (position, heading) the vehicle has reached as a goal (skip_viewed_poses) keeps no
  // gain: what the model still predicts there, the flight did not collect.
  const double half_spacing = 0.5 * config_.volumetric.candidate_spacing_m;
  const FlownViewBins flown(
      config_.volumetric.skip_flown_poses ? input.flown_views : std::vector<Eigen::Vector3d>{},
      std::max(half_spacing, 1e-3));
  auto heading_bin = [n_yaw](double yaw_rad) {
    const long m = std::lround(yaw_rad / (2.0 * M_PI / n_yaw));
    return static_cast<size_t>(((m % n_yaw) + n_yaw) % n_yaw);
  };
  auto mask_viewed = [](Position* p) {
    for (size_t m = 0; m < p->viewed.size() && m < p->gains.size(); ++m) {
      if (p->viewed[m]) p->gains[m] = 0.0;
    }
  };
  // Goals need the full clearance (escape cells are for leaving, not for goals): each block's
  // candidate is its traversable reachable cell nearest to the block's corner.
  DistanceField goals = result.field;
  for (size_t i = 0; i < goals.distance_m.size(); ++i) {
    if (!tr.traversable[i]) goals.distance_m[i] = std::numeric_limits<double>::infinity();
  }
  for (int cell : CandidateCells(goals, cc)) {
    Position p;
    p.cell = cell;
    p.xy = grid.CenterOf(grid.CellAt(cell));
    p.distance_m = result.field.distance_m[static_cast<size_t>(cell)];
    p.bump = Bump(p.distance_m, d_max);
    if (!input.peer_goals.empty()) {
      p.discount =
          PeerDiscount(grid, p.xy, input.peer_goals, config_.volumetric.peer_view_radius_m);
    }
    // Exact reuse: nothing changed within the rays' reach since the cache entry was made (a new
    // entry has no bounds).
    CachedPose& c = cache_[cell];
    if (!Affected(grid.CellAt(cell)) && static_cast<int>(c.bounds.size()) == n_yaw) {
      ++reused_positions_;
    } else {
      // The rays that read the same priors as at their last evaluation bound with their exact
      // I_ray (RayMemo); the rest with the prior-entropy bound.
      PoseGains b = gains_.Evaluate(input.map, Eigen::Vector3d(p.xy.x(), p.xy.y(), z), n_yaw, false,
                                    &result.volumetric_stats, &c.memo);
      c.bounds = std::move(b.bound_nats);
      c.gains.clear();
    }
    p.max_bound = *std::max_element(c.bounds.begin(), c.bounds.end());
    p.viewed.assign(static_cast<size_t>(n_yaw), false);
    flown.ForNear(p.xy, half_spacing, [&](const Eigen::Vector3d& v) {
      p.viewed[heading_bin(v.z())] = true;  // its heading's window holds the flown yaw
    });
    if (config_.volumetric.skip_viewed_poses) {
      for (size_t i = 0; i < input.reached_goals.size(); ++i) {
        const Eigen::Vector3d& v = input.reached_goals[i];
        if ((v.head<2>() - p.xy).norm() >= half_spacing) continue;
        // Only where the vehicle faced the goal's heading when it got there (within half a
        // step): a goal passed mid-turn was not looked from.
        if (i >= input.reached_views.size() ||
            std::abs(std::remainder(input.reached_views[i].z() - v.z(), 2.0 * M_PI)) >=
                M_PI / n_yaw) {
          continue;
        }
        p.viewed[heading_bin(v.z())] = true;
      }
    }
    if (!c.gains.empty()) {
      p.gains = c.gains;
      p.evaluated = true;
      mask_viewed(&p);
    }
    positions.push_back(std::move(p));
  }
  result.volumetric_stats.positions = static_cast<long>(positions.size());
  auto evaluate = [&](Position* p) {
    if (p->evaluated) return;
    CachedPose& entry = cache_[p->cell];
    PoseGains g = gains_.Evaluate(input.map, Eigen::Vector3d(p->xy.x(), p->xy.y(), z), n_yaw, true,
                                  &result.volumetric_stats, &entry.memo);
    p->gains = g.gain_nats;
    p->evaluated = true;
    mask_viewed(p);
    entry.bounds = std::move(g.bound_nats);
    entry.gains = std::move(g.gain_nats);
  };
  // Exact argmax of gain x bump, in decreasing bound x bump. Local first: with d_max capped at
  // the horizon, then, if no pose within it keeps end_gain_nats, over everything with the full
  // d_max.
  const double end_gain = config_.volumetric.end_gain_nats;
  const double horizon = config_.volumetric.local_horizon_m;
  std::vector<size_t> order(positions.size());
  double best_gain = 0.0;
  auto choose = [&](double bump_d_max, double min_goal_gain) {
    // The weight of each position's gains: the bump (eq. 17) times the other vehicles' discount.
    for (Position& p : positions) p.bump = Bump(p.distance_m, bump_d_max);
    auto weight = [](const Position& p) { return p.bump * p.discount; };
    std::iota(order.begin(), order.end(), size_t{0});
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
      return positions[a].max_bound * weight(positions[a]) >
             positions[b].max_bound * weight(positions[b]);
    });
    double best_objective = -1.0;
    double best_weighted_gain = 0.0;  // best gain among poses with a positive bump
    for (size_t i : order) {
      Position& p = positions[i];
      if (p.max_bound * weight(p) <= best_objective) break;
      if (p.max_bound < min_goal_gain) continue;  // no heading here can be a goal
      evaluate(&p);
      for (double g : p.gains) {
        if (g >= min_goal_gain) best_objective = std::max(best_objective, g * weight(p));
        best_gain = std::max(best_gain, g);
        if (weight(p) > 0.0) best_weighted_gain = std::max(best_weighted_gain, g);
      }
    }
    return best_weighted_gain;
  };
  double min_goal_gain = 0.0;
  if (horizon > 0.0 && horizon < d_max && choose(horizon, end_gain) >= end_gain) {
    min_goal_gain = end_gain;
  } else {
    choose(d_max, 0.0);
  }
  for (const Position& p : positions) {  // reused exact gains count too
    for (double g : p.gains) best_gain = std::max(best_gain, g);
  }
  // The end rule: does ANY reachable candidate keep end_gain_nats of gain?
  if (best_gain < end_gain) {
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
      return positions[a].max_bound > positions[b].max_bound;
    });
    for (size_t i : order) {
      Position& p = positions[i];
      if (p.max_bound < end_gain || best_gain >= end_gain) break;
      evaluate(&p);
      for (double g : p.gains) best_gain = std::max(best_gain, g);
    }
  }
  // The evaluated poses become the candidates.
  for (const Position& p : positions) {
    if (!p.evaluated) continue;
    for (int m = 0; m < n_yaw; ++m) {
      Candidate c;
      c.cell = p.cell;
      c.position_m = p.xy;
      c.yaw_rad = 2.0 * M_PI * m / n_yaw;
      c.gain_nats = p.gains[static_cast<size_t>(m)];
      c.distance_m = p.distance_m;
      c.bump = p.bump;
      c.discount = p.discount;
      result.candidates.push_back(c);
    }
  }
  // Goals are poses worth the end threshold (docs/exploration.md, "Choosing the next pose"): a
  // pose below it is what the end rule calls explored, so the flight never wanders among them
  // while a pose that still holds end_gain_nats waits elsewhere.
  int chosen = -1;
  for (size_t i = 0; i < result.candidates.size(); ++i) {
    if (result.candidates[i].gain_nats < min_goal_gain) continue;
    if (chosen < 0 || result.candidates[i].objective() >
                          result.candidates[static_cast<size_t>(chosen)].objective()) {
      chosen = static_cast<int>(i);
    }
  }
  // Hysteresis (candidates.switch_margin): keep the goal being flown to unless beaten by the
  // margin. Its pose is evaluated if the pruning skipped it.
  if (input.current_goal && chosen >= 0) {
    const std::optional<Cell2> gc = grid.CellOf(input.current_goal->head<2>());
    const double half = 0.5 * config_.volumetric.candidate_spacing_m;
    for (Position& p : positions) {
      if (!gc || (p.xy - input.current_goal->head<2>()).norm() > half) continue;
      const int m =
          static_cast<int>(std::lround(input.current_goal->z() / (2.0 * M_PI / n_yaw))) % n_yaw;
      const int mm = (m + n_yaw) % n_yaw;
      const bool was_evaluated = p.evaluated;
      evaluate(&p);
      const double objective = p.gains[static_cast<size_t>(mm)] * p.bump * p.discount;
      const double best = result.candidates[static_cast<size_t>(chosen)].objective();
      if (objective > 0.0 && p.gains[static_cast<size_t>(mm)] >= min_goal_gain &&
          best <= (1.0 + config_.candidates.switch_margin) * objective) {
        if (!was_evaluated) {
          for (int k = 0; k < n_yaw; ++k) {
            Candidate c;
            c.cell = p.cell;
            c.position_m = p.xy;
            c.yaw_rad = 2.0 * M_PI * k / n_yaw;
            c.gain_nats = p.gains[static_cast<size_t>(k)];
            c.distance_m = p.distance_m;
            c.bump = p.bump;
            c.discount = p.discount;
            result.candidates.push_back(c);
          }
        }
        for (size_t i = 0; i < result.candidates.size(); ++i) {
          const Candidate& c = result.candidates[i];
          if (c.cell == p.cell &&
              std::abs(std::remainder(c.yaw_rad - 2.0 * M_PI * mm / n_yaw, 2.0 * M_PI)) < 1e-9) {
            chosen = static_cast<int>(i);
          }
        }
      }
      break;
    }
  }
  result.best_unweighted_gain_nats = best_gain;
  result.end_test_gain_nats = best_gain;
  result.timings.gain_s = SecondsSince(t1);
  if (positions.empty()) {
    // A failure, not the end: new map data (noise cleared, the vehicle moved on) can open space
    // again; the explorer ends exploration with this rule after max_failed_plans in a row.
    result.status = PlanStatus::kFailed;
    result.end_rule = "no reachable candidate";
    result.reason = "no reachable candidate position";
  } else if (best_gain < end_gain) {
    result.status = PlanStatus::kExplorationDone;
    result.end_rule = "gain rule";
    result.reason = "best unweighted gain " + std::to_string(best_gain) + " nats below " +
                    std::to_string(end_gain) + " nats over " + std::to_string(positions.size()) +
                    " reachable positions";
  } else {
    TrajectoryToBest(config_, input, traversable, chosen, min_goal_gain, &result);
  }
  result.timings.total_s = SecondsSince(t0);
  return result;
}

FineFrontierPlanner::FineFrontierPlanner(const PlannerConfig& config)
    : config_(config), gains_(config.volumetric.gain) {
  config_.mode = ExplorationMode::kFrontier;
  config_.Validate();
}

PlanResult FineFrontierPlanner::Plan(const PlannerInput& input) {
  const Clock::time_point t0 = Clock::now();
  PlanResult result;
  std::vector<bool> traversable;
  if (!FineSearch(config_, input, true, &result, &traversable)) {
    result.timings.total_s = SecondsSince(t0);
    return result;
  }
  const Clock::time_point t1 = Clock::now();
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
  result.timings.gain_s = SecondsSince(t1);
  result.volumetric_stats.positions = static_cast<long>(result.candidates.size());
  if (best < 0) {
    result.status = PlanStatus::kExplorationDone;
    result.end_rule = "no reachable frontier";
    result.reason = "no reachable frontier (" + std::to_string(found) + " frontier cells, " +
                    std::to_string(cleared) + " of them seen from reached goals; " +
                    std::to_string(order.size()) + " reachable cells within " +
                    std::to_string(goal_view.max_range_m) + " m of the rest, none sees " +
                    std::to_string(fc.min_frontier_cells) + ")";
    result.timings.total_s = SecondsSince(t0);
    return result;
  }
  Candidate& goal = result.candidates[static_cast<size_t>(best)];
  const PoseGains g = gains_.Evaluate(
      input.map,
      Eigen::Vector3d(goal.position_m.x(), goal.position_m.y(), GainHeight(config_, input.map)), 1,
      true, &result.volumetric_stats);
  goal.gain_nats = g.gain_nats.empty() ? 0.0 : g.gain_nats[0];  // heading 0: for the status only
  result.best_unweighted_gain_nats = goal.gain_nats;
  result.chosen = best;
  FineTrajectoryTo(config_, input, traversable, goal.cell, goal.yaw_rad, &result);
  if (result.status != PlanStatus::kGoal) result.chosen = -1;
  result.timings.total_s = SecondsSince(t0);
  return result;
}

PlanResult PlanToPointFine(const PlannerConfig& config, const PlannerInput& input,
                           const Eigen::Vector2d& goal_xy, double goal_yaw_rad) {
  const Clock::time_point t0 = Clock::now();
  PlanResult result;
  std::vector<bool> traversable;
  if (!FineSearch(config, input, true, &result, &traversable)) {
    result.timings.total_s = SecondsSince(t0);
    return result;
  }
  const GridMap2D& grid = result.traversability->band;
  std::optional<Cell2> goal = grid.CellOf(goal_xy);
  if (!goal) {
    result.reason = "goal outside the map";
  } else {
    // The goal's cell, or the reachable cell nearest to it within the vehicle radius.
    int goal_cell = grid.IndexOf(*goal);
    if (!result.field.Reachable(goal_cell)) {
      double best = config.trajectory.vehicle_radius_m;
      goal_cell = -1;
      const int r = static_cast<int>(std::ceil(best / grid.resolution_m));
      for (int y = std::max(0, goal->y - r); y <= std::min(grid.height - 1, goal->y + r); ++y) {
        for (int x = std::max(0, goal->x - r); x <= std::min(grid.width - 1, goal->x + r); ++x) {
          const int i = grid.IndexOf(x, y);
          const double d = (grid.CenterOf({x, y}) - goal_xy).norm();
          if (result.field.Reachable(i) && d <= best) {
            best = d;
            goal_cell = i;
          }
        }
      }
    }
    if (goal_cell < 0) {
      result.reason = "goal unreachable: no path over known-free or flown space";
    } else {
      FineTrajectoryTo(config, input, traversable, goal_cell, goal_yaw_rad, &result);
    }
  }
  result.timings.total_s = SecondsSince(t0);
  return result;
}

bool TrajectoryStillClear(const PlannerConfig& config, const PlannerInput& input,
                          const PiecewisePolynomialTrajectory& trajectory, double from_time_s) {
  const bool fine =
      config.mode == ExplorationMode::kVolumetric ||
      (config.mode == ExplorationMode::kFrontier && config.frontier.fine_traversability);
  const Eigen::Vector2d start_xy =
      trajectory.Evaluate(trajectory.start_time_s()).position_m.head<2>();
  GridMap2D grid;
  std::vector<bool> allowed;
  double radius = config.trajectory.vehicle_radius_m;
  if (fine) {
    const TraversabilityConfig tc = FineTraversabilityConfig(config);
    std::optional<StartupFreeZone> zone;
    if (input.startup_center_m) {
      zone = StartupFreeZone{
          *input.startup_center_m,
          StartupFreeRadius(2.0 * tc.required_clearance_m(), config.startup_vertical_fov_rad)};
    }
    Traversability tr = ComputeTraversability(input.map, tc, zone, &input.flown_path);
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
    const int k = CollisionFactor(config.projection, input.map.resolution_m);
    std::optional<StartupFreeZone> zone;
    if (input.startup_center_m) {
      zone = StartupFreeZone{
          *input.startup_center_m,
          StartupFreeRadius(k * input.map.resolution_m, config.startup_vertical_fov_rad)};
    }
    CollisionProjection c = ProjectCollisionMaps(input.map, config.projection, zone);
    const std::vector<bool> traversable =
        TraversableCells(c.collision, config.projection.collision_threshold);
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

}  // namespace kestrel
