#include "mapping/traversal_pipeline.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

namespace kestrel {
namespace {

// Every ray comes back in index order with exactly the cells an inline cast gives, across many
// batches and repeated runs.
TEST(TraversalPipeline, ReturnsRaysInOrderWithInlineCells) {
  const GridGeometry g = GridGeometry::Fixed(MapLimits{});
  TraversalPipeline pipeline(g, 4.0);
  const RayCaster caster(g);
  RayCells expected(4.0, g.resolution_m());
  for (int run = 0; run < 3; ++run) {
    const int count = 1000 + 37 * run;
    const auto source = [&](int i, TraversalPipeline::RaySpec* spec) {
      const double a = 0.01 * i + run;
      spec->origin_W = Eigen::Vector3d(0.1, 0.2, 0.7);
      spec->direction_W =
          Eigen::Vector3d(std::cos(a), std::sin(a), 0.1 * std::sin(3 * a)).normalized();
      spec->reading = i % 5 == 0 ? Reading{} : Reading{ReadingKind::kReturn, 1.0 + (i % 30) * 0.1};
      spec->length_m = spec->reading.z_m;
    };
    int next = 0;
    pipeline.Run(count, source, [&](const TraversalPipeline::RaySpec& spec, const RayCells& ray) {
      TraversalPipeline::RaySpec mine;
      source(next, &mine);
      ASSERT_EQ(spec.direction_W, mine.direction_W) << next;
      if (mine.reading.kind == ReadingKind::kInvalid) {
        EXPECT_EQ(ray.size, 0);
      } else {
        caster.Cast(mine.origin_W, mine.direction_W, mine.length_m, &expected);
        ASSERT_EQ(ray.size, expected.size);
        for (int k = 0; k < ray.size; ++k) {
          ASSERT_EQ(ray.cells[k], expected.cells[k]);
          ASSERT_EQ(ray.distance_m[k], expected.distance_m[k]);
        }
      }
      ++next;
    });
    EXPECT_EQ(next, count);
  }
}

// An exception in the source (worker thread) or in the sink (caller) is rethrown by Run, and the
// pipeline keeps working afterwards.
TEST(TraversalPipeline, RethrowsErrorsAndRecovers) {
  const GridGeometry g = GridGeometry::Fixed(MapLimits{});
  TraversalPipeline pipeline(g, 4.0);
  const auto good = [](int, TraversalPipeline::RaySpec* spec) {
    spec->origin_W = Eigen::Vector3d(0.1, 0.2, 0.7);
    spec->direction_W = Eigen::Vector3d::UnitX();
    spec->reading = Reading{ReadingKind::kNoReturn, 0.0};
    spec->length_m = 4.0;
  };
  const auto bad_source = [&](int i, TraversalPipeline::RaySpec* spec) {
    if (i == 300) throw std::runtime_error("source failed");
    good(i, spec);
  };
  int seen = 0;
  EXPECT_THROW(pipeline.Run(1000, bad_source,
                            [&](const TraversalPipeline::RaySpec&, const RayCells&) { ++seen; }),
               std::runtime_error);
  EXPECT_LE(seen, 300);
  const auto bad_direction = [&](int i, TraversalPipeline::RaySpec* spec) {
    good(i, spec);
    if (i == 10) spec->direction_W = Eigen::Vector3d(2.0, 0.0, 0.0);  // not unit: Cast throws
  };
  EXPECT_THROW(
      pipeline.Run(100, bad_direction, [](const TraversalPipeline::RaySpec&, const RayCells&) {}),
      std::invalid_argument);
  EXPECT_THROW(pipeline.Run(1000, good,
                            [](const TraversalPipeline::RaySpec&, const RayCells&) {
                              throw std::logic_error("sink failed");
                            }),
               std::logic_error);
  seen = 0;
  pipeline.Run(500, good, [&](const TraversalPipeline::RaySpec&, const RayCells& ray) {
    EXPECT_GT(ray.size, 0);
    ++seen;
  });
  EXPECT_EQ(seen, 500);
}

}  // namespace
}  // namespace kestrel
