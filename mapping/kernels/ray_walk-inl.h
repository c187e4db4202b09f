// The vector walk of a batch's lanes (kernels.h, WalkLanesFn; RayCaster::CastBatch), one source
// for every Highway target (simd_kernels.cc compiles it once per target).
// NOLINT(llvm-header-guard)
#if defined(KESTREL_MAPPING_KERNELS_RAY_WALK_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef KESTREL_MAPPING_KERNELS_RAY_WALK_INL_H_
#undef KESTREL_MAPPING_KERNELS_RAY_WALK_INL_H_
#else
#define KESTREL_MAPPING_KERNELS_RAY_WALK_INL_H_
#endif

#include <hwy/highway.h>

#include <cstddef>
#include <cstdint>

#include "mapping/kernels/ray_walk.h"
#include "mapping/kernels/simd-inl.h"
#include "mapping/lanes.h"

HWY_BEFORE_NAMESPACE();
namespace kestrel::kernels::HWY_NAMESPACE {

// WalkRay's loop for the lanes first .. first + Lanes(d) - 1 of a batch, from row 1 on (every
// active lane has stored its first cell in row 0, StartLanes). Every lane does WalkRay's
// operations on its own values, so its cells are the scalar walk's bit for bit; a lane that has
// ended keeps its size and writes only into rows at or beyond it, which hold nothing of its ray.
// Each axis's crossing after the next one is computed a step ahead (the same expression as
// StepAxes), so the chain from one crossing to the next is min, compare, select. The linear
// index and the cell count are kept in doubles (exact) and converted when stored.
template <class D>
HWY_INLINE void WalkGroup(D d, const detail::LaneStart& start, size_t first,
                          const double origin_m[3], double resolution, double* distance,
                          int32_t* linear_out, int32_t* size) {
  using V = hn::Vec<D>;
  const hn::Rebind<int32_t, D> di;
  auto active = LaneBits(d, start.active, first);
  V t_in = hn::LoadU(d, start.t_in + first);
  const V length = hn::LoadU(d, start.length + first);
  const V half = hn::Set(d, 0.5);
  const V alpha = hn::Set(d, resolution);
  const V one = hn::Set(d, 1.0);
  // Per axis a: t_max, the crossing after it (t_after), exit index, step, 1/u, o, the grid's
  // lower corner and the linear index's step.
  const auto load = [&](const double* lanes) { return hn::LoadU(d, lanes + first); };
  V t_max0 = load(start.t_max[0]), t_max1 = load(start.t_max[1]), t_max2 = load(start.t_max[2]);
  V exit0 = load(start.exit_index[0]), exit1 = load(start.exit_index[1]),
    exit2 = load(start.exit_index[2]);
  const V step0 = load(start.step_d[0]), step1 = load(start.step_d[1]),
          step2 = load(start.step_d[2]);
  const V inv_u0 = load(start.inv_u[0]), inv_u1 = load(start.inv_u[1]),
          inv_u2 = load(start.inv_u[2]);
  const V o0 = load(start.o[0]), o1 = load(start.o[1]), o2 = load(start.o[2]);
  const V origin0 = hn::Set(d, origin_m[0]), origin1 = hn::Set(d, origin_m[1]),
          origin2 = hn::Set(d, origin_m[2]);
  const V linear_step0 = load(start.linear_step[0]), linear_step1 = load(start.linear_step[1]),
          linear_step2 = load(start.linear_step[2]);
  // ((origin + exit * alpha) - o) * (1/u) at `exit`: StepAxes's crossing, the same expression.
  const auto crossing = [&](V exit, V origin, V o, V inv_u) {
    return hn::Mul(hn::Sub(hn::Add(origin, hn::Mul(exit, alpha)), o), inv_u);
  };
  V t_after0 = crossing(hn::Add(exit0, step0), origin0, o0, inv_u0);
  V t_after1 = crossing(hn::Add(exit1, step1), origin1, o1, inv_u1);
  V t_after2 = crossing(hn::Add(exit2, step2), origin2, o2, inv_u2);
  V linear = load(start.linear);
  V count = hn::PromoteTo(d, hn::LoadU(di, size + first));
  for (ptrdiff_t row = 1; !hn::AllFalse(d, active); ++row) {
    // NextCrossing: t_xy = t0 < t1 ? t0 : t1, then t_xy < t2 ? t_xy : t2.
    const V t = MinLikeScalar(d, MinLikeScalar(d, t_max0, t_max1), t_max2);
    const auto ends = hn::Ge(t, length);  // t >= length (false for NaN, as in the scalar code)
    const V t_out = hn::IfThenElse(ends, length, t);
    const ptrdiff_t at = row * lanes::kLanes + static_cast<ptrdiff_t>(first);
    hn::StoreU(hn::Mul(half, hn::Add(t_in, t_out)), d, distance + at);
    hn::StoreU(hn::DemoteTo(di, linear), di, linear_out + at);
    count = hn::IfThenElse(active, hn::Add(count, one), count);
    const auto go = hn::AndNot(ends, active);
    // StepAxes: the axes whose crossing is the minimum step.
    const auto step_axis = [&](V& t_max, V& t_after, V& exit, V step, V origin, V o, V inv_u,
                               V linear_step) {
      const auto m = hn::And(go, hn::Le(t_max, t));
      linear = hn::IfThenElse(m, hn::Add(linear, linear_step), linear);
      t_max = hn::IfThenElse(m, t_after, t_max);
      exit = hn::IfThenElse(m, hn::Add(exit, step), exit);
      t_after = hn::IfThenElse(m, crossing(hn::Add(exit, step), origin, o, inv_u), t_after);
    };
    step_axis(t_max0, t_after0, exit0, step0, origin0, o0, inv_u0, linear_step0);
    step_axis(t_max1, t_after1, exit1, step1, origin1, o1, inv_u1, linear_step1);
    step_axis(t_max2, t_after2, exit2, step2, origin2, o2, inv_u2, linear_step2);
    t_in = hn::IfThenElse(go, t, t_in);
    active = go;
  }
  hn::StoreU(hn::DemoteTo(di, count), di, size + first);
}

// kernels::WalkLanesFn: each lane's first cell as the scalar walk stores it, then the other rows
// in vector lanes, Lanes(D8) lanes at a time.
void WalkLanes(const RaySegment* rays, int count, const bool* started, detail::RayWalk* walks,
               const Eigen::Vector3d& origin, double resolution, double* distance,
               int32_t* linear_out, int32_t* size) {
  const ZeroUpperOnReturn zero_upper;
  detail::LaneStart start;
  detail::StartLanes(rays, count, started, walks, origin, resolution, distance, linear_out, size,
                     &start);
  const double origin_m[3] = {origin[0], origin[1], origin[2]};
  const D8 d;
  const size_t n = hn::Lanes(d);
  for (size_t first = 0; first < static_cast<size_t>(lanes::kLanes); first += n) {
    if (((start.active >> first) & ((1u << n) - 1u)) == 0) continue;  // no lane walks on
    WalkGroup(d, start, first, origin_m, resolution, distance, linear_out, size);
  }
}

}  // namespace kestrel::kernels::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#endif  // KESTREL_MAPPING_KERNELS_RAY_WALK_INL_H_
