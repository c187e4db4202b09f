#include "mapping/occupancy_map.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <map>
#include <random>
#include <set>
#include <string>
#include <tuple>
#include <type_traits>
#include <vector>

#include "mapping/kernels/kernels.h"
#include "mapping/scan_integrator.h"

namespace kestrel {
namespace {

const OccupancyLimits kOccupancy{};

Eigen::Vector3d RandomUnit(std::mt19937& rng, double z_scale = 1.0) {
  std::normal_distribution<double> n(0.0, 1.0);
  return Eigen::Vector3d(n(rng), n(rng), z_scale * n(rng)).normalized();
}

// Applies `count` random rays (returns across the range, no-return and invalid readings) from
// random origins near the middle of the paper's map to `map`.
template <class Map>
ScanStats ApplyRandomRays(Map* map, const SensorModel& model, int count, uint32_t seed) {
  ScanIntegrator integrator(map);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> range(0.3, 4.5);
  ScanStats stats;
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector3d o(std::uniform_real_distribution<double>(-1.0, 1.0)(rng),
                            std::uniform_real_distribution<double>(-1.0, 1.0)(rng),
                            std::uniform_real_distribution<double>(0.5, 1.0)(rng));
    stats += integrator.IntegrateRay(o, RandomUnit(rng, 0.3),
                                     i % 13 == 0 ? std::nan("") : range(rng), model);
  }
  return stats;
}

// Section 5: the incrementally kept H(map) equals a full recomputation after many random
// updates, for the exact model on both grids and for the log-odds baseline.
TEST(OccupancyMap, IncrementalEntropyMatchesRecomputation) {
  const SensorModel xtion(SensorModelConfig::PaperXtion());
  const SensorModel hokuyo(SensorModelConfig::PaperHokuyo());
  auto dense = MakeExactDenseMap(MapLimits{}, kOccupancy, 4.0);
  auto growing = MakeExactGrowingMap(MapLimits{}, kOccupancy, 4.0);
  auto log_odds = MakeLogOddsDenseMap(MapLimits{}, LogOddsConfig{}, 4.0);
  const double h0 = dense->entropy_nats();
  EXPECT_NEAR(h0, 107 * 160 * 22 * BinaryEntropy(0.1f), 1e-6);
  ApplyRandomRays(dense.get(), xtion, 20000, 1);
  ApplyRandomRays(dense.get(), hokuyo, 20000, 2);
  ApplyRandomRays(growing.get(), xtion, 20000, 1);
  ApplyRandomRays(log_odds.get(), xtion, 20000, 1);
  EXPECT_LT(dense->entropy_nats(), h0 - 100.0);  // the updates really changed it
  // Relative 1e-10: ~10^6 double additions of per-cell changes against one fresh sum.
  EXPECT_NEAR(dense->entropy_nats(), dense->RecomputeEntropy(), 1e-10 * h0);
  EXPECT_NEAR(growing->entropy_nats(), growing->RecomputeEntropy(),
              1e-10 * growing->RecomputeEntropy());
  EXPECT_NEAR(log_odds->entropy_nats(), log_odds->RecomputeEntropy(), 1e-10 * h0);
  EXPECT_GT(std::abs(log_odds->entropy_nats() - h0), 100.0);
}

// Section 5, lazy blocks: H(map) is a function of the cell values only, whatever the queries in
// between. One map queried after every ray, one only at the end: bit-identical entropies, equal
// to a from-scratch recomputation to rounding (1e-12 relative), for the dense and growing exact
// maps and the log-odds baseline, and bit-identical to every block recomputed from scratch.
TEST(OccupancyMap, LazyEntropyIsIndependentOfQueriesAndExact) {
  const SensorModel xtion(SensorModelConfig::PaperXtion());
  const auto check = [&](auto make) {
    auto queried = make();
    auto quiet = make();
    ScanIntegrator into_queried(queried.get());
    ScanIntegrator into_quiet(quiet.get());
    std::mt19937 rng(77);
    for (int i = 0; i < 3000; ++i) {
      const Eigen::Vector3d o(0.1, -0.2, 0.7);
      const Eigen::Vector3d u = RandomUnit(rng, 0.3);
      const double range = std::uniform_real_distribution<double>(0.4, 4.5)(rng);
      into_queried.IntegrateRay(o, u, range, xtion);
      into_quiet.IntegrateRay(o, u, range, xtion);
      [[maybe_unused]] const double h = queried->entropy_nats();
    }
    EXPECT_EQ(queried->entropy_nats(), quiet->entropy_nats());
    // Against the independent cell-by-cell sum: equal up to its summation rounding (~10^5 terms).
    EXPECT_NEAR(quiet->entropy_nats(), quiet->RecomputeEntropy(),
                1e-10 * quiet->RecomputeEntropy());
    // Against every block recomputed from scratch (ResetEntropy): bit-identical, so no block the
    // rays changed was left stale, however small its change.
    const double lazy = queried->entropy_nats();
    queried->ResetEntropy();
    EXPECT_EQ(queried->entropy_nats(), lazy);
    // One more ray: the change shows up as the recomputation sees it.
    const double before = quiet->RecomputeEntropy();
    into_quiet.IntegrateRay(Eigen::Vector3d(0.1, -0.2, 0.7), Eigen::Vector3d::UnitY(), 1.3, xtion);
    const double after = quiet->RecomputeEntropy();
    EXPECT_GT(std::abs(after - before), 1e-3);
    EXPECT_NEAR(quiet->entropy_nats(), after, 1e-10 * after);
    const double lazy_after = quiet->entropy_nats();
    quiet->ResetEntropy();
    EXPECT_EQ(quiet->entropy_nats(), lazy_after);
  };
  check([] { return MakeExactDenseMap(MapLimits{}, kOccupancy, 4.0); });
  check([] { return MakeExactGrowingMap(MapLimits{}, kOccupancy, 4.0); });
  check([] { return MakeLogOddsDenseMap(MapLimits{}, LogOddsConfig{}, 4.0); });
}

// The worker thread evaluates a_k ahead (PrecomputeBatch, where the kernels have it): the
// update must give the same bits whether a_k was precomputed or evaluated in the update,
// whether cells are addressed by linear index (UpdateBatchLane) or by pointer
// (UpdateBatchLaneAt), and with every instruction set's kernels.
TEST(OccupancyMap, PrecomputedLikelihoodsAndCellAddressesGiveIdenticalCells) {
  const SensorModel xtion(SensorModelConfig::PaperXtion());
  const SensorModel hokuyo(SensorModelConfig::PaperHokuyo());
  const GridGeometry g = GridGeometry::Fixed(MapLimits{});
  const int capacity = RayCells::CapacityFor(4.0, g.resolution_m());
  const RayCaster caster(g);
  // Reference: the scalar kernels, a_k in the update, cells by linear index.
  const kernels::Kernels& scalar = kernels::Scalar();
  ExactBayesUpdater reference_updater(kOccupancy, capacity, g.resolution_m());
  DenseGrid reference(MapLimits{}, reference_updater.initial_value());
  RayBatch batch(4.0, g.resolution_m());
  std::vector<int> changed(static_cast<size_t>(capacity));
  std::vector<float*> pointers(static_cast<size_t>(capacity) * lanes::kLanes);  // batch layout
  const auto rays_of = [&](int i, RaySegment* rays, Reading* readings) {
    std::mt19937 rng(31 + static_cast<uint32_t>(i));
    const SensorModel& model = i % 3 ? xtion : hokuyo;
    for (int l = 0; l < lanes::kLanes; ++l) {
      readings[l] = model.Classify(std::uniform_real_distribution<double>(0.5, 4.5)(rng));
      rays[l] = RaySegment{Eigen::Vector3d(0.2 * (i % 5), -0.1 * (i % 7), 0.7),
                           RandomUnit(rng, 0.3), reference_updater.CastLength(model, readings[l])};
    }
    return &model;
  };
  uint64_t written_reference = 0;
  for (int i = 0; i < 2500; ++i) {
    RaySegment rays[lanes::kLanes];
    Reading readings[lanes::kLanes];
    const SensorModel& model = *rays_of(i, rays, readings);
    caster.CastBatch(rays, lanes::kLanes, &batch, scalar);
    for (int l = 0; l < lanes::kLanes; ++l) {
      reference_updater.UpdateBatchLane(model, readings[l], batch, l,
                                        reference.mutable_values().data(), scalar,
                                        &written_reference, changed.data());
    }
  }
  for (const kernels::Kernels* k : kernels::Supported()) {
    SCOPED_TRACE(k->name);
    ExactBayesUpdater updater(kOccupancy, capacity, g.resolution_m());
    DenseGrid grid(MapLimits{}, updater.initial_value());
    uint64_t written = 0;
    int precomputed = 0;
    for (int i = 0; i < 2500; ++i) {
      RaySegment rays[lanes::kLanes];
      Reading readings[lanes::kLanes];
      const SensorModel& model = *rays_of(i, rays, readings);
      caster.CastBatch(rays, lanes::kLanes, &batch, *k);
      if (i % 2 == 0) {
        updater.PrecomputeBatch(model, readings, *k, &batch);
        precomputed += batch.has_likelihood;
      }
      for (int l = 0; l < lanes::kLanes; ++l) {
        if (i % 3 == 0) {
          for (int c = 0; c < batch.size[l]; ++c) {
            pointers[RayBatch::At(c, l)] =
                &grid.mutable_values()[static_cast<size_t>(batch.linear_index[RayBatch::At(c, l)])];
          }
          updater.UpdateBatchLaneAt(model, readings[l], batch, l, pointers.data() + l, *k, &written,
                                    changed.data());
        } else {
          updater.UpdateBatchLane(model, readings[l], batch, l, grid.mutable_values().data(), *k,
                                  &written, changed.data());
        }
      }
    }
    EXPECT_EQ(precomputed > 0, k->fill_likelihoods != nullptr);
    EXPECT_EQ(written, written_reference);
    int differing = 0, moved = 0;
    for (size_t c = 0; c < grid.size(); ++c) {
      differing += grid.values()[c] != reference.values()[c];
      moved += grid.values()[c] != updater.initial_value();
    }
    EXPECT_EQ(differing, 0);
    EXPECT_GT(moved, 10000);
  }
}

// The lane updates report exactly the cells whose stored value changed, ascending, with every
// instruction set's kernels and both ways of addressing cells.
TEST(OccupancyMap, LaneUpdatesReportExactlyTheChangedCells) {
  const SensorModel xtion(SensorModelConfig::PaperXtion());
  const GridGeometry g = GridGeometry::Fixed(MapLimits{});
  const int capacity = RayCells::CapacityFor(4.0, g.resolution_m());
  for (const kernels::Kernels* k : kernels::Supported()) {
    SCOPED_TRACE(k->name);
    ExactBayesUpdater exact(kOccupancy, capacity, g.resolution_m());
    LogOddsUpdater log_odds{LogOddsConfig{}};
    for (OccupancyUpdater* updater :
         {static_cast<OccupancyUpdater*>(&exact), static_cast<OccupancyUpdater*>(&log_odds)}) {
      DenseGrid grid(MapLimits{}, updater->initial_value());
      RayBatch batch(4.0, g.resolution_m());
      std::vector<float*> pointers(static_cast<size_t>(capacity) * lanes::kLanes);
      std::vector<int> changed(static_cast<size_t>(capacity));
      std::vector<float> before(static_cast<size_t>(capacity));
      std::mt19937 rng(8);
      uint64_t written = 0;
      int total_changed = 0, total_unchanged = 0;
      for (int i = 0; i < 3000; ++i) {
        const Reading reading =
            xtion.Classify(std::uniform_real_distribution<double>(0.5, 4.5)(rng));
        const RaySegment ray{Eigen::Vector3d(0.0, 0.1, 0.7), RandomUnit(rng, 0.3),
                             updater->CastLength(xtion, reading)};
        RayCaster(g).CastBatch(&ray, 1, &batch, *k);
        const int n = batch.size[0];
        for (int c = 0; c < n; ++c) {
          pointers[RayBatch::At(c, 0)] =
              &grid.mutable_values()[static_cast<size_t>(batch.linear_index[RayBatch::At(c, 0)])];
          before[static_cast<size_t>(c)] = *pointers[RayBatch::At(c, 0)];
        }
        const int m =
            i % 2 == 0
                ? updater->UpdateBatchLane(xtion, reading, batch, 0, grid.mutable_values().data(),
                                           *k, &written, changed.data())
                : updater->UpdateBatchLaneAt(xtion, reading, batch, 0, pointers.data(), *k,
                                             &written, changed.data());
        int j = 0;
        for (int c = 0; c < n; ++c) {
          if (*pointers[RayBatch::At(c, 0)] != before[static_cast<size_t>(c)]) {
            ASSERT_LT(j, m);
            ASSERT_EQ(changed[static_cast<size_t>(j)], c);
            ++j;
            ++total_changed;
          } else {
            ++total_unchanged;
          }
        }
        ASSERT_EQ(j, m);
      }
      EXPECT_GT(total_changed, 1000) << updater->name();
      EXPECT_GT(total_unchanged, 1000) << updater->name();
    }
  }
}

// Inside the fixed limits the growing grid gives identical numbers for rays that stay inside:
// a large fixed map (rays of 4 m from near its middle never leave it) and a growing map on the
// same lattice end bit-identical cell by cell.
TEST(OccupancyMap, GrowingGridMatchesDenseGridInsideLimits) {
  MapLimits limits;
  limits.min_m = Eigen::Vector3d(-6.0, -6.0, -5.0);
  limits.max_m = Eigen::Vector3d(6.0, 6.0, 6.0);
  const SensorModel xtion(SensorModelConfig::PaperXtion());
  auto dense = MakeExactDenseMap(limits, kOccupancy, 4.0);
  auto growing = MakeExactGrowingMap(limits, kOccupancy, 4.0);
  ApplyRandomRays(dense.get(), xtion, 5000, 3);
  ApplyRandomRays(growing.get(), xtion, 5000, 3);
  const CellIndex dims = dense->grid().dims();
  int changed = 0;
  for (int z = 0; z < dims.z; ++z) {
    for (int y = 0; y < dims.y; ++y) {
      for (int x = 0; x < dims.x; ++x) {
        const CellIndex c{x, y, z};
        ASSERT_EQ(dense->grid().Get(c), growing->grid().Get(c));
        changed += dense->grid().Get(c) != 0.1f;
      }
    }
  }
  EXPECT_GT(changed, 1000);
  EXPECT_LT(growing->grid().block_count() * GrowingGrid::kBlockCells, dense->grid().size());
}

// The growing grid's rays are cast on windows around their origins (CastLattice) whose linear
// indices the map turns into blocks: with negative cell indices, origins all over (windows
// moving between rays and scans) and rays crossing many blocks, it still matches a dense grid
// on the same lattice cell by cell (no ray reaches the dense map's limits), with every
// instruction set. alpha = 0.125 and origins on
// multiples of it keep both lattices' boundaries exact, so the growing grid can be aligned
// at 0 (indices from -48) while the dense map starts at -6 m.
TEST(OccupancyMap, GrowingGridWindowsMatchDenseGridAcrossNegativeIndices) {
  MapLimits limits;
  limits.min_m = Eigen::Vector3d(-6.0, -6.0, -5.0);
  limits.max_m = Eigen::Vector3d(6.0, 6.0, 6.0);
  limits.resolution_m = 0.125;
  MapLimits growing_limits = limits;
  growing_limits.min_m = Eigen::Vector3d::Zero();
  growing_limits.max_m = Eigen::Vector3d::Ones();
  const SensorModel xtion(SensorModelConfig::PaperXtion());
  const SensorModel hokuyo(SensorModelConfig::PaperHokuyo());
  auto dense = MakeExactDenseMap(limits, kOccupancy, 4.0);
  ScanIntegrator into_dense(dense.get());
  std::vector<uint16_t> depth(40 * 30);
  std::vector<float> ranges(300);
  for (const kernels::Kernels* k : kernels::Supported()) {
    SCOPED_TRACE(k->name);
    auto growing = MakeExactGrowingMap(growing_limits, kOccupancy, 4.0);
    ScanIntegrator into_growing(growing.get(), ScanIntegrator::Options{false, k->name});
    std::mt19937 rng(21);
    for (int f = 0; f < 40; ++f) {
      Pose3 X_WS;
      X_WS.p = Eigen::Vector3d(std::uniform_real_distribution<double>(-1.8, 1.8)(rng),
                               std::uniform_real_distribution<double>(-1.8, 1.8)(rng),
                               std::uniform_real_distribution<double>(-0.9, 0.9)(rng));
      X_WS.q = Eigen::Quaterniond(Eigen::Vector4d(RandomUnit(rng).x(), RandomUnit(rng).y(),
                                                  RandomUnit(rng).z(), 1.0))
                   .normalized();
      for (uint16_t& d : depth) d = rng() % 9 == 0 ? 0 : static_cast<uint16_t>(300 + rng() % 4500);
      for (float& r : ranges) r = rng() % 11 == 0 ? std::nanf("") : 0.3f + 0.001f * (rng() % 4500);
      const DepthIntrinsics in{30.0, 30.0, 19.5, 14.5};
      const auto apply = [&](ScanIntegrator* integrator) {
        integrator->IntegrateDepthImage(X_WS, in, depth.data(), 40, 30, 0.001, xtion);
        integrator->IntegratePlanarScan(X_WS, -2.0, 0.015, ranges.data(), 300, hokuyo);
        integrator->IntegrateRay(X_WS.p + Eigen::Vector3d(0.125, -0.25, 0.0625),
                                 Eigen::Vector3d(-1.0, 0.0, 0.0), 2.5, xtion);
      };
      if (k == kernels::Supported().front()) apply(&into_dense);
      apply(&into_growing);
    }
    const CellIndex dims = dense->grid().dims();
    int changed = 0;
    for (int z = 0; z < dims.z; ++z) {
      for (int y = 0; y < dims.y; ++y) {
        for (int x = 0; x < dims.x; ++x) {
          const CellIndex c{x, y, z};
          ASSERT_EQ(dense->grid().Get(c), growing->grid().Get(CellIndex{x - 48, y - 48, z - 40}));
          changed += dense->grid().Get(c) != 0.1f;
        }
      }
    }
    EXPECT_GT(changed, 10000);
    EXPECT_NEAR(growing->entropy_nats(), growing->RecomputeEntropy(),
                1e-10 * growing->RecomputeEntropy());
  }
}

// Every stored cell that differs from the initial value, by cell index.
template <class Map>
std::map<std::tuple<int32_t, int32_t, int32_t>, float> StoredCells(const Map& map) {
  std::map<std::tuple<int32_t, int32_t, int32_t>, float> out;
  const float initial = map.grid().initial_value();
  if constexpr (std::is_same_v<Map, GrowingOccupancyMap>) {
    map.grid().ForEachBlock([&](const CellIndex& o, const GrowingGrid::Block& block) {
      for (int i = 0; i < GrowingGrid::kBlockCells; ++i) {
        if (block.values[i] != initial) {
          out[{o.x + (i & 7), o.y + ((i >> 3) & 7), o.z + (i >> 6)}] = block.values[i];
        }
      }
    });
  } else {
    const CellIndex dims = map.grid().dims();
    for (int z = 0; z < dims.z; ++z) {
      for (int y = 0; y < dims.y; ++y) {
        for (int x = 0; x < dims.x; ++x) {
          const float v = map.grid().Get(CellIndex{x, y, z});
          if (v != initial) out[{x, y, z}] = v;
        }
      }
    }
  }
  return out;
}

// The map tracks the cells its updates changed (ForEachChangedCell, like OctoMap's changed keys):
// after many rays every cell whose value differs from before is reported (a cell may also have
// changed and changed back), each with its current value; after one ray exactly the cells it
// changed; ClearChanges forgets them. Both grids, and the log-odds baseline.
TEST(OccupancyMap, TracksTheCellsUpdatesChanged) {
  const SensorModel xtion(SensorModelConfig::PaperXtion());
  const auto check = [&](auto map) {
    using Cells = std::map<std::tuple<int32_t, int32_t, int32_t>, float>;
    const float initial = map->grid().initial_value();
    const auto reported = [&] {
      Cells out;
      map->ForEachChangedCell([&](const CellIndex& c, float stored) {
        EXPECT_EQ(stored, map->grid().Get(c));
        EXPECT_TRUE(out.emplace(std::make_tuple(c.x, c.y, c.z), stored).second) << "twice";
      });
      EXPECT_EQ(out.size(), map->ChangedCellCount());
      return out;
    };
    // The cells whose value differs between two StoredCells.
    const auto differing = [&](const Cells& before, const Cells& after) {
      std::set<std::tuple<int32_t, int32_t, int32_t>> out;
      for (const auto& [c, v] : after) {
        const auto it = before.find(c);
        if ((it == before.end() ? initial : it->second) != v) out.insert(c);
      }
      for (const auto& [c, v] : before) {
        if (after.count(c) == 0 && v != initial) out.insert(c);
      }
      return out;
    };
    EXPECT_EQ(map->ChangedCellCount(), 0u);
    ApplyRandomRays(map.get(), xtion, 300, 4);
    map->ClearChanges();
    EXPECT_EQ(map->ChangedCellCount(), 0u);
    const Cells before = StoredCells(*map);
    ApplyRandomRays(map.get(), xtion, 2000, 5);
    const Cells changed = reported();
    const auto differ = differing(before, StoredCells(*map));
    EXPECT_GT(differ.size(), 1000u);
    for (const auto& c : differ) ASSERT_EQ(changed.count(c), 1u);
    // One ray: exactly its changed cells.
    map->ClearChanges();
    EXPECT_TRUE(reported().empty());
    const Cells before_ray = StoredCells(*map);
    ScanIntegrator(map.get()).IntegrateRay(Eigen::Vector3d(0.1, 0.2, 0.7),
                                           Eigen::Vector3d(0.6, 0.8, 0.0), 2.5, xtion);
    const Cells by_ray = reported();
    const auto differ_ray = differing(before_ray, StoredCells(*map));
    EXPECT_GT(differ_ray.size(), 5u);
    ASSERT_EQ(by_ray.size(), differ_ray.size());
    for (const auto& c : differ_ray) EXPECT_EQ(by_ray.count(c), 1u);
  };
  check(MakeExactDenseMap(MapLimits{}, kOccupancy, 4.0));
  check(MakeExactGrowingMap(MapLimits{}, kOccupancy, 4.0));
  check(MakeLogOddsDenseMap(MapLimits{}, LogOddsConfig{}, 4.0));
}

// Determinism: the same inputs twice give bit-identical maps (hash of the cell array), and a
// single different reading gives a different hash (the hash sees the cells).
TEST(OccupancyMap, SameInputsGiveBitIdenticalMaps) {
  const SensorModel xtion(SensorModelConfig::PaperXtion());
  auto a = MakeExactDenseMap(MapLimits{}, kOccupancy, 4.0);
  auto b = MakeExactDenseMap(MapLimits{}, kOccupancy, 4.0);
  ApplyRandomRays(a.get(), xtion, 10000, 5);
  ApplyRandomRays(b.get(), xtion, 10000, 5);
  EXPECT_EQ(a->Hash(), b->Hash());
  ScanIntegrator(b.get()).IntegrateRay(Eigen::Vector3d(0.0, 0.0, 0.7), Eigen::Vector3d::UnitX(),
                                       2.0, xtion);
  EXPECT_NE(a->Hash(), b->Hash());
  auto ga = MakeExactGrowingMap(MapLimits{}, kOccupancy, 4.0);
  auto gb = MakeExactGrowingMap(MapLimits{}, kOccupancy, 4.0);
  ApplyRandomRays(ga.get(), xtion, 5000, 6);
  ApplyRandomRays(gb.get(), xtion, 5000, 6);
  EXPECT_EQ(ga->Hash(), gb->Hash());
}

// Depth image geometry: a 3x3 image with 45 degree pixels (fx = fy = 1), camera at p looking
// along world +x (optical z -> W x, optical x -> W -y, optical y -> W -z). The centre pixel's
// depth d ends at p + d x; the pixel one focal length to the right has range d*sqrt(2) and ends at
// p + d(x - y). With the log-odds baseline the end-point cell is exactly the one raised to a hit.
TEST(OccupancyMap, DepthImageEndPointsFollowPinholeGeometry) {
  auto map = MakeLogOddsDenseMap(MapLimits{}, LogOddsConfig{}, 4.0);
  const SensorModel xtion(SensorModelConfig::PaperXtion());
  Pose3 X_WS;
  X_WS.p = Eigen::Vector3d(0.01, 0.02, 0.7);
  Eigen::Matrix3d R_WS;
  R_WS.col(0) = -Eigen::Vector3d::UnitY();
  R_WS.col(1) = -Eigen::Vector3d::UnitZ();
  R_WS.col(2) = Eigen::Vector3d::UnitX();
  X_WS.q = Eigen::Quaterniond(R_WS);
  const DepthIntrinsics in{1.0, 1.0, 1.0, 1.0};
  std::vector<uint16_t> depth(9, 0);
  depth[1 * 3 + 1] = 2000;  // centre, depth 2 m
  depth[1 * 3 + 2] = 1500;  // u = 2: one focal length right, depth 1.5 m
  const ScanStats stats =
      ScanIntegrator(map.get()).IntegrateDepthImage(X_WS, in, depth.data(), 3, 3, 0.001, xtion);
  EXPECT_EQ(stats.rays_applied, 9u);
  EXPECT_EQ(stats.rays_no_return, 7u);
  const GridGeometry& g = map->grid().geometry();
  const CellIndex centre_hit = *g.CellOf(X_WS.p + Eigen::Vector3d(2.0, 0.0, 0.0));
  const CellIndex side_hit = *g.CellOf(X_WS.p + Eigen::Vector3d(1.5, -1.5, 0.0));
  EXPECT_NEAR(map->ProbabilityAt(centre_hit), 0.7, 1e-6);
  EXPECT_NEAR(map->ProbabilityAt(side_hit), 0.7, 1e-6);

  // A wide pixel (45 degrees off axis): depth 1 m is a range of sqrt(2) m, ending at p+(1,-1,0).
  auto wide = MakeLogOddsDenseMap(MapLimits{}, LogOddsConfig{}, 4.0);
  const DepthIntrinsics wide_in{1.0, 1.0, 0.0, 0.0};
  const uint16_t one_pixel[2] = {0, 1000};
  ScanIntegrator(wide.get()).IntegrateDepthImage(X_WS, wide_in, one_pixel, 2, 1, 0.001, xtion);
  EXPECT_NEAR(wide->ProbabilityAt(*g.CellOf(X_WS.p + Eigen::Vector3d(1.0, -1.0, 0.0))), 0.7, 1e-6);
}

// Planar scan geometry: beam i at angle_min + i*step about the LIDAR's z; the exact model raises
// each end-point cell above the prior (one reading shares the return among the cells within
// about sigma) and lowers the cells half-way along the beam.
TEST(OccupancyMap, PlanarScanEndPointsFollowBeamAngles) {
  auto map = MakeExactDenseMap(MapLimits{}, kOccupancy, 4.0);
  const SensorModel hokuyo(SensorModelConfig::PaperHokuyo());
  Pose3 X_WS;
  X_WS.p = Eigen::Vector3d(0.01, 0.02, 0.7);
  X_WS.q = QuaternionFromYaw(0.3);
  const float ranges[4] = {2.0f, std::nanf(""), 3.0f, 10.0f};
  const ScanStats stats =
      ScanIntegrator(map.get()).IntegratePlanarScan(X_WS, -0.5, 0.25, ranges, 4, hokuyo);
  EXPECT_EQ(stats.rays_applied, 3u);
  EXPECT_EQ(stats.rays_invalid, 1u);
  EXPECT_EQ(stats.rays_no_return, 1u);
  const GridGeometry& g = map->grid().geometry();
  for (int i : {0, 2}) {
    const double angle = 0.3 - 0.5 + 0.25 * i;
    const Eigen::Vector3d dir(std::cos(angle), std::sin(angle), 0.0);
    EXPECT_GT(map->ProbabilityAt(*g.CellOf(X_WS.p + ranges[i] * dir)), 0.12) << i;
    EXPECT_LT(map->ProbabilityAt(*g.CellOf(X_WS.p + 0.5 * ranges[i] * dir)), 0.1) << i;
  }
}

// The log-odds baseline follows OctoMap's arithmetic: a miss is logit(0.4), a hit logit(0.7),
// clamped to [logit(0.12), logit(0.97)].
TEST(LogOddsUpdater, FollowsOctoMapArithmetic) {
  auto map = MakeLogOddsDenseMap(MapLimits{}, LogOddsConfig{}, 4.0);
  const SensorModel xtion(SensorModelConfig::PaperXtion());
  const Eigen::Vector3d o(0.01, 0.02, 0.7);
  const GridGeometry& g = map->grid().geometry();
  const CellIndex free_cell = *g.CellOf(o + Eigen::Vector3d(1.0, 0, 0));
  const CellIndex end_cell = *g.CellOf(o + Eigen::Vector3d(2.0, 0, 0));
  ScanIntegrator integrator(map.get());
  integrator.IntegrateRay(o, Eigen::Vector3d::UnitX(), 2.0, xtion);
  EXPECT_NEAR(map->ProbabilityAt(free_cell), 0.4, 1e-6);
  EXPECT_NEAR(map->ProbabilityAt(end_cell), 0.7, 1e-6);
  integrator.IntegrateRay(o, Eigen::Vector3d::UnitX(), 2.0, xtion);
  const double two_misses = 1.0 / (1.0 + std::pow(0.6 / 0.4, 2));
  EXPECT_NEAR(map->ProbabilityAt(free_cell), two_misses, 1e-6);
  for (int i = 0; i < 20; ++i) integrator.IntegrateRay(o, Eigen::Vector3d::UnitX(), 2.0, xtion);
  EXPECT_NEAR(map->ProbabilityAt(free_cell), 0.12, 1e-6);
  EXPECT_NEAR(map->ProbabilityAt(end_cell), 0.97, 1e-6);
}

// IntegrateRay casts a return only to z + c sigma (+ one cell diagonal): its cells end exactly as
// the section 4 update over the full ray to z_max gives them (computed here from a full cast and
// ComputeExactPosteriors, clamped and stored as float), and the cells past the cut keep their
// values.
TEST(OccupancyMap, ShortenedCastEqualsFullRayUpdate) {
  const SensorModel xtion(SensorModelConfig::PaperXtion());
  auto map = MakeExactDenseMap(MapLimits{}, kOccupancy, 4.0);
  ApplyRandomRays(map.get(), xtion, 3000, 9);  // non-trivial priors
  ScanIntegrator integrator(map.get());
  const GridGeometry& g = map->grid().geometry();
  RayCells full(4.0, g.resolution_m());
  InverseSensorModelScratch scratch(full.cells.size());
  std::mt19937 rng(10);
  int cut_cells = 0;
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector3d o(0.05, -0.1, 0.7);
    const Eigen::Vector3d u = RandomUnit(rng, 0.2);
    const double z = std::uniform_real_distribution<double>(0.5, 2.5)(rng);
    const int n = RayCaster(g).Cast(o, u, 4.0, &full);
    std::vector<double> prior(n), posterior(n);
    for (int k = 0; k < n; ++k) prior[k] = map->ProbabilityAt(full.cells[k]);
    const ExactUpdateResult r =
        ComputeExactPosteriors(xtion, Reading{ReadingKind::kReturn, z}, full.distance_m.data(),
                               prior.data(), n, posterior.data(), &scratch);
    integrator.IntegrateRay(o, u, z, xtion);
    for (int k = 0; k < n; ++k) {
      const float expected = k < r.first + r.count
                                 ? static_cast<float>(ClampProbability(posterior[k], 1e-4))
                                 : static_cast<float>(prior[k]);
      ASSERT_EQ(map->grid().Get(full.cells[k]), expected) << "ray " << i << " cell " << k;
    }
    cut_cells += n - r.count;
  }
  EXPECT_GT(cut_cells, 1000);
}

