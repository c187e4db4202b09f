#include "mapping/ray_caster.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>

#include "common/check.h"
#include "mapping/kernels/kernels.h"
#include "mapping/kernels/ray_walk.h"

namespace kestrel {

using detail::RayWalk;
using detail::WalkRay;

RayCells::RayCells(double max_length, double resolution_m) : max_length_m(max_length) {
  const int capacity = CapacityFor(max_length, resolution_m);
  cells.resize(static_cast<size_t>(capacity));
  distance_m.resize(static_cast<size_t>(capacity));
  linear_index.resize(static_cast<size_t>(capacity));
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
  const CellIndex& lo = geometry_.lower();
  const CellIndex& hi = geometry_.upper();
  return geometry_.bounded() && static_cast<double>(hi.x - lo.x) *
                                        static_cast<double>(hi.y - lo.y) *
                                        static_cast<double>(hi.z - lo.z) <
                                    2147483648.0;
}

int RayCaster::CastWithLinearIndex(const Eigen::Vector3d& o, const Eigen::Vector3d& u,
                                   double length_m, RayCells* out) const {
  return LinearIndexable() ? CastImpl<true>(o, u, length_m, out)
                           : CastImpl<false>(o, u, length_m, out);
}

bool RayCaster::StartWalk(const Eigen::Vector3d& o, const Eigen::Vector3d& u, double length_m,
                          double max_length_m, int capacity, Eigen::Vector3d* last_origin_W,
                          CellIndex* last_origin_cell, GridGeometry* last_origin_lattice,
                          RayWalk* walk) const {
  RayWalk& w = *walk;
  KESTREL_THROW_UNLESS(
      o.allFinite() && u.allFinite() && std::abs(u.squaredNorm() - 1.0) < 2e-6,
      "RayCaster::Cast: origin must be finite and direction unit, |u| = " << u.norm());
  KESTREL_THROW_UNLESS(
      length_m >= 0.0 && length_m <= max_length_m,
      "RayCaster::Cast: length_m = " << length_m << ", accepted [0, " << max_length_m << "]");
  CellIndex c;
  if (o == *last_origin_W && geometry_.SameLattice(*last_origin_lattice)) {
    c = *last_origin_cell;  // same origin as the previous ray (ray_caster.h, RayCells)
  } else {
    const std::optional<CellIndex> start = geometry_.CellOf(o);
    if (!start) {
      w.left_bounds = true;
      return false;
    }
    c = *start;
    *last_origin_W = o;
    *last_origin_cell = c;
    *last_origin_lattice = geometry_;
  }
  const CellIndex lower = geometry_.lower();
  const CellIndex upper = geometry_.upper();
  constexpr double kInf = std::numeric_limits<double>::infinity();
  constexpr double kTiny = 1e-300;

  // Per axis: step direction, the offset from the cell index to the index of the boundary it
  // leaves through (1 going up, 0 going down), 1/u, and the exit parameter t_max.
  // exit_index: the index of the boundary each axis leaves through next, as a double (exact for
  // |i| < 2^53, and GridGeometry::Boundary converts the same integer), stepped by +-1.0 without
  // conversions.
  // The ray leaves the bounds' box at t_box: the crossing of the last in-bounds cell's exit
  // boundary, the same expression as that cell's t_max (file comment), so clipping the length to
  // it ends the ray exactly where stepping out of the bounds would.
  double t_box = kInf;
  for (int a = 0; a < 3; ++a) {
    w.cell[a] = c[a];
    // Components below 1e-300 in magnitude count as 0 (their 1/u would overflow).
    w.step[a] = u[a] > kTiny ? 1 : (u[a] < -kTiny ? -1 : 0);
    // An axis the ray runs along (u = 0) exits through its upper boundary, which lies strictly
    // above o (half-open cells), at t = (B - o) * (+inf) = +inf: it never steps.
    const int32_t exit_offset = w.step[a] < 0 ? 0 : 1;
    w.inv_u[a] = w.step[a] == 0 ? kInf : 1.0 / u[a];
    w.t_max[a] = (geometry_.Boundary(a, int64_t{c[a]} + exit_offset) - o[a]) *
                 w.inv_u[a];  // (B - o) * (1/u), file comment
    w.exit_index[a] = static_cast<double>(int64_t{c[a]} + exit_offset);
    w.step_d[a] = static_cast<double>(w.step[a]);
    if (w.step[a] != 0) {
      const int64_t last = w.step[a] > 0 ? int64_t{upper[a]} - 1 : int64_t{lower[a]};
      const double t_exit = (geometry_.Boundary(a, last + exit_offset) - o[a]) * w.inv_u[a];
      t_box = t_exit < t_box ? t_exit : t_box;
    }
  }
  w.length = t_box < length_m ? t_box : length_m;
  w.left_bounds = t_box < length_m;

  // Linear index (bounded lattice only): x + nx (y + ny z), one addition per step, counted from
  // the lower bound. (LinearIndexable: every index fits in 32 bits.)
  w.linear = 0;
  for (int32_t& s : w.linear_step) s = 0;
  if (LinearIndexable()) {
    const int32_t nx = upper.x - lower.x, ny = upper.y - lower.y;
    w.linear = (c.x - lower.x) + nx * ((c.y - lower.y) + ny * (c.z - lower.z));
    w.linear_step[0] = w.step[0];
    w.linear_step[1] = w.step[1] * nx;
    w.linear_step[2] = w.step[2] * nx * ny;
  }
  // Room for every cell, checked once per ray instead of per step: axis a steps only at
  // crossings t < length, i.e. at boundaries within |u_a| length of o along a, at most
  // floor(|u_a| length / alpha) + 1 of them, +1 for rounding; every cell after the first follows
  // a step of at least one axis.
  double bound = 1.0;
  for (int a = 0; a < 3; ++a) {
    if (w.step[a] != 0) {
      bound += std::floor(std::abs(u[a]) * w.length / geometry_.resolution_m()) + 2.0;
    }
  }
  KESTREL_DEMAND(bound <= static_cast<double>(capacity));
  return true;
}

template <bool kLinear>
int RayCaster::CastImpl(const Eigen::Vector3d& o, const Eigen::Vector3d& u, double length_m,
                        RayCells* out) const {
  KESTREL_THROW_UNLESS(out != nullptr, "RayCaster::Cast: out must not be null");
  out->size = 0;
  out->left_bounds = false;
  out->has_linear_index = kLinear;
  if constexpr (kLinear) {
    if (out->linear_index.size() < out->cells.size()) out->linear_index.resize(out->cells.size());
  }
  RayWalk w;
  if (!StartWalk(o, u, length_m, out->max_length_m, static_cast<int>(out->cells.size()),
                 &out->last_origin_W, &out->last_origin_cell, &out->last_origin_lattice, &w)) {
    out->left_bounds = true;
    return 0;
  }
  out->left_bounds = w.left_bounds;
  out->size = WalkRay<kLinear, true>(
                  &w, o, geometry_.origin_m(), geometry_.resolution_m(), 1, out->distance_m.data(),
                  kLinear ? out->linear_index.data() : nullptr, out->cells.data())
                  .cells;
  return out->size;
}

RayBatch::RayBatch(double max_length, double resolution_m)
    : max_length_m(max_length), capacity_(RayCells::CapacityFor(max_length, resolution_m)) {
  const size_t n = static_cast<size_t>(capacity_) * lanes::kLanes;
  distance_m.resize(n);
  linear_index.resize(n);
  likelihood.resize(n);
}

void RayCaster::CastBatch(const RaySegment* rays, int count, RayBatch* out,
                          const kernels::Kernels& kernels) const {
  using lanes::kLanes;
  KESTREL_THROW_UNLESS(
      out != nullptr && count >= 0 && count <= kLanes && (count == 0 || rays != nullptr),
      "RayCaster::CastBatch: count = " << count << ", accepted [0, 8] with rays");
  KESTREL_THROW_UNLESS(LinearIndexable(),
                       "RayCaster::CastBatch: needs a bounded lattice of fewer than 2^31 cells");
  out->count = count;
  out->lattice = geometry_;
  out->has_likelihood = false;
  RayWalk walks[kLanes];
  bool started[kLanes] = {};
  for (int l = 0; l < count; ++l) {
    started[l] = StartWalk(rays[l].origin_W, rays[l].direction_W, rays[l].length_m,
                           out->max_length_m, out->capacity(), &out->last_origin_W,
                           &out->last_origin_cell, &out->last_origin_lattice, &walks[l]);
  }
  int32_t size[kLanes] = {};
  kernels.walk_lanes(rays, count, started, walks, geometry_.origin_m(), geometry_.resolution_m(),
                     out->distance_m.data(), out->linear_index.data(), size);
  out->longest = 0;
  for (int l = 0; l < kLanes; ++l) {
    out->size[l] = l < count ? size[l] : 0;
    out->left_bounds[l] = l < count && (!started[l] || walks[l].left_bounds);
    out->longest = std::max(out->longest, out->size[l]);
  }
}

}  // namespace kestrel
