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
  linear_index.resize(static_cast<size_t>(capacity));
  likelihood.resize(static_cast<size_t>(capacity));
}

int RayCells::CapacityFor(double length_m, double resolution_m) {
  KESTREL_THROW_UNLESS(std::isfinite(length_m) && length_m > 0.0 && std::isfinite(resolution_m) &&
                           resolution_m > 0.0 && length_m / resolution_m < 1e7,
                       "ray scratch: length_m = " << length_m << ", resolution_m = " << resolution_m
                                                  << ", accepted positive, length/alpha < 1e7");
  // A segment crosses at most floor(|u_i| L / alpha) + 1 boundaries per axis (+1 for rounding),
  // sum |u_i| <= sqrt(3) |u| (|u| within 1e-6 of 1), plus the first cell: see CastImpl's bound.
  return static_cast<int>(std::ceil(std::sqrt(3.0) * (1.0 + 1e-5) * length_m / resolution_m)) + 8;
}

int RayCaster::Cast(const Eigen::Vector3d& o, const Eigen::Vector3d& u, double length_m,
                    RayCells* out) const {
  return CastImpl<false>(o, u, length_m, out);
}

bool RayCaster::LinearIndexable() const {
  const CellIndex& n = geometry_.upper();
  return geometry_.bounded() &&
         static_cast<double>(n.x) * static_cast<double>(n.y) * static_cast<double>(n.z) <
             2147483648.0;
}

int RayCaster::CastWithLinearIndex(const Eigen::Vector3d& o, const Eigen::Vector3d& u,
                                   double length_m, RayCells* out) const {
  return LinearIndexable() ? CastImpl<true>(o, u, length_m, out)
                           : CastImpl<false>(o, u, length_m, out);
}

int RayCaster::CastLinearOnly(const Eigen::Vector3d& o, const Eigen::Vector3d& u, double length_m,
                              RayCells* out) const {
  return LinearIndexable() ? CastImpl<true, false>(o, u, length_m, out)
                           : CastImpl<false>(o, u, length_m, out);
}

