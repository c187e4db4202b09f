// The AVX-512 walk of a batch's lanes (kernels.h, WalkLanesFn; RayCaster::CastBatch).
#include <cstddef>
#include <cstdint>

#include "mapping/kernels/avx512.h"
#include "mapping/kernels/kernels.h"
#include "mapping/kernels/ray_walk.h"
#include "mapping/lanes.h"
#include "mapping/ray_caster.h"

#if defined(__x86_64__)
namespace kestrel::kernels {

using detail::RayWalk;
using detail::WalkEnd;
using detail::WalkRay;

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
[[KESTREL_AVX512]] void WalkRowsAvx512(const LaneStart& start, const double origin_m[3],
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

void WalkLanesAvx512(const RaySegment* rays, int count, const bool* started, RayWalk* walks,
                     const Eigen::Vector3d& origin, double resolution, double* distance,
                     int32_t* linear_out, int32_t* size) {
  using lanes::kLanes;
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
  WalkRowsAvx512(start, origin_m, resolution, distance, linear_out, size);
}

}  // namespace kestrel::kernels
#endif
