#include "mapping/ray_batch_pipeline.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

#include "mapping/kernels/kernels.h"

namespace kestrel {
namespace {

// Ray i of the tests: a fan from one origin; every 5th reading invalid.
RaySpec SpecOf(int i, int run) {
  const double a = 0.01 * i + run;
  RaySpec spec;
  spec.segment.origin_W = Eigen::Vector3d(0.1, 0.2, 0.7);
  spec.segment.direction_W =
      Eigen::Vector3d(std::cos(a), std::sin(a), 0.1 * std::sin(3 * a)).normalized();
  spec.reading = i % 5 == 0 ? Reading{} : Reading{ReadingKind::kReturn, 1.0 + (i % 30) * 0.1};
  spec.segment.length_m = spec.reading.z_m;
  return spec;
}

// On every instruction set: the batches come back in ray order, each lane with exactly what
// CastBatch gives that ray on the caller's thread, the prepare step applied, and the invalid
// readings counted where they were skipped; repeated runs reuse the worker. RunInline hands the
// sink the same batches.
TEST(RayBatchPipeline, ReturnsBatchesInOrderAsCastInline) {
  const GridGeometry g = GridGeometry::Fixed(MapLimits{});
  const RayCaster caster(g);
  RayBatchPipeline pipeline(4.0, g.resolution_m());
  for (const kernels::Kernels* isa : kernels::Supported()) {
    SCOPED_TRACE(isa->name);
    RayBatch expected(4.0, g.resolution_m());
    RayBatch inline_batch(4.0, g.resolution_m());
    for (int run = 0; run < 4; ++run) {
      const int count = 1000 + 37 * run;  // not a multiple of 8, more batches than slots
      const auto source = [&](int i, RaySpec* spec) { *spec = SpecOf(i, run); };
      const auto prepare = [&](const RaySegment* segments, const Reading*, int lanes_used,
                               RayBatch* batch) {
        caster.CastBatch(segments, lanes_used, batch, *isa);
        batch->likelihood[0] = 42.0;
      };
      int next = 0;  // the next source ray this side expects
      uint64_t invalid_seen = 0, invalid_expected = 0;
      const auto sink = [&](const Reading* readings, const RayBatch& batch, uint64_t invalid) {
        // The eight valid rays from `next` on, as this thread would cast them.
        RaySegment segments[lanes::kLanes];
        int lanes_used = 0;
        for (; next < count && lanes_used < lanes::kLanes; ++next) {
          const RaySpec spec = SpecOf(next, run);
          if (spec.reading.kind == ReadingKind::kInvalid) {
            ++invalid_expected;
            continue;
          }
          ASSERT_EQ(readings[lanes_used].z_m, spec.reading.z_m);
          segments[lanes_used++] = spec.segment;
        }
        invalid_seen += invalid;
        ASSERT_EQ(invalid_seen, invalid_expected);
        ASSERT_EQ(batch.count, lanes_used);
        ASSERT_EQ(batch.likelihood[0], 42.0);  // prepared on the worker
        caster.CastBatch(segments, lanes_used, &expected, *isa);
        for (int l = 0; l < lanes_used; ++l) {
          ASSERT_EQ(batch.size[l], expected.size[l]);
          for (int k = 0; k < batch.size[l]; ++k) {
            ASSERT_EQ(batch.distance_m[RayBatch::At(k, l)],
                      expected.distance_m[RayBatch::At(k, l)]);
            ASSERT_EQ(batch.linear_index[RayBatch::At(k, l)],
                      expected.linear_index[RayBatch::At(k, l)]);
          }
        }
      };
      if (run == 3) {
        RayBatchPipeline::RunInline(count, source, prepare, sink, &inline_batch);
      } else {
        pipeline.Run(count, source, prepare, sink);
      }
      EXPECT_EQ(next, count);
      EXPECT_EQ(invalid_seen, static_cast<uint64_t>((count + 4) / 5));
    }
  }
}

// An exception in the source or the caster (worker thread), or in the sink (caller), is
// rethrown by Run, and the pipeline keeps working afterwards.
TEST(RayBatchPipeline, RethrowsErrorsAndRecovers) {
  const GridGeometry g = GridGeometry::Fixed(MapLimits{});
  RayBatchPipeline pipeline(4.0, g.resolution_m());
  const RayCaster caster(g);
  const auto none = [&](const RaySegment* segments, const Reading*, int lanes_used,
                        RayBatch* batch) {
    caster.CastBatch(segments, lanes_used, batch, kernels::Best());
  };
  const auto good = [](int i, RaySpec* spec) { *spec = SpecOf(i, 0); };
  int batches = 0;
  const auto count_batches = [&](const Reading*, const RayBatch&, uint64_t) { ++batches; };
  const auto bad_source = [&](int i, RaySpec* spec) {
    if (i == 300) throw std::runtime_error("source failed");
    good(i, spec);
  };
  EXPECT_THROW(pipeline.Run(1000, bad_source, none, count_batches), std::runtime_error);
  EXPECT_LE(batches, 300 / 8 + 1);
  const auto bad_direction = [&](int i, RaySpec* spec) {
    good(i, spec);
    if (i == 11) spec->segment.direction_W = Eigen::Vector3d(2.0, 0.0, 0.0);  // not unit
  };
  EXPECT_THROW(pipeline.Run(100, bad_direction, none, count_batches), std::invalid_argument);
  EXPECT_THROW(pipeline.Run(1000, good, none,
                            [](const Reading*, const RayBatch&, uint64_t) {
                              throw std::logic_error("sink failed");
                            }),
               std::logic_error);
  batches = 0;
  uint64_t rays = 0;
  pipeline.Run(1000, good, none, [&](const Reading*, const RayBatch& batch, uint64_t invalid) {
    rays += static_cast<uint64_t>(batch.count) + invalid;
  });
  EXPECT_EQ(rays, 1000u);
}

// WorkerChoice tries each way first, then keeps the faster one, re-trying the slower one every
// kProbePeriod-th scan, and follows a change of speed.
TEST(WorkerChoice, KeepsTheFasterWayAndProbesTheOther) {
  WorkerChoice choice;
  EXPECT_TRUE(choice.NextUsesWorker());  // untried: the worker first
  choice.Record(true, 1000, 1e-3);       // 1 M rays/s with the worker
  EXPECT_FALSE(choice.NextUsesWorker());
  choice.Record(false, 1000, 0.5e-3);  // 2 M rays/s on one thread
  int with_worker = 0;
  for (int scan = 0; scan < 4 * WorkerChoice::kProbePeriod; ++scan) {
    const bool worker = choice.NextUsesWorker();
    with_worker += worker ? 1 : 0;
    choice.Record(worker, 1000, worker ? 1e-3 : 0.5e-3);
  }
  EXPECT_EQ(with_worker, 4);  // only the probes
  // The worker becomes much faster: the probes notice and the choice flips.
  int flipped_after = -1;
  for (int scan = 0; scan < 4 * WorkerChoice::kProbePeriod && flipped_after < 0; ++scan) {
    const bool worker = choice.NextUsesWorker();
    choice.Record(worker, 1000, worker ? 0.1e-3 : 0.5e-3);
    if (choice.rate(true) > choice.rate(false)) flipped_after = scan;
  }
  EXPECT_GE(flipped_after, 0);
  EXPECT_TRUE(choice.NextUsesWorker() || choice.NextUsesWorker());  // next or its probe
  // Empty scans and zero durations are not recorded.
  const double before = choice.rate(true);
  choice.Record(true, 0, 1.0);
  choice.Record(true, 100, 0.0);
  EXPECT_EQ(choice.rate(true), before);
}

}  // namespace
}  // namespace kestrel
