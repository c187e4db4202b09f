#pragma once
/// @file
/// Planner inputs on the hand-made 3D maps of the exploration tests.
#include <Eigen/Core>
#include <vector>

#include "exploration/planner.h"

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

}  // namespace kestrel::test
