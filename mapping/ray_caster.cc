#include "mapping/ray_caster.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>

#include "common/check.h"
#include "mapping/lanes_vector.h"

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

namespace detail {

// One ray's DDA state after its set-up (RayCaster::StartWalk's comments explain each field).
struct RayWalk {
  int32_t cell[3];         // current cell
  int32_t step[3];         // +-1 or 0 per axis
  double inv_u[3];         // 1/u (+inf for an axis the ray runs along)
  double t_max[3];         // parameter of the next boundary crossing per axis
  double exit_index[3];    // index of that boundary, as a double
  double step_d[3];        // step as a double
  int32_t linear;          // x + nx (y + ny z) (bounded lattice)
  int32_t linear_step[3];  // change of linear per step of each axis
  double length;           // length clipped to where the ray leaves the bounds
  bool left_bounds;        // whether the bounds cut the ray
};

// Steps every axis whose boundary is crossed at t_axis (ties together: no zero-length cells).
// (A branch-free variant that recomputes every axis was slower: it puts the conversion and
// multiplications on the loop-carried dependency chain.)
template <bool kLinear>
[[gnu::always_inline]] inline void StepAxes(RayWalk* w, double t_axis,
                                            const Eigen::Vector3d& origin, double resolution,
                                            const Eigen::Vector3d& o) {
  for (int a = 0; a < 3; ++a) {
    if (w->t_max[a] <= t_axis) {  // == t_axis (the minimum); <= needs no NaN test
      w->cell[a] += w->step[a];
      if constexpr (kLinear) w->linear += w->linear_step[a];
      w->exit_index[a] += w->step_d[a];
      // (Boundary(a, c + exit_offset) - o) * (1/u), the same expression and value.
      w->t_max[a] = ((origin[a] + w->exit_index[a] * resolution) - o[a]) * w->inv_u[a];
    }
  }
}

// The next boundary crossing: min over the axes.
[[gnu::always_inline]] inline double NextCrossing(const RayWalk& w) {
  const double t_xy = w.t_max[0] < w.t_max[1] ? w.t_max[0] : w.t_max[1];
  return t_xy < w.t_max[2] ? t_xy : w.t_max[2];
}

}  // namespace detail

