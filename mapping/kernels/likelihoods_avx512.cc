// The AVX-512 forward model of a batch (kernels.h, FillLikelihoodsFn;
// SensorModel::FillLikelihoods).
#include <cstddef>
#include <cstdint>

#include "mapping/kernels/avx512.h"
#include "mapping/kernels/kernels.h"

#if defined(__x86_64__)
namespace kestrel::kernels {

namespace {

KESTREL_AVX512_BEGIN

// ReturnLikelihoodEvaluator::Hermite in eight lanes: index min(trunc(s), last) (s is also
// clamped at 0, which only changes lanes whose value is not used), t = s - index, and
// c0 + t (c1 + t (c2 + t c3)) with the same roundings. Each lane's four coefficients are one
// 32-byte load; an in-register transpose turns the eight loads into c0..c3 (gather
// instructions are slower here).
[[KESTREL_AVX512, gnu::always_inline]] inline __m512d HermiteLanes(const double* table, double last,
                                                                   __m512d s) {
  const __m512d s_in = _mm512_max_pd(_mm512_min_pd(s, _mm512_set1_pd(last)), _mm512_setzero_pd());
  const __m256i index = _mm512_cvttpd_epi32(s_in);
  const __m512d t = _mm512_sub_pd(s, _mm512_cvtepi32_pd(index));
  alignas(32) int32_t at[8];
  _mm256_store_si256(reinterpret_cast<__m256i*>(at), index);
  // Rows of two lanes' coefficients: [c0 c1 c2 c3 | c0 c1 c2 c3] of lanes (0,1), (2,3), ...
  __m512d pair[4];
  const auto row = [&](int lane) { return table + ptrdiff_t{4} * at[lane]; };
  for (int p = 0; p < 4; ++p) {
    const __m512d low = _mm512_castpd256_pd512(_mm256_loadu_pd(row(2 * p)));
    pair[p] = _mm512_insertf64x4(low, _mm256_loadu_pd(row(2 * p + 1)), 1);
  }
  // [c0 of lanes 0-3 | c1 of lanes 0-3] and [c2 | c3] from pairs (0,1); likewise lanes 4-7.
  const __m512i even = _mm512_setr_epi64(0, 4, 8, 12, 1, 5, 9, 13);
  const __m512i odd = _mm512_setr_epi64(2, 6, 10, 14, 3, 7, 11, 15);
  const __m512d c01_lo = _mm512_permutex2var_pd(pair[0], even, pair[1]);
  const __m512d c23_lo = _mm512_permutex2var_pd(pair[0], odd, pair[1]);
  const __m512d c01_hi = _mm512_permutex2var_pd(pair[2], even, pair[3]);
  const __m512d c23_hi = _mm512_permutex2var_pd(pair[2], odd, pair[3]);
  const __m512d c0 = _mm512_shuffle_f64x2(c01_lo, c01_hi, 0x44);  // low halves
  const __m512d c1 = _mm512_shuffle_f64x2(c01_lo, c01_hi, 0xEE);  // high halves
  const __m512d c2 = _mm512_shuffle_f64x2(c23_lo, c23_hi, 0x44);
  const __m512d c3 = _mm512_shuffle_f64x2(c23_lo, c23_hi, 0xEE);
  const __m512d inner = _mm512_add_pd(c2, _mm512_mul_pd(t, c3));
  const __m512d mid = _mm512_add_pd(c1, _mm512_mul_pd(t, inner));
  return _mm512_add_pd(c0, _mm512_mul_pd(t, mid));
}

[[KESTREL_AVX512]] void FillRowsAvx512(const LikelihoodLanes& c, const double* z,
                                       __mmask8 is_return, const double* distance_m, int rows,
                                       double* likelihood) {
  const __m512d v_z = _mm512_loadu_pd(z);
  const __m512d z_min = _mm512_set1_pd(c.z_min), z_max = _mm512_set1_pd(c.z_max);
  const __m512d cutoff = _mm512_set1_pd(c.cutoff), spurious = _mm512_set1_pd(c.spurious);
  const __m512d scale = _mm512_set1_pd(c.scale);
  const __m512d g_per_m = _mm512_set1_pd(c.gaussian_index_per_m);
  const __m512d m_per_m = _mm512_set1_pd(c.mass_index_per_m);
  const __m512d near_none = _mm512_set1_pd(c.near_none);
  const __m512d in_range_none = _mm512_set1_pd(c.in_range_none);
  for (int k = 0; k < rows; ++k) {
    const __m512d d = _mm512_loadu_pd(distance_m + static_cast<ptrdiff_t>(k) * 8);
    // d >= z_min && d < z_max (ordered: false for NaN, as in the scalar code).
    const __mmask8 in_range =
        _mm512_cmp_pd_mask(d, z_min, _CMP_GE_OQ) & _mm512_cmp_pd_mask(d, z_max, _CMP_LT_OQ);
    const __m512d none = _mm512_mask_blend_pd(in_range, near_none, in_range_none);
    // Return lanes: the spurious term outside the window, p_rand u + scale G(r) / D(d) inside.
    const __m512d r = _mm512_abs_pd(_mm512_sub_pd(v_z, d));  // |z - d|
    const __mmask8 window = is_return & in_range & _mm512_cmp_pd_mask(r, cutoff, _CMP_LE_OQ);
    __m512d a = _mm512_mask_blend_pd(is_return, none, spurious);
    if (window != 0) {
      const __m512d g = HermiteLanes(c.gaussian_table, c.gaussian_last, _mm512_mul_pd(r, g_per_m));
      const __m512d m = HermiteLanes(c.inv_mass_table, c.mass_last,
                                     _mm512_mul_pd(_mm512_sub_pd(d, z_min), m_per_m));
      const __m512d ret = _mm512_add_pd(spurious, _mm512_mul_pd(_mm512_mul_pd(scale, g), m));
      a = _mm512_mask_blend_pd(window, a, ret);
    }
    _mm512_storeu_pd(likelihood + static_cast<ptrdiff_t>(k) * 8, a);
  }
}
KESTREL_AVX512_END

}  // namespace

void FillLikelihoodsAvx512(const LikelihoodLanes& c, const double* z, unsigned is_return,
                           const double* distance_m, int rows, double* likelihood) {
  FillRowsAvx512(c, z, static_cast<__mmask8>(is_return), distance_m, rows, likelihood);
}

}  // namespace kestrel::kernels
#endif
