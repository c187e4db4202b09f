#include "mapping/occupancy_updater.h"

#include <algorithm>
#include <cstdint>
#include <cstring>

#include "common/check.h"
#include "mapping/kernels/kernels.h"
#include "mapping/lanes.h"

namespace kestrel {
namespace {
float Logit(double p) { return static_cast<float>(std::log(p / (1.0 - p))); }
}  // namespace

ExactBayesUpdater::ExactBayesUpdater(const OccupancyLimits& limits, int capacity,
                                     double resolution_m)
    : limits_(limits),
      diagonal_m_(std::sqrt(3.0) * resolution_m),
      scratch_(capacity),
      lane_cells_(static_cast<size_t>(capacity)),
      lane_pointers_(static_cast<size_t>(capacity)),
      lane_priors_(static_cast<size_t>(capacity)) {
  limits_.Validate();
}

double ExactBayesUpdater::CastLength(const SensorModel& model, const Reading& reading) const {
  const double z_max = model.config().z_max_m;
  if (reading.kind != ReadingKind::kReturn) return z_max;
  // A surface_unknown return updates only the cells before its band (docs/algorithms.md §3.8).
  if (reading.surface_unknown) {
    return std::min(z_max, reading.z_m - reading.below_m + diagonal_m_ * (1.0 + 1e-9));
  }
  // Cells with d_k <= z + c sigma have entry <= z + c sigma and a chord of at most sqrt(3)
  // alpha, so casting this far gives them their full chords (their d_k unchanged); the factor
  // keeps a corner-to-corner chord clear of rounding.
  return std::min(z_max, model.GaussianReach(reading.z_m) + diagonal_m_ * (1.0 + 1e-9));
}

void ExactBayesUpdater::PrecomputeBatch(const SensorModel& model, const Reading* readings,
                                        const kernels::Kernels& kernels, RayBatch* batch) const {
  batch->has_likelihood = model.FillLikelihoods(readings, batch->count, batch->distance_m.data(),
                                                batch->longest, batch->likelihood.data(), kernels);
}

template <class ReadCell, class Store>
int ExactBayesUpdater::UpdateLane(const SensorModel& model, const Reading& reading,
                                  const RayBatch& batch, int lane, const ReadCell& read_cell,
                                  const Store& store, uint64_t* cells_written) {
  const int n = batch.size[lane];
  KESTREL_DEMAND(n <= scratch_.capacity());
  const LaneView distance{batch.distance_m.data() + lane};
  const LaneView likelihood{batch.has_likelihood ? batch.likelihood.data() + lane : nullptr};
  float* const priors = lane_priors_.data();
  // docs/algorithms.md §4.1 and §4.7 with the cells read once (their indices and values kept in
  // order), then the write step, P'_k = scale_k P_k segment by segment, by the kernels.
  const ExactForward f = ExactUpdate::Forward(
      model, reading, distance, n,
      [&](int k) {
        priors[k] = read_cell(k);
        return static_cast<double>(priors[k]);
      },
      &scratch_, likelihood);
  *cells_written += static_cast<uint64_t>(f.end - f.first);
  int changed = 0;
  for (int i = 0; i < f.segment_count; ++i) {
    const ExactForward::Segment& seg = f.segments[i];
    const double* const scale = seg.per_cell ? scratch_.scale() + seg.begin : &seg.scale;
    changed += store(scale, seg.per_cell, seg.begin, seg.end - seg.begin, changed);
  }
  return changed;
}

int ExactBayesUpdater::UpdateBatchLane(const SensorModel& model, const Reading& reading,
                                       const RayBatch& batch, int lane, float* base,
                                       const kernels::Kernels& kernels, uint64_t* cells_written,
                                       int* changed) {
  const int32_t* const linear = batch.linear_index.data() + lane;
  int32_t* const cells = lane_cells_.data();
  const float* const priors = lane_priors_.data();
  return UpdateLane(
      model, reading, batch, lane,
      [&](int k) {
        const int32_t cell = linear[static_cast<ptrdiff_t>(k) * lanes::kLanes];
        cells[k] = cell;
        return base[cell];
      },
      [&](const double* scale, bool per_cell, int first, int count, int listed) {
        return kernels.store_posteriors(scale, per_cell, priors + first, cells + first, first,
                                        count, limits_.p_min, base, changed + listed);
      },
      cells_written);
}

int ExactBayesUpdater::UpdateBatchLaneAt(const SensorModel& model, const Reading& reading,
                                         const RayBatch& batch, int lane, float* const* cells,
                                         const kernels::Kernels& kernels, uint64_t* cells_written,
                                         int* changed) {
  float** const pointers = lane_pointers_.data();
  const float* const priors = lane_priors_.data();
  return UpdateLane(
      model, reading, batch, lane,
      [&](int k) {
        float* const cell = cells[static_cast<ptrdiff_t>(k) * lanes::kLanes];
        pointers[k] = cell;
        return *cell;
      },
      [&](const double* scale, bool per_cell, int first, int count, int listed) {
        return kernels.store_posteriors_at(scale, per_cell, priors + first, pointers + first, first,
                                           count, limits_.p_min, changed + listed);
      },
      cells_written);
}

void LogOddsConfig::Validate() const {
  KESTREL_THROW_UNLESS(p_hit > 0.5 && p_hit < 1.0,
                       "log-odds p_hit = " << p_hit << ", accepted (0.5, 1)");
  KESTREL_THROW_UNLESS(p_miss > 0.0 && p_miss < 0.5,
                       "log-odds p_miss = " << p_miss << ", accepted (0, 0.5)");
  KESTREL_THROW_UNLESS(p_clamp_min > 0.0 && p_clamp_min <= p_unknown && p_unknown <= p_clamp_max &&
                           p_clamp_max < 1.0,
                       "log-odds clamps: p_clamp_min = " << p_clamp_min
                                                         << ", p_unknown = " << p_unknown
                                                         << ", p_clamp_max = " << p_clamp_max
                                                         << ", accepted 0 < min <= unknown <= "
                                                            "max < 1");
}

LogOddsUpdater::LogOddsUpdater(const LogOddsConfig& config) : config_(config) {
  config_.Validate();
  hit_ = Logit(config_.p_hit);
  miss_ = Logit(config_.p_miss);
  min_ = Logit(config_.p_clamp_min);
  max_ = Logit(config_.p_clamp_max);
  initial_ = Logit(config_.p_unknown);
}

double LogOddsUpdater::CastLength(const SensorModel& model, const Reading& reading) const {
  return reading.kind == ReadingKind::kReturn ? reading.z_m : model.config().z_max_m;
}

int LogOddsUpdater::UpdateBatchLane(const SensorModel& /*model*/, const Reading& reading,
                                    const RayBatch& batch, int lane, float* base,
                                    const kernels::Kernels& /*kernels*/, uint64_t* cells_written,
                                    int* changed) {
  const int32_t* const linear = batch.linear_index.data() + lane;
  return Update(
      reading, batch.size[lane], batch.left_bounds[lane],
      [base, linear](int k) -> float& {
        return base[linear[static_cast<ptrdiff_t>(k) * lanes::kLanes]];
      },
      cells_written, changed);
}

int LogOddsUpdater::UpdateBatchLaneAt(const SensorModel& /*model*/, const Reading& reading,
                                      const RayBatch& batch, int lane, float* const* cells,
                                      const kernels::Kernels& /*kernels*/, uint64_t* cells_written,
                                      int* changed) {
  return Update(
      reading, batch.size[lane], batch.left_bounds[lane],
      [cells](int k) -> float& { return *cells[static_cast<ptrdiff_t>(k) * lanes::kLanes]; },
      cells_written, changed);
}

template <class CellAt>
int LogOddsUpdater::Update(const Reading& reading, int n, bool left_bounds, const CellAt& cell_at,
                           uint64_t* cells_written, int* changed) {
  int m = 0;
  for (int k = 0; k < n; ++k) {
    float& cell = cell_at(k);
    const float prior = cell;
    // The end point's cell is the last one cast for a return: a hit (OctoMap updateNode(hit)).
    // A ray that ended at the map limits never reached its end point: all misses.
    const bool hit = reading.kind == ReadingKind::kReturn && k == n - 1 && !left_bounds;
    const float stored = std::clamp(prior + (hit ? hit_ : miss_), min_, max_);
    changed[m] = k;
    m += stored != prior ? 1 : 0;
    cell = stored;
  }
  *cells_written += static_cast<uint64_t>(n);
  return m;
}

}  // namespace kestrel
