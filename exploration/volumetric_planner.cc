// The volumetric planner (exploration/volumetric_planner.h; docs/exploration.md, sections
// "Volumetric gain", "Traversability" and "Choosing the next pose").
#include "exploration/volumetric_planner.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <numeric>
#include <string>
#include <unordered_map>
#include <utility>

#include "exploration/tour.h"

namespace kestrel {

// One candidate position of the volumetric planner.
struct VolumetricPlanner::Position {
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

// One replan: its input and result, the positions, their order, the best exact gain so far.
struct VolumetricPlanner::Pass {
  const PlannerInput& input;
  PlanResult& result;
  double z;           // the gain height (VolumetricGainHeight)
  int n_yaw;          // headings per position
  double d_max{0.0};  // the bump's d_max over every reachable cell (eq. 17)
  std::vector<Position> positions{};
  std::vector<size_t> order{};  // of positions, as the last ChooseByBound sorted them
  double best_gain{0.0};        // the best exact unweighted gain of any position evaluated
};

namespace {

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

// Sets the gains of the headings looked from (Position::viewed) to 0.
template <typename P>
void MaskViewed(P* p) {
  for (size_t m = 0; m < p->viewed.size() && m < p->gains.size(); ++m) {
    if (p->viewed[m]) p->gains[m] = 0.0;
  }
}

// The candidates of one position, one per heading.
template <typename P>
void AppendCandidates(const P& p, int n_yaw, std::vector<Candidate>* candidates) {
  for (int m = 0; m < n_yaw; ++m) {
    Candidate c;
    c.cell = p.cell;
    c.position_m = p.xy;
    c.yaw_rad = 2.0 * M_PI * m / n_yaw;
    c.gain_nats = p.gains[static_cast<size_t>(m)];
    c.distance_m = p.distance_m;
    c.bump = p.bump;
    c.discount = p.discount;
    candidates->push_back(c);
  }
}

}  // namespace

double VolumetricGainHeight(const PlannerConfig& config, const OccupancyGridView& map) {
  const double h = config.projection.height_m;
  for (const VolumetricSensor& s : config.volumetric.gain.sensors) {
    const double cells = (h + s.height_offset_m - map.origin_m.z()) / map.resolution_m;
    if (std::abs(cells - std::round(cells)) * map.resolution_m < 1e-6) return h + 1e-3;
  }
  return h;
}

VolumetricPlanner::VolumetricPlanner(const PlannerConfig& config)
    : config_(config), gains_(config.volumetric.gain), space_(SearchSpace::Fine(config)) {
  if (config_.mode != ExplorationMode::kVolumetricTour) config_.mode = ExplorationMode::kVolumetric;
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
  return RunPlan(input, space_, this);
}

void VolumetricPlanner::Positions(Pass* pass) {
  const PlannerInput& input = pass->input;
  PlanResult& result = pass->result;
  const Traversability& tr = *result.traversability;
  const GridMap2D& grid = tr.band;
  const int n_yaw = pass->n_yaw;
  CandidateConfig cc = config_.candidates;
  cc.lattice_step = std::max(
      1, static_cast<int>(std::lround(config_.volumetric.candidate_spacing_m / grid.resolution_m)));
  cc.exclude_vehicle_cell = true;
  const double d_max = DMax(cc, result.field.MaxDistance());
  pass->d_max = d_max;
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
      PoseGains b = gains_.Evaluate(input.GainMap(), Eigen::Vector3d(p.xy.x(), p.xy.y(), pass->z),
                                    n_yaw, false, &result.volumetric_stats, &c.memo);
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
      MaskViewed(&p);
    }
    pass->positions.push_back(std::move(p));
  }
  result.volumetric_stats.positions = static_cast<long>(pass->positions.size());
}

void VolumetricPlanner::Evaluate(Pass* pass, Position* p) {
  if (p->evaluated) return;
  CachedPose& entry = cache_[p->cell];
  PoseGains g =
      gains_.Evaluate(pass->input.GainMap(), Eigen::Vector3d(p->xy.x(), p->xy.y(), pass->z),
                      pass->n_yaw, true, &pass->result.volumetric_stats, &entry.memo);
  p->gains = g.gain_nats;
  p->evaluated = true;
  MaskViewed(p);
  entry.bounds = std::move(g.bound_nats);
  entry.gains = std::move(g.gain_nats);
}

