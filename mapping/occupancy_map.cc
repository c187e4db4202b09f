#include "mapping/occupancy_map.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <type_traits>

#include "common/check.h"

namespace kestrel {

template <class Grid>
OccupancyMap<Grid>::OccupancyMap(Grid grid, std::unique_ptr<OccupancyUpdater> updater,
                                 double max_range_m)
    : grid_(std::move(grid)),
      updater_(std::move(updater)),
      caster_(grid_.geometry()),
      ray_(max_range_m, grid_.geometry().resolution_m()),
      batch_(max_range_m, grid_.geometry().resolution_m()) {
  KESTREL_THROW_UNLESS(updater_ != nullptr, "OccupancyMap: updater must not be null");
  cell_pointers_.resize(ray_.cells.size());
  changed_.resize(ray_.cells.size());
  if constexpr (std::is_same_v<Grid, GrowingGrid>) {
    accessor_ = std::make_unique<GrowingGrid::Accessor>(&grid_);
    cell_block_.resize(ray_.cells.size());
  }
  SetRayBatches(lanes::BestIsa() == lanes::Isa::kAvx512);
  ResetEntropy();
}

template <class Grid>
float* OccupancyMap<Grid>::DenseValues() {
  if constexpr (std::is_same_v<Grid, GrowingGrid>) {
    return nullptr;
  } else {
    return grid_.mutable_values().data();
  }
}

template <class Grid>
void OccupancyMap<Grid>::SyncBlocks() {
  size_t count;
  if constexpr (std::is_same_v<Grid, GrowingGrid>) {
    count = grid_.block_count();
  } else {
    count = (grid_.size() + (size_t{1} << kDenseBlockShift) - 1) >> kDenseBlockShift;
  }
  const size_t old = block_entropy_.size();
  if (count == old) return;
  block_entropy_.resize(count, 0.0);
  block_dirty_.resize(count, 0);
  dirty_blocks_.reserve(count);
  for (size_t b = old; b < count; ++b) MarkDirty(static_cast<uint32_t>(b));
}

template <class Grid>
void OccupancyMap<Grid>::ResetEntropy() {
  SyncBlocks();
  for (size_t b = 0; b < block_entropy_.size(); ++b) MarkDirty(static_cast<uint32_t>(b));
}

template <class Grid>
uint32_t OccupancyMap<Grid>::EntropyBlockOf(const RayCells& ray, int k) const {
  if constexpr (std::is_same_v<Grid, GrowingGrid>) {
    (void)ray;
    return cell_block_[static_cast<size_t>(k)];
  } else {
    const size_t i = static_cast<size_t>(k);
    return DenseBlockOf(ray.has_linear_index
                            ? int64_t{ray.linear_index[i]}
                            : static_cast<int64_t>(grid_.LinearIndexOf(ray.cells[i])));
  }
}

template <class Grid>
double OccupancyMap<Grid>::BlockEntropy(uint32_t b) const {
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
    for (float v : grid_.block(b).values) h += cached_entropy(v);
  } else {
    const std::vector<float>& values = grid_.values();
    const size_t begin = size_t{b} << kDenseBlockShift;
    const size_t end = std::min(values.size(), begin + (size_t{1} << kDenseBlockShift));
    for (size_t i = begin; i < end; ++i) h += cached_entropy(values[i]);
  }
  return h;
}

template <class Grid>
double OccupancyMap<Grid>::entropy_nats() const {
  if (!dirty_blocks_.empty()) {
    for (uint32_t b : dirty_blocks_) {
      block_entropy_[b] = BlockEntropy(b);
      block_dirty_[b] = 0;
    }
    dirty_blocks_.clear();
    double h = 0.0;
    for (double e : block_entropy_) h += e;  // block order: independent of query times
    entropy_nats_ = h;
  }
  return entropy_nats_;
}

template <class Grid>
float* OccupancyMap<Grid>::CellPointer(const CellIndex& c) {
  if constexpr (std::is_same_v<Grid, GrowingGrid>) {
    return accessor_->FindOrCreate(c);
  } else {
    return grid_.Find(c);
  }
}

template <class Grid>
ScanStats OccupancyMap<Grid>::ApplyRay(const Eigen::Vector3d& origin_W,
                                       const Eigen::Vector3d& direction_W, double range_m,
                                       const SensorModel& model) {
  return ApplyReading(origin_W, direction_W, model.Classify(range_m), model);
}