// Six depth images (97 x 61: not a multiple of any batch size; returns, "no return" pixels)
// and six 682-beam scans (with invalid beams) from varied poses, applied to `map`.
ScanStats ApplyMixedFrames(ScanIntegrator* integrator) {
  const SensorModel xtion(SensorModelConfig::PaperXtion());
  const SensorModel hokuyo(SensorModelConfig::PaperHokuyo());
  std::mt19937 rng(12);
  std::vector<uint16_t> depth(97 * 61);
  for (uint16_t& d : depth) d = rng() % 9 == 0 ? 0 : static_cast<uint16_t>(300 + rng() % 4500);
  std::vector<float> ranges(682);
  for (float& r : ranges) r = rng() % 11 == 0 ? std::nanf("") : 0.3f + 0.001f * (rng() % 4500);
  const DepthIntrinsics in{80.0, 80.0, 48.0, 30.0};
  ScanStats stats;
  for (int f = 0; f < 6; ++f) {
    Pose3 X_WS;
    X_WS.p = Eigen::Vector3d(0.1 * f, -0.2 * f, 0.7);
    X_WS.q = QuaternionFromYaw(0.7 * f) *
             Eigen::Quaterniond(Eigen::AngleAxisd(1.3, Eigen::Vector3d::UnitY()));
    stats += integrator->IntegrateDepthImage(X_WS, in, depth.data(), 97, 61, 0.001, xtion);
    stats += integrator->IntegratePlanarScan(X_WS, -2.0, 0.006, ranges.data(), 682, hokuyo);
  }
  return stats;
}

