#pragma once
/// @file
/// Eight lanes for the batched hot paths, where eight rays are worked on at once (the ray casting
/// of RayCaster::CastBatch): the lane count
/// and the instruction sets a kernel is compiled for, chosen at run time by what the CPU offers.
/// The vector types and the per-instruction-set compilation are in mapping/lanes_vector.h.

#include <cstdint>
#include <vector>

namespace kestrel::lanes {

/// Rays per batch: one AVX-512 register of doubles.
constexpr int kLanes = 8;

/// The instruction sets a kernel is compiled for.
enum class Isa {
  kBaseline,  ///< what the whole build targets (x86-64: SSE2; arm64: NEON)
  kAvx2,      ///< x86-64 with AVX2
  kAvx512,    ///< x86-64 with AVX-512 F, DQ, VL and BW
};

/// Name for logs and benchmarks ("baseline", "avx2", "avx512").
[[nodiscard]] const char* IsaName(Isa isa);
/// Whether this CPU runs code compiled for `isa`.
[[nodiscard]] bool CpuSupports(Isa isa);
/// The widest instruction set this CPU supports (evaluated once). The environment variable
/// KESTREL_ISA (baseline, avx2, avx512) lowers it, e.g. to compare speeds.
[[nodiscard]] Isa BestIsa();
/// Every instruction set this CPU supports, baseline first.
[[nodiscard]] std::vector<Isa> SupportedIsas();

}  // namespace kestrel::lanes