template <class Grid>
ScanStats OccupancyMap<Grid>::ApplyReading(const Eigen::Vector3d& origin_W,
                                           const Eigen::Vector3d& direction_W,
                                           const Reading& reading, const SensorModel& model) {
  ScanStats stats;
  if (reading.kind == ReadingKind::kInvalid) {
    stats.rays_invalid = 1;
    return stats;
  }
  KESTREL_THROW_UNLESS(model.config().z_max_m <= ray_.max_length_m,
                       "OccupancyMap: sensor z_max_m = " << model.config().z_max_m
                                                         << " exceeds the map's max_range_m = "
                                                         << ray_.max_length_m);
  caster_.CastWithLinearIndex(origin_W, direction_W, updater_->CastLength(model, reading), &ray_);
  ApplyCastRay(reading, ray_, model, &stats);
  return stats;
}

template <class Grid>
void OccupancyMap<Grid>::ApplyCastRay(const Reading& reading, const RayCells& ray,
                                      const SensorModel& model, ScanStats* stats) {
  if (reading.kind == ReadingKind::kInvalid) {
    ++stats->rays_invalid;
    return;
  }
  const int n = ray.size;
  if constexpr (std::is_same_v<Grid, GrowingGrid>) {
    const size_t blocks_before = grid_.block_count();
    for (int k = 0; k < n; ++k) {
      cell_pointers_[k] = accessor_->FindOrCreate(ray.cells[k]);
      cell_block_[k] = accessor_->last_block_index();
    }
    // Newly allocated cells join the summed entropy at P_init (file comment).
    if (grid_.block_count() != blocks_before) SyncBlocks();
  }
  int changed;
  if (!std::is_same_v<Grid, GrowingGrid> && ray.has_linear_index) {
    // DenseGrid: the caster's linear indices address the cells directly.
    changed = updater_->UpdateRayLinear(model, reading, ray, DenseValues(), &stats->cells_updated,
                                        changed_.data());
  } else {
    if constexpr (!std::is_same_v<Grid, GrowingGrid>) {
      for (int k = 0; k < n; ++k) cell_pointers_[k] = CellPointer(ray.cells[k]);
    }
    changed = updater_->UpdateRay(model, reading, ray, cell_pointers_.data(), &stats->cells_updated,
                                  changed_.data());
  }
  for (int i = 0; i < changed; ++i) MarkDirty(EntropyBlockOf(ray, changed_[i]));
  ++stats->rays_applied;
  if (reading.kind == ReadingKind::kNoReturn) ++stats->rays_no_return;
}

template <class Grid>
void OccupancyMap<Grid>::SetTraversalThread(bool enabled) {
  traversal_thread_ = enabled;
  ConfigureWorkers();
}

template <class Grid>
void OccupancyMap<Grid>::SetRayBatches(bool enabled, lanes::Isa isa) {
  KESTREL_THROW_UNLESS(lanes::CpuSupports(isa),
                       "SetRayBatches: this CPU does not run " << lanes::IsaName(isa) << " code");
  batch_isa_.reset();
  if (enabled) batch_isa_ = isa;
  ConfigureWorkers();
}

template <class Grid>
bool OccupancyMap<Grid>::Batched() const {
  return std::is_same_v<Grid, DenseGrid> && batch_isa_.has_value() && caster_.LinearIndexable();
}

template <class Grid>
void OccupancyMap<Grid>::ConfigureWorkers() {
  // A worker of the kind the rays are cast with (batches or one by one), created once.
  const bool batched = traversal_thread_ && Batched();
  if (!batched || (batch_pipeline_ != nullptr && batch_pipeline_->isa() != *batch_isa_)) {
    batch_pipeline_.reset();
  }
  if (batched && batch_pipeline_ == nullptr) {
    batch_pipeline_ =
        std::make_unique<RayBatchPipeline>(grid_.geometry(), ray_.max_length_m, *batch_isa_);
  }
  if (!traversal_thread_ || batched) {
    pipeline_.reset();
  } else if (pipeline_ == nullptr) {
    // The updates need a ray's CellIndex only through its linear index (ApplyCastRay).
    pipeline_ = std::make_unique<TraversalPipeline>(grid_.geometry(), ray_.max_length_m,
                                                    /*cells_needed=*/false);
  }
}

template <class Grid>
void OccupancyMap<Grid>::ApplyBatch(const Reading* readings, const RayBatch& batch,
                                    const SensorModel& model, ScanStats* stats) {
  float* const values = DenseValues();
  const int32_t* const linear = batch.linear_index.data();
  // The rays one after the other, in order: each sees its predecessors' posteriors.
  for (int l = 0; l < batch.count; ++l) {
    const int changed = updater_->UpdateBatchLane(model, readings[l], batch, l, values,
                                                  &stats->cells_updated, changed_.data());
    for (int c = 0; c < changed; ++c) {
      MarkDirty(DenseBlockOf(linear[RayBatch::At(changed_[static_cast<size_t>(c)], l)]));
    }
    ++stats->rays_applied;
    if (readings[l].kind == ReadingKind::kNoReturn) ++stats->rays_no_return;
  }
}

