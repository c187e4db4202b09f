// The vector kernels (kernels.h) compiled once per Highway target from one source each
// (ray_walk-inl.h, likelihoods-inl.h, posterior_store-inl.h, window_cells-inl.h), and the table
// of each target's kernels. Highway's foreach_target includes this file once per target.
//
// Targets: every one Highway attains on the architecture (x86-64: SSE4, AVX2, AVX3; arm64:
// NEON, SVE, SVE2 and their fixed-width variants) except SSSE3 (CPUs before SSE4.1, 2008) and
// AVX3_DL (Ice Lake's AVX-512 extensions: these kernels use none of them, so it would be AVX3's
// code again). Highway's own fallback (HWY_SCALAR or EMU128) is compiled but not listed: the
// scalar kernels (*_scalar.cc) are the scalar path.
#ifndef HWY_DISABLED_TARGETS
#define HWY_DISABLED_TARGETS HWY_SSSE3
#endif
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "mapping/kernels/simd_kernels.cc"
#include <hwy/foreach_target.h>  // IWYU pragma: keep

#include <hwy/highway.h>

#include "mapping/kernels/kernels.h"

#if HWY_TARGET != HWY_SCALAR && HWY_TARGET != HWY_EMU128
#include "mapping/kernels/likelihoods-inl.h"
#include "mapping/kernels/posterior_store-inl.h"
#include "mapping/kernels/ray_walk-inl.h"
#include "mapping/kernels/window_cells-inl.h"

HWY_BEFORE_NAMESPACE();
namespace kestrel::kernels::HWY_NAMESPACE {

// This target's kernels (the name is filled in by CompiledSimdKernels).
Kernels Table() {
  return Kernels{HWY_TARGET,         nullptr,          &WalkLanes,
                 &FillLikelihoods,   &StorePosteriors, &StorePosteriorsAt,
                 &ResolveWindowCells};
}

}  // namespace kestrel::kernels::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();
#endif

#if HWY_ONCE
#include <algorithm>
#include <cctype>
#include <string>

namespace kestrel::kernels {

const std::vector<Kernels>& CompiledSimdKernels() {
  static const std::vector<Kernels> compiled = [] {
    using TableFn = Kernels (*)();
    // Null where a target is not compiled (HWY_CHOOSE_*).
    const TableFn tables[] = {
#if HWY_ARCH_X86
      HWY_CHOOSE_SSSE3(Table),
      HWY_CHOOSE_SSE4(Table),
      HWY_CHOOSE_AVX2(Table),
      HWY_CHOOSE_AVX3(Table),
      HWY_CHOOSE_AVX3_DL(Table),
#elif HWY_ARCH_ARM
      HWY_CHOOSE_NEON(Table),
      HWY_CHOOSE_SVE(Table),
      HWY_CHOOSE_SVE2(Table),
      HWY_CHOOSE_SVE_256(Table),
      HWY_CHOOSE_SVE2_128(Table),
#endif
      nullptr
    };
    static std::vector<std::string> names;  // Kernels::name points into it
    std::vector<Kernels> out;
    for (const TableFn table : tables) {
      if (table != nullptr) out.push_back(table());
    }
    names.reserve(out.size());
    for (Kernels& k : out) {
      std::string name = hwy::TargetName(k.target);
      std::transform(name.begin(), name.end(), name.begin(),
                     [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
      names.push_back(name);
      k.name = names.back().c_str();
    }
    // Highway ranks a target above another by a lower bit: narrowest vectors first.
    std::sort(out.begin(), out.end(),
              [](const Kernels& a, const Kernels& b) { return a.target > b.target; });
    return out;
  }();
  return compiled;
}

}  // namespace kestrel::kernels
#endif  // HWY_ONCE
