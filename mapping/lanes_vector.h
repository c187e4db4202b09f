#pragma once
/// @file
/// Eight-lane vectors for the batched kernels (mapping/lanes.h), written with GCC vector
/// extensions, so that one source compiles to AVX-512, AVX2, SSE2 or NEON; the function that
/// holds a kernel is compiled once per instruction set (RunWithIsa) and picked at run time.
///
/// Every lane does the same IEEE operations as the scalar code with the same expression, and
/// the library is built with -ffp-contract=off (no fused multiply-add), so each lane's result
/// is the scalar result bit for bit, on every instruction set: a map does not depend on the
/// machine that built it (tests/mapping/ray_caster_test.cc checks every instruction set this
/// machine offers against the scalar code).
///
/// Include only from the mapping library's .cc files: vectors never cross a function boundary
/// (the helpers are always inlined), and the library builds with -Wno-psabi, whose warnings are
/// about passing such vectors between functions.

#include <cstdint>
#include <cstring>

#include "mapping/lanes.h"

namespace kestrel::lanes {

/// Eight doubles.
using VD = double __attribute__((vector_size(kLanes * sizeof(double))));
/// Eight 64-bit integers: the masks of VD comparisons (all bits set where true).
using VL = int64_t __attribute__((vector_size(kLanes * sizeof(int64_t))));
/// Eight 32-bit integers.
using VI = int32_t __attribute__((vector_size(kLanes * sizeof(int32_t))));

// Small helpers; always inlined, so that they are compiled for the instruction set of the
// kernel that uses them (and no vector crosses a function boundary).
#define KESTREL_LANES_INLINE [[gnu::always_inline]] inline

/// All lanes set to v.
KESTREL_LANES_INLINE VD Splat(double v) { return VD{} + v; }
/// Lane-wise a < b ? a : b (the scalar code's minimum, so ties and signed zeros agree).
KESTREL_LANES_INLINE VD Min(VD a, VD b) { return a < b ? a : b; }
/// Lane-wise mask ? a : b.
KESTREL_LANES_INLINE VD Select(VL mask, VD a, VD b) { return mask ? a : b; }
/// Whether any lane of a mask is set (an OR across the lanes in three shuffles).
KESTREL_LANES_INLINE bool Any(VL mask) {
  mask |= __builtin_shuffle(mask, VL{4, 5, 6, 7, 0, 1, 2, 3});
  mask |= __builtin_shuffle(mask, VL{2, 3, 0, 1, 6, 7, 4, 5});
  mask |= __builtin_shuffle(mask, VL{1, 0, 3, 2, 5, 4, 7, 6});
  return mask[0] != 0;
}
/// Loads eight doubles from p (no alignment needed).
KESTREL_LANES_INLINE VD Load(const double* p) {
  VD v;
  std::memcpy(&v, p, sizeof(v));
  return v;
}
/// Loads eight 32-bit integers from p (no alignment needed).
KESTREL_LANES_INLINE VI LoadInt(const int32_t* p) {
  VI v;
  std::memcpy(&v, p, sizeof(v));
  return v;
}
/// Stores eight doubles to p (no alignment needed).
KESTREL_LANES_INLINE void Store(double* p, VD v) { std::memcpy(p, &v, sizeof(v)); }
/// Stores eight 32-bit integers to p (no alignment needed).
KESTREL_LANES_INLINE void Store(int32_t* p, VI v) { std::memcpy(p, &v, sizeof(v)); }

/// Calls body() compiled for `isa` (which the CPU must support; see BestIsa). `body` must be a
/// lambda marked always_inline, e.g. [&]() KESTREL_LANES_BODY { ... }, so that its code is
/// generated inside the per-instruction-set function.
#define KESTREL_LANES_BODY __attribute__((always_inline))

#if defined(__x86_64__)
template <class Body>
[[gnu::target("avx512f,avx512dq,avx512vl,avx512bw"), gnu::noinline]] void RunAvx512(
    const Body& body) {
  body();
}
template <class Body>
[[gnu::target("avx2"), gnu::noinline]] void RunAvx2(const Body& body) {
  body();
}
#endif
template <class Body>
[[gnu::noinline]] void RunBaseline(const Body& body) {
  body();
}

/// Runs body() compiled for `isa` (file comment).
template <class Body>
void RunWithIsa(Isa isa, const Body& body) {
#if defined(__x86_64__)
  if (isa == Isa::kAvx512) return RunAvx512(body);
  if (isa == Isa::kAvx2) return RunAvx2(body);
#endif
  RunBaseline(body);
}

}  // namespace kestrel::lanes
