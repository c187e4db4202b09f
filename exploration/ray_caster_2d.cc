#include "exploration/ray_caster_2d.h"

#include <cmath>
#include <limits>

#include "common/check.h"

namespace kestrel {

int CastRay2D(const GridMap2D& grid, const Eigen::Vector2d& origin_m,
              const Eigen::Vector2d& direction, double length_m, Ray2D* out) {
  KESTREL_THROW_UNLESS(out != nullptr, "CastRay2D: out is null");
  KESTREL_THROW_UNLESS(origin_m.allFinite(), "CastRay2D: origin not finite");
  KESTREL_THROW_UNLESS(std::abs(direction.norm() - 1.0) <= 1e-6,
                       "CastRay2D: |direction| = " << direction.norm() << ", accepted 1");
  KESTREL_THROW_UNLESS(std::isfinite(length_m) && length_m >= 0.0,
                       "CastRay2D: length_m = " << length_m << ", accepted [0, inf)");
  out->Clear();
  const double alpha = grid.resolution_m;
  const auto boundary = [&](int axis, long i) {
    return grid.origin_m[axis] + static_cast<double>(i) * alpha;
  };
  long cell[2];
  int step[2];
  for (int a = 0; a < 2; ++a) {
    long i = static_cast<long>(std::floor((origin_m[a] - grid.origin_m[a]) / alpha));
    // Exact half-open membership with the boundary expression (floor may be off by one).
    while (origin_m[a] < boundary(a, i)) --i;
    while (origin_m[a] >= boundary(a, i + 1)) ++i;
    // On a boundary and pointing down: the cell below is the first with a positive chord.
    if (origin_m[a] == boundary(a, i) && direction[a] < 0.0) --i;
    cell[a] = i;
    step[a] = direction[a] > 0.0 ? 1 : (direction[a] < 0.0 ? -1 : 0);
  }
  const auto inside = [&]() {
    return cell[0] >= 0 && cell[1] >= 0 && cell[0] < grid.width && cell[1] < grid.height;
  };
  if (!inside()) {
    out->left_bounds = true;
    return 0;
  }
  const auto next_crossing = [&](int a) {
    if (step[a] == 0) return std::numeric_limits<double>::infinity();
    const long b = step[a] > 0 ? cell[a] + 1 : cell[a];
    return (boundary(a, b) - origin_m[a]) / direction[a];
  };
  double t_entry = 0.0;
  double t_next[2] = {next_crossing(0), next_crossing(1)};
  while (t_entry < length_m) {
    const double t_cross = std::min(t_next[0], t_next[1]);
    const double t_exit = std::min(t_cross, length_m);
    if (t_exit > t_entry) {
      out->index.push_back(static_cast<int>(cell[0] + grid.width * cell[1]));
      out->entry_m.push_back(t_entry);
      out->exit_m.push_back(t_exit);
      out->distance_m.push_back(0.5 * (t_entry + t_exit));
      ++out->size;
    }
    if (t_cross >= length_m) break;
    for (int a = 0; a < 2; ++a) {
      if (t_next[a] == t_cross) cell[a] += step[a];
    }
    if (!inside()) {
      out->left_bounds = true;
      break;
    }
    for (int a = 0; a < 2; ++a) {
      if (t_next[a] == t_cross) t_next[a] = next_crossing(a);
    }
    t_entry = std::max(t_entry, t_cross);
  }
  return out->size;
}

}  // namespace kestrel
