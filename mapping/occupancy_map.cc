#include "mapping/occupancy_map.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <type_traits>

#include "common/check.h"
#include "common/fnv1a.h"
#include "mapping/kernels/kernels.h"
#include "mapping/lanes.h"

namespace kestrel {

namespace {
// Cells from a GrowingGrid's ray origin cell to the edge of its cast window: a ray of length
// max_range_m stays more than one cell inside, so the window's bounds never cut it
// (CastLattice).
int WindowReach(double max_range_m, double resolution_m) {
  return static_cast<int>(std::ceil(max_range_m / resolution_m)) + 1;
}
}  // namespace

template <class Grid>
OccupancyMap<Grid>::OccupancyMap(Grid grid, std::unique_ptr<OccupancyUpdater> updater,
                                 double max_range_m)
    : grid_(std::move(grid)), updater_(std::move(updater)), max_range_m_(max_range_m) {
  KESTREL_THROW_UNLESS(updater_ != nullptr, "OccupancyMap: updater must not be null");
  const size_t capacity =
      static_cast<size_t>(RayCells::CapacityFor(max_range_m, grid_.geometry().resolution_m()));
  changed_.resize(capacity);
  if constexpr (std::is_same_v<Grid, GrowingGrid>) {
    // A window of 2^shift cells per axis holds [origin cell - reach, origin cell + reach] from a
    // lower corner rounded down to a block (up to 7 cells more); its linear indices (32 bits)
    // need 3 shift < 31.
    window_reach_ = WindowReach(max_range_m, grid_.geometry().resolution_m());
    window_shift_ = GrowingGrid::kBlockShift;
    while ((1 << window_shift_) < 2 * window_reach_ + GrowingGrid::kBlockEdge) ++window_shift_;
    KESTREL_THROW_UNLESS(window_shift_ <= 10,
                         "growing map: ceil(max_range_m / resolution_m) = "
                             << window_reach_ - 1
                             << " cells, accepted at most 507 (the cast window's 1024 cells)");
    const int blocks_per_axis = 1 << (window_shift_ - GrowingGrid::kBlockShift);
    const size_t slots = static_cast<size_t>(blocks_per_axis) * blocks_per_axis * blocks_per_axis;
    window_blocks_.resize(slots, nullptr);
    window_indices_.resize(slots, 0);
    window_filled_.reserve(slots);
    cell_pointers_.resize(capacity * lanes::kLanes);
    cell_slots_.resize(capacity * lanes::kLanes);
  }
  ResetEntropy();
}

template <class Grid>
void OccupancyMap<Grid>::SyncChunks() {
  size_t count;
  if constexpr (std::is_same_v<Grid, GrowingGrid>) {
    count = grid_.block_count();
  } else {
    count = (grid_.size() + kChunkMask) >> kChunkShift;
  }
  const size_t old = chunk_entropy_.size();
  if (count == old) return;
  chunk_entropy_.resize(count, 0.0);
  chunk_stale_.resize(count, 0);
  stale_chunks_.reserve(count);
  changed_bits_.resize(count * kWordsPerChunk, 0);
  chunk_changed_.resize(count, 0);
  changed_chunks_.reserve(count);
  for (size_t c = old; c < count; ++c) MarkStale(static_cast<uint32_t>(c));
}

template <class Grid>
void OccupancyMap<Grid>::ResetEntropy() {
  SyncChunks();
  for (size_t c = 0; c < chunk_entropy_.size(); ++c) MarkStale(static_cast<uint32_t>(c));
  // Cells may have been written through mutable_grid(): look the window's blocks up again.
  window_set_ = false;
}

template <class Grid>
CellIndex OccupancyMap<Grid>::CellOfChunk(uint32_t c, uint32_t cell) const {
  if constexpr (std::is_same_v<Grid, GrowingGrid>) {
    const CellIndex origin = grid_.block_origin(c);
    // GrowingGrid::OffsetInBlock, inverted.
    constexpr uint32_t kIn = GrowingGrid::kBlockEdge - 1;
    return CellIndex{origin.x + static_cast<int32_t>(cell & kIn),
                     origin.y + static_cast<int32_t>((cell >> GrowingGrid::kBlockShift) & kIn),
                     origin.z + static_cast<int32_t>(cell >> (2 * GrowingGrid::kBlockShift))};
  } else {
    // DenseGrid::LinearIndexOf, inverted.
    const size_t linear = (size_t{c} << kChunkShift) + cell;
    const size_t nx = static_cast<size_t>(grid_.dims().x);
    const size_t ny = static_cast<size_t>(grid_.dims().y);
    return CellIndex{static_cast<int32_t>(linear % nx), static_cast<int32_t>((linear / nx) % ny),
                     static_cast<int32_t>(linear / (nx * ny))};
  }
}

template <class Grid>
size_t OccupancyMap<Grid>::ChangedCellCount() const {
  size_t n = 0;
  for (const uint32_t c : changed_chunks_) {
    for (int w = 0; w < kWordsPerChunk; ++w) {
      n += static_cast<size_t>(__builtin_popcountll(changed_bits_[size_t{c} * kWordsPerChunk + w]));
    }
  }
  return n;
}

template <class Grid>
void OccupancyMap<Grid>::ClearChanges() {
  for (const uint32_t c : changed_chunks_) {
    std::fill_n(changed_bits_.begin() + static_cast<ptrdiff_t>(size_t{c} * kWordsPerChunk),
                kWordsPerChunk, 0);
    chunk_changed_[c] = 0;
  }
  changed_chunks_.clear();
}

template <class Grid>
double OccupancyMap<Grid>::ChunkEntropy(uint32_t c) const {
  // Neighbouring cells often hold the same value (the clamp, the prior): reuse its H.
  float last_v = updater_->initial_value();
  double last_h = BinaryEntropy(updater_->ProbabilityOf(last_v));
  const auto cached_entropy = [&](float v) {
    if (v != last_v) {
      last_v = v;
      last_h = BinaryEntropy(updater_->ProbabilityOf(v));
    }
    return last_h;
  };
  double h = 0.0;
  if constexpr (std::is_same_v<Grid, GrowingGrid>) {
    for (float v : grid_.block(c).values) h += cached_entropy(v);
  } else {
    const std::vector<float>& values = grid_.values();
    const size_t begin = size_t{c} << kChunkShift;
    const size_t end = std::min(values.size(), begin + (size_t{1} << kChunkShift));
    for (size_t i = begin; i < end; ++i) h += cached_entropy(values[i]);
  }
  return h;
}

template <class Grid>
double OccupancyMap<Grid>::entropy_nats() const {
  if (!stale_chunks_.empty()) {
    for (uint32_t c : stale_chunks_) {
      chunk_entropy_[c] = ChunkEntropy(c);
      chunk_stale_[c] = 0;
    }
    stale_chunks_.clear();
    double h = 0.0;
    for (double e : chunk_entropy_) h += e;  // chunk order: independent of query times
    entropy_nats_ = h;
  }
  return entropy_nats_;
}

template <class Grid>
GridGeometry OccupancyMap<Grid>::CastLattice(const Eigen::Vector3d& origin_W) const {
  if constexpr (std::is_same_v<Grid, GrowingGrid>) {
    const GridGeometry& g = grid_.geometry();
    const int32_t edge = int32_t{1} << window_shift_;
    CellIndex lower;  // an origin outside the lattice: any window (its rays have no cells)
    if (const std::optional<CellIndex> c = g.CellOf(origin_W)) {
      for (int a = 0; a < 3; ++a) {
        // Rounded down to a multiple of the block edge (two's complement: also below 0).
        lower[a] = ((*c)[a] - window_reach_) & ~(GrowingGrid::kBlockEdge - 1);
        KESTREL_THROW_UNLESS(
            lower[a] >= g.lower()[a] && lower[a] + edge <= g.upper()[a],
            "growing map: ray origin " << origin_W.transpose() << " too close to the index limit");
      }
    }
    return g.WithBounds(lower, CellIndex{lower.x + edge, lower.y + edge, lower.z + edge});
  } else {
    (void)origin_W;
    return grid_.geometry();
  }
}

template <class Grid>
void OccupancyMap<Grid>::UseWindow(const GridGeometry& window) {
  if (window_set_ && window.lower() == window_lower_) return;
  for (uint32_t slot : window_filled_) window_blocks_[slot] = nullptr;
  window_filled_.clear();
  window_lower_ = window.lower();
  window_set_ = true;
}

template <class Grid>
void OccupancyMap<Grid>::ResolveWindowBlock(uint32_t slot) {
  if constexpr (std::is_same_v<Grid, GrowingGrid>) {
    const int per_axis_shift = window_shift_ - GrowingGrid::kBlockShift;
    const uint32_t mask = (1u << per_axis_shift) - 1;
    const CellIndex origin{
        window_lower_.x + static_cast<int32_t>((slot & mask) << GrowingGrid::kBlockShift),
        window_lower_.y +
            static_cast<int32_t>(((slot >> per_axis_shift) & mask) << GrowingGrid::kBlockShift),
        window_lower_.z +
            static_cast<int32_t>((slot >> (2 * per_axis_shift)) << GrowingGrid::kBlockShift)};
    window_blocks_[slot] = grid_.FindOrCreateBlock(origin, &window_indices_[slot])->values;
    window_filled_.push_back(slot);
  } else {
    (void)slot;
  }
}

template <class Grid>
void OccupancyMap<Grid>::UpdateRays(const Reading* readings, const RayBatch& batch,
                                    const SensorModel& model, const kernels::Kernels& kernels,
                                    ScanStats* stats) {
  const int32_t* const linear = batch.linear_index.data();
  if constexpr (std::is_same_v<Grid, GrowingGrid>) {
    // Cast on a window of this lattice (CastLattice), which the window table describes.
    const GridGeometry& window = batch.lattice;
    KESTREL_DEMAND(window.upper().x - window.lower().x == (int32_t{1} << window_shift_) &&
                   window.origin_m() == grid_.geometry().origin_m() &&
                   window.resolution_m() == grid_.geometry().resolution_m());
    UseWindow(window);
    float** const cells = cell_pointers_.data();
    uint32_t* const slot_cells = cell_slots_.data();
    const auto resolve = [&] {
      return kernels.resolve_window_cells(linear, batch.size, batch.longest, window_shift_,
                                          window_blocks_.data(), cells, slot_cells);
    };
    if (!resolve()) {
      // Some cell's block is not in the window's table yet: look the blocks up, or create them
      // on first touch in ray and cell order (as ray by ray), then resolve again.
      const size_t blocks_before = grid_.block_count();
      for (int l = 0; l < batch.count; ++l) {
        for (int k = 0; k < batch.size[l]; ++k) {
          const uint32_t slot = WindowSlotOf(linear[RayBatch::At(k, l)]);
          if (window_blocks_[slot] == nullptr) ResolveWindowBlock(slot);
        }
      }
      // Newly allocated cells join the summed entropy at P_init (file comment).
      if (grid_.block_count() != blocks_before) SyncChunks();
      KESTREL_DEMAND(resolve());
    }
    // The rays one after the other, in order: each sees its predecessors' posteriors.
    for (int l = 0; l < batch.count; ++l) {
      const int changed = updater_->UpdateBatchLaneAt(
          model, readings[l], batch, l, cells + l, kernels, &stats->cells_updated, changed_.data());
      for (int c = 0; c < changed; ++c) {
        // The cell's chunk is its block (ResolveWindowCellsFn: slot * 512 + offset).
        const uint32_t slot_cell = slot_cells[RayBatch::At(changed_[static_cast<size_t>(c)], l)];
        MarkChanged(window_indices_[slot_cell >> kChunkShift], slot_cell & kChunkMask);
      }
      ++stats->rays_applied;
      if (readings[l].kind == ReadingKind::kNoReturn) ++stats->rays_no_return;
    }
  } else {
    KESTREL_DEMAND(batch.lattice.SameLattice(grid_.geometry()));
    float* const values = grid_.mutable_values().data();
    // The rays one after the other, in order: each sees its predecessors' posteriors.
    for (int l = 0; l < batch.count; ++l) {
      const int changed = updater_->UpdateBatchLane(model, readings[l], batch, l, values, kernels,
                                                    &stats->cells_updated, changed_.data());
      for (int c = 0; c < changed; ++c) {
        const uint32_t cell =
            static_cast<uint32_t>(linear[RayBatch::At(changed_[static_cast<size_t>(c)], l)]);
        MarkChanged(cell >> kChunkShift, cell & kChunkMask);
      }
      ++stats->rays_applied;
      if (readings[l].kind == ReadingKind::kNoReturn) ++stats->rays_no_return;
    }
  }
}

template <class Grid>
double OccupancyMap<Grid>::RecomputeEntropy() const {
  double h = 0.0;
  if constexpr (std::is_same_v<Grid, GrowingGrid>) {
    grid_.ForEachBlock([&](const CellIndex&, const GrowingGrid::Block& block) {
      for (float v : block.values) h += BinaryEntropy(updater_->ProbabilityOf(v));
    });
  } else {
    for (float v : grid_.values()) h += BinaryEntropy(updater_->ProbabilityOf(v));
  }
  return h;
}

template <class Grid>
double OccupancyMap<Grid>::ProbabilityAt(const CellIndex& cell) const {
  return updater_->ProbabilityOf(grid_.Get(cell));
}

template <class Grid>
uint64_t OccupancyMap<Grid>::Hash() const {
  uint64_t h = kFnv1aOffset;
  if constexpr (std::is_same_v<Grid, GrowingGrid>) {
    grid_.ForEachBlock([&](const CellIndex& origin, const GrowingGrid::Block& block) {
      h = Fnv1a(&origin, sizeof(origin), h);
      h = Fnv1a(block.values, sizeof(block.values), h);
    });
  } else {
    h = Fnv1a(grid_.values().data(), grid_.values().size() * sizeof(float), h);
  }
  return h;
}

template class OccupancyMap<DenseGrid>;
template class OccupancyMap<GrowingGrid>;

std::unique_ptr<DenseOccupancyMap> MakeExactDenseMap(const MapLimits& limits,
                                                     const OccupancyLimits& occupancy,
                                                     double max_range_m) {
  auto updater = std::make_unique<ExactBayesUpdater>(
      occupancy, RayCells::CapacityFor(max_range_m, limits.resolution_m), limits.resolution_m);
  DenseGrid grid(limits, updater->initial_value());
  return std::make_unique<DenseOccupancyMap>(std::move(grid), std::move(updater), max_range_m);
}

std::unique_ptr<GrowingOccupancyMap> MakeExactGrowingMap(const MapLimits& limits,
                                                         const OccupancyLimits& occupancy,
                                                         double max_range_m) {
  limits.Validate();
  auto updater = std::make_unique<ExactBayesUpdater>(
      occupancy, RayCells::CapacityFor(max_range_m, limits.resolution_m), limits.resolution_m);
  GrowingGrid grid(limits.min_m, limits.resolution_m, updater->initial_value());
  return std::make_unique<GrowingOccupancyMap>(std::move(grid), std::move(updater), max_range_m);
}

std::unique_ptr<DenseOccupancyMap> MakeLogOddsDenseMap(const MapLimits& limits,
                                                       const LogOddsConfig& config,
                                                       double max_range_m) {
  auto updater = std::make_unique<LogOddsUpdater>(config);
  DenseGrid grid(limits, updater->initial_value());
  return std::make_unique<DenseOccupancyMap>(std::move(grid), std::move(updater), max_range_m);
}

}  // namespace kestrel
