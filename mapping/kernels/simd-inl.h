// What the vector kernels (kernels.h: ray_walk-inl.h, likelihoods-inl.h, posterior_store-inl.h,
// window_cells-inl.h) share, per Highway target: the tag of a batch's eight lanes of doubles and
// the comparisons that give the scalar code's results in every lane. Included once per target
// by simd_kernels.cc (Highway's foreach_target), hence the toggled guard instead of #pragma once.
// NOLINT(llvm-header-guard)
#if defined(KESTREL_MAPPING_KERNELS_SIMD_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef KESTREL_MAPPING_KERNELS_SIMD_INL_H_
#undef KESTREL_MAPPING_KERNELS_SIMD_INL_H_
#else
#define KESTREL_MAPPING_KERNELS_SIMD_INL_H_
#endif

#include <hwy/highway.h>

#include "mapping/lanes.h"

#if HWY_ARCH_X86
#include <immintrin.h>
#endif

HWY_BEFORE_NAMESPACE();
namespace kestrel::kernels::HWY_NAMESPACE {

namespace hn = hwy::HWY_NAMESPACE;

/// Up to the eight lanes of a batch (lanes.h) of doubles in one vector: eight on AVX3 and on SVE
/// with 512-bit vectors, four on AVX2, two on SSE4 and NEON. A batch's row is worked on in
/// groups of Lanes(D8) lanes.
using D8 = hn::CappedTag<double, lanes::kLanes>;

/// `a < b ? a : b` in every lane, the scalar code's minimum (NaN and signed zeros included). On
/// x86 that is what MINPD does; elsewhere (NEON's and SVE's minimum return the NaN, and -0 for
/// +-0) a compare and a select.
template <class D, class V = hn::Vec<D>>
HWY_INLINE V MinLikeScalar(D /*d*/, V a, V b) {
#if HWY_ARCH_X86
  return hn::Min(a, b);
#else
  return hn::IfThenElse(hn::Lt(a, b), a, b);
#endif
}

/// `a > b ? a : b` in every lane (MAXPD's rule; a compare and a select elsewhere).
template <class D, class V = hn::Vec<D>>
HWY_INLINE V MaxLikeScalar(D /*d*/, V a, V b) {
#if HWY_ARCH_X86
  return hn::Max(a, b);
#else
  return hn::IfThenElse(hn::Gt(a, b), a, b);
#endif
}

/// Declared first in every kernel's entry function: on AVX2 and AVX3 clears the upper halves of
/// the vector registers when the kernel returns (VZEROUPPER). GCC 12 does not insert it into
/// functions compiled for these targets with Highway's target pragma, and on this AMD Zen 4 the
/// callers' SSE code then ran 2-3 times slower (ExactBayesUpdater's update, the ray set-up).
struct ZeroUpperOnReturn {
  ZeroUpperOnReturn() = default;
  ZeroUpperOnReturn(const ZeroUpperOnReturn&) = delete;
  ZeroUpperOnReturn& operator=(const ZeroUpperOnReturn&) = delete;
  ~ZeroUpperOnReturn() {
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX2
    _mm256_zeroupper();
#endif
  }
};

/// The mask of lanes first .. first + Lanes(d) - 1 of an eight-lane bit set (bit l: lane l).
template <class D>
HWY_INLINE hn::Mask<D> LaneBits(D d, unsigned bits, size_t first) {
  const unsigned lanes_in_d = static_cast<unsigned>(hn::Lanes(d));  // at most 8
  const uint8_t byte = static_cast<uint8_t>((bits >> first) & ((1u << lanes_in_d) - 1u));
  const uint8_t bytes[8] = {byte, 0, 0, 0, 0, 0, 0, 0};
  return hn::LoadMaskBits(d, bytes);
}

}  // namespace kestrel::kernels::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#endif  // KESTREL_MAPPING_KERNELS_SIMD_INL_H_