using detail::NextCrossing;
using detail::RayWalk;
using detail::StepAxes;

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

  // Linear index (bounded lattice only): x + nx (y + ny z), one addition per step.
  // (LinearIndexable: every index fits in 32 bits.)
  w.linear = 0;
  for (int32_t& s : w.linear_step) s = 0;
  if (LinearIndexable()) {
    const int32_t nx = upper.x, ny = upper.y;
    w.linear = c.x + nx * (c.y + ny * c.z);
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

template <bool kLinear, bool kCells>
int RayCaster::CastImpl(const Eigen::Vector3d& o, const Eigen::Vector3d& u, double length_m,
                        RayCells* out) const {
  KESTREL_THROW_UNLESS(out != nullptr, "RayCaster::Cast: out must not be null");
  out->size = 0;
  out->left_bounds = false;
  out->has_likelihood = false;
  out->has_linear_index = kLinear;
  out->has_cells = kCells;
  if constexpr (kLinear) {
    if (out->linear_index.size() < out->cells.size()) out->linear_index.resize(out->cells.size());
  }
  const int capacity = static_cast<int>(out->cells.size());
  RayWalk w;
  if (!StartWalk(o, u, length_m, out->max_length_m, capacity, &out->last_origin_W,
                 &out->last_origin_cell, &out->last_origin_lattice, &w)) {
    out->left_bounds = true;
    return 0;
  }
  out->left_bounds = w.left_bounds;
  const double length = w.length;
  const Eigen::Vector3d& origin = geometry_.origin_m();
  const double resolution = geometry_.resolution_m();
  CellIndex* const cells = out->cells.data();
  double* const distance = out->distance_m.data();
  int32_t* const linear_out = kLinear ? out->linear_index.data() : nullptr;
  // The current cell's indices stay plain integers in registers (RayWalk is a local): CellIndex's
  // operator[] picks a member by reference, which kept the cell in memory, and storing it whole
  // right after a one-member update stalled store-to-load forwarding on every step.
  int n = 0;
  double t_in = 0.0;
  const auto store = [&](double t_out) {
    KESTREL_ASSERT(n < capacity);  // StartWalk's bound
    if constexpr (kCells) cells[n] = CellIndex{w.cell[0], w.cell[1], w.cell[2]};
    distance[n] = 0.5 * (t_in + t_out);  // ALGORITHMS.md section 2: d_k at the chord midpoint
    if constexpr (kLinear) linear_out[n] = w.linear;
    ++n;
  };
  const auto step_axes = [&](double t_axis) {
    StepAxes<kLinear>(&w, t_axis, origin, resolution, o);
    t_in = t_axis;
  };
  // The first cell is the only one whose chord can have zero length (the origin on a boundary,
  // the ray pointing away): every later cell is entered at t_in < length and left at a strictly
  // larger crossing (or at length), so the loop below stores without testing.
  double t_axis = NextCrossing(w);
  const double t_first = t_axis < length ? t_axis : length;
  if (t_first > t_in) store(t_first);  // positive-length chord only (file comment)
  if (t_axis < length) {
    step_axes(t_axis);
    for (;;) {
      t_axis = NextCrossing(w);
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

RayBatch::RayBatch(double max_length, double resolution_m)
    : max_length_m(max_length), capacity_(RayCells::CapacityFor(max_length, resolution_m)) {
  const size_t n = static_cast<size_t>(capacity_) * lanes::kLanes;
  distance_m.resize(n);
  linear_index.resize(n);
  likelihood.resize(n);
}

void RayCaster::CastBatch(const RaySegment* rays, int count, RayBatch* out, lanes::Isa isa) const {
  using lanes::kLanes;
  KESTREL_THROW_UNLESS(
      out != nullptr && count >= 0 && count <= kLanes && (count == 0 || rays != nullptr),
      "RayCaster::CastBatch: count = " << count << ", accepted [0, 8] with rays");
  KESTREL_THROW_UNLESS(LinearIndexable(),
                       "RayCaster::CastBatch: needs a bounded lattice of fewer than 2^31 cells");
  out->count = count;
  out->isa = isa;
  out->has_likelihood = false;
  // Each lane's set-up and first cell as in CastImpl (scalar); afterwards every active lane has
  // stored exactly one cell, so all lanes store their k-th cell in the same step.
  alignas(64) double t_in[kLanes] = {}, length[kLanes] = {};
  alignas(64) double t_max[3][kLanes] = {}, exit_index[3][kLanes] = {}, step_d[3][kLanes] = {};
  alignas(64) double inv_u[3][kLanes] = {}, o[3][kLanes] = {};
  alignas(64) int32_t linear[kLanes] = {}, linear_step[3][kLanes] = {};
  alignas(64) int64_t active[kLanes] = {}, size[kLanes] = {};
  const Eigen::Vector3d& origin = geometry_.origin_m();
  const double resolution = geometry_.resolution_m();
  double* const distance = out->distance_m.data();
  int32_t* const linear_out = out->linear_index.data();
  for (int l = 0; l < kLanes; ++l) {
    out->size[l] = 0;
    out->left_bounds[l] = false;
    if (l >= count) continue;
    const RaySegment& ray = rays[l];
    RayWalk w;
    if (!StartWalk(ray.origin_W, ray.direction_W, ray.length_m, out->max_length_m, out->capacity(),
                   &out->last_origin_W, &out->last_origin_cell, &out->last_origin_lattice, &w)) {
      out->left_bounds[l] = true;
      continue;
    }
    out->left_bounds[l] = w.left_bounds;
    int n = 0;
    double t = 0.0;
    const auto store = [&](double t_out) {
      distance[RayBatch::At(0, l)] = 0.5 * (t + t_out);  // only slot 0 is stored here
      linear_out[RayBatch::At(0, l)] = w.linear;
      n = 1;
    };
    bool walking = false;
    double t_axis = NextCrossing(w);
    const double t_first = t_axis < w.length ? t_axis : w.length;
    if (t_first > t) store(t_first);
    if (t_axis < w.length) {
      StepAxes<true>(&w, t_axis, origin, resolution, ray.origin_W);
      t = t_axis;
      walking = true;
      if (n == 0) {  // the first cell had a zero-length chord: one more step of CastImpl's loop
        t_axis = NextCrossing(w);
        if (t_axis >= w.length) {
          store(w.length);
          walking = false;
        } else {
          store(t_axis);
          StepAxes<true>(&w, t_axis, origin, resolution, ray.origin_W);
          t = t_axis;
        }
      }
    }
    size[l] = n;
    active[l] = walking ? -1 : 0;
    t_in[l] = t;
    length[l] = w.length;
    linear[l] = w.linear;
    for (int a = 0; a < 3; ++a) {
      t_max[a][l] = w.t_max[a];
      exit_index[a][l] = w.exit_index[a];
      step_d[a][l] = w.step_d[a];
      inv_u[a][l] = w.inv_u[a];
      o[a][l] = ray.origin_W[a];
      linear_step[a][l] = w.linear_step[a];
    }
  }
  // CastImpl's loop, eight lanes at once: a lane that has ended keeps its size and writes only
  // into rows at or beyond it, which hold nothing of its ray.
  lanes::RunWithIsa(isa, [&]() KESTREL_LANES_BODY {
    using lanes::Load;
    using lanes::Min;
    using lanes::VD;
    using lanes::VI;
    using lanes::VL;
    // Locals, not the closure's references: the stores below cannot alias them.
    double* const distance_rows = distance;
    int32_t* const linear_rows = linear_out;
    const double alpha = resolution;
    VD v_t_in = Load(t_in);
    const VD v_length = Load(length);
    // Per axis: the next crossing t_max and the one after it (the crossing of the boundary past
    // exit_index + step, the same expression as StepAxes computes when it steps), so that a
    // step only selects values computed the iteration before: the chain from one crossing to
    // the next is min, compare, select.
    VD v_t_max[3], v_t_after[3], v_exit[3], v_step_d[3], v_inv_u[3], v_o[3], v_origin[3];
    VD v_linear_step[3];
    const auto crossing = [&](int a, VD exit) KESTREL_LANES_BODY {
      return ((v_origin[a] + exit * alpha) - v_o[a]) * v_inv_u[a];  // as StepAxes
    };
    for (int a = 0; a < 3; ++a) {
      v_t_max[a] = Load(t_max[a]);
      v_exit[a] = Load(exit_index[a]);
      v_step_d[a] = Load(step_d[a]);
      v_inv_u[a] = Load(inv_u[a]);
      v_o[a] = Load(o[a]);
      v_origin[a] = lanes::Splat(origin[a]);
      v_linear_step[a] = __builtin_convertvector(lanes::LoadInt(linear_step[a]), VD);
      v_t_after[a] = crossing(a, v_exit[a] + v_step_d[a]);
    }
    // The linear index in doubles (exact below 2^53): selects and adds stay in one register
    // type; converted to 32 bits when stored.
    VD v_linear = __builtin_convertvector(lanes::LoadInt(linear), VD);
    VL v_active, v_size;
    std::memcpy(&v_active, active, sizeof(VL));
    std::memcpy(&v_size, size, sizeof(VL));
    for (int k = 1; lanes::Any(v_active); ++k) {
      const VD t = Min(Min(v_t_max[0], v_t_max[1]), v_t_max[2]);  // NextCrossing
      const VL ends = t >= v_length;
      const VD t_out = ends ? v_length : t;
      lanes::Store(distance_rows + RayBatch::At(k, 0), 0.5 * (v_t_in + t_out));  // d_k
      lanes::Store(linear_rows + RayBatch::At(k, 0), __builtin_convertvector(v_linear, VI));
      v_size -= v_active;  // +1 where active
      const VL go = v_active & ~ends;
      for (int a = 0; a < 3; ++a) {  // StepAxes
        const VL m = go & (v_t_max[a] <= t);
        v_linear = m ? v_linear + v_linear_step[a] : v_linear;
        v_t_max[a] = m ? v_t_after[a] : v_t_max[a];
        v_exit[a] = m ? v_exit[a] + v_step_d[a] : v_exit[a];
        v_t_after[a] = m ? crossing(a, v_exit[a] + v_step_d[a]) : v_t_after[a];
      }
      v_t_in = go ? t : v_t_in;
      v_active = go;
    }
    std::memcpy(size, &v_size, sizeof(VL));
  });
  out->longest = 0;
  for (int l = 0; l < count; ++l) {
    out->size[l] = static_cast<int>(size[l]);
    out->longest = std::max(out->longest, out->size[l]);
  }
}

}  // namespace kestrel