double VolumetricPlanner::ChooseByBound(Pass* pass, double bump_d_max, double min_goal_gain) {
  std::vector<Position>& positions = pass->positions;
  std::vector<size_t>& order = pass->order;
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
    Evaluate(pass, &p);
    for (double g : p.gains) {
      if (g >= min_goal_gain) best_objective = std::max(best_objective, g * weight(p));
      pass->best_gain = std::max(pass->best_gain, g);
      if (weight(p) > 0.0) best_weighted_gain = std::max(best_weighted_gain, g);
    }
  }
  return best_weighted_gain;
}

void VolumetricPlanner::EndRule(Pass* pass) {
  const double end_gain = config_.volumetric.end_gain_nats;
  for (const Position& p : pass->positions) {  // reused exact gains count too
    for (double g : p.gains) pass->best_gain = std::max(pass->best_gain, g);
  }
  if (pass->best_gain >= end_gain) return;
  std::vector<Position>& positions = pass->positions;
  std::vector<size_t>& order = pass->order;
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return positions[a].max_bound > positions[b].max_bound;
  });
  for (size_t i : order) {
    Position& p = positions[i];
    if (p.max_bound < end_gain || pass->best_gain >= end_gain) break;
    Evaluate(pass, &p);
    for (double g : p.gains) pass->best_gain = std::max(pass->best_gain, g);
  }
}

int VolumetricPlanner::ListCandidates(Pass* pass, double min_goal_gain) {
  std::vector<Candidate>& candidates = pass->result.candidates;
  for (const Position& p : pass->positions) {
    if (p.evaluated) AppendCandidates(p, pass->n_yaw, &candidates);
  }
  // Goals are poses worth the end threshold (docs/exploration.md, "Choosing the next pose"): a
  // pose below it is what the end rule calls explored, so the flight never wanders among them
  // while a pose that still holds end_gain_nats waits elsewhere.
  int chosen = -1;
  for (size_t i = 0; i < candidates.size(); ++i) {
    if (candidates[i].gain_nats < min_goal_gain) continue;
    if (chosen < 0 ||
        candidates[i].objective() > candidates[static_cast<size_t>(chosen)].objective()) {
      chosen = static_cast<int>(i);
    }
  }
  return chosen;
}

int VolumetricPlanner::KeepCurrentGoal(Pass* pass, int chosen, double min_goal_gain) {
  const PlannerInput& input = pass->input;
  if (!input.current_goal || chosen < 0) return chosen;
  std::vector<Candidate>& candidates = pass->result.candidates;
  const int n_yaw = pass->n_yaw;
  const std::optional<Cell2> gc =
      pass->result.traversability->band.CellOf(input.current_goal->head<2>());
  const double half = 0.5 * config_.volumetric.candidate_spacing_m;
  for (Position& p : pass->positions) {
    if (!gc || (p.xy - input.current_goal->head<2>()).norm() > half) continue;
    const int m =
        static_cast<int>(std::lround(input.current_goal->z() / (2.0 * M_PI / n_yaw))) % n_yaw;
    const int mm = (m + n_yaw) % n_yaw;
    const bool was_evaluated = p.evaluated;
    Evaluate(pass, &p);
    const double objective = p.gains[static_cast<size_t>(mm)] * p.bump * p.discount;
    const double best = candidates[static_cast<size_t>(chosen)].objective();
    if (objective > 0.0 && p.gains[static_cast<size_t>(mm)] >= min_goal_gain &&
        best <= (1.0 + config_.candidates.switch_margin) * objective) {
      if (!was_evaluated) AppendCandidates(p, n_yaw, &candidates);
      for (size_t i = 0; i < candidates.size(); ++i) {
        const Candidate& c = candidates[i];
        if (c.cell == p.cell &&
            std::abs(std::remainder(c.yaw_rad - 2.0 * M_PI * mm / n_yaw, 2.0 * M_PI)) < 1e-9) {
          chosen = static_cast<int>(i);
        }
      }
    }
    break;
  }
  return chosen;
}