template <bool kLinear, bool kCells>
int RayCaster::CastImpl(const Eigen::Vector3d& o, const Eigen::Vector3d& u, double length_m,
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
  out->has_linear_index = kLinear;
  out->has_cells = kCells;
  if constexpr (kLinear) {
    if (out->linear_index.size() < out->cells.size()) out->linear_index.resize(out->cells.size());
  }
  CellIndex c;
  if (o == out->last_origin_W && geometry_.SameLattice(out->last_origin_lattice)) {
    c = out->last_origin_cell;  // same origin as the previous ray (ray_caster.h, RayCells)
  } else {
    const std::optional<CellIndex> start = geometry_.CellOf(o);
    if (!start) {
      out->left_bounds = true;
      return 0;
    }
    c = *start;
    out->last_origin_W = o;
    out->last_origin_cell = c;
    out->last_origin_lattice = geometry_;
  }
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
  // Index of the boundary each axis leaves through next, as a double (exact for |i| < 2^53, and
  // GridGeometry::Boundary converts the same integer), stepped by +-1.0 without conversions.
  double exit_index[3];
  double step_d[3];
  // The ray leaves the bounds' box at t_box: the crossing of the last in-bounds cell's exit
  // boundary, the same expression as that cell's t_max (file comment), so clipping the length to
  // it ends the ray exactly where stepping out of the bounds would.
  double t_box = kInf;
  for (int a = 0; a < 3; ++a) {
    // Components below 1e-300 in magnitude count as 0 (their 1/u would overflow).
    step[a] = u[a] > kTiny ? 1 : (u[a] < -kTiny ? -1 : 0);
    // An axis the ray runs along (u = 0) exits through its upper boundary, which lies strictly
    // above o (half-open cells), at t = (B - o) * (+inf) = +inf: it never steps.
    exit_offset[a] = step[a] < 0 ? 0 : 1;
    inv_u[a] = step[a] == 0 ? kInf : 1.0 / u[a];
    t_max[a] = (geometry_.Boundary(a, int64_t{c[a]} + exit_offset[a]) - o[a]) *
               inv_u[a];  // (B - o) * (1/u), file comment
    exit_index[a] = static_cast<double>(int64_t{c[a]} + exit_offset[a]);
    step_d[a] = static_cast<double>(step[a]);
    if (step[a] != 0) {
      const int64_t last = step[a] > 0 ? int64_t{upper[a]} - 1 : int64_t{lower[a]};
      const double t_exit = (geometry_.Boundary(a, last + exit_offset[a]) - o[a]) * inv_u[a];
      t_box = t_exit < t_box ? t_exit : t_box;
    }
  }
  const double length = t_box < length_m ? t_box : length_m;
  out->left_bounds = t_box < length_m;

  // Linear index (bounded lattice only): x + nx (y + ny z), one addition per step.
  // (LinearIndexable: every index fits in 32 bits.)
  int32_t linear = 0;
  int32_t linear_step[3] = {0, 0, 0};
  int32_t* const linear_out = kLinear ? out->linear_index.data() : nullptr;
  if constexpr (kLinear) {
    const int32_t nx = upper.x, ny = upper.y;
    linear = c.x + nx * (c.y + ny * c.z);
    linear_step[0] = step[0];
    linear_step[1] = step[1] * nx;
    linear_step[2] = step[2] * nx * ny;
  }

  const Eigen::Vector3d& origin = geometry_.origin_m();
  const double resolution = geometry_.resolution_m();
  CellIndex* const cells = out->cells.data();
  double* const distance = out->distance_m.data();
  const int capacity = static_cast<int>(out->cells.size());
  // Room for every cell, checked once per ray instead of per step: axis a steps only at
  // crossings t < length, i.e. at boundaries within |u_a| length of o along a, at most
  // floor(|u_a| length / alpha) + 1 of them, +1 for rounding; every cell after the first follows
  // a step of at least one axis.
  {
    double bound = 1.0;
    for (int a = 0; a < 3; ++a) {
      if (step[a] != 0) bound += std::floor(std::abs(u[a]) * length / resolution) + 2.0;
    }
    KESTREL_DEMAND(bound <= static_cast<double>(capacity));
  }
  // The current cell's indices as plain integers (registers): CellIndex's operator[] picks a
  // member by reference, which kept the cell in memory, and storing it whole right after a
  // one-member update stalled store-to-load forwarding on every step.
  int32_t cell[3] = {c.x, c.y, c.z};
  int n = 0;
  double t_in = 0.0;
  const auto store = [&](double t_out) {
    KESTREL_ASSERT(n < capacity);  // the bound above
    if constexpr (kCells) cells[n] = CellIndex{cell[0], cell[1], cell[2]};
    distance[n] = 0.5 * (t_in + t_out);  // ALGORITHMS.md section 2: d_k at the chord midpoint
    if constexpr (kLinear) linear_out[n] = linear;
    ++n;
  };
  // Step every axis whose boundary is crossed at t_axis (ties together: no zero-length cells).
  // (A branch-free variant that recomputes every axis was slower: it puts the conversion and
  // multiplications on the loop-carried dependency chain.)
  const auto step_axes = [&](double t_axis) {
    for (int a = 0; a < 3; ++a) {
      if (t_max[a] <= t_axis) {  // == t_axis (the minimum); <= needs no NaN test
        cell[a] += step[a];
        if constexpr (kLinear) linear += linear_step[a];
        exit_index[a] += step_d[a];
        // (Boundary(a, c + exit_offset) - o) * (1/u), the same expression and value.
        t_max[a] = ((origin[a] + exit_index[a] * resolution) - o[a]) * inv_u[a];
      }
    }
    t_in = t_axis;
  };
  const auto next_crossing = [&] {
    const double t_xy = t_max[0] < t_max[1] ? t_max[0] : t_max[1];
    return t_xy < t_max[2] ? t_xy : t_max[2];
  };
  // The first cell is the only one whose chord can have zero length (the origin on a boundary,
  // the ray pointing away): every later cell is entered at t_in < length and left at a strictly
  // larger crossing (or at length), so the loop below stores without testing.
  double t_axis = next_crossing();
  const double t_first = t_axis < length ? t_axis : length;
  if (t_first > t_in) store(t_first);  // positive-length chord only (file comment)
  if (t_axis < length) {
    step_axes(t_axis);
    for (;;) {
      t_axis = next_crossing();
      if (t_axis >= length) {
        store(length);
        break;
      }
      store(t_axis);
      step_axes(t_axis);
    }
  }
  out->size = n;
  return n;
}

}  // namespace kestrel
