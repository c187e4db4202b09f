#include "exploration/dijkstra.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>
#include <utility>

#include "common/check.h"
#include "exploration/projected_maps.h"

namespace kestrel {

bool DistanceField::Reachable(int index) const {
  return index >= 0 && index < static_cast<int>(distance_m.size()) &&
         std::isfinite(distance_m[static_cast<size_t>(index)]);
}

std::vector<int> DistanceField::PathTo(int goal) const {
  std::vector<int> path;
  if (!Reachable(goal)) return path;
  for (int c = goal; c != -1; c = parent[static_cast<size_t>(c)]) path.push_back(c);
  std::reverse(path.begin(), path.end());
  return path;
}

double DistanceField::MaxDistance() const {
  double m = 0.0;
  for (double d : distance_m) {
    if (std::isfinite(d)) m = std::max(m, d);
  }
  return m;
}

std::vector<bool> TraversableCells(const GridMap2D& collision, double collision_threshold) {
  std::vector<bool> t(collision.values.size());
  for (size_t i = 0; i < t.size(); ++i)
    t[i] = IsTraversable(collision.values[i], collision_threshold);
  return t;
}

DistanceField ComputeDistanceField(int width, int height, const std::vector<bool>& traversable,
                                   const Cell2& start, double cell_size_m,
                                   const std::vector<double>& step_weight) {
  KESTREL_THROW_UNLESS(
      width > 0 && height > 0 && traversable.size() == static_cast<size_t>(width) * height,
      "ComputeDistanceField: " << width << " x " << height << " grid with " << traversable.size()
                               << " flags");
  KESTREL_THROW_UNLESS(
      start.x >= 0 && start.y >= 0 && start.x < width && start.y < height,
      "ComputeDistanceField: start (" << start.x << ", " << start.y << ") outside the grid");
  KESTREL_THROW_UNLESS(cell_size_m > 0.0, "ComputeDistanceField: cell_size_m = " << cell_size_m);
  KESTREL_THROW_UNLESS(step_weight.empty() || step_weight.size() == traversable.size(),
                       "ComputeDistanceField: " << step_weight.size() << " step weights for "
                                                << traversable.size() << " cells");
  for (double w : step_weight) {
    KESTREL_THROW_UNLESS(std::isfinite(w) && w >= 1.0,
                         "ComputeDistanceField: step weight " << w << ", accepted [1, inf)");
  }
  const bool weighted = !step_weight.empty();
  DistanceField f;
  f.width = width;
  f.height = height;
  f.start = start.x + width * start.y;
  const size_t n = traversable.size();
  f.distance_m.assign(n, std::numeric_limits<double>::infinity());
  f.parent.assign(n, -1);
  std::vector<bool> done(n, false);
  const auto usable = [&](int x, int y) {
    if (x < 0 || y < 0 || x >= width || y >= height) return false;
    const int i = x + width * y;
    return i == f.start || traversable[static_cast<size_t>(i)];
  };
  using Entry = std::pair<double, int>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> open;
  f.distance_m[static_cast<size_t>(f.start)] = 0.0;
  open.push({0.0, f.start});
  const double diagonal = std::sqrt(2.0) * cell_size_m;
  while (!open.empty()) {
    const auto [d, i] = open.top();
    open.pop();
    if (done[static_cast<size_t>(i)]) continue;
    done[static_cast<size_t>(i)] = true;
    const int x = i % width;
    const int y = i / width;
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        if (dx == 0 && dy == 0) continue;
        if (!usable(x + dx, y + dy)) continue;
        const bool diag = dx != 0 && dy != 0;
        if (diag && !(usable(x + dx, y) && usable(x, y + dy))) continue;  // no corner cutting
        const int j = (x + dx) + width * (y + dy);
        double step = diag ? diagonal : cell_size_m;  // Euclidean step cost
        if (weighted) {
          step *= 0.5 * (step_weight[static_cast<size_t>(i)] + step_weight[static_cast<size_t>(j)]);
        }
        const double nd = d + step;
        double& dj = f.distance_m[static_cast<size_t>(j)];
        if (nd < dj) {
          dj = nd;
          f.parent[static_cast<size_t>(j)] = i;
          open.push({nd, j});
        }
      }
    }
  }
  return f;
}

}  // namespace kestrel
