#include <cstdlib>
#include <cstring>

#include "common/check.h"
#include "mapping/kernels/kernels.h"

namespace kestrel::kernels {

namespace {
// Each table in the order of Kernels' fields.
constexpr Kernels kScalarKernels{Isa::kScalar,
                                 "scalar",
                                 &WalkLanesScalar,
                                 nullptr,
                                 &StorePosteriorsScalar,
                                 &StorePosteriorsAtScalar,
                                 &ResolveWindowCellsScalar};
#if defined(__x86_64__)
constexpr Kernels kAvx512Kernels{Isa::kAvx512,
                                 "avx512",
                                 &WalkLanesAvx512,
                                 &FillLikelihoodsAvx512,
                                 &StorePosteriorsAvx512,
                                 &StorePosteriorsAtAvx512,
                                 &ResolveWindowCellsAvx512};
#endif
const char* NameOf(Isa isa) { return isa == Isa::kAvx512 ? "avx512" : "scalar"; }
}  // namespace

bool CpuSupports(Isa isa) {
  if (isa == Isa::kScalar) return true;
#if defined(__x86_64__)
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
         __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512bw");
#else
  return false;
#endif
}

const Kernels& For(Isa isa) {
  KESTREL_THROW_UNLESS(CpuSupports(isa), "this CPU does not run " << NameOf(isa) << " code");
#if defined(__x86_64__)
  if (isa == Isa::kAvx512) return kAvx512Kernels;
#endif
  return kScalarKernels;
}

const Kernels& Best() {
  static const Kernels& best = []() -> const Kernels& {
    const char* want = std::getenv("KESTREL_ISA");
    if (want != nullptr && std::strcmp(want, NameOf(Isa::kScalar)) == 0) return kScalarKernels;
    return For(CpuSupports(Isa::kAvx512) ? Isa::kAvx512 : Isa::kScalar);
  }();
  return best;
}

const Kernels& Named(const std::string& name) {
  if (name.empty()) return Best();
  const bool avx512 = name == NameOf(Isa::kAvx512);
  KESTREL_THROW_UNLESS(avx512 || name == NameOf(Isa::kScalar),
                       "unknown instruction set '" << name << "', accepted scalar, avx512 or "
                                                   << "empty (the best this CPU runs)");
  return For(avx512 ? Isa::kAvx512 : Isa::kScalar);
}

std::vector<const Kernels*> Supported() {
  std::vector<const Kernels*> out{&For(Isa::kScalar)};
  if (CpuSupports(Isa::kAvx512)) out.push_back(&For(Isa::kAvx512));
  return out;
}

}  // namespace kestrel::kernels
