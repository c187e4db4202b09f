// Information sites and travel times (exploration/info_sites.h; docs/exploration.md, "The
// information tour").
#include "exploration/info_sites.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>
#include <string>

namespace kestrel {
namespace {

constexpr double kUnreachedSeconds = 1e6;

// The leg time of FUEL's cost: the path at the speed limit or the turn at the yaw rate limit,
// whichever takes longer.
double LegTime(double distance_m, double yaw_from_rad, double yaw_to_rad,
               const TravelTimeConfig& config) {
  if (!std::isfinite(distance_m)) return kUnreachedSeconds;
  const double turn = std::abs(std::remainder(yaw_to_rad - yaw_from_rad, 2.0 * M_PI));
  return std::max(distance_m / config.speed_mps, turn / config.yaw_rate_radps);
}

}  // namespace

std::vector<InfoSite> GroupSites(const GridMap2D& grid, const std::vector<SitePose>& poses,
                                 int tile_cells, double min_gain_nats) {
  if (tile_cells < 1) {
    throw std::invalid_argument("GroupSites: tile_cells = " + std::to_string(tile_cells) +
                                ", need >= 1");
  }
  const int tiles_x = (grid.width + tile_cells - 1) / tile_cells;
  std::map<int, InfoSite> sites;
  for (const SitePose& p : poses) {
    if (p.gain_nats < min_gain_nats) continue;
    const Cell2 c = grid.CellAt(p.cell);
    const int tile = c.x / tile_cells + tiles_x * (c.y / tile_cells);
    InfoSite& s = sites[tile];
    if (s.poses == 0 || p.gain_nats > s.best.gain_nats) s.best = p;
    s.tile = tile;
    ++s.poses;
    s.total_gain_nats += p.gain_nats;
  }
  std::vector<InfoSite> out;
  out.reserve(sites.size());
  for (const auto& [tile, s] : sites) out.push_back(s);
  return out;
}

TourProblem TravelTimes(const DistanceField& vehicle_field, double vehicle_yaw_rad,
                        const std::vector<InfoSite>& sites, int width, int height,
                        const std::vector<bool>& traversable, double cell_m,
                        const std::vector<double>& step_weight, const TravelTimeConfig& config) {
  if (!(config.speed_mps > 0.0) || !(config.yaw_rate_radps > 0.0) || config.coarsen < 1) {
    throw std::invalid_argument("TravelTimes: speed_mps, yaw_rate_radps > 0 and coarsen >= 1");
  }
  if (traversable.size() != static_cast<size_t>(width) * static_cast<size_t>(height) ||
      vehicle_field.distance_m.size() != traversable.size() ||
      (!step_weight.empty() && step_weight.size() != traversable.size())) {
    throw std::invalid_argument("TravelTimes: inconsistent grid sizes");
  }
  const int n = static_cast<int>(sites.size()) + 1;
  TourProblem problem;
  problem.n = n;
  problem.cost.assign(static_cast<size_t>(n) * static_cast<size_t>(n), 0.0);
  auto at = [n](int i, int j) { return static_cast<size_t>(i) * static_cast<size_t>(n) + j; };
  for (int k = 1; k < n; ++k) {
    const SitePose& b = sites[static_cast<size_t>(k - 1)].best;
    problem.cost[at(0, k)] = LegTime(vehicle_field.distance_m[static_cast<size_t>(b.cell)],
                                     vehicle_yaw_rad, b.yaw_rad, config);
  }
  // The grid the site-to-site searches run on: the given one, or coarsened.
  const int f = config.coarsen;
  const int cw = (width + f - 1) / f;
  const int ch = (height + f - 1) / f;
  std::vector<bool> usable(static_cast<size_t>(cw) * static_cast<size_t>(ch), false);
  std::vector<double> weight;
  if (!step_weight.empty()) weight.assign(usable.size(), 0.0);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const size_t i = static_cast<size_t>(x) + static_cast<size_t>(width) * y;
      if (!traversable[i]) continue;
      const size_t c = static_cast<size_t>(x / f) + static_cast<size_t>(cw) * (y / f);
      if (!weight.empty())
        weight[c] = usable[c] ? std::min(weight[c], step_weight[i]) : step_weight[i];
      usable[c] = true;
    }
  }
  for (double& w : weight) w = std::max(w, 1.0);  // unusable cells: any valid weight
  auto coarse_of = [&](int cell) {
    const int x = cell % width;
    const int y = cell / width;
    return (x / f) + cw * (y / f);
  };
  for (int i = 1; i < n; ++i) {
    const SitePose& a = sites[static_cast<size_t>(i - 1)].best;
    const int ca = coarse_of(a.cell);
    const DistanceField field =
        ComputeDistanceField(cw, ch, usable, Cell2{ca % cw, ca / cw}, cell_m * f, weight);
    for (int j = 1; j < n; ++j) {
      if (j == i) continue;
      const SitePose& b = sites[static_cast<size_t>(j - 1)].best;
      problem.cost[at(i, j)] = LegTime(field.distance_m[static_cast<size_t>(coarse_of(b.cell))],
                                       a.yaw_rad, b.yaw_rad, config);
    }
  }
  return problem;
}

}  // namespace kestrel
