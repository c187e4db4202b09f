#include "mapping/lanes.h"

#include <cstdlib>
#include <cstring>

namespace kestrel::lanes {

const char* IsaName(Isa isa) {
  switch (isa) {
    case Isa::kAvx512:
      return "avx512";
    case Isa::kAvx2:
      return "avx2";
    case Isa::kBaseline:
      break;
  }
  return "baseline";
}

bool CpuSupports(Isa isa) {
#if defined(__x86_64__)
  __builtin_cpu_init();
  switch (isa) {
    case Isa::kAvx512:
      return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
             __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512bw");
    case Isa::kAvx2:
      return __builtin_cpu_supports("avx2");
    case Isa::kBaseline:
      return true;
  }
  return false;
#else
  return isa == Isa::kBaseline;
#endif
}

namespace {
Isa DetectBestIsa() {
  Isa best = Isa::kBaseline;
  for (Isa isa : {Isa::kAvx2, Isa::kAvx512}) {
    if (CpuSupports(isa)) best = isa;
  }
  // KESTREL_ISA lowers the choice (never raises it past what the CPU runs).
  if (const char* want = std::getenv("KESTREL_ISA")) {
    for (Isa isa : {Isa::kBaseline, Isa::kAvx2, Isa::kAvx512}) {
      if (std::strcmp(want, IsaName(isa)) == 0 && static_cast<int>(isa) < static_cast<int>(best)) {
        best = isa;
      }
    }
  }
  return best;
}
}  // namespace

Isa BestIsa() {
  static const Isa best = DetectBestIsa();
  return best;
}

std::vector<Isa> SupportedIsas() {
  std::vector<Isa> out;
  for (Isa isa : {Isa::kBaseline, Isa::kAvx2, Isa::kAvx512}) {
    if (CpuSupports(isa)) out.push_back(isa);
  }
  return out;
}

}  // namespace kestrel::lanes
