#include "tools/map_score/map_claims.h"

#include <algorithm>
#include <cmath>
#include <queue>
#include <stdexcept>
#include <string>

namespace kestrel {

namespace {

void CheckSize(const char* what, size_t size, const GridSpec& grid) {
  if (size != grid.size()) {
    throw std::invalid_argument(std::string("ClaimTracker: ") + what + " holds " +
                                std::to_string(size) + " cells, the grid " +
                                std::to_string(grid.size()));
  }
}

}  // namespace

ClaimTracker::ClaimTracker(const World& world, const GridSpec& grid,
                           const std::vector<uint8_t>& truth)
    : grid_(grid),
      outside_(grid.size(), 0),
      in_solid_(grid.size(), 0),
      first_free_s_(grid.size(), std::numeric_limits<double>::infinity()) {
  CheckSize("the truth", truth.size(), grid_);
  const double half_m = 0.5 * grid_.resolution_m;
  for (size_t i = 0; i < grid_.size(); ++i) {
    const Eigen::Vector3d center = grid_.BoxOf(grid_.CellOf(i)).center();
    in_solid_[i] = DepthInsideObstacle(world, center) >= half_m ? 1 : 0;
  }
  // The inside: truth-free cells face-connected to the start's cell at the exploration height;
  // the outside, every other truth-free cell.
  std::vector<uint8_t> inside(grid.size(), 0);
  const Eigen::Vector3d start =
      world.start_X_WB.p +
      Eigen::Vector3d(0, 0, world.exploration_height_m - world.start_X_WB.p.z());
  const Eigen::Vector3i s =
      ((start - grid_.min_m) / grid_.resolution_m).array().floor().cast<int>();
  std::queue<Eigen::Vector3i> queue;
  const auto visit = [&](const Eigen::Vector3i& c) {
    if ((c.array() < 0).any() || (c.array() >= grid_.dims.array()).any()) return;
    const size_t i = grid_.IndexOf(c);
    if (truth[i] != 0 || inside[i] != 0) return;
    inside[i] = 1;
    queue.push(c);
  };
  visit(s);
  while (!queue.empty()) {
    const Eigen::Vector3i c = queue.front();
    queue.pop();
    for (int a = 0; a < 3; ++a) {
      for (const int step : {-1, 1}) {
        Eigen::Vector3i n = c;
        n[a] += step;
        visit(n);
      }
    }
  }
  for (size_t i = 0; i < grid_.size(); ++i) outside_[i] = truth[i] == 0 && inside[i] == 0 ? 1 : 0;
}

void ClaimTracker::Sample(double time_s, const std::vector<uint8_t>& known_free) {
  CheckSize("the known-free mask", known_free.size(), grid_);
  sampled_ = true;
  for (size_t i = 0; i < known_free.size(); ++i) {
    if (known_free[i] != 0 && std::isinf(first_free_s_[i])) first_free_s_[i] = time_s;
  }
}

MapClaims ClaimTracker::Claims(const std::vector<uint8_t>& known_free,
                               const std::vector<double>* first_reach_s) const {
  CheckSize("the known-free mask", known_free.size(), grid_);
  if (first_reach_s != nullptr) CheckSize("the reach record", first_reach_s->size(), grid_);
  MapClaims c;
  if (first_reach_s != nullptr) c.free_unreached = 0;
  if (first_reach_s != nullptr && sampled_) c.freed_early = 0;
  for (size_t i = 0; i < known_free.size(); ++i) {
    const double reached_s =
        first_reach_s != nullptr ? (*first_reach_s)[i] : std::numeric_limits<double>::quiet_NaN();
    if (sampled_ && first_free_s_[i] < reached_s) {  // false without a record (NaN)
      ++c.freed_early;
      if (std::isfinite(reached_s))
        c.max_lead_s = std::max(c.max_lead_s, reached_s - first_free_s_[i]);
    }
    if (known_free[i] == 0) continue;
    ++c.known_free;
    c.free_in_solid += in_solid_[i];
    c.free_outside += outside_[i];
    if (first_reach_s != nullptr && std::isinf(reached_s)) ++c.free_unreached;
  }
  return c;
}

std::vector<uint8_t> ClaimTracker::ClaimMask(const std::vector<uint8_t>& known_free,
                                             const std::vector<double>* first_reach_s) const {
  CheckSize("the known-free mask", known_free.size(), grid_);
  std::vector<uint8_t> mask(known_free.size(), 0);
  for (size_t i = 0; i < known_free.size(); ++i) {
    const bool unreached = first_reach_s != nullptr && std::isinf((*first_reach_s)[i]);
    mask[i] = known_free[i] != 0 && (in_solid_[i] != 0 || outside_[i] != 0 || unreached);
  }
  return mask;
}

MaskPlanView PlanViewOf(const GridSpec& grid, const std::vector<uint8_t>& mask, double bin_m) {
  CheckSize("the mask", mask.size(), grid);
  MaskPlanView v;
  v.bins_x = static_cast<int>(std::ceil(grid.dims.x() * grid.resolution_m / bin_m));
  v.bins_y = static_cast<int>(std::ceil(grid.dims.y() * grid.resolution_m / bin_m));
  v.per_bin.assign(static_cast<size_t>(v.bins_x) * v.bins_y, 0);
  v.per_layer.assign(grid.dims.z(), 0);
  for (size_t i = 0; i < mask.size(); ++i) {
    if (mask[i] == 0) continue;
    const Eigen::Vector3i c = grid.CellOf(i);
    ++v.per_layer[c.z()];
    const int bx =
        std::min(v.bins_x - 1, static_cast<int>((c.x() + 0.5) * grid.resolution_m / bin_m));
    const int by =
        std::min(v.bins_y - 1, static_cast<int>((c.y() + 0.5) * grid.resolution_m / bin_m));
    ++v.per_bin[static_cast<size_t>(by) * v.bins_x + bx];
  }
  return v;
}

std::vector<uint8_t> KnownFreeBelow(const std::vector<double>& probability, double p_init) {
  std::vector<uint8_t> out(probability.size());
  for (size_t i = 0; i < probability.size(); ++i) out[i] = probability[i] < 0.5 * p_init ? 1 : 0;
  return out;
}

std::vector<uint8_t> KnownFreeObserved(const std::vector<double>& probability,
                                       const std::vector<uint8_t>& observed) {
  if (observed.size() != probability.size()) {
    throw std::invalid_argument("KnownFreeObserved: masks of different sizes");
  }
  std::vector<uint8_t> out(probability.size());
  for (size_t i = 0; i < probability.size(); ++i) {
    out[i] = observed[i] != 0 && probability[i] < 0.5 ? 1 : 0;
  }
  return out;
}

}  // namespace kestrel
