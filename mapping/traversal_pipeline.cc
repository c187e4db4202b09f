#include "mapping/traversal_pipeline.h"

#include "common/check.h"

namespace kestrel {

TraversalPipeline::TraversalPipeline(const GridGeometry& geometry, double max_length_m)
    : caster_(geometry) {
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
      {
        std::unique_lock<std::mutex> lock(mutex_);
        worker_cv_.wait(lock, [&] { return shutdown_ || cancel_ || !batch.filled; });
        if (shutdown_) return;
        if (cancel_) break;
      }
      const int first = b * kBatchRays;
      batch.count = std::min(kBatchRays, count - first);
      batch.error = nullptr;
      try {
        for (int i = 0; i < batch.count; ++i) {
          RaySpec& spec = batch.specs[i];
          (*source)(first + i, &spec);
          if (spec.reading.kind == ReadingKind::kInvalid) {
            batch.rays[i].size = 0;
            continue;
          }
          caster_.Cast(spec.origin_W, spec.direction_W, spec.length_m, &batch.rays[i]);
          if (prepare != nullptr) (*prepare)(spec, &batch.rays[i]);
        }
      } catch (...) {
        batch.error = std::current_exception();
      }
      {
        std::lock_guard<std::mutex> lock(mutex_);
        batch.filled = true;
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
    {
      std::unique_lock<std::mutex> lock(mutex_);
      caller_cv_.wait(lock, [&] { return batch.filled; });
    }
    if (batch.error) {
      error = batch.error;
    } else {
      try {
        for (int i = 0; i < batch.count; ++i) sink(batch.specs[i], batch.rays[i]);
      } catch (...) {
        error = std::current_exception();
      }
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      batch.filled = false;
      if (error) cancel_ = true;
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