// Casting on the worker thread (SetWorkerThread) gives the same map bit for bit as casting
// inline, for depth images and scans, on both grids, with every instruction set.
TEST(OccupancyMap, WorkerThreadGivesBitIdenticalMaps) {
  const auto compare = [](auto make) {
    auto inline_map = make();
    ScanIntegrator inline_integrator(inline_map.get());
    EXPECT_FALSE(inline_integrator.worker_thread());
    const ScanStats a = ApplyMixedFrames(&inline_integrator);
    EXPECT_GT(a.rays_invalid, 0u);
    for (const std::string& isa : ScanIntegrator::SupportedInstructionSets()) {
      SCOPED_TRACE(isa);
      auto threaded_map = make();
      // The first scan of each kind goes through the worker (WorkerChoice).
      ScanIntegrator threaded(threaded_map.get(), ScanIntegrator::Options{true, isa});
      EXPECT_TRUE(threaded.worker_thread());
      EXPECT_EQ(threaded.instruction_set(), isa);
      const ScanStats b = ApplyMixedFrames(&threaded);
      EXPECT_EQ(threaded_map->Hash(), inline_map->Hash());
      EXPECT_EQ(b.cells_updated, a.cells_updated);
      EXPECT_EQ(b.rays_invalid, a.rays_invalid);
      EXPECT_EQ(threaded_map->entropy_nats(), inline_map->entropy_nats());
      threaded.SetWorkerThread(false);
      EXPECT_FALSE(threaded.worker_thread());
    }
  };
  compare([] { return MakeExactDenseMap(MapLimits{}, kOccupancy, 4.0); });
  compare([] { return MakeExactGrowingMap(MapLimits{}, kOccupancy, 4.0); });
}

