// Frontiers on the fine traversability (exploration/frontiers.h).
#include "exploration/frontiers.h"

#include <algorithm>
#include <cmath>

#include "common/check.h"
#include "exploration/ray_caster_2d.h"

namespace kestrel {
namespace {

bool Free(const GridMap2D& band, int i, double free_threshold) {
  return band.values[static_cast<size_t>(i)] <= free_threshold;
}

// Whether the frontier cell `to` lies in [min_range, max_range] of `from_m`, inside the field of
// view centred on `yaw_rad` and in sight past cells of band P <= max_crossed_p.
bool Covers(const GridMap2D& band, const Eigen::Vector2d& from_m, double yaw_rad, int to,
            const FrontierView& view, double max_crossed_p) {
  const Eigen::Vector2d d = band.CenterOf(band.CellAt(to)) - from_m;
  const double r = d.norm();
  if (r < view.min_range_m || r > view.max_range_m) return false;
  const double off = std::remainder(std::atan2(d.y(), d.x()) - yaw_rad, 2.0 * M_PI);
  if (std::abs(off) > 0.5 * view.horizontal_fov_rad) return false;
  return InSight(band, from_m, to, max_crossed_p);
}

// Calls f(i) for every frontier cell within max_range of p.
template <typename F>
void ForFrontiersNear(const GridMap2D& band, const std::vector<bool>& frontier,
                      const Eigen::Vector2d& p, double max_range_m, F f) {
  const int r = static_cast<int>(std::ceil(max_range_m / band.resolution_m)) + 1;
  const int cx = static_cast<int>(std::floor((p.x() - band.origin_m.x()) / band.resolution_m));
  const int cy = static_cast<int>(std::floor((p.y() - band.origin_m.y()) / band.resolution_m));
  for (int y = std::max(0, cy - r); y <= std::min(band.height - 1, cy + r); ++y) {
    for (int x = std::max(0, cx - r); x <= std::min(band.width - 1, cx + r); ++x) {
      const int i = band.IndexOf(x, y);
      if (frontier[static_cast<size_t>(i)]) f(i);
    }
  }
}

}  // namespace

std::vector<bool> FrontierCells(const Traversability& map, double free_threshold) {
  const GridMap2D& band = map.band;
  KESTREL_THROW_UNLESS(map.unknown.size() == band.values.size(),
                       "FrontierCells: unknown has " << map.unknown.size() << " cells, the band "
                                                     << band.values.size());
  std::vector<bool> frontier(band.values.size(), false);
  for (int y = 0; y < band.height; ++y) {
    for (int x = 0; x < band.width; ++x) {
      const int i = band.IndexOf(x, y);
      if (!map.unknown[static_cast<size_t>(i)]) continue;
      const bool edge =
          (x > 0 && Free(band, band.IndexOf(x - 1, y), free_threshold)) ||
          (x + 1 < band.width && Free(band, band.IndexOf(x + 1, y), free_threshold)) ||
          (y > 0 && Free(band, band.IndexOf(x, y - 1), free_threshold)) ||
          (y + 1 < band.height && Free(band, band.IndexOf(x, y + 1), free_threshold));
      frontier[static_cast<size_t>(i)] = edge;
    }
  }
  return frontier;
}

bool InSight(const GridMap2D& band, const Eigen::Vector2d& from_m, int to, double max_crossed_p) {
  thread_local Ray2D ray;
  const Eigen::Vector2d d = band.CenterOf(band.CellAt(to)) - from_m;
  const double length = d.norm();
  if (length <= 0.0) return true;
  CastRay2D(band, from_m, d / length, length, &ray);
  for (int k = 0; k < ray.size; ++k) {
    const int i = ray.index[static_cast<size_t>(k)];
    if (i == to) return true;
    if (!Free(band, i, max_crossed_p)) return false;
  }
  return true;  // the segment ended on the target's boundary
}

int ClearCoveredFrontiers(const GridMap2D& band, const std::vector<Eigen::Vector3d>& views,
                          const FrontierView& view, std::vector<bool>* frontier) {
  KESTREL_THROW_UNLESS(frontier != nullptr && frontier->size() == band.values.size(),
                       "ClearCoveredFrontiers: frontier must have one entry per band cell");
  int cleared = 0;
  for (const Eigen::Vector3d& g : views) {
    std::vector<int> covered;
    ForFrontiersNear(band, *frontier, g.head<2>(), view.max_range_m, [&](int i) {
      if (Covers(band, g.head<2>(), g.z(), i, view, kOccupiedBandP)) covered.push_back(i);
    });
    for (const int i : covered) (*frontier)[static_cast<size_t>(i)] = false;
    cleared += static_cast<int>(covered.size());
  }
  return cleared;
}

double BestFrontierHeading(const GridMap2D& band, const std::vector<bool>& frontier,
                           const Eigen::Vector2d& position_m, const FrontierView& view,
                           double free_threshold, int bins, int* covered) {
  KESTREL_THROW_UNLESS(bins >= 1, "BestFrontierHeading: bins = " << bins << ", accepted >= 1");
  KESTREL_THROW_UNLESS(frontier.size() == band.values.size(),
                       "BestFrontierHeading: frontier must have one entry per band cell");
  // Bearings of the frontier cells in range and in sight, then a sliding count per heading.
  std::vector<double> bearings;
  ForFrontiersNear(band, frontier, position_m, view.max_range_m, [&](int i) {
    const Eigen::Vector2d d = band.CenterOf(band.CellAt(i)) - position_m;
    const double r = d.norm();
    if (r < view.min_range_m || r > view.max_range_m) return;
    if (InSight(band, position_m, i, free_threshold)) bearings.push_back(std::atan2(d.y(), d.x()));
  });
  int best_count = -1;
  double best_yaw = 0.0;
  for (int b = 0; b < bins; ++b) {
    const double yaw = std::remainder(2.0 * M_PI * b / bins, 2.0 * M_PI);
    int count = 0;
    for (const double a : bearings) {
      count += std::abs(std::remainder(a - yaw, 2.0 * M_PI)) <= 0.5 * view.horizontal_fov_rad;
    }
    if (count > best_count) {
      best_count = count;
      best_yaw = yaw;
    }
  }
  if (covered != nullptr) *covered = best_count;
  return best_yaw;
}

}  // namespace kestrel
