#include "mapping/ray_caster.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>

#include "common/check.h"
#include "mapping/avx512.h"

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

namespace detail {

// What WalkRay leaves: the cells stored, whether the ray goes on (kFirstCell), and t_in.
struct WalkEnd {
  int cells{0};
  bool walking{false};
  double t_in{0.0};
};

// The walk of one set-up ray *w (StartWalk): stores d_k at distance[n * stride], and the linear
// index (kLinear) and cell (kCells) likewise, for every cell with a positive-length chord, in
// order. The first cell is the only one whose chord can have zero length (the origin on a
// boundary, the ray pointing away): every later cell is entered at t_in < length and left at a
// strictly larger crossing (or at length), so the loop stores without testing. With kFirstCell
// it stops after the first stored cell, leaving *w and the returned t_in where the walk goes on
// (CastBatch continues it in vector lanes). The current cell's indices stay plain integers in
// registers (*w is a local of the caller): CellIndex's operator[] picks a member by reference,
// which kept the cell in memory, and storing it whole right after a one-member update stalled
// store-to-load forwarding on every step.
template <bool kLinear, bool kCells, bool kFirstCell = false>
[[gnu::always_inline]] inline WalkEnd WalkRay(RayWalk* w, const Eigen::Vector3d& o,
                                              const Eigen::Vector3d& origin, double resolution,
                                              ptrdiff_t stride, double* distance,
                                              int32_t* linear_out, CellIndex* cells) {
  const double length = w->length;
  ptrdiff_t at = 0;
  WalkEnd end;
  const auto store = [&](double t_out) {
    if constexpr (kCells) cells[at] = CellIndex{w->cell[0], w->cell[1], w->cell[2]};
    distance[at] = 0.5 * (end.t_in + t_out);  // ALGORITHMS.md section 2: d_k at the chord midpoint
    if constexpr (kLinear) linear_out[at] = w->linear;
    at += stride;
  };
  const auto step_axes = [&](double t_axis) {
    StepAxes<kLinear>(w, t_axis, origin, resolution, o);
    end.t_in = t_axis;
  };
  double t_axis = NextCrossing(*w);
  const double t_first = t_axis < length ? t_axis : length;
  if (t_first > end.t_in) store(t_first);  // positive-length chord only (file comment)
  if (t_axis < length) {
    step_axes(t_axis);
    end.walking = true;
    while (!kFirstCell || at == 0) {
      t_axis = NextCrossing(*w);
      if (t_axis >= length) {
        store(length);
        end.walking = false;
        break;
      }
      store(t_axis);
      step_axes(t_axis);
    }
  }
  end.cells = static_cast<int>(at / stride);
  return end;
}

}  // namespace detail

