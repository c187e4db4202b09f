#include "mapping/lanes.h"

#include <cstdlib>
#include <cstring>

namespace kestrel::lanes {

const char* IsaName(Isa isa) { return isa == Isa::kAvx512 ? "avx512" : "baseline"; }

bool CpuSupports(Isa isa) {
  if (isa == Isa::kBaseline) return true;
#if defined(__x86_64__)
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
         __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512bw");
#else
  return false;
#endif
}

Isa BestIsa() {
  static const Isa best = [] {
    const char* want = std::getenv("KESTREL_ISA");
    if (want != nullptr && std::strcmp(want, IsaName(Isa::kBaseline)) == 0) return Isa::kBaseline;
    return CpuSupports(Isa::kAvx512) ? Isa::kAvx512 : Isa::kBaseline;
  }();
  return best;
}

std::vector<Isa> SupportedIsas() {
  std::vector<Isa> out{Isa::kBaseline};
  if (CpuSupports(Isa::kAvx512)) out.push_back(Isa::kAvx512);
  return out;
}

}  // namespace kestrel::lanes
