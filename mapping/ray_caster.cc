#include "mapping/ray_caster.h"

#include <cmath>
#include <cstdint>
#include <limits>

#include "common/check.h"

namespace kestrel {

RayCells::RayCells(double max_length, double resolution_m) : max_length_m(max_length) {
  const int capacity = CapacityFor(max_length, resolution_m);
  cells.resize(static_cast<size_t>(capacity));
  distance_m.resize(static_cast<size_t>(capacity));
  likelihood.resize(static_cast<size_t>(capacity));
}

int RayCells::CapacityFor(double length_m, double resolution_m) {
  KESTREL_THROW_UNLESS(std::isfinite(length_m) && length_m > 0.0 && std::isfinite(resolution_m) &&
                           resolution_m > 0.0 && length_m / resolution_m < 1e7,
                       "ray scratch: length_m = " << length_m << ", resolution_m = " << resolution_m
                                                  << ", accepted positive, length/alpha < 1e7");
  // A segment crosses at most |u_i| L / alpha + 1 boundaries per axis, and sum |u_i| <= sqrt(3).
  return static_cast<int>(std::ceil(std::sqrt(3.0) * length_m / resolution_m)) + 4;
}

int RayCaster::Cast(const Eigen::Vector3d& o, const Eigen::Vector3d& u, double length_m,
                    RayCells* out) const {
  KESTREL_THROW_UNLESS(out != nullptr, "RayCaster::Cast: out must not be null");
  KESTREL_THROW_UNLESS(
      o.allFinite() && u.allFinite() && std::abs(u.squaredNorm() - 1.0) < 2e-6,
      "RayCaster::Cast: origin must be finite and direction unit, |u| = " << u.norm());
  KESTREL_THROW_UNLESS(
      length_m >= 0.0 && length_m <= out->max_length_m,
      "RayCaster::Cast: length_m = " << length_m << ", accepted [0, " << out->max_length_m << "]");
  out->size = 0;
  out->left_bounds = false;
  out->has_likelihood = false;
  const std::optional<CellIndex> start = geometry_.CellOf(o);
  if (!start) {
    out->left_bounds = true;
    return 0;
  }
  CellIndex c = *start;
  const CellIndex lower = geometry_.lower();
  const CellIndex upper = geometry_.upper();
  constexpr double kInf = std::numeric_limits<double>::infinity();
  constexpr double kTiny = 1e-300;

  // Per axis: step direction, the offset from the cell index to the index of the boundary it
  // leaves through (1 going up, 0 going down), 1/u, and the exit parameter t_max.
  int32_t step[3];
  int32_t exit_offset[3];
  double inv_u[3];
  double t_max[3];
  for (int a = 0; a < 3; ++a) {
    // Components below 1e-300 in magnitude count as 0 (their 1/u would overflow).
    step[a] = u[a] > kTiny ? 1 : (u[a] < -kTiny ? -1 : 0);
    // An axis the ray runs along (u = 0) exits through its upper boundary, which lies strictly
    // above o (half-open cells), at t = (B - o) * (+inf) = +inf: it never steps.
    exit_offset[a] = step[a] < 0 ? 0 : 1;
    inv_u[a] = step[a] == 0 ? kInf : 1.0 / u[a];
    t_max[a] = (geometry_.Boundary(a, int64_t{c[a]} + exit_offset[a]) - o[a]) *
               inv_u[a];  // (B - o) * (1/u), file comment
  }

  CellIndex* const cells = out->cells.data();
  double* const distance = out->distance_m.data();
  const int capacity = static_cast<int>(out->cells.size());
  int n = 0;
  double t_in = 0.0;
  // Unsigned range check: lower <= c < upper  <=>  (c - lower) < (upper - lower) as unsigned.
  const auto outside = [&](int a) {
    return static_cast<uint32_t>(c[a] - lower[a]) >= static_cast<uint32_t>(upper[a] - lower[a]);
  };
  for (;;) {
    const double t_xy = t_max[0] < t_max[1] ? t_max[0] : t_max[1];
    const double t_axis = t_xy < t_max[2] ? t_xy : t_max[2];
    const double t_out = t_axis < length_m ? t_axis : length_m;
    if (t_out > t_in) {  // positive-length chord only (file comment)
      KESTREL_DEMAND(n < capacity);
      cells[n] = c;
      distance[n] = 0.5 * (t_in + t_out);  // ALGORITHMS.md section 2: d_k at the chord midpoint
      ++n;
    }
    if (t_axis >= length_m) break;
    // Step every axis whose boundary is crossed at t_axis (ties together: no zero-length cells).
    // (A branch-free variant that recomputes every axis was slower: it puts the conversion and
    // multiplications on the loop-carried dependency chain.)
    bool left = false;
    for (int a = 0; a < 3; ++a) {
      if (t_max[a] == t_axis) {
        c[a] += step[a];
        left |= outside(a);
        t_max[a] = (geometry_.Boundary(a, int64_t{c[a]} + exit_offset[a]) - o[a]) * inv_u[a];
      }
    }
    if (left) {
      out->left_bounds = true;
      break;
    }
    t_in = t_axis;
  }
  out->size = n;
  return n;
}

}  // namespace kestrel