using detail::WalkEnd;
using detail::WalkRay;

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
  RayWalk w;
  if (!StartWalk(o, u, length_m, out->max_length_m, static_cast<int>(out->cells.size()),
                 &out->last_origin_W, &out->last_origin_cell, &out->last_origin_lattice, &w)) {
    out->left_bounds = true;
    return 0;
  }
  out->left_bounds = w.left_bounds;
  out->size = WalkRay<kLinear, kCells>(
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

#if defined(__x86_64__)
namespace {

// The lanes of a batch after their set-up and first cell (CastBatch), as arrays of 8.
struct LaneStart {
  alignas(64) double t_in[lanes::kLanes];
  alignas(64) double length[lanes::kLanes];
  alignas(64) double t_max[3][lanes::kLanes];
  alignas(64) double exit_index[3][lanes::kLanes];
  alignas(64) double step_d[3][lanes::kLanes];
  alignas(64) double inv_u[3][lanes::kLanes];
  alignas(64) double o[3][lanes::kLanes];
  alignas(64) double linear[lanes::kLanes];
  alignas(64) double linear_step[3][lanes::kLanes];
  unsigned active;  // lanes still walking (bit l)
};

// WalkRay's loop for eight lanes in AVX-512 registers, from row 1 on (every active lane has
// stored its first cell in row 0). Every lane does WalkRay's operations on its own values,
// so its cells are the scalar walk's bit for bit; a lane that has ended keeps its size and
// writes only into rows at or beyond it, which hold nothing of its ray. Each axis's crossing
// after the next one is computed a step ahead (the same expression as StepAxes), so the chain
// from one crossing to the next is min, compare, select. The linear index is kept in doubles
// (exact below 2^53) and converted when stored. size[l] counts lane l's cells.
KESTREL_AVX512_BEGIN
[[KESTREL_AVX512]] void WalkLanesAvx512(const LaneStart& start, const double origin_m[3],
                                        double resolution, double* distance, int32_t* linear_out,
                                        int32_t size[lanes::kLanes]) {
  __mmask8 active = static_cast<__mmask8>(start.active);
  __m512d t_in = _mm512_load_pd(start.t_in);
  const __m512d length = _mm512_load_pd(start.length);
  const __m512d half = _mm512_set1_pd(0.5);
  const __m512d alpha = _mm512_set1_pd(resolution);
  __m512d t_max[3], t_after[3], exit_index[3], step_d[3], inv_u[3], o[3], origin[3];
  __m512d linear_step[3];
  for (int a = 0; a < 3; ++a) {
    t_max[a] = _mm512_load_pd(start.t_max[a]);
    exit_index[a] = _mm512_load_pd(start.exit_index[a]);
    step_d[a] = _mm512_load_pd(start.step_d[a]);
    inv_u[a] = _mm512_load_pd(start.inv_u[a]);
    o[a] = _mm512_load_pd(start.o[a]);
    origin[a] = _mm512_set1_pd(origin_m[a]);
    linear_step[a] = _mm512_load_pd(start.linear_step[a]);
    // ((origin + exit * alpha) - o) * (1/u) at exit + step: StepAxes's next crossing.
    const __m512d next = _mm512_add_pd(exit_index[a], step_d[a]);
    t_after[a] = _mm512_mul_pd(
        _mm512_sub_pd(_mm512_add_pd(origin[a], _mm512_mul_pd(next, alpha)), o[a]), inv_u[a]);
  }
  __m512d linear = _mm512_load_pd(start.linear);
  __m256i count = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(size));
  const __m256i one = _mm256_set1_epi32(1);
  for (ptrdiff_t row = 1; active != 0; ++row) {
    // NextCrossing: t_xy = t0 < t1 ? t0 : t1, then t_xy < t2 ? t_xy : t2 (vminpd's rule).
    const __m512d t = _mm512_min_pd(_mm512_min_pd(t_max[0], t_max[1]), t_max[2]);
    const __mmask8 ends = _mm512_cmp_pd_mask(t, length, _CMP_GE_OQ);  // t >= length
    const __m512d t_out = _mm512_mask_blend_pd(ends, t, length);
    _mm512_storeu_pd(distance + row * lanes::kLanes,
                     _mm512_mul_pd(half, _mm512_add_pd(t_in, t_out)));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(linear_out + row * lanes::kLanes),
                        _mm512_cvttpd_epi32(linear));
    count = _mm256_mask_add_epi32(count, active, count, one);
    const __mmask8 go = active & static_cast<__mmask8>(~ends);
    for (int a = 0; a < 3; ++a) {  // StepAxes: the axes whose crossing is the minimum
      const __mmask8 m = _mm512_mask_cmp_pd_mask(go, t_max[a], t, _CMP_LE_OQ);
      linear = _mm512_mask_add_pd(linear, m, linear, linear_step[a]);
      t_max[a] = _mm512_mask_mov_pd(t_max[a], m, t_after[a]);
      exit_index[a] = _mm512_mask_add_pd(exit_index[a], m, exit_index[a], step_d[a]);
      const __m512d next = _mm512_add_pd(exit_index[a], step_d[a]);
      t_after[a] = _mm512_mask_mul_pd(
          t_after[a], m, _mm512_sub_pd(_mm512_add_pd(origin[a], _mm512_mul_pd(next, alpha)), o[a]),
          inv_u[a]);
    }
    t_in = _mm512_mask_mov_pd(t_in, go, t);
    active = go;
  }
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(size), count);
}
KESTREL_AVX512_END

}  // namespace
#endif

