#pragma once
/// @file
/// A 3D occupancy map (docs/algorithms.md §1, §4 and §5): a grid (DenseGrid with the paper's
/// fixed limits, or GrowingGrid), an OccupancyUpdater (Kestrel's exact model or the log-odds
/// baseline) and the bookkeeping of what changed. It keeps cells only: rays come to it cast, in
/// batches (RayCaster::CastBatch), from a ScanIntegrator (mapping/scan_integrator.h), which
/// turns depth images, scans and single readings into rays.
///
/// Bookkeeping is per chunk of 512 cells: a GrowingGrid's 8^3 block (chunk c is the block
/// created c-th), or a run of 512 consecutive cells of a DenseGrid's array (a cell's chunk is
/// its linear index / 512). ("Block" means only an 8^3 cube of cells.) The map entropy
/// H(map) = sum_i H(P(m_i)) (eqs. 5-6) is kept per chunk: a ray marks the chunks of the cells it
/// changed, and a query recomputes the marked chunks' sums and adds all chunk sums in chunk
/// order. The result is a function of the cell values only (not of when it is queried), costs
/// no logarithm per cell update, and is O(changed chunks x 512 + chunks) per query; for a
/// GrowingGrid it sums the allocated cells (each new block adds 512 H(P_init)). The map also
/// tracks which cells changed since the last ClearChanges, a bit per cell (like OctoMap's
/// changed keys), so that a caller can publish them without a copy of the map.
///
/// Rays are updated one fully before the next, in batch and lane order; no allocation per ray (the
/// scratch is sized at construction from max_range_m); a GrowingGrid allocates a block the first
/// time a ray touches it. A GrowingGrid's rays are cast on a window of the lattice around their
/// origin (CastLattice), whose linear indices the map resolves to blocks through a table of the
/// window's blocks.

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <optional>
#include <type_traits>
#include <vector>

#include "common/se3.h"
#include "mapping/grid.h"
#include "mapping/occupancy_updater.h"
#include "mapping/ray_caster.h"
#include "mapping/sensor_model.h"

namespace kestrel {

/// What applying one scan did.
struct ScanStats {
  uint64_t rays_applied{0};    ///< returns and "no return" readings applied
  uint64_t rays_no_return{0};  ///< of which "no return"
  uint64_t rays_invalid{0};    ///< readings dropped as carrying no information
  uint64_t cells_updated{0};   ///< cell writes

  /// Adds another scan's counts.
  ScanStats& operator+=(const ScanStats& o) {
    rays_applied += o.rays_applied;
    rays_no_return += o.rays_no_return;
    rays_invalid += o.rays_invalid;
    cells_updated += o.cells_updated;
    return *this;
  }
};

namespace kernels {
struct Kernels;  // one instruction set's kernels (kernels/kernels.h)
}  // namespace kernels

/// The map over a grid type (DenseGrid or GrowingGrid). Neither copyable nor movable (scratch
/// pointers into the grid).
template <class Grid>
class OccupancyMap {
 public:
  /// A map over `grid` (whose cells should hold updater->initial_value()) whose sensors reach at
  /// most `max_range_m` (sizes the per-ray scratch).
  /// @throws std::invalid_argument if updater is null or max_range_m is not positive, or for a
  /// GrowingGrid if ceil(max_range_m / resolution) exceeds 507 cells (the window of CastLattice
  /// is at most 1024 cells per axis).
  OccupancyMap(Grid grid, std::unique_ptr<OccupancyUpdater> updater, double max_range_m);
  OccupancyMap(const OccupancyMap&) = delete;
  OccupancyMap& operator=(const OccupancyMap&) = delete;

  /// The lattice to cast rays from origin_W on (RayCaster::CastBatch) for UpdateRays: a
  /// DenseGrid's own; for a GrowingGrid, the block-aligned window of its lattice that holds every
  /// cell within max_range_m of the origin (cut by nothing: the same cells and d_k as the whole
  /// lattice), whose linear indices UpdateRays turns into blocks.
  /// @throws std::invalid_argument if a GrowingGrid's window would leave its lattice (an origin
  /// within a window's edge of the +-2^23-cell index limit).
  [[nodiscard]] GridGeometry CastLattice(const Eigen::Vector3d& origin_W) const;
  /// Updates the cells of the rays of `batch` (cast on CastLattice of their origin, maybe
  /// prepared by updater().PrecomputeBatch) for readings[0 .. batch.count) (kReturn or kNoReturn),
  /// one ray after the other in lane order: each sees its predecessors' posteriors. Marks the
  /// changed cells and their chunks (file comment) and adds to *stats (rays_applied,
  /// rays_no_return, cells_updated). The same cells bit for bit with every instruction set's
  /// `kernels`.
  void UpdateRays(const Reading* readings, const RayBatch& batch, const SensorModel& model,
                  const kernels::Kernels& kernels, ScanStats* stats);

