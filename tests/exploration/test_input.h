#pragma once
/// @file
/// Planner inputs on the hand-made 3D maps of the exploration tests.
#include <Eigen/Core>
#include <vector>

#include "exploration/dijkstra.h"
#include "exploration/planner.h"
#include "exploration/traversability.h"

namespace kestrel::test {

/// The view of a test's map: dims cells of edge alpha_m from origin_m, x fastest.
inline OccupancyGridView GridView(const Eigen::Vector3i& dims, const Eigen::Vector3d& origin_m,
                                  double alpha_m, const std::vector<float>& values) {
  OccupancyGridView v;
  v.dims = dims;
  v.origin_m = origin_m;
  v.resolution_m = alpha_m;
  v.probability = values.data();
  return v;
}

/// A planner input on `map` with the vehicle at (x, y, 0.75 m), at t = 10 s.
inline PlannerInput InputOn(const OccupancyGridView& map, double x_m, double y_m) {
  PlannerInput in;
  in.map = map;
  in.position_m = Eigen::Vector3d(x_m, y_m, 0.75);
  in.time_s = 10.0;
  return in;
}

/// Whether `to` is traversable and reachable from `from` over the traversable cells and the
/// passages of `t` (AllowPassages), as the fine planners' paths are.
inline bool Reachable(const Traversability& t, const Eigen::Vector2d& from,
                      const Eigen::Vector2d& to) {
  const auto a = t.band.CellOf(from);
  const auto b = t.band.CellOf(to);
  if (!a || !b) return false;
  std::vector<bool> usable = t.traversable;
  AllowPassages(t, &usable);
  const DistanceField f =
      ComputeDistanceField(t.band.width, t.band.height, usable, *a, t.band.resolution_m);
  return f.Reachable(t.band.IndexOf(*b)) && t.traversable[static_cast<size_t>(t.band.IndexOf(*b))];
}

/// A test's 3D map: dims cells of edge alpha from origin, values x fastest.
struct TestMap {
  Eigen::Vector3i dims;
  Eigen::Vector3d origin;
  double alpha;
  std::vector<float> values;
  /// A planner input on this map with the vehicle at (x, y) (InputOn).
  [[nodiscard]] PlannerInput Input(double x, double y) const {
    return InputOn(GridView(dims, origin, alpha, values), x, y);
  }
};

/// Cell values of a dims grid from origin_m at alpha_m, x fastest: `fill`, then
/// set(x, y, z, &value) at every cell centre (m) may change the cell's value.
template <typename F>
std::vector<float> FillGrid(const Eigen::Vector3i& dims, const Eigen::Vector3d& origin_m,
                            double alpha_m, float fill, F set) {
  std::vector<float> values(static_cast<size_t>(dims.prod()), fill);
  for (int k = 0; k < dims.z(); ++k) {
    for (int j = 0; j < dims.y(); ++j) {
      for (int i = 0; i < dims.x(); ++i) {
        set(origin_m.x() + (i + 0.5) * alpha_m, origin_m.y() + (j + 0.5) * alpha_m,
            origin_m.z() + (k + 0.5) * alpha_m,
            &values[static_cast<size_t>(i + dims.x() * (j + dims.y() * k))]);
      }
    }
  }
  return values;
}

}  // namespace kestrel::test
