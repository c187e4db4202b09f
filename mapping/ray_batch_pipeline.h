#pragma once
/// @file
/// Batched ray casting on a second core (docs/algorithms.md §13: traversal of the next rays on
/// one core while the other applies updates in order): a worker thread fills a ring of
/// RayBatch slots, eight rays each (the source, then the prepare step: RayCaster::CastBatch and
/// the map-independent work, e.g. a_k), while the caller consumes the slots strictly in order.
/// Neither step on the worker reads the map, so the map is bit-identical to a single thread's.
/// The scan integrator's one worker pipeline (mapping/scan_integrator.h); RunInline does the
/// same steps on the caller's thread alone.
///
/// Hand-over is by one atomic state per slot; a side that waits spins briefly, then yields its
/// core (on a shared machine the other side may not be running). The worker and the slots are
/// created once; Run allocates nothing.
///
/// On the 2-vCPU development machine (bench/mapping, BM_KestrelExactThreaded_*) it is faster than
/// one thread in some spells and slower in others (each ray's d_k, cell indices and a_k cross
/// between the cores, and what that costs depends on where the host places the two vCPUs;
/// docs/STATUS.md, "Mapping"), so it is off by default.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "mapping/lanes.h"
#include "mapping/ray_caster.h"
#include "mapping/sensor_model.h"

namespace kestrel {

/// One ray to integrate: the segment to cast and the reading along it; a kInvalid reading is
/// not cast.
struct RaySpec {
  RaySegment segment;  ///< what to cast
  Reading reading;     ///< the reading along it
};

/// Takes rays *next, *next + 1, ... (below count) from source(index, RaySpec*) until eight
/// carry information: their segments and readings fill the lanes, in order; the invalid ones
/// are skipped and added to *invalid. Returns the lanes filled (0 once the rays run out).
template <class Source>
int GatherLanes(const Source& source, int count, int* next, RaySegment segments[lanes::kLanes],
                Reading readings[lanes::kLanes], uint64_t* invalid) {
  RaySpec spec;
  int lanes_used = 0;
  for (; *next < count && lanes_used < lanes::kLanes; ++*next) {
    source(*next, &spec);
    if (spec.reading.kind == ReadingKind::kInvalid) {
      ++*invalid;
      continue;
    }
    segments[lanes_used] = spec.segment;
    readings[lanes_used] = spec.reading;
    ++lanes_used;
  }
  return lanes_used;
}

/// Chooses, scan by scan, whether a kind of scan goes through the worker or stays on one
/// thread: whichever has been faster in rays per wall second (exponentially averaged), trying
/// the other one every kProbePeriod-th scan so that a change of speed is noticed. The map is the
/// same either way; only the time differs. Pure logic (the caller times the scans).
class WorkerChoice {
 public:
  /// Every this many scans the slower way is tried again.
  static constexpr int kProbePeriod = 16;
  /// Whether the next scan should use the worker (an untried way is tried first).
  [[nodiscard]] bool NextUsesWorker();
  /// The scan just applied: `rays` in `seconds` of wall time, with or without the worker.
  void Record(bool worker, uint64_t rays, double seconds);
  /// Averaged rays per second with (true) or without the worker; 0 until tried.
  [[nodiscard]] double rate(bool worker) const { return rate_[worker ? 1 : 0]; }

 private:
  double rate_[2] = {0.0, 0.0};
  uint64_t scans_{0};
};

/// Casts batches of rays on a worker thread, hands them to the caller in order.
class RayBatchPipeline {
 public:
  /// Slots in the ring (eight rays each).
  static constexpr int kSlots = 32;

  /// Fills the spec of ray `index` (runs on the worker; must only read shared data).
  using Source = std::function<void(int index, RaySpec* spec)>;
  /// Casts the lanes' segments into *batch and does the map-independent work on it (runs on the
  /// worker), e.g. a_k.
  using Prepare = std::function<void(const RaySegment* segments, const Reading* readings, int count,
                                     RayBatch* batch)>;
  /// Consumes a batch on the caller's thread, in ray order: its lanes' readings, the batch,
  /// and the invalid readings skipped since the previous batch.
  using Sink =
      std::function<void(const Reading* readings, const RayBatch& batch, uint64_t invalid)>;

  /// A worker whose slots hold rays up to `max_length_m` long on lattices of edge
  /// `resolution_m`.
  RayBatchPipeline(double max_length_m, double resolution_m);
  ~RayBatchPipeline();
  RayBatchPipeline(const RayBatchPipeline&) = delete;
  RayBatchPipeline& operator=(const RayBatchPipeline&) = delete;

  /// Runs rays 0..count-1 of `source`: cast and prepared on the worker, consumed by `sink` here
  /// in order. Exceptions from the source, prepare or the sink are rethrown here after the
  /// worker has stopped on this job.
  void Run(int count, const Source& source, const Prepare& prepare, const Sink& sink);

  /// The same steps on this thread alone, with `batch` as the one slot: the same batches reach
  /// the sink, in the same order.
  template <class SourceFn, class PrepareFn, class SinkFn>
  static void RunInline(int count, const SourceFn& source, const PrepareFn& prepare,
                        const SinkFn& sink, RayBatch* batch) {
    RaySegment segments[lanes::kLanes];
    Reading readings[lanes::kLanes];
    int next = 0;
    while (next < count) {
      uint64_t invalid = 0;
      const int lanes_used = GatherLanes(source, count, &next, segments, readings, &invalid);
      prepare(segments, readings, lanes_used, batch);
      sink(readings, *batch, invalid);
    }
  }

 private:
  enum SlotState : int { kFree = 0, kFilled = 1 };
  struct Slot {
    explicit Slot(double max_length_m, double resolution_m) : batch(max_length_m, resolution_m) {}
    RayBatch batch;
    Reading readings[lanes::kLanes];
    uint64_t invalid{0};  // invalid readings skipped before this batch's rays
    bool last{false};     // no rays after this batch
    std::exception_ptr error;
    std::atomic<int> state{kFree};
  };

  void WorkerLoop();
  // Waits until slot.state == want, or the job is cancelled (returns false).
  bool WaitFor(const Slot& slot, int want) const;

  std::vector<std::unique_ptr<Slot>> slots_;
  std::atomic<bool> cancel_{false};
  // Job hand-over, guarded by mutex_.
  std::mutex mutex_;
  std::condition_variable worker_cv_;
  std::condition_variable caller_cv_;
  const Source* source_{nullptr};
  const Prepare* prepare_{nullptr};
  int job_count_{0};
  uint64_t job_generation_{0};
  bool job_active_{false};
  bool shutdown_{false};
  std::thread worker_;
};

}  // namespace kestrel