// Every instruction set's kernels give the same map bit for bit as the scalar kernels, with the
// same statistics and entropy, for the exact model on both grids and the log-odds baseline. Each
// target is forced through Highway (kernels::ScopedTargetForTest, as on a CPU whose widest it
// is): the integrator's default choice must be it, and Highway's detection is back after it.
TEST(OccupancyMap, EveryInstructionSetGivesBitIdenticalMaps) {
  ASSERT_EQ(unsetenv("KESTREL_ISA"), 0);  // the default must be the forced target
  const std::vector<std::string> supported = ScanIntegrator::SupportedInstructionSets();
  const auto compare = [&](auto make) {
    auto scalar = make();
    ScanIntegrator scalar_integrator(scalar.get(), ScanIntegrator::Options{false, "scalar"});
    EXPECT_STREQ(scalar_integrator.instruction_set(), "scalar");
    const ScanStats expected = ApplyMixedFrames(&scalar_integrator);
    for (const kernels::Kernels* k : kernels::Supported()) {
      SCOPED_TRACE(k->name);
      auto map = make();
      const kernels::ScopedTargetForTest forced(*k);
      ASSERT_EQ(kernels::Supported().back(), k);
      ScanIntegrator integrator(map.get());
      ASSERT_STREQ(integrator.instruction_set(), k->name);
      const ScanStats got = ApplyMixedFrames(&integrator);
      EXPECT_EQ(map->Hash(), scalar->Hash());
      EXPECT_EQ(got.rays_applied, expected.rays_applied);
      EXPECT_EQ(got.rays_no_return, expected.rays_no_return);
      EXPECT_EQ(got.rays_invalid, expected.rays_invalid);
      EXPECT_EQ(got.cells_updated, expected.cells_updated);
      EXPECT_EQ(map->entropy_nats(), scalar->entropy_nats());
    }
    EXPECT_GT(expected.rays_invalid, 0u);
    EXPECT_GT(expected.rays_no_return, 0u);
  };
  compare([] { return MakeExactDenseMap(MapLimits{}, kOccupancy, 4.0); });
  compare([] { return MakeExactGrowingMap(MapLimits{}, kOccupancy, 4.0); });
  compare([] { return MakeLogOddsDenseMap(MapLimits{}, LogOddsConfig{}, 4.0); });
  EXPECT_EQ(ScanIntegrator::SupportedInstructionSets(), supported);
}

