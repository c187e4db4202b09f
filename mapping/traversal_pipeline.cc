#include "mapping/traversal_pipeline.h"

#include <algorithm>

#include "common/check.h"

namespace kestrel {

TraversalPipeline::TraversalPipeline(const GridGeometry& geometry, double max_length_m,
                                     bool cells_needed)
    : caster_(geometry), cells_needed_(cells_needed) {
  batches_.resize(kBatches);
  for (Batch& b : batches_) {
    b.specs.resize(kBatchRays);
    b.rays.reserve(kBatchRays);
    for (int i = 0; i < kBatchRays; ++i) b.rays.emplace_back(max_length_m, geometry.resolution_m());
  }
  worker_ = std::thread([this] { WorkerLoop(); });
}

TraversalPipeline::~TraversalPipeline() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    shutdown_ = true;
  }
  worker_cv_.notify_all();
  worker_.join();
}

void TraversalPipeline::CastRay(const RaySpec& spec, RayCells* ray) const {
  if (cells_needed_) {
    caster_.CastWithLinearIndex(spec.origin_W, spec.direction_W, spec.length_m, ray);
  } else {
    caster_.CastLinearOnly(spec.origin_W, spec.direction_W, spec.length_m, ray);
  }
}

void TraversalPipeline::WorkerLoop() {
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
    const int batches = (count + kBatchRays - 1) / kBatchRays;
    for (int b = 0; b < batches; ++b) {
      Batch& batch = batches_[b % kBatches];
      bool ahead;
      int share;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        worker_cv_.wait(lock, [&] { return shutdown_ || cancel_ || !batch.filled; });
        if (shutdown_) return;
        if (cancel_) break;
        ahead = pending_ >= kBatches / 2;
        share = worker_share_;
      }
      // Balance the two threads: the optional prepare step runs here only while the caller is
      // the slower side (half the batches or more wait for it); otherwise the caller's update
      // does that work itself. Either way the values are the same (the header comment).
      const Prepare* const prepare_now = ahead ? prepare : nullptr;
      const int first = b * kBatchRays;
      batch.count = std::min(kBatchRays, count - first);
      batch.worker_count = std::min(batch.count, share);
      batch.error = nullptr;
      try {
        for (int i = 0; i < batch.worker_count; ++i) {
          RaySpec& spec = batch.specs[i];
          (*source)(first + i, &spec);
          if (spec.reading.kind == ReadingKind::kInvalid) {
            batch.rays[i].size = 0;
            continue;
          }
          CastRay(spec, &batch.rays[i]);
          if (prepare_now != nullptr) (*prepare_now)(spec, &batch.rays[i]);
        }
      } catch (...) {
        batch.error = std::current_exception();
      }
      {
        std::lock_guard<std::mutex> lock(mutex_);
        batch.filled = true;
        ++pending_;
      }
      caller_cv_.notify_one();
      if (batch.error) break;
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      job_active_ = false;
    }
    caller_cv_.notify_one();
  }
}

void TraversalPipeline::Run(int count, const Source& source, const Sink& sink) {
  Run(count, source, nullptr, sink);
}

void TraversalPipeline::Run(int count, const Source& source, const Prepare* prepare,
                            const Sink& sink) {
  if (count <= 0) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (Batch& b : batches_) b.filled = false;
    pending_ = 0;
    source_ = &source;
    prepare_ = prepare;
    job_count_ = count;
    job_active_ = true;
    cancel_ = false;
    ++job_generation_;
  }
  worker_cv_.notify_one();
  std::exception_ptr error;
  const int batches = (count + kBatchRays - 1) / kBatchRays;
  for (int b = 0; b < batches && !error; ++b) {
    Batch& batch = batches_[b % kBatches];
    bool waited;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      waited = !batch.filled;
      caller_cv_.wait(lock, [&] { return batch.filled; });
    }
    if (batch.error) {
      error = batch.error;
    } else {
      try {
        // The rays the worker left to this thread (load balancing, header comment).
        const int first = b * kBatchRays;
        for (int i = batch.worker_count; i < batch.count; ++i) {
          RaySpec& spec = batch.specs[i];
          source(first + i, &spec);
          if (spec.reading.kind == ReadingKind::kInvalid) {
            batch.rays[i].size = 0;
            continue;
          }
          CastRay(spec, &batch.rays[i]);
        }
        for (int i = 0; i < batch.count; ++i) sink(batch.specs[i], batch.rays[i]);
      } catch (...) {
        error = std::current_exception();
      }
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      batch.filled = false;
      --pending_;
      if (error) cancel_ = true;
      // Balance: this thread waited for the worker -> cast a few more rays per batch here; the
      // worker is ahead (half the batches wait) -> leave it more.
      constexpr int kShareStep = kBatchRays / 16;
      if (waited) {
        worker_share_ = std::max(kBatchRays / 4, worker_share_ - kShareStep);
      } else if (pending_ >= kBatches / 2) {
        worker_share_ = std::min(kBatchRays, worker_share_ + kShareStep);
      }
    }
    worker_cv_.notify_one();
  }
  {
    // Wait until the worker is done with this job before the source goes out of scope.
    std::unique_lock<std::mutex> lock(mutex_);
    caller_cv_.wait(lock, [&] { return !job_active_; });
  }
  if (error) std::rethrow_exception(error);
}

}  // namespace kestrel
