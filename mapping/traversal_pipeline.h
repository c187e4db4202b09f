#pragma once
/// @file
/// Ray traversal on a second core (docs/algorithms.md §13): a worker
/// thread casts the rays of a scan ahead of the caller in batches, while the caller applies the
/// updates strictly in ray order. Traversal reads no map, so the result is bit-identical to
/// casting and applying one ray at a time. The worker and its batches (kBatches x kBatchRays ray
/// scratches) are created once; Run allocates nothing per ray.
/// Load balancing (timing-dependent, results not): when the caller has to wait for the worker,
/// the worker leaves the last rays of each batch for the caller to cast itself (at least a
/// quarter stay with the worker); when the worker runs ahead, it takes them back and then also
/// runs the optional prepare step.

#include <Eigen/Core>
#include <condition_variable>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "mapping/ray_caster.h"
#include "mapping/sensor_model.h"

namespace kestrel {

/// Casts rays on a worker thread, hands them back in order.
class TraversalPipeline {
 public:
  /// Rays per batch.
  static constexpr int kBatchRays = 64;
  /// Batches in flight.
  static constexpr int kBatches = 4;

  /// One ray to cast: filled by the source on the worker thread.
  struct RaySpec {
    Eigen::Vector3d origin_W{Eigen::Vector3d::Zero()};      ///< m, W
    Eigen::Vector3d direction_W{Eigen::Vector3d::UnitX()};  ///< unit, W
    Reading reading;                                        ///< kInvalid: not cast
    double length_m{0.0};                                   ///< cast length, m
  };
  /// Fills the spec of ray `index` (runs on either thread; must only read shared data).
  using Source = std::function<void(int index, RaySpec* spec)>;
  /// Consumes a cast ray (runs on the caller's thread, in index order).
  using Sink = std::function<void(const RaySpec& spec, const RayCells& cells)>;
  /// Optional work on a cast ray that reads no map (runs on the worker after the cast, but only
  /// while the worker is ahead of the caller: the sink must do the same work itself when it was
  /// skipped, and get the same values, so that results never depend on the timing).
  using Prepare = std::function<void(const RaySpec& spec, RayCells* cells)>;

  /// A worker casting through `geometry` rays up to `max_length_m` long. With `cells_needed`
  /// false, rays on a lattice with linear indices carry those instead of their CellIndex
  /// (RayCaster::CastLinearOnly: fewer bytes cross between the threads); otherwise both.
  TraversalPipeline(const GridGeometry& geometry, double max_length_m, bool cells_needed = true);
  ~TraversalPipeline();
  TraversalPipeline(const TraversalPipeline&) = delete;
  TraversalPipeline& operator=(const TraversalPipeline&) = delete;

  /// Casts rays 0..count-1 from `source` on the worker and feeds them to `sink` in order.
  /// Exceptions from the source, the caster or the sink are rethrown here after the worker has
  /// stopped on this job.
  void Run(int count, const Source& source, const Sink& sink);
  /// Same, with `prepare` applied to each cast ray on the worker (null: none).
  void Run(int count, const Source& source, const Prepare* prepare, const Sink& sink);

 private:
  struct Batch {
    std::vector<RaySpec> specs;
    std::vector<RayCells> rays;
    int count{0};
    int worker_count{0};  // rays [0, worker_count) cast by the worker, the rest by the caller
    bool filled{false};
    std::exception_ptr error;
  };
  void WorkerLoop();

  // Casts one ray as configured (cells_needed_).
  void CastRay(const RaySpec& spec, RayCells* ray) const;

  RayCaster caster_;
  bool cells_needed_;
  std::vector<Batch> batches_;
  std::mutex mutex_;
  std::condition_variable worker_cv_;
  std::condition_variable caller_cv_;
  // Job state, guarded by mutex_.
  const Source* source_{nullptr};
  const Prepare* prepare_{nullptr};
  int job_count_{0};
  int pending_{0};                // batches filled and not yet consumed
  int worker_share_{kBatchRays};  // rays per batch the worker casts (load balancing)
  uint64_t job_generation_{0};
  bool job_active_{false};
  bool cancel_{false};
  bool shutdown_{false};
  std::thread worker_;
};

}  // namespace kestrel