int VolumetricPlanner::ChooseByTour(Pass* pass, const SearchedCells& cells) {
  const PlannerInput& input = pass->input;
  PlanResult& result = pass->result;
  const Traversability& tr = *result.traversability;
  const GridMap2D& grid = tr.band;
  const double end_gain = config_.volumetric.end_gain_nats;
  const int n_yaw = pass->n_yaw;
  const int tile_cells = std::max(
      1, static_cast<int>(std::lround(config_.volumetric.tour_site_m / grid.resolution_m)));
  const int tiles_x = (grid.width + tile_cells - 1) / tile_cells;
  auto tile_of = [&](int cell) {
    const Cell2 c = grid.CellAt(cell);
    return c.x / tile_cells + tiles_x * (c.y / tile_cells);
  };
  // Each tile's exact best gain: its positions in decreasing bound until the best exact gain
  // reaches the next bound (a gain never exceeds its bound).
  std::map<int, std::vector<size_t>> by_tile;
  for (size_t i = 0; i < pass->positions.size(); ++i) {
    by_tile[tile_of(pass->positions[i].cell)].push_back(i);
  }
  auto best_heading = [](const Position& p) {
    return static_cast<int>(std::max_element(p.gains.begin(), p.gains.end()) - p.gains.begin());
  };
  std::vector<SitePose> poses;
  for (auto& [tile, members] : by_tile) {
    std::stable_sort(members.begin(), members.end(), [&](size_t a, size_t b) {
      return pass->positions[a].max_bound > pass->positions[b].max_bound;
    });
    double best = -1.0;
    for (size_t i : members) {
      Position& p = pass->positions[i];
      if (p.max_bound < end_gain || p.max_bound <= best) break;
      Evaluate(pass, &p);
      const int m = best_heading(p);
      const double g = p.gains[static_cast<size_t>(m)];
      pass->best_gain = std::max(pass->best_gain, g);
      best = std::max(best, g);
    }
  }
  for (const Position& p : pass->positions) {
    if (!p.evaluated) continue;
    const int m = best_heading(p);
    poses.push_back(
        SitePose{p.cell, p.xy, 2.0 * M_PI * m / n_yaw, p.gains[static_cast<size_t>(m)]});
  }
  std::vector<InfoSite> sites = GroupSites(grid, poses, tile_cells, end_gain);
  ListCandidates(pass, end_gain);  // every evaluated pose; the tour picks among them
  tour_sites_.clear();
  tour_order_.clear();
  if (sites.empty()) return -1;
  const size_t max_sites = static_cast<size_t>(config_.volumetric.tour_max_sites);
  if (sites.size() > max_sites) {  // the largest gains, then back in tile order
    std::stable_sort(sites.begin(), sites.end(), [](const InfoSite& a, const InfoSite& b) {
      return a.best.gain_nats > b.best.gain_nats;
    });
    sites.resize(max_sites);
    std::sort(sites.begin(), sites.end(),
              [](const InfoSite& a, const InfoSite& b) { return a.tile < b.tile; });
  }
  TravelTimeConfig tc;
  tc.speed_mps = config_.trajectory.max_speed_mps;
  tc.yaw_rate_radps = config_.trajectory.max_yaw_rate_radps;
  tc.coarsen = config_.volumetric.tour_coarsen;
  TourProblem problem = TravelTimes(
      result.field, input.yaw_rad, sites, grid.width, grid.height, cells.traversable,
      grid.resolution_m, ClearanceStepWeights(tr, FineTraversabilityConfig(config_)), tc);
  Tour tour;
  if (config_.volumetric.tour_prize_weight > 0.0) {  // prize-collecting: gains against time
    problem.cost_weight = config_.volumetric.tour_prize_weight;
    problem.prize.assign(static_cast<size_t>(problem.n), 0.0);
    for (size_t k = 0; k < sites.size(); ++k) problem.prize[k + 1] = sites[k].best.gain_nats;
    tour = SolveTour(problem);
    problem.prize.clear();
  }
  if (tour.order.size() < 2) tour = SolveTour(problem);
  tour_sites_ = sites;
  for (size_t k = 1; k < tour.order.size(); ++k) tour_order_.push_back(tour.order[k] - 1);
  const InfoSite& first = sites[static_cast<size_t>(tour_order_.front())];
  // The candidate index of a pose (cell, heading m).
  const std::vector<Candidate>& candidates = result.candidates;
  auto candidate_of = [&](int cell, int m) {
    for (size_t i = 0; i < candidates.size(); ++i) {
      const Candidate& c = candidates[i];
      if (c.cell == cell &&
          std::abs(std::remainder(c.yaw_rad - 2.0 * M_PI * m / n_yaw, 2.0 * M_PI)) < 1e-9) {
        return static_cast<int>(i);
      }
    }
    return -1;
  };
  // The current goal, while it lies in the first site and keeps end_gain_nats: replans on the way
  // do not swap poses of one site.
  if (input.current_goal) {
    const double half = 0.5 * config_.volumetric.candidate_spacing_m;
    for (const Position& p : pass->positions) {
      if (!p.evaluated || (p.xy - input.current_goal->head<2>()).norm() > half) continue;
      const long m = std::lround(input.current_goal->z() / (2.0 * M_PI / n_yaw));
      const int mm = static_cast<int>(((m % n_yaw) + n_yaw) % n_yaw);
      if (tile_of(p.cell) == first.tile && p.gains[static_cast<size_t>(mm)] >= end_gain) {
        const int kept = candidate_of(p.cell, mm);
        if (kept >= 0) return kept;
      }
      break;
    }
  }
  // Refinement towards the next site: among the first site's poses worth 3/4 of its best gain,
  // the one with the least time from the vehicle (its Dijkstra path) plus the time on to the next
  // site's best pose (straight line), each leg the larger of path and turn time.
  const double v = tc.speed_mps;
  const double w = tc.yaw_rate_radps;
  auto leg = [&](double d, double yaw_a, double yaw_b) {
    return std::max(d / v, std::abs(std::remainder(yaw_b - yaw_a, 2.0 * M_PI)) / w);
  };
  const InfoSite* next =
      tour_order_.size() > 1 ? &sites[static_cast<size_t>(tour_order_[1])] : nullptr;
  int chosen_cell = first.best.cell;
  int chosen_m = static_cast<int>(std::lround(first.best.yaw_rad / (2.0 * M_PI / n_yaw))) % n_yaw;
  double chosen_time = std::numeric_limits<double>::infinity();
  for (const Position& p : pass->positions) {
    if (!p.evaluated || tile_of(p.cell) != first.tile) continue;
    for (int m = 0; m < n_yaw; ++m) {
      const double g = p.gains[static_cast<size_t>(m)];
      if (g < end_gain || g < 0.75 * first.best.gain_nats) continue;
      const double yaw = 2.0 * M_PI * m / n_yaw;
      double t = leg(p.distance_m, input.yaw_rad, yaw);
      if (next != nullptr) t += leg((next->best.xy_m - p.xy).norm(), yaw, next->best.yaw_rad);
      if (t < chosen_time) {
        chosen_time = t;
        chosen_cell = p.cell;
        chosen_m = m;
      }
    }
  }
  return candidate_of(chosen_cell, chosen_m);
}