void RayCaster::CastBatch(const RaySegment* rays, int count, RayBatch* out, lanes::Isa isa) const {
  using lanes::kLanes;
  KESTREL_THROW_UNLESS(
      out != nullptr && count >= 0 && count <= kLanes && (count == 0 || rays != nullptr),
      "RayCaster::CastBatch: count = " << count << ", accepted [0, 8] with rays");
  KESTREL_THROW_UNLESS(LinearIndexable(),
                       "RayCaster::CastBatch: needs a bounded lattice of fewer than 2^31 cells");
  KESTREL_THROW_UNLESS(lanes::CpuSupports(isa), "RayCaster::CastBatch: this CPU does not run "
                                                    << lanes::IsaName(isa) << " code");
  out->count = count;
  out->isa = isa;
  out->has_likelihood = false;
  const Eigen::Vector3d& origin = geometry_.origin_m();
  const double resolution = geometry_.resolution_m();
  double* const distance = out->distance_m.data();
  int32_t* const linear_out = out->linear_index.data();
  RayWalk walks[kLanes];
  bool started[kLanes] = {};
  for (int l = 0; l < count; ++l) {
    started[l] = StartWalk(rays[l].origin_W, rays[l].direction_W, rays[l].length_m,
                           out->max_length_m, out->capacity(), &out->last_origin_W,
                           &out->last_origin_cell, &out->last_origin_lattice, &walks[l]);
  }
  int32_t size[kLanes] = {};
#if defined(__x86_64__)
  if (isa == lanes::Isa::kAvx512) {
    // Each lane's first cell as WalkRay stores it (scalar), then the other rows in lanes: after
    // this, every active lane has stored exactly one cell, in row 0.
    LaneStart start{};
    start.active = 0;
    for (int l = 0; l < count; ++l) {
      if (!started[l]) continue;
      RayWalk& w = walks[l];
      const Eigen::Vector3d& o = rays[l].origin_W;
      const WalkEnd first = WalkRay<true, false, true>(&w, o, origin, resolution, kLanes,
                                                       distance + l, linear_out + l, nullptr);
      size[l] = first.cells;
      if (first.walking) start.active |= 1u << l;
      start.t_in[l] = first.t_in;
      start.length[l] = w.length;
      start.linear[l] = static_cast<double>(w.linear);
      for (int a = 0; a < 3; ++a) {
        start.t_max[a][l] = w.t_max[a];
        start.exit_index[a][l] = w.exit_index[a];
        start.step_d[a][l] = w.step_d[a];
        start.inv_u[a][l] = w.inv_u[a];
        start.o[a][l] = o[a];
        start.linear_step[a][l] = static_cast<double>(w.linear_step[a]);
      }
    }
    const double origin_m[3] = {origin[0], origin[1], origin[2]};
    WalkLanesAvx512(start, origin_m, resolution, distance, linear_out, size);
  } else  // NOLINT(readability-misleading-indentation): the #if closes the else's scope
#endif
  {
    for (int l = 0; l < count; ++l) {
      if (!started[l]) continue;
      RayWalk w = walks[l];
      size[l] = WalkRay<true, false>(&w, rays[l].origin_W, origin, resolution, kLanes, distance + l,
                                     linear_out + l, nullptr)
                    .cells;
    }
  }
  out->longest = 0;
  for (int l = 0; l < kLanes; ++l) {
    out->size[l] = l < count ? size[l] : 0;
    out->left_bounds[l] = l < count && (!started[l] || walks[l].left_bounds);
    out->longest = std::max(out->longest, out->size[l]);
  }
}

}  // namespace kestrel