TEST(OccupancyMap, RejectsBadImages) {
  auto map = MakeExactDenseMap(MapLimits{}, kOccupancy, 4.0);
  ScanIntegrator integrator(map.get());
  const SensorModel xtion(SensorModelConfig::PaperXtion());
  const uint16_t px[1] = {1000};
  EXPECT_THROW(integrator.IntegrateDepthImage(Pose3{}, DepthIntrinsics{0.0, 1.0, 0.0, 0.0}, px, 1,
                                              1, 0.001, xtion),
               std::invalid_argument);
  EXPECT_THROW(integrator.IntegrateDepthImage(Pose3{}, DepthIntrinsics{1.0, 1.0, 0.0, 0.0}, px, 0,
                                              1, 0.001, xtion),
               std::invalid_argument);
  Pose3 zero_q;
  zero_q.q = Eigen::Quaterniond(0.0, 0.0, 0.0, 0.0);
  EXPECT_THROW(integrator.IntegrateDepthImage(zero_q, DepthIntrinsics{1.0, 1.0, 0.0, 0.0}, px, 1, 1,
                                              0.001, xtion),
               std::invalid_argument);
  const float range[1] = {1.0f};
  EXPECT_THROW(integrator.IntegratePlanarScan(zero_q, 0.0, 0.01, range, 1, xtion),
               std::invalid_argument);
  SensorModelConfig far = SensorModelConfig::PaperXtion();
  far.z_max_m = 8.0;
  EXPECT_THROW(integrator.IntegrateRay(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(), 2.0,
                                       SensorModel(far)),
               std::invalid_argument);
}