GoalChoice VolumetricPlanner::Choose(const PlannerInput& input, const SearchedCells& cells,
                                     PlanResult* result) {
  UpdateAffectedTiles(input.GainMap());
  reused_positions_ = 0;
  Pass pass{input, *result, VolumetricGainHeight(config_, input.map), config_.candidates.n_yaw};
  Positions(&pass);
  // Exact argmax of gain x bump, in decreasing bound x bump. Local first: with d_max capped at
  // the horizon, then, if no pose within it keeps end_gain_nats, over everything with the full
  // d_max.
  const double d_max = pass.d_max;
  const double end_gain = config_.volumetric.end_gain_nats;
  const double horizon = config_.volumetric.local_horizon_m;
  pass.order.resize(pass.positions.size());
  double min_goal_gain = 0.0;
  int chosen = -1;
  if (config_.mode == ExplorationMode::kVolumetricTour) {
    // The tour (docs/exploration.md, "The information tour"); its goals are poses worth the end
    // threshold, like local first's. Without a site no pose keeps end_gain_nats: the end rule
    // below ends the flight.
    min_goal_gain = end_gain;
    chosen = ChooseByTour(&pass, cells);
    std::iota(pass.order.begin(), pass.order.end(), size_t{0});
    EndRule(&pass);
  } else {
    if (horizon > 0.0 && horizon < d_max && ChooseByBound(&pass, horizon, end_gain) >= end_gain) {
      min_goal_gain = end_gain;
    } else {
      ChooseByBound(&pass, d_max, 0.0);
    }
    EndRule(&pass);
    chosen = KeepCurrentGoal(&pass, ListCandidates(&pass, min_goal_gain), min_goal_gain);
  }
  const double best_gain = pass.best_gain;
  result->best_unweighted_gain_nats = best_gain;
  result->end_test_gain_nats = best_gain;
  if (pass.positions.empty()) {
    // A failure, not the end: new map data (noise cleared, the vehicle moved on) can open space
    // again; the explorer ends exploration with this rule after max_failed_plans in a row.
    result->status = PlanStatus::kFailed;
    result->end_rule = "no reachable candidate";
    result->reason = "no reachable candidate position";
    return {};
  }
  if (best_gain < end_gain) {
    result->status = PlanStatus::kExplorationDone;
    result->end_rule = "gain rule";
    result->reason = "best unweighted gain " + std::to_string(best_gain) + " nats below " +
                     std::to_string(end_gain) + " nats over " +
                     std::to_string(pass.positions.size()) + " reachable positions";
    return {};
  }
  // The chosen pose; if no trajectory reaches it (or the other vehicles refuse it), the next ones
  // by objective among the goals worth min_goal_gain (GoalChoice's limits).
  GoalChoice choice;
  choice.goals = GoalsByObjective(result->candidates, chosen, min_goal_gain);
  return choice;
}

}  // namespace kestrel