  /// H(map), nats, from the chunk sums (file comment); recomputes the chunks changed since the
  /// last query (so a const call writes a cache: not for concurrent calls).
  [[nodiscard]] double entropy_nats() const;
  /// H(map) recomputed from every cell (O(cells)), for tests and checks.
  [[nodiscard]] double RecomputeEntropy() const;
  /// Occupancy probability of a cell (the initial one for an untouched growing-grid cell).
  [[nodiscard]] double ProbabilityAt(const CellIndex& cell) const;
  /// FNV-1a hash of every stored cell value (bit patterns) in a deterministic order.
  [[nodiscard]] uint64_t Hash() const;
  /// The grid.
  [[nodiscard]] const Grid& grid() const { return grid_; }
  /// The grid, mutable (loading a map; call ResetEntropy() afterwards).
  [[nodiscard]] Grid& mutable_grid() { return grid_; }
  /// Marks every chunk for entropy recomputation (after cells were written through
  /// mutable_grid(), e.g. when loading a map; such writes are not changes for
  /// ForEachChangedCell).
  void ResetEntropy();

  /// Calls f(cell, stored value) for every cell an update changed since the last ClearChanges
  /// (or construction): its stored bit pattern changed (it may have changed back since). Chunk
  /// by chunk in the order they first changed, cells ascending within a chunk: the same order
  /// for the same inputs. O(changed chunks x 8 + changed cells).
  template <class F>
  void ForEachChangedCell(F&& f) const;
  /// The number of cells ForEachChangedCell visits.
  [[nodiscard]] size_t ChangedCellCount() const;
  /// Forgets the changes (e.g. once they are published).
  void ClearChanges();
  /// The update rule.
  [[nodiscard]] const OccupancyUpdater& updater() const { return *updater_; }
  /// Longest ray the scratch holds, m.
  [[nodiscard]] double max_range_m() const { return max_range_m_; }

 private:
  static constexpr int kChunkShift = 9;  // 512 cells per chunk (file comment)
  static constexpr uint32_t kChunkMask = (1u << kChunkShift) - 1;
  static constexpr int kWordsPerChunk = (1 << kChunkShift) / 64;  // changed-cell bits
  // Sum of H over the cells of chunk c.
  double ChunkEntropy(uint32_t c) const;
  // Marks chunk c for entropy recomputation.
  void MarkStale(uint32_t c) const {
    if (chunk_stale_[c] == 0) {
      chunk_stale_[c] = 1;
      stale_chunks_.push_back(c);
    }
  }
  // Marks cell `cell` (0 .. 511) of chunk c changed, and the chunk for entropy recomputation.
  void MarkChanged(uint32_t c, uint32_t cell) {
    MarkStale(c);
    if (chunk_changed_[c] == 0) {
      chunk_changed_[c] = 1;
      changed_chunks_.push_back(c);
    }
    changed_bits_[size_t{c} * kWordsPerChunk + (cell >> 6)] |= uint64_t{1} << (cell & 63);
  }
  // Grows the chunk arrays to the grid's chunk count (GrowingGrid: its blocks), new chunks
  // stale.
  void SyncChunks();
  // The cell `cell` (0 .. 511) of chunk c, and its stored value.
  [[nodiscard]] CellIndex CellOfChunk(uint32_t c, uint32_t cell) const;
  [[nodiscard]] float StoredInChunk(uint32_t c, uint32_t cell) const {
    if constexpr (std::is_same_v<Grid, GrowingGrid>) {
      return grid_.block(c).values[cell];
    } else {
      return grid_.values()[(size_t{c} << kChunkShift) + cell];
    }
  }
  // GrowingGrid: makes `window` (a CastLattice) the one the window table describes.
  void UseWindow(const GridGeometry& window);
  // GrowingGrid: looks up (or creates) the block of the window table's slot `slot`.
  void ResolveWindowBlock(uint32_t slot);
  // GrowingGrid: the window table's slot of the block holding the cell with window linear
  // index `cell` = x + E (y + E z) (kernels::ResolveWindowCellsFn).
  [[nodiscard]] uint32_t WindowSlotOf(int32_t cell) const {
    const int s = window_shift_;
    const int b = s - GrowingGrid::kBlockShift;  // log2 of the window's blocks per axis
    const int32_t mask = (int32_t{1} << s) - 1;
    const int32_t x = cell & mask, y = (cell >> s) & mask, z = cell >> (2 * s);
    return static_cast<uint32_t>((x >> GrowingGrid::kBlockShift) |
                                 ((y >> GrowingGrid::kBlockShift) << b) |
                                 ((z >> GrowingGrid::kBlockShift) << (2 * b)));
  }

