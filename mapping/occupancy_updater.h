#pragma once
/// @file
/// How one ray's reading changes the cells it crosses, behind one interface so that Kestrel's
/// exact model and an OctoMap-style log-odds baseline can be run on identical data:
///  - ExactBayesUpdater: the exact inverse sensor model (docs/algorithms.md §4.1); cells store
///    the probability P(m_i) as float, clamped to [P_min, 1 - P_min] (docs/algorithms.md §1.2).
///  - LogOddsUpdater: OctoMap's update (hit 0.7 / miss 0.4, clamping 0.12 / 0.97); cells store
///    log-odds as float. The cell holding a return's end point is a hit, every other cell the ray
///    crosses up to it a miss; "no return" clears the whole ray to z_max (OctoMap's maxrange).
/// Each update reports which cells it changed, so that the map can keep H(map)
/// (docs/algorithms.md §5) up to date per chunk of cells. Rays come cast in batches
/// (RayCaster::CastBatch) and are updated one lane (ray) at a time, in order.

#include <cmath>
#include <memory>
#include <vector>

#include "mapping/grid.h"
#include "mapping/inverse_sensor_model.h"
#include "mapping/ray_caster.h"
#include "mapping/sensor_model.h"

namespace kestrel {

namespace kernels {
struct Kernels;  // one instruction set's kernels (kernels/kernels.h)
}  // namespace kernels

/// Binary entropy H(p) = -p ln p - (1-p) ln(1-p), nats (eq. 5); H(0) = H(1) = 0.
[[nodiscard]] inline double BinaryEntropy(double p) {
  if (p <= 0.0 || p >= 1.0) return 0.0;
  return -p * std::log(p) - (1.0 - p) * std::log(1.0 - p);
}

/// BinaryEntropy of a stored float probability: 1 - p is exact in double for a float p, so
/// log(1 - p) loses nothing against log1p(-p).
[[nodiscard]] inline double BinaryEntropy(float p) { return BinaryEntropy(static_cast<double>(p)); }

/// The per-ray update rule and the meaning of a stored cell value. Not thread-safe (owns its
/// scratch); one per map.
class OccupancyUpdater {
 public:
  virtual ~OccupancyUpdater() = default;
  /// Short name for reports ("exact", "log_odds").
  [[nodiscard]] virtual const char* name() const = 0;
  /// Stored value of a cell no reading has touched.
  [[nodiscard]] virtual float initial_value() const = 0;
  /// Occupancy probability a stored value stands for.
  [[nodiscard]] virtual double ProbabilityOf(float stored) const = 0;
  /// How far (m) the ray must be cast for this reading (kReturn or kNoReturn).
  [[nodiscard]] virtual double CastLength(const SensorModel& model,
                                          const Reading& reading) const = 0;
  /// Work for the readings of a cast batch that reads no map, eight rays at once with `kernels`
  /// (ExactBayesUpdater: a_k, SensorModel::FillLikelihoods, where that is faster); done on the
  /// scan integrator's worker thread when there is one. Must be thread-safe (const, no scratch).
  virtual void PrecomputeBatch(const SensorModel& /*model*/, const Reading* /*readings*/,
                               const kernels::Kernels& /*kernels*/, RayBatch* /*batch*/) const {}
  /// Updates the stored values of the cells of lane `lane` of a batch cast by
  /// RayCaster::CastBatch (and maybe PrecomputeBatch) for `reading` (kReturn or kNoReturn):
  /// cell k (k < batch.size[lane]) is stored at base[batch.linear_index[RayBatch::At(k, lane)]]
  /// (a DenseGrid's values). Writes the indices k of the cells whose stored value changed,
  /// ascending, to changed[0 .. m) (room for batch.size[lane] entries) and returns m; adds the
  /// cells written to *cells_written. The same values with every instruction set's `kernels`.
  virtual int UpdateBatchLane(const SensorModel& model, const Reading& reading,
                              const RayBatch& batch, int lane, float* base,
                              const kernels::Kernels& kernels, uint64_t* cells_written,
                              int* changed) = 0;
  /// Same as UpdateBatchLane with cell k stored at *cells[RayBatch::At(k, 0)] (cells in the
  /// batch's layout, from the lane's first; a GrowingGrid's blocks).
  virtual int UpdateBatchLaneAt(const SensorModel& model, const Reading& reading,
                                const RayBatch& batch, int lane, float* const* cells,
                                const kernels::Kernels& kernels, uint64_t* cells_written,
                                int* changed) = 0;
};

/// Kestrel's exact update (docs/algorithms.md §4.1), float storage, double accumulation.
class ExactBayesUpdater final : public OccupancyUpdater {
 public:
  /// Scratch for rays of up to `capacity` cells on a lattice of edge `resolution_m`.
  /// @throws std::invalid_argument if limits.Validate() throws.
  ExactBayesUpdater(const OccupancyLimits& limits, int capacity, double resolution_m);
  [[nodiscard]] const char* name() const override { return "exact"; }
  [[nodiscard]] float initial_value() const override { return static_cast<float>(limits_.p_init); }
  [[nodiscard]] double ProbabilityOf(float stored) const override { return stored; }
  /// A return needs the cells up to z + c sigma (the shortcut) plus one cell diagonal, so the
  /// last kept cell's chord is complete; "no return" runs to z_max.
  [[nodiscard]] double CastLength(const SensorModel& model, const Reading& reading) const override;
  /// Fills batch->likelihood where SensorModel::FillLikelihoods can (has_likelihood).
  void PrecomputeBatch(const SensorModel& model, const Reading* readings,
                       const kernels::Kernels& kernels, RayBatch* batch) const override;
  int UpdateBatchLane(const SensorModel& model, const Reading& reading, const RayBatch& batch,
                      int lane, float* base, const kernels::Kernels& kernels,
                      uint64_t* cells_written, int* changed) override;
  int UpdateBatchLaneAt(const SensorModel& model, const Reading& reading, const RayBatch& batch,
                        int lane, float* const* cells, const kernels::Kernels& kernels,
                        uint64_t* cells_written, int* changed) override;
  /// The clamp and prior.
  [[nodiscard]] const OccupancyLimits& limits() const { return limits_; }

