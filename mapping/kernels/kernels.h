#pragma once
/// @file
/// The instruction-set kernels of the batched hot paths, where eight rays are worked on at once
/// (lanes.h: ray casting, RayCaster::CastBatch; the forward model, SensorModel::FillLikelihoods;
/// the posterior stores, ExactBayesUpdater::UpdateBatchLane), and the table that dispatches
/// them, chosen once by what the CPU offers (ScanIntegrator picks it at construction). Internal
/// to mapping/: public headers only name kernels::Kernels (declared there, defined here), so no
/// instruction set or intrinsic type leaves this folder. Each instruction set's kernels live in
/// their own files (*_scalar.cc, *_avx512.cc).
///
/// The AVX-512 kernels do, in every lane, the IEEE operations of the scalar code with the same
/// expression, and the library is built with -ffp-contract=off (no fused multiply-add), so each
/// lane's result is the scalar result bit for bit: a map does not depend on the machine or the
/// instruction set (tests/mapping/ray_caster_test.cc, inverse_sensor_model_test.cc and
/// occupancy_map_test.cc check every instruction set this machine offers against the scalar
/// code). Elsewhere (kScalar) the same entry points run the scalar code lane by lane.

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

/// The instruction sets the kernels are written for.
enum class Isa {
  kScalar,  ///< scalar code, what the whole build targets (x86-64, arm64)
  kAvx512,  ///< x86-64 with AVX-512 F, DQ, VL and BW
};

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

/// SensorModel::FillLikelihoods's eight lanes: a_k for `rows` rows of distance_m (z[l] the
/// return of lane l where bit l of is_return is set).
using FillLikelihoodsFn = void (*)(const LikelihoodLanes& c, const double* z, unsigned is_return,
                                   const double* distance_m, int rows, double* likelihood);

/// The write step of ExactBayesUpdater's update for n cells: clamps posterior[i] to
/// [p_min, 1 - p_min] (ClampProbability), converts it to float, stores it at base[cells[i]],
/// and lists the cells whose stored value changed, first + i ascending, in
/// changed[0 .. returned count); priors[i] is the value stored before (compared bit for bit).
using StorePosteriorsFn = int (*)(const double* posterior, const int32_t* cells,
                                  const float* priors, int first, int n, double p_min, float* base,
                                  int* changed);
/// The same with each cell's address: stores at *cells[i].
using StorePosteriorsAtFn = int (*)(const double* posterior, float* const* cells,
                                    const float* priors, int first, int n, double p_min,
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
  Isa isa;                 ///< what they are compiled for
  const char* name;        ///< "scalar", "avx512" (logs, tests, KESTREL_ISA)
  WalkLanesFn walk_lanes;  ///< RayCaster::CastBatch's walk
  /// a_k of a batch; null where evaluating a_k inside the update is faster (scalar).
  FillLikelihoodsFn fill_likelihoods;
  StorePosteriorsFn store_posteriors;         ///< the exact update's stores, by linear index
  StorePosteriorsAtFn store_posteriors_at;    ///< the same, by address
  ResolveWindowCellsFn resolve_window_cells;  ///< a GrowingGrid's cells of a batch
};

/// Whether this CPU runs code compiled for `isa`.
[[nodiscard]] bool CpuSupports(Isa isa);
/// The kernels of `isa`.
/// @throws std::invalid_argument if the CPU does not run them.
[[nodiscard]] const Kernels& For(Isa isa);
/// The kernels of the widest instruction set this CPU supports (evaluated once). The environment
/// variable KESTREL_ISA=scalar lowers it, e.g. to compare speeds.
[[nodiscard]] const Kernels& Best();
/// The kernels named `name` ("" = Best()).
/// @throws std::invalid_argument for an unknown name or one this CPU does not run.
[[nodiscard]] const Kernels& Named(const std::string& name);
/// The kernels of every instruction set this CPU supports, scalar first.
[[nodiscard]] std::vector<const Kernels*> Supported();

// Each instruction set's kernels (*_scalar.cc, *_avx512.cc; the AVX-512 ones on x86-64 only).
void WalkLanesScalar(const RaySegment* rays, int count, const bool* started, detail::RayWalk* walks,
                     const Eigen::Vector3d& origin_m, double resolution, double* distance,
                     int32_t* linear, int32_t* size);
int StorePosteriorsScalar(const double* posterior, const int32_t* cells, const float* priors,
                          int first, int n, double p_min, float* base, int* changed);
int StorePosteriorsAtScalar(const double* posterior, float* const* cells, const float* priors,
                            int first, int n, double p_min, int* changed);
bool ResolveWindowCellsScalar(const int32_t* linear, const int* size, int rows, int shift,
                              float* const* blocks, float** cells, uint32_t* slot_cells);
#if defined(__x86_64__)
void WalkLanesAvx512(const RaySegment* rays, int count, const bool* started, detail::RayWalk* walks,
                     const Eigen::Vector3d& origin_m, double resolution, double* distance,
                     int32_t* linear, int32_t* size);
void FillLikelihoodsAvx512(const LikelihoodLanes& c, const double* z, unsigned is_return,
                           const double* distance_m, int rows, double* likelihood);
int StorePosteriorsAvx512(const double* posterior, const int32_t* cells, const float* priors,
                          int first, int n, double p_min, float* base, int* changed);
int StorePosteriorsAtAvx512(const double* posterior, float* const* cells, const float* priors,
                            int first, int n, double p_min, int* changed);
bool ResolveWindowCellsAvx512(const int32_t* linear, const int* size, int rows, int shift,
                              float* const* blocks, float** cells, uint32_t* slot_cells);
#endif

}  // namespace kernels
}  // namespace kestrel
