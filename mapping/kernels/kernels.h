#pragma once
/// @file
/// The instruction-set kernels of the batched hot paths, where eight rays are worked on at once
/// (lanes.h: ray casting, RayCaster::CastBatch; the forward model, SensorModel::FillLikelihoods;
/// the posterior stores, ExactBayesUpdater::UpdateBatchLane; a growing grid's cells,
/// OccupancyMap::UpdateRays), and the one table that dispatches them, chosen by what the CPU
/// offers (ScanIntegrator picks one at construction). Internal to mapping/: public headers only
/// name kernels::Kernels (declared there, defined here), so no instruction set or vector type
/// leaves this folder.
///
/// Two implementations: the scalar code (*_scalar.cc, lane by lane), and one source for every
/// vector instruction set (*-inl.h, written with Google Highway and compiled by simd_kernels.cc
/// once per Highway target: SSE4, AVX2, AVX3 = AVX-512 F/BW/DQ/VL on x86-64; NEON and SVE on
/// arm64). Highway's runtime detection says which targets this CPU runs. Every lane does the
/// scalar code's IEEE operations with the same expression (a < b ? a : b where the scalar code
/// has it, never a fused multiply-add: the library is built with -ffp-contract=off and no kernel
/// calls Highway's MulAdd), so each lane's result is the scalar result bit for bit and a map does
/// not depend on the machine or the instruction set (tests/mapping/ray_caster_test.cc,
/// inverse_sensor_model_test.cc and occupancy_map_test.cc check every target this machine runs,
/// each also forced through Highway, against the scalar code).

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace kestrel {

struct RaySegment;
namespace detail {
struct RayWalk;
}  // namespace detail

namespace kernels {

/// RayCaster::CastBatch after each lane's set-up (StartWalk): for every lane l < count with
/// started[l], the walk of walks[l] from rays[l].origin_W on the lattice with lower corner
/// `origin_m` and edge `resolution`, exactly as WalkRay<true, false> gives it (d_k and linear
/// indices at [k * kLanes + l] of distance and linear); size[l] gets the lane's cell count
/// (0 for lanes not started). walks[] may be changed.
using WalkLanesFn = void (*)(const RaySegment* rays, int count, const bool* started,
                             detail::RayWalk* walks, const Eigen::Vector3d& origin_m,
                             double resolution, double* distance, int32_t* linear, int32_t* size);

/// The constants of one SensorModel::FillLikelihoods call.
struct LikelihoodLanes {
  const double* gaussian_table;
  const double* inv_mass_table;
  double gaussian_last, mass_last;  // last interval, as doubles
  double gaussian_index_per_m, mass_index_per_m;
  double z_min, z_max, cutoff, spurious, scale;
  double near_none, in_range_none;  // P(none | r_k+) below z_min / in range
};

/// SensorModel::FillLikelihoods's eight lanes: a_k for `rows` rows of distance_m, where bit l of
/// is_return is set, for a return z[l] of lane l whose range band is [lo[l], z[l]] (lo = z
/// without a band) and whose Gaussian height is scale[l] (c.scale times the band's scale;
/// docs/algorithms.md §3.8).
using FillLikelihoodsFn = void (*)(const LikelihoodLanes& c, const double* lo, const double* z,
                                   const double* scale, unsigned is_return,
                                   const double* distance_m, int rows, double* likelihood);

/// The write step of ExactBayesUpdater's update for n cells (docs/algorithms.md §4.7): cell i's
/// posterior is scale[per_cell ? i : 0] * P_i with P_i = priors[i] (the value stored before) as a
/// double; it is clamped to [p_min, 1 - p_min] (ClampProbability), converted to float and stored
/// at base[cells[i]]. Lists the cells whose stored value changed (bit for bit), first + i
/// ascending, in changed[0 .. returned count).
using StorePosteriorsFn = int (*)(const double* scale, bool per_cell, const float* priors,
                                  const int32_t* cells, int first, int n, double p_min, float* base,
                                  int* changed);
/// The same with each cell's address: stores at *cells[i].
using StorePosteriorsAtFn = int (*)(const double* scale, bool per_cell, const float* priors,
                                    float* const* cells, int first, int n, double p_min,
                                    int* changed);

/// The GrowingGrid cells of a batch cast on a window of its lattice (OccupancyMap::CastLattice):
/// for every lane l < 8 and row k < size[l] (size[l] = 0 for unused lanes), the window's linear
/// index linear[k * kLanes + l] = x + E (y + E z) (E = 2^shift cells per axis, the window's
/// lower corner on a block corner) lies in block slot (x / 8) + (E / 8) ((y / 8) + (E / 8)
/// (z / 8)), at offset (x % 8) + 8 ((y % 8) + 8 (z % 8)) of its cells (GrowingGrid::
/// OffsetInBlock). Writes the cell's address blocks[slot] + offset to cells[k * kLanes + l] and
/// slot * 512 + offset to slot_cells[k * kLanes + l], for rows < rows. Returns false, with the
/// outputs unspecified, if some cell's blocks[slot] is null.
using ResolveWindowCellsFn = bool (*)(const int32_t* linear, const int* size, int rows, int shift,
                                      float* const* blocks, float** cells, uint32_t* slot_cells);

/// One instruction set's kernels.
struct Kernels {
  /// The Highway target they are compiled for (hwy/detect_targets.h: HWY_AVX2, HWY_NEON, ...);
  /// 0 for the scalar code.
  int64_t target;
  /// Highway's name of the target in lower case ("sse4", "avx2", "avx3", "neon", "sve", ...), or
  /// "scalar": what logs print and instruction_set / KESTREL_ISA accept.
  const char* name;
  WalkLanesFn walk_lanes;  ///< RayCaster::CastBatch's walk
  /// a_k of a batch; null where evaluating a_k inside the update is faster (scalar).
  FillLikelihoodsFn fill_likelihoods;
  StorePosteriorsFn store_posteriors;         ///< the exact update's stores, by linear index
  StorePosteriorsAtFn store_posteriors_at;    ///< the same, by address
  ResolveWindowCellsFn resolve_window_cells;  ///< a GrowingGrid's cells of a batch
};

/// The scalar code's kernels (every CPU runs them).
[[nodiscard]] const Kernels& Scalar();
/// The kernels of every instruction set this CPU runs (as Highway's runtime detection reports
/// it, hwy::SupportedTargets), scalar first, then from the narrowest vectors to the widest.
[[nodiscard]] std::vector<const Kernels*> Supported();
/// The names of Supported(), comma-separated ("scalar, sse4, avx2, avx3").
[[nodiscard]] std::string SupportedNames();
/// The kernels named by the environment variable KESTREL_ISA if it is set and not empty (any
/// name Named() accepts, e.g. to compare speeds), otherwise the widest this CPU runs (the last
/// of Supported()).
/// @throws std::invalid_argument if KESTREL_ISA names kernels this CPU does not run.
[[nodiscard]] const Kernels& Best();
/// The kernels named `name`: "" = Best(), "scalar", or a Highway target's name in lower case
/// ("sse4", "avx2", "avx3", "neon", "sve", "sve2", ...; "avx512" is another name of "avx3").
/// @throws std::invalid_argument, listing SupportedNames(), for a name this CPU does not run
/// (unknown names included).
[[nodiscard]] const Kernels& Named(const std::string& name);
/// Whether `kernels` use AVX-512 registers (Highway's AVX3 targets): code outside these kernels
/// with its own AVX-512 path (exploration's entropy lanes) follows the choice.
[[nodiscard]] bool UsesAvx512(const Kernels& kernels);

/// For tests: while it lives, Supported(), Best() and Named() see only the scalar code and the
/// target of `kernels` (hwy::SetSupportedTargetsForTest), as on a CPU whose widest instruction
/// set it is; restores Highway's own detection when destroyed. One at a time, not thread-safe.
class ScopedTargetForTest {
 public:
  /// Limits the targets to those of `kernels` (one of Supported()).
  explicit ScopedTargetForTest(const Kernels& kernels);
  ~ScopedTargetForTest();
  ScopedTargetForTest(const ScopedTargetForTest&) = delete;
  ScopedTargetForTest& operator=(const ScopedTargetForTest&) = delete;
};

// The scalar kernels (*_scalar.cc).
void WalkLanesScalar(const RaySegment* rays, int count, const bool* started, detail::RayWalk* walks,
                     const Eigen::Vector3d& origin_m, double resolution, double* distance,
                     int32_t* linear, int32_t* size);
int StorePosteriorsScalar(const double* scale, bool per_cell, const float* priors,
                          const int32_t* cells, int first, int n, double p_min, float* base,
                          int* changed);
int StorePosteriorsAtScalar(const double* scale, bool per_cell, const float* priors,
                            float* const* cells, int first, int n, double p_min, int* changed);
bool ResolveWindowCellsScalar(const int32_t* linear, const int* size, int rows, int shift,
                              float* const* blocks, float** cells, uint32_t* slot_cells);
/// The vector kernels of every Highway target compiled in (simd_kernels.cc), whether or not this
/// CPU runs them, from the narrowest vectors to the widest.
[[nodiscard]] const std::vector<Kernels>& CompiledSimdKernels();

}  // namespace kernels
}  // namespace kestrel