 private:
  // The update of lane `lane` of `batch` (a_k from the batch if it holds them): cell k's stored
  // value from read_cell(k) (once, in order), then for each segment of cells written
  // (ExactForward) store(scale, per_cell, first, count, listed) writes their posteriors, lists
  // the changed ones from `listed` on and returns how many.
  template <class ReadCell, class Store>
  int UpdateLane(const SensorModel& model, const Reading& reading, const RayBatch& batch, int lane,
                 const ReadCell& read_cell, const Store& store, uint64_t* cells_written);

  OccupancyLimits limits_;
  double diagonal_m_;  // sqrt(3) alpha: the longest chord through one cell, m
  InverseSensorModelScratch scratch_;
  // UpdateBatchLane(At): the lane's cell indices or addresses and priors (as stored).
  std::vector<int32_t> lane_cells_;
  std::vector<float*> lane_pointers_;
  std::vector<float> lane_priors_;
};

/// OctoMap's defaults for the log-odds baseline.
struct LogOddsConfig {
  double p_hit{0.7};         ///< probability a hit stands for (OctoMap prob_hit)
  double p_miss{0.4};        ///< probability a miss stands for (OctoMap prob_miss)
  double p_clamp_min{0.12};  ///< lower clamping threshold (OctoMap clamping_thres_min)
  double p_clamp_max{0.97};  ///< upper clamping threshold (OctoMap clamping_thres_max)
  double p_unknown{0.5};     ///< value of an untouched cell (OctoMap: log-odds 0)

  /// @throws std::invalid_argument unless 0 < p_miss < 0.5 < p_hit < 1 and
  /// 0 < p_clamp_min <= p_unknown <= p_clamp_max < 1.
  void Validate() const;
};

/// OctoMap-style log-odds update (file comment).
class LogOddsUpdater final : public OccupancyUpdater {
 public:
  /// @throws std::invalid_argument if config.Validate() throws.
  explicit LogOddsUpdater(const LogOddsConfig& config);
  [[nodiscard]] const char* name() const override { return "log_odds"; }
  [[nodiscard]] float initial_value() const override { return initial_; }
  [[nodiscard]] double ProbabilityOf(float stored) const override {
    return 1.0 / (1.0 + std::exp(-static_cast<double>(stored)));
  }
  /// A return: to z (the end-point cell is the last); "no return": z_max.
  [[nodiscard]] double CastLength(const SensorModel& model, const Reading& reading) const override;
  int UpdateBatchLane(const SensorModel& model, const Reading& reading, const RayBatch& batch,
                      int lane, float* base, const kernels::Kernels& kernels,
                      uint64_t* cells_written, int* changed) override;
  int UpdateBatchLaneAt(const SensorModel& model, const Reading& reading, const RayBatch& batch,
                        int lane, float* const* cells, const kernels::Kernels& kernels,
                        uint64_t* cells_written, int* changed) override;
  /// The parameters.
  [[nodiscard]] const LogOddsConfig& config() const { return config_; }

 private:
  // The update of a ray of n cells (left_bounds: it ended at the map limits) with cell k's value
  // at cell_at(k) (a float&).
  template <class CellAt>
  int Update(const Reading& reading, int n, bool left_bounds, const CellAt& cell_at,
             uint64_t* cells_written, int* changed);

  LogOddsConfig config_;
  float hit_, miss_, min_, max_, initial_;
};

}  // namespace kestrel