// Unknown instruction sets are refused; a growing map's window limits its range per cell edge.
// The message an instruction-set name gets refused with ("" if accepted).
std::string RefusalOf(const std::string& name) {
  try {
    (void)ScanIntegrator::ResolveInstructionSet(name);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

// An instruction set the CPU lacks is refused with the list of those it runs: with each target
// forced as the widest, the wider ones are refused (and the one forced is what "" chooses);
// unknown names too. "avx512" is another name of "avx3"; KESTREL_ISA picks the default.
TEST(ScanIntegrator, RefusesInstructionSetsTheCpuLacksWithTheListItRuns) {
  ASSERT_EQ(unsetenv("KESTREL_ISA"), 0);
  const std::vector<const kernels::Kernels*> all = kernels::Supported();
  for (size_t i = 0; i < all.size(); ++i) {
    SCOPED_TRACE(all[i]->name);
    const kernels::ScopedTargetForTest forced(*all[i]);
    EXPECT_EQ(ScanIntegrator::ResolveInstructionSet(""), all[i]->name);
    EXPECT_EQ(ScanIntegrator::ResolveInstructionSet("scalar"), "scalar");
    // The list of the forced CPU: scalar and the target forced, nothing after them.
    const std::string list =
        std::string("it runs scalar") + (i > 0 ? ", " : "") + (i > 0 ? all[i]->name : "");
    for (size_t wider = i + 1; wider < all.size(); ++wider) {
      const std::string why = RefusalOf(all[wider]->name);
      const size_t at = why.find(list);
      ASSERT_NE(at, std::string::npos) << why;
      EXPECT_TRUE(at + list.size() == why.size() || why[at + list.size()] == ' ') << why;
    }
  }
  EXPECT_EQ(kernels::Supported(), all);  // Highway's own detection again
  for (const char* unknown : {"sse9", "AVX2", "emu128", "avx3 "}) {
    EXPECT_NE(RefusalOf(unknown).find("it runs scalar"), std::string::npos) << unknown;
  }
  if (kernels::UsesAvx512(*all.back())) {
    EXPECT_EQ(ScanIntegrator::ResolveInstructionSet("avx512"), "avx3");
  }
  for (const kernels::Kernels* k : all) {
    ASSERT_EQ(setenv("KESTREL_ISA", k->name, 1), 0);
    EXPECT_EQ(ScanIntegrator::ResolveInstructionSet(""), k->name);
  }
  ASSERT_EQ(setenv("KESTREL_ISA", "sse9", 1), 0);
  EXPECT_NE(RefusalOf("").find("'sse9'"), std::string::npos);
  ASSERT_EQ(unsetenv("KESTREL_ISA"), 0);
  EXPECT_EQ(ScanIntegrator::ResolveInstructionSet(""), all.back()->name);
}

TEST(ScanIntegrator, RejectsUnknownInstructionSetsAndNullMaps) {
  auto map = MakeExactDenseMap(MapLimits{}, kOccupancy, 4.0);
  EXPECT_THROW(ScanIntegrator(map.get(), ScanIntegrator::Options{false, "sse9"}),
               std::invalid_argument);
  EXPECT_THROW(ScanIntegrator(static_cast<DenseOccupancyMap*>(nullptr)), std::invalid_argument);
  MapLimits fine;
  fine.resolution_m = 0.005;
  EXPECT_THROW(MakeExactGrowingMap(fine, kOccupancy, 4.0), std::invalid_argument);
  EXPECT_EQ(ScanIntegrator::SupportedInstructionSets().front(), "scalar");
}

}  // namespace
}  // namespace kestrel
