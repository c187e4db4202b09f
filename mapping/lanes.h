#pragma once
/// @file
/// Eight lanes for the batched hot paths, where eight rays are worked on at once (ray casting,
/// RayCaster::CastBatch; the forward model, SensorModel::FillLikelihoods; the posterior stores,
/// ExactBayesUpdater::UpdateBatchLane): the lane count and the instruction sets their kernels
/// are written for, chosen at run time by what the CPU offers.
///
/// The AVX-512 kernels do, in every lane, the IEEE operations of the scalar code with the same
/// expression, and the library is built with -ffp-contract=off (no fused multiply-add), so each
/// lane's result is the scalar result bit for bit: a map does not depend on the machine or the
/// instruction set (tests/mapping/ray_caster_test.cc, inverse_sensor_model_test.cc and
/// occupancy_map_test.cc check every instruction set this machine offers against the scalar
/// code). Elsewhere (kBaseline) the same entry points run the scalar code lane by lane.

#include <vector>

namespace kestrel::lanes {

/// Rays per batch: one AVX-512 register of doubles.
constexpr int kLanes = 8;

/// The instruction sets the kernels are written for.
enum class Isa {
  kBaseline,  ///< scalar code, what the whole build targets (x86-64, arm64)
  kAvx512,    ///< x86-64 with AVX-512 F, DQ, VL and BW
};

/// Name for logs and benchmarks ("baseline", "avx512").
[[nodiscard]] const char* IsaName(Isa isa);
/// Whether this CPU runs code compiled for `isa`.
[[nodiscard]] bool CpuSupports(Isa isa);
/// The widest instruction set this CPU supports (evaluated once). The environment variable
/// KESTREL_ISA=baseline lowers it, e.g. to compare speeds.
[[nodiscard]] Isa BestIsa();
/// Every instruction set this CPU supports, baseline first.
[[nodiscard]] std::vector<Isa> SupportedIsas();

}  // namespace kestrel::lanes
