// The table of kernels (kernels.h): the scalar code's, and those of every Highway target this
// CPU runs (simd_kernels.cc), as Highway's runtime detection reports them.
#include <hwy/targets.h>

#include <cstdlib>
#include <stdexcept>
#include <string>

#include "mapping/kernels/kernels.h"

namespace kestrel::kernels {

const Kernels& Scalar() {
  // In the order of Kernels' fields.
  static constexpr Kernels kScalar{0,
                                   "scalar",
                                   &WalkLanesScalar,
                                   nullptr,
                                   &StorePosteriorsScalar,
                                   &StorePosteriorsAtScalar,
                                   &ResolveWindowCellsScalar};
  return kScalar;
}

std::vector<const Kernels*> Supported() {
  std::vector<const Kernels*> out{&Scalar()};
  const int64_t targets = hwy::SupportedTargets();
  for (const Kernels& k : CompiledSimdKernels()) {
    if ((targets & k.target) != 0) out.push_back(&k);
  }
  return out;
}

std::string SupportedNames() {
  std::string names;
  for (const Kernels* k : Supported()) names += (names.empty() ? "" : ", ") + std::string(k->name);
  return names;
}

const Kernels& Best() {
  const char* want = std::getenv("KESTREL_ISA");
  if (want != nullptr && want[0] != '\0') return Named(want);
  return *Supported().back();
}

const Kernels& Named(const std::string& name) {
  if (name.empty()) return Best();
  const std::string canonical = name == "avx512" ? "avx3" : name;  // AVX3 is AVX-512 F/BW/DQ/VL
  for (const Kernels* k : Supported()) {
    if (canonical == k->name) return *k;
  }
#if HWY_ARCH_X86
  const char* const alias = " (avx512 is another name of avx3)";
#else
  const char* const alias = "";
#endif
  throw std::invalid_argument("instruction set '" + name + "' is not one this CPU runs; it runs " +
                              SupportedNames() + alias);
}

bool UsesAvx512(const Kernels& kernels) {
#if HWY_ARCH_X86
  return kernels.target == HWY_AVX3 || kernels.target == HWY_AVX3_DL;
#else
  (void)kernels;
  return false;
#endif
}

ScopedTargetForTest::ScopedTargetForTest(const Kernels& kernels) {
  // Highway's fallback bit stands for "no vector target": only the scalar code remains.
  hwy::SetSupportedTargetsForTest(kernels.target != 0 ? kernels.target : HWY_SCALAR);
}

ScopedTargetForTest::~ScopedTargetForTest() { hwy::SetSupportedTargetsForTest(0); }

}  // namespace kestrel::kernels
