// The AVX-512 resolution of a GrowingGrid's cells in a cast window (kernels.h,
// ResolveWindowCellsFn; OccupancyMap<GrowingGrid>::UpdateRays): a row of eight lanes at a time,
// the block addresses gathered from the window's table.
#include <cstdint>

#include "mapping/kernels/avx512.h"
#include "mapping/kernels/kernels.h"
#include "mapping/lanes.h"

#if defined(__x86_64__)
namespace kestrel::kernels {

namespace {

KESTREL_AVX512_BEGIN
[[KESTREL_AVX512]] bool ResolveRowsAvx512(const int32_t* linear, const int* size, int rows,
                                          int shift, float* const* blocks, float** cells,
                                          uint32_t* slot_cells) {
  using lanes::kLanes;
  const __m256i sizes = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(size));
  const __m256i mask = _mm256_set1_epi32((1 << shift) - 1);
  const __m256i seven = _mm256_set1_epi32(7);
  const __m128i s1 = _mm_cvtsi32_si128(shift);
  const __m128i s2 = _mm_cvtsi32_si128(2 * shift);
  const __m128i b1 = _mm_cvtsi32_si128(shift - 3);
  const __m128i b2 = _mm_cvtsi32_si128(2 * (shift - 3));
  __mmask8 missing = 0;
  for (int k = 0; k < rows; ++k) {
    const __mmask8 live = _mm256_cmpgt_epi32_mask(sizes, _mm256_set1_epi32(k));  // k < size[l]
    const __m256i cell = _mm256_maskz_loadu_epi32(live, linear + k * kLanes);
    const __m256i x = _mm256_and_si256(cell, mask);
    const __m256i y = _mm256_and_si256(_mm256_srl_epi32(cell, s1), mask);
    const __m256i z = _mm256_srl_epi32(cell, s2);
    const __m256i slot = _mm256_or_si256(
        _mm256_srli_epi32(x, 3), _mm256_or_si256(_mm256_sll_epi32(_mm256_srli_epi32(y, 3), b1),
                                                 _mm256_sll_epi32(_mm256_srli_epi32(z, 3), b2)));
    const __m256i offset =
        _mm256_or_si256(_mm256_and_si256(x, seven),
                        _mm256_or_si256(_mm256_slli_epi32(_mm256_and_si256(y, seven), 3),
                                        _mm256_slli_epi32(_mm256_and_si256(z, seven), 6)));
    const __m512i block =
        _mm512_mask_i32gather_epi64(_mm512_setzero_si512(), live, slot, blocks, 8);
    missing |= _mm512_mask_cmpeq_epi64_mask(live, block, _mm512_setzero_si512());
    // The address of float `offset` of the block: block + 4 offset bytes.
    const __m512i address =
        _mm512_add_epi64(block, _mm512_slli_epi64(_mm512_cvtepu32_epi64(offset), 2));
    _mm512_storeu_si512(cells + k * kLanes, address);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(slot_cells + k * kLanes),
                        _mm256_or_si256(_mm256_slli_epi32(slot, 9), offset));
  }
  return missing == 0;
}
KESTREL_AVX512_END

}  // namespace

bool ResolveWindowCellsAvx512(const int32_t* linear, const int* size, int rows, int shift,
                              float* const* blocks, float** cells, uint32_t* slot_cells) {
  return ResolveRowsAvx512(linear, size, rows, shift, blocks, cells, slot_cells);
}

}  // namespace kestrel::kernels
#endif
