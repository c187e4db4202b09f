// The AVX-512 posterior stores of the exact update (kernels.h, StorePosteriorsFn and
// StorePosteriorsAtFn; ExactBayesUpdater::UpdateBatchLane).
#include <cstdint>

#include "mapping/kernels/avx512.h"
#include "mapping/kernels/kernels.h"

#if defined(__x86_64__)
namespace kestrel::kernels {

namespace {

KESTREL_AVX512_BEGIN
// The write step of ExactBayesUpdater::Update for n cells, eight at a time: clamps posterior[i]
// (ClampProbability as min then max with the scalar code's operand order, so ties and values
// agree), converts it to float, stores it at base[cells[i]] (a scatter: a ray never lists a cell
// twice, so the order of the stores does not matter), and lists the cells whose stored value
// changed, first + i ascending, in changed[0 .. returned count); priors[i] is the value stored
// before (compared bit for bit).
[[KESTREL_AVX512]] int StoreRowsAvx512(const double* posterior, const int32_t* cells,
                                       const float* priors, int first, int n, double p_min,
                                       float* base, int* changed) {
  const __m512d lower = _mm512_set1_pd(p_min);
  const __m512d upper = _mm512_set1_pd(1.0 - p_min);
  const __m256i step = _mm256_set1_epi32(8);
  __m256i k = _mm256_add_epi32(_mm256_set1_epi32(first), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
  int m = 0;
  for (int i = 0; i < n; i += 8) {
    const __mmask8 live = n - i >= 8 ? __mmask8{0xFF} : static_cast<__mmask8>((1u << (n - i)) - 1);
    const __m512d p = _mm512_maskz_loadu_pd(live, posterior + i);
    // upper < p ? upper : p, then below_upper < p_min ? p_min : below_upper.
    const __m512d clamped = _mm512_max_pd(lower, _mm512_min_pd(upper, p));
    const __m256 stored = _mm512_cvtpd_ps(clamped);
    const __m256i stored_bits = _mm256_castps_si256(stored);
    const __m256i prior_bits = _mm256_maskz_loadu_epi32(live, priors + i);
    const __mmask8 differ = _mm256_mask_cmpneq_epi32_mask(live, stored_bits, prior_bits);
    _mm256_mask_compressstoreu_epi32(changed + m, differ, k);
    m += __builtin_popcount(differ);
    const __m256i where = _mm256_maskz_loadu_epi32(live, cells + i);
    _mm256_mask_i32scatter_ps(base, live, where, stored, 4);
    k = _mm256_add_epi32(k, step);
  }
  return m;
}

// StoreRowsAvx512 with each cell's address: the scatter takes the eight addresses as 64-bit
// indices from address 0.
[[KESTREL_AVX512]] int StoreRowsAtAvx512(const double* posterior, float* const* cells,
                                         const float* priors, int first, int n, double p_min,
                                         int* changed) {
  const __m512d lower = _mm512_set1_pd(p_min);
  const __m512d upper = _mm512_set1_pd(1.0 - p_min);
  const __m256i step = _mm256_set1_epi32(8);
  __m256i k = _mm256_add_epi32(_mm256_set1_epi32(first), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
  int m = 0;
  for (int i = 0; i < n; i += 8) {
    const __mmask8 live = n - i >= 8 ? __mmask8{0xFF} : static_cast<__mmask8>((1u << (n - i)) - 1);
    const __m512d p = _mm512_maskz_loadu_pd(live, posterior + i);
    // upper < p ? upper : p, then below_upper < p_min ? p_min : below_upper.
    const __m512d clamped = _mm512_max_pd(lower, _mm512_min_pd(upper, p));
    const __m256 stored = _mm512_cvtpd_ps(clamped);
    const __m256i stored_bits = _mm256_castps_si256(stored);
    const __m256i prior_bits = _mm256_maskz_loadu_epi32(live, priors + i);
    const __mmask8 differ = _mm256_mask_cmpneq_epi32_mask(live, stored_bits, prior_bits);
    _mm256_mask_compressstoreu_epi32(changed + m, differ, k);
    m += __builtin_popcount(differ);
    const __m512i where = _mm512_maskz_loadu_epi64(live, cells + i);
    _mm512_mask_i64scatter_ps(nullptr, live, where, stored, 1);
    k = _mm256_add_epi32(k, step);
  }
  return m;
}
KESTREL_AVX512_END

}  // namespace

int StorePosteriorsAvx512(const double* posterior, const int32_t* cells, const float* priors,
                          int first, int n, double p_min, float* base, int* changed) {
  return StoreRowsAvx512(posterior, cells, priors, first, n, p_min, base, changed);
}

int StorePosteriorsAtAvx512(const double* posterior, float* const* cells, const float* priors,
                            int first, int n, double p_min, int* changed) {
  return StoreRowsAtAvx512(posterior, cells, priors, first, n, p_min, changed);
}

}  // namespace kestrel::kernels
#endif
