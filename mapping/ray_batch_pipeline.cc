#include "mapping/ray_batch_pipeline.h"

#include "common/check.h"

namespace kestrel {

bool WorkerChoice::NextUsesWorker() {
  ++scans_;
  if (rate_[1] == 0.0) return true;
  if (rate_[0] == 0.0) return false;
  const bool faster = rate_[1] > rate_[0];
  return scans_ % kProbePeriod == 0 ? !faster : faster;
}

void WorkerChoice::Record(bool worker, uint64_t rays, double seconds) {
  if (rays == 0 || !(seconds > 0.0)) return;
  const double rate = static_cast<double>(rays) / seconds;
  double& r = rate_[worker ? 1 : 0];
  r = r == 0.0 ? rate : 0.75 * r + 0.25 * rate;
}

RayBatchPipeline::RayBatchPipeline(double max_length_m, double resolution_m) {
  slots_.reserve(kSlots);
  for (int i = 0; i < kSlots; ++i) {
    slots_.push_back(std::make_unique<Slot>(max_length_m, resolution_m));
  }
  worker_ = std::thread([this] { WorkerLoop(); });
}

RayBatchPipeline::~RayBatchPipeline() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    shutdown_ = true;
  }
  cancel_ = true;
  worker_cv_.notify_all();
  worker_.join();
}

bool RayBatchPipeline::WaitFor(const Slot& slot, int want) const {
  for (int spins = 0; slot.state.load(std::memory_order_acquire) != want;) {
    if (cancel_.load(std::memory_order_relaxed)) return false;
    // Spin while the other side is probably running; then give the core away.
    if (spins < 256) {
      ++spins;
    } else {
      std::this_thread::yield();
    }
  }
  return true;
}

void RayBatchPipeline::WorkerLoop() {
  uint64_t seen_generation = 0;
  for (;;) {
    const Source* source;
    const Prepare* prepare;
    int count;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      worker_cv_.wait(lock, [&] { return shutdown_ || job_generation_ != seen_generation; });
      if (shutdown_) return;
      seen_generation = job_generation_;
      source = source_;
      prepare = prepare_;
      count = job_count_;
    }
    RaySegment segments[lanes::kLanes];
    int next = 0;
    for (size_t s = 0;; s = (s + 1) % slots_.size()) {
      Slot& slot = *slots_[s];
      if (!WaitFor(slot, kFree)) break;  // cancelled
      slot.error = nullptr;
      slot.invalid = 0;
      try {
        const int lanes_used =
            GatherLanes(*source, count, &next, segments, slot.readings, &slot.invalid);
        (*prepare)(segments, slot.readings, lanes_used, &slot.batch);
      } catch (...) {
        slot.error = std::current_exception();
      }
      slot.last = next >= count || slot.error != nullptr;
      const bool last = slot.last;
      slot.state.store(kFilled, std::memory_order_release);
      if (last) break;
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      job_active_ = false;
    }
    caller_cv_.notify_one();
  }
}

void RayBatchPipeline::Run(int count, const Source& source, const Prepare& prepare,
                           const Sink& sink) {
  if (count <= 0) return;
  for (auto& slot : slots_) slot->state.store(kFree, std::memory_order_relaxed);
  cancel_ = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    source_ = &source;
    prepare_ = &prepare;
    job_count_ = count;
    job_active_ = true;
    ++job_generation_;
  }
  worker_cv_.notify_one();
  std::exception_ptr error;
  for (size_t s = 0;; s = (s + 1) % slots_.size()) {
    Slot& slot = *slots_[s];
    WaitFor(slot, kFilled);  // never cancelled here: only this thread cancels
    const bool last = slot.last;
    if (slot.error) {
      error = slot.error;
    } else {
      try {
        sink(slot.readings, slot.batch, slot.invalid);
      } catch (...) {
        error = std::current_exception();
      }
    }
    if (error) {
      cancel_ = true;  // the worker stops at its next wait
      break;
    }
    slot.state.store(kFree, std::memory_order_release);
    if (last) break;
  }
  {
    // Wait until the worker is done with this job before the source goes out of scope.
    std::unique_lock<std::mutex> lock(mutex_);
    caller_cv_.wait(lock, [&] { return !job_active_; });
  }
  if (error) std::rethrow_exception(error);
}

}  // namespace kestrel