  Grid grid_;
  std::unique_ptr<OccupancyUpdater> updater_;
  double max_range_m_;
  std::vector<int> changed_;  // indices k of the cells the last ray changed
  // Lazy entropy (file comment): per-chunk sums, stale flags and list, cached total.
  mutable std::vector<double> chunk_entropy_;
  mutable std::vector<uint8_t> chunk_stale_;
  mutable std::vector<uint32_t> stale_chunks_;
  mutable double entropy_nats_{0.0};
  // Changes since ClearChanges (file comment): a bit per cell (kWordsPerChunk words per chunk),
  // per-chunk flags and the chunks in the order they first changed.
  std::vector<uint64_t> changed_bits_;
  std::vector<uint8_t> chunk_changed_;
  std::vector<uint32_t> changed_chunks_;
  // GrowingGrid only: the cast window (CastLattice), 2^window_shift_ cells per axis from
  // window_lower_ (a multiple of the block edge), within window_reach_ cells of the origin cell
  // and beyond; its blocks in x-fastest order (their cells, null until looked up, and creation
  // indices), the slots filled since UseWindow, and the cells of the batch being updated, in its
  // layout: addresses, and slot * 512 + offset in the block (kernels::ResolveWindowCellsFn).
  int window_reach_{0};
  int window_shift_{0};
  CellIndex window_lower_;
  bool window_set_{false};
  std::vector<float*> window_blocks_;
  std::vector<uint32_t> window_indices_;
  std::vector<uint32_t> window_filled_;
  std::vector<float*> cell_pointers_;
  std::vector<uint32_t> cell_slots_;
};

template <class Grid>
template <class F>
void OccupancyMap<Grid>::ForEachChangedCell(F&& f) const {
  for (const uint32_t c : changed_chunks_) {
    for (int w = 0; w < kWordsPerChunk; ++w) {
      for (uint64_t bits = changed_bits_[size_t{c} * kWordsPerChunk + w]; bits != 0;
           bits &= bits - 1) {
        const uint32_t cell = static_cast<uint32_t>(64 * w + __builtin_ctzll(bits));
        f(CellOfChunk(c, cell), StoredInChunk(c, cell));
      }
    }
  }
}

/// The paper's map: fixed limits, dense storage.
using DenseOccupancyMap = OccupancyMap<DenseGrid>;
/// A map that grows in 8^3 blocks.
using GrowingOccupancyMap = OccupancyMap<GrowingGrid>;

/// Kestrel's exact map over fixed limits (section 1 parameters, section 4 updates).
/// @throws std::invalid_argument on invalid limits.
std::unique_ptr<DenseOccupancyMap> MakeExactDenseMap(const MapLimits& limits,
                                                     const OccupancyLimits& occupancy,
                                                     double max_range_m);
/// Kestrel's exact map that grows, aligned to limits.min_m with limits.resolution_m.
std::unique_ptr<GrowingOccupancyMap> MakeExactGrowingMap(const MapLimits& limits,
                                                         const OccupancyLimits& occupancy,
                                                         double max_range_m);
/// The log-odds baseline over fixed limits.
std::unique_ptr<DenseOccupancyMap> MakeLogOddsDenseMap(const MapLimits& limits,
                                                       const LogOddsConfig& config,
                                                       double max_range_m);

}  // namespace kestrel