template <class Grid>
template <class Source>
ScanStats OccupancyMap<Grid>::ApplyRays(ScanKind kind, int count, const Source& source,
                                        const SensorModel& model) {
  KESTREL_THROW_UNLESS(model.config().z_max_m <= ray_.max_length_m,
                       "OccupancyMap: sensor z_max_m = " << model.config().z_max_m
                                                         << " exceeds the map's max_range_m = "
                                                         << ray_.max_length_m);
  ScanStats stats;
  // With a batch worker, each kind of scan goes the way that has been faster (WorkerChoice).
  WorkerChoice& choice = choices_[kind];
  const bool use_worker = batch_pipeline_ != nullptr && choice.NextUsesWorker();
  const auto started = std::chrono::steady_clock::now();
  const auto record = [&](bool worker) {
    if (batch_pipeline_ == nullptr) return;
    choice.Record(
        worker, stats.rays_applied,
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
  };
  // The source as batches take it.
  const auto batch_source = [&source](int i, BatchRaySpec* out) {
    TraversalPipeline::RaySpec spec;
    source(i, &spec);
    out->reading = spec.reading;
    out->segment = RaySegment{spec.origin_W, spec.direction_W, spec.length_m};
  };
  if (use_worker) {
    // Batches cast and their forward models evaluated on the worker, updated here in order.
    const OccupancyUpdater& updater = *updater_;
    const lanes::Isa isa = *batch_isa_;
    const auto prepare = [&](const Reading* readings, RayBatch* batch) {
      updater.PrecomputeBatch(model, readings, isa, batch);
    };
    const auto sink = [&](const Reading* readings, const RayBatch& batch, uint64_t invalid) {
      stats.rays_invalid += invalid;
      ApplyBatch(readings, batch, model, &stats);
    };
    // std::function over reference wrappers: no allocation.
    batch_pipeline_->Run(count, RayBatchPipeline::Source(std::cref(batch_source)),
                         RayBatchPipeline::Prepare(std::cref(prepare)),
                         RayBatchPipeline::Sink(std::cref(sink)));
    record(true);
    return stats;
  }
  if (pipeline_ != nullptr) {
    const auto sink = [&](const TraversalPipeline::RaySpec& spec, const RayCells& ray) {
      ApplyCastRay(spec.reading, ray, model, &stats);
    };
    // The forward model reads no map: evaluate it on the worker too.
    const OccupancyUpdater& updater = *updater_;
    const auto prepare = [&](const TraversalPipeline::RaySpec& spec, RayCells* ray) {
      updater.PrecomputeRay(model, spec.reading, ray);
    };
    // std::function over reference wrappers: no allocation.
    const TraversalPipeline::Prepare prepare_fn(std::cref(prepare));
    pipeline_->Run(count, TraversalPipeline::Source(std::cref(source)), &prepare_fn,
                   TraversalPipeline::Sink(std::cref(sink)));
    return stats;
  }
  if (Batched()) {
    ApplyRayBatches(count, batch_source, model, &stats);
    record(false);
    return stats;
  }
  TraversalPipeline::RaySpec spec;
  for (int i = 0; i < count; ++i) {
    source(i, &spec);
    if (spec.reading.kind != ReadingKind::kInvalid) {
      caster_.CastWithLinearIndex(spec.origin_W, spec.direction_W, spec.length_m, &ray_);
    }
    ApplyCastRay(spec.reading, ray_, model, &stats);
  }
  return stats;
}

template <class Grid>
template <class Source>
void OccupancyMap<Grid>::ApplyRayBatches(int count, const Source& source, const SensorModel& model,
                                         ScanStats* stats) {
  RaySegment segments[lanes::kLanes];
  Reading readings[lanes::kLanes];
  int next = 0;
  while (next < count) {
    const int lanes_used =
        GatherLanes(source, count, &next, segments, readings, &stats->rays_invalid);
    caster_.CastBatch(segments, lanes_used, &batch_, *batch_isa_);
    updater_->PrecomputeBatch(model, readings, *batch_isa_, &batch_);
    ApplyBatch(readings, batch_, model, stats);
  }
}

template <class Grid>
ScanStats OccupancyMap<Grid>::ApplyDepthImage(const Pose3& X_WS, const DepthIntrinsics& in,
                                              const uint16_t* depth, int width, int height,
                                              double depth_scale_m, const SensorModel& model) {
  KESTREL_THROW_UNLESS(depth != nullptr && width > 0 && height > 0 &&
                           int64_t{width} * int64_t{height} <= int64_t{1} << 30,
                       "ApplyDepthImage: width = " << width << ", height = " << height
                                                   << ", accepted positive (at most 2^30 "
                                                      "pixels) with data");
  KESTREL_THROW_UNLESS(std::isfinite(in.fx) && in.fx > 0.0 && std::isfinite(in.fy) && in.fy > 0.0 &&
                           std::isfinite(in.cx) && std::isfinite(in.cy),
                       "ApplyDepthImage: intrinsics fx = " << in.fx << ", fy = " << in.fy
                                                           << ", accepted positive and finite");
  KESTREL_THROW_UNLESS(
      std::isfinite(depth_scale_m) && depth_scale_m > 0.0,
      "ApplyDepthImage: depth_scale_m = " << depth_scale_m << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(
      X_WS.p.allFinite() && X_WS.q.coeffs().allFinite() && std::abs(X_WS.q.norm() - 1.0) < 0.5,
      "ApplyDepthImage: pose must be finite with |q| in (0.5, 1.5), |q| = " << X_WS.q.norm());
  const Eigen::Matrix3d R_WS = X_WS.q.normalized().toRotationMatrix();
  const double inv_fx = 1.0 / in.fx;
  const double inv_fy = 1.0 / in.fy;
  const OccupancyUpdater& updater = *updater_;
  // Row-major: ray i is pixel (u, v) = (i % width, i / width).
  const auto source = [&](int i, TraversalPipeline::RaySpec* spec) {
    const int v = i / width;
    const int u = i - v * width;
    const uint16_t raw = depth[static_cast<size_t>(i)];
    const Eigen::Vector3d ray_S((u - in.cx) * inv_fx, (v - in.cy) * inv_fy, 1.0);
    const double norm = ray_S.norm();
    spec->origin_W = X_WS.p;
    spec->direction_W = R_WS * (ray_S / norm);
    // Depth is along the optical axis; the range along the pixel's ray is depth * |ray_S|.
    spec->reading = raw == 0 ? Reading{ReadingKind::kNoReturn, 0.0}
                             : model.Classify(raw * depth_scale_m * norm);
    if (spec->reading.kind != ReadingKind::kInvalid) {
      spec->length_m = updater.CastLength(model, spec->reading);
    }
  };
  return ApplyRays(ScanKind::kDepthImage, width * height, source, model);
}

template <class Grid>
ScanStats OccupancyMap<Grid>::ApplyPlanarScan(const Pose3& X_WS, double angle_min_rad,
                                              double angle_step_rad, const float* ranges_m,
                                              int count, const SensorModel& model) {
  KESTREL_THROW_UNLESS(count >= 0 && (count == 0 || ranges_m != nullptr),
                       "ApplyPlanarScan: count = " << count << ", accepted >= 0 with data");
  KESTREL_THROW_UNLESS(
      std::isfinite(angle_min_rad) && std::isfinite(angle_step_rad) && angle_step_rad > 0.0,
      "ApplyPlanarScan: angle_min_rad = " << angle_min_rad << ", angle_step_rad = "
                                          << angle_step_rad << ", accepted finite, step > 0");
  KESTREL_THROW_UNLESS(
      X_WS.p.allFinite() && X_WS.q.coeffs().allFinite() && std::abs(X_WS.q.norm() - 1.0) < 0.5,
      "ApplyPlanarScan: pose must be finite with |q| in (0.5, 1.5), |q| = " << X_WS.q.norm());
  const Eigen::Matrix3d R_WS = X_WS.q.normalized().toRotationMatrix();
  const OccupancyUpdater& updater = *updater_;
  const auto source = [&](int i, TraversalPipeline::RaySpec* spec) {
    const double angle = angle_min_rad + i * angle_step_rad;
    spec->origin_W = X_WS.p;
    spec->direction_W =
        (R_WS * Eigen::Vector3d(std::cos(angle), std::sin(angle), 0.0)).normalized();
    spec->reading = model.Classify(ranges_m[i]);
    if (spec->reading.kind != ReadingKind::kInvalid) {
      spec->length_m = updater.CastLength(model, spec->reading);
    }
  };
  return ApplyRays(ScanKind::kPlanarScan, count, source, model);
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

namespace {
void HashBytes(const void* data, size_t size, uint64_t* h) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < size; ++i) {
    *h ^= bytes[i];
    *h *= 1099511628211ull;  // FNV-1a 64
  }
}
}  // namespace

template <class Grid>
uint64_t OccupancyMap<Grid>::Hash() const {
  uint64_t h = 14695981039346656037ull;
  if constexpr (std::is_same_v<Grid, GrowingGrid>) {
    grid_.ForEachBlock([&](const CellIndex& origin, const GrowingGrid::Block& block) {
      HashBytes(&origin, sizeof(origin), &h);
      HashBytes(block.values, sizeof(block.values), &h);
    });
  } else {
    HashBytes(grid_.values().data(), grid_.values().size() * sizeof(float), &h);
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
