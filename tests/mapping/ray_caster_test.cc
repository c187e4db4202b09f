#include "mapping/ray_caster.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <set>
#include <tuple>

#include "mapping/kernels/kernels.h"

namespace kestrel {
namespace {

struct OracleCell {
  CellIndex cell;
  double t_lo;
  double t_hi;
};

// Exact oracle, independent of the walk: the chord of the segment [0, L] through the half-open
// box of `cell`, by slab intersection with the same boundary expression B(i) and the same
// crossing parameter t = (B - o) * (1/u) as the caster (ray_caster.h). Returns false when empty or
// of zero length.
bool SlabChord(const GridGeometry& g, const Eigen::Vector3d& o, const Eigen::Vector3d& u, double L,
               const CellIndex& c, double* t_lo, double* t_hi) {
  double lo = 0.0;
  double hi = L;
  for (int a = 0; a < 3; ++a) {
    const double b0 = g.Boundary(a, c[a]);
    const double b1 = g.Boundary(a, int64_t{c[a]} + 1);
    if (std::abs(u[a]) < 1e-300) {  // ray_caster.h: treated as 0
      if (!(o[a] >= b0 && o[a] < b1)) return false;
      continue;
    }
    const double inv_u = 1.0 / u[a];
    double ta = (b0 - o[a]) * inv_u;
    double tb = (b1 - o[a]) * inv_u;
    if (ta > tb) std::swap(ta, tb);
    lo = std::max(lo, ta);
    hi = std::min(hi, tb);
  }
  *t_lo = lo;
  *t_hi = hi;
  return hi > lo;
}

// Every cell the segment crosses with positive length, inside the bounds, sorted by entry.
std::vector<OracleCell> OracleRay(const GridGeometry& g, const Eigen::Vector3d& o,
                                  const Eigen::Vector3d& u, double L) {
  // Candidates: the 27-neighbourhood of the cell of sample points every alpha/4 (a crossed cell
  // always lies within one cell of some sample).
  std::set<std::tuple<int64_t, int64_t, int64_t>> candidates;
  const int samples = static_cast<int>(std::ceil(L / (g.resolution_m() / 4.0))) + 1;
  for (int s = 0; s <= samples; ++s) {
    const Eigen::Vector3d p = o + std::min(L, s * g.resolution_m() / 4.0) * u;
    const int64_t i = g.AxisIndexOf(0, p.x());
    const int64_t j = g.AxisIndexOf(1, p.y());
    const int64_t k = g.AxisIndexOf(2, p.z());
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) candidates.emplace(i + dx, j + dy, k + dz);
  }
  std::vector<OracleCell> out;
  for (const auto& [i, j, k] : candidates) {
    const CellIndex c{static_cast<int32_t>(i), static_cast<int32_t>(j), static_cast<int32_t>(k)};
    if (!g.Contains(c)) continue;
    OracleCell oc{c, 0.0, 0.0};
    if (SlabChord(g, o, u, L, c, &oc.t_lo, &oc.t_hi)) out.push_back(oc);
  }
  std::sort(out.begin(), out.end(),
            [](const OracleCell& a, const OracleCell& b) { return a.t_lo < b.t_lo; });
  // Bounds are convex: once the segment leaves them it never re-enters, so the in-bounds cells
  // are already the prefix the caster must return.
  return out;
}

// Checks Cast and CastWithLinearIndex against the oracle: the cells in order, d_k, whether the
// ray left the bounds before L (the last chord ends before L), and for a bounded lattice the
// linear index x + nx (y + ny z) of every cell, counted from the lower bound.
void ExpectMatchesOracle(const GridGeometry& g, const Eigen::Vector3d& o, const Eigen::Vector3d& u,
                         double L, RayCells* scratch) {
  const RayCaster caster(g);
  const std::vector<OracleCell> expected =
      g.CellOf(o) ? OracleRay(g, o, u, L) : std::vector<OracleCell>{};
  for (const bool linear : {false, true}) {
    const int n =
        linear ? caster.CastWithLinearIndex(o, u, L, scratch) : caster.Cast(o, u, L, scratch);
    ASSERT_EQ(n, static_cast<int>(expected.size()))
        << "o = " << o.transpose() << " u = " << u.transpose() << " L = " << L;
    ASSERT_EQ(scratch->has_linear_index, linear && g.bounded());
    if (!expected.empty()) {
      ASSERT_EQ(scratch->left_bounds, expected.back().t_hi < L)
          << "o = " << o.transpose() << " u = " << u.transpose() << " L = " << L;
    }
    for (int k = 0; k < n; ++k) {
      ASSERT_EQ(scratch->cells[k], expected[k].cell)
          << "k = " << k << " o = " << o.transpose() << " u = " << u.transpose();
      ASSERT_NEAR(scratch->distance_m[k], 0.5 * (expected[k].t_lo + expected[k].t_hi), 1e-12);
      if (k > 0) {
        ASSERT_GE(scratch->distance_m[k], scratch->distance_m[k - 1]);
      }
      if (scratch->has_linear_index) {
        const CellIndex& c = expected[k].cell;
        const CellIndex& lo = g.lower();
        const int64_t nx = g.upper().x - lo.x, ny = g.upper().y - lo.y;
        ASSERT_EQ(scratch->linear_index[k],
                  (c.x - lo.x) + nx * ((c.y - lo.y) + ny * int64_t{c.z - lo.z}));
      }
    }
  }
}

Eigen::Vector3d RandomUnit(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Vector3d u(n(rng), n(rng), n(rng));
  return u.normalized();
}

// Directions that run along grid planes or axes, or along exact diagonals: components zeroed or
// made equal in magnitude.
Eigen::Vector3d RandomSpecialDirection(std::mt19937& rng) {
  Eigen::Vector3d u = RandomUnit(rng);
  switch (rng() % 5) {
    case 0:
      u[rng() % 3] = 0.0;
      break;
    case 1: {
      const int keep = static_cast<int>(rng() % 3);
      for (int a = 0; a < 3; ++a)
        if (a != keep) u[a] = 0.0;
      break;
    }
    case 2:
      u = Eigen::Vector3d(rng() % 2 ? 1.0 : -1.0, rng() % 2 ? 1.0 : -1.0, 0.0);
      break;
    case 3:
      u = Eigen::Vector3d(rng() % 2 ? 1.0 : -1.0, rng() % 2 ? 1.0 : -1.0, rng() % 2 ? 1.0 : -1.0);
      break;
    default:
      break;
  }
  return u.normalized();
}

// Origins inside the given box; `snap_axes` coordinates are moved onto a boundary, so 1, 2 or 3
// snapped axes start the ray on a face, an edge or a corner.
Eigen::Vector3d RandomOrigin(std::mt19937& rng, const GridGeometry& g, const Eigen::Vector3d& lo,
                             const Eigen::Vector3d& hi, int snap_axes) {
  Eigen::Vector3d o;
  for (int a = 0; a < 3; ++a) {
    o[a] = std::uniform_real_distribution<double>(lo[a], hi[a])(rng);
  }
  std::vector<int> axes{0, 1, 2};
  std::shuffle(axes.begin(), axes.end(), rng);
  for (int s = 0; s < snap_axes; ++s) {
    const int a = axes[s];
    o[a] = g.Boundary(a, g.AxisIndexOf(a, o[a]));
  }
  return o;
}

// The paper's map (alpha = 0.075, not a binary fraction): thousands of random rays of the sensor
// range from random origins, and from origins on faces, edges and corners with directions along
// grid planes, axes and diagonals; many leave the 1.65 m high map and must end there.
TEST(RayCaster, VisitsEveryCellTheSegmentCrossesInPaperMap) {
  const GridGeometry g = GridGeometry::Fixed(MapLimits{});
  RayCells scratch(4.0, g.resolution_m());
  std::mt19937 rng(42);
  const Eigen::Vector3d lo(-4.0, -6.0, -0.15);
  const Eigen::Vector3d hi(4.0, 6.0, 1.5);
  for (int n = 0; n < 4000; ++n) {
    const int snap = n % 4;
    const Eigen::Vector3d o = RandomOrigin(rng, g, lo, hi, snap);
    const Eigen::Vector3d u = (n % 3 == 0) ? RandomUnit(rng) : RandomSpecialDirection(rng);
    const double L = (n % 7 == 0) ? std::uniform_real_distribution<double>(0.0, 4.0)(rng) : 4.0;
    ExpectMatchesOracle(g, o, u, L, &scratch);
    if (HasFatalFailure()) return;
  }
}

// alpha = 0.125 (exact binary fraction): boundaries and exact diagonals give exact ties, so rays
// really pass through edges and corners; zero-length cells must not be listed.
TEST(RayCaster, StepsTiedAxesTogetherThroughEdgesAndCorners) {
  const GridGeometry g = GridGeometry::Unbounded(Eigen::Vector3d(-1.0, -2.0, -0.5), 0.125);
  RayCells scratch(3.0, g.resolution_m());
  std::mt19937 rng(5);
  const Eigen::Vector3d lo(-2.0, -2.0, -2.0);
  const Eigen::Vector3d hi(2.0, 2.0, 2.0);
  for (int n = 0; n < 4000; ++n) {
    const Eigen::Vector3d o = RandomOrigin(rng, g, lo, hi, 1 + n % 3);
    const Eigen::Vector3d u = RandomSpecialDirection(rng);
    ExpectMatchesOracle(g, o, u, 3.0, &scratch);
    if (HasFatalFailure()) return;
  }
}

// A small fixed map where most rays run out of bounds: the ray ends at the first outside cell,
// and an origin outside the map gives no cells.
// CastBatch, compiled for every instruction set this CPU runs, gives each lane exactly what
// CastWithLinearIndex gives that ray alone (sizes, left_bounds, d_k and linear indices bit for
// bit) on `g` (bounded), for batches of 1 to 8 rays from `origin_of` along `direction_of`.
template <class Origin, class Direction>
void ExpectBatchesMatchSingleRays(const GridGeometry& g, double max_length, int batches,
                                  std::mt19937& rng, const Origin& origin_of,
                                  const Direction& direction_of) {
  const RayCaster caster(g);
  RayCells single(max_length, g.resolution_m());
  for (const kernels::Kernels* isa : kernels::Supported()) {
    SCOPED_TRACE(isa->name);
    RayBatch batch(max_length, g.resolution_m());
    for (int b = 0; b < batches; ++b) {
      const int count = 1 + b % lanes::kLanes;
      RaySegment rays[lanes::kLanes];
      for (int l = 0; l < count; ++l) {
        rays[l].origin_W = origin_of(l);
        rays[l].direction_W = direction_of(l);
        // Mostly full length; some short, some zero-length rays.
        const int kind = static_cast<int>(rng() % 10);
        rays[l].length_m = kind == 0   ? 0.0
                           : kind == 1 ? std::uniform_real_distribution<double>(0.0, 0.2)(rng)
                           : kind == 2
                               ? std::uniform_real_distribution<double>(0.0, max_length)(rng)
                               : max_length;
      }
      caster.CastBatch(rays, count, &batch, *isa);
      ASSERT_EQ(batch.count, count);
      ASSERT_TRUE(batch.lattice.SameLattice(g));
      int longest = 0;
      for (int l = 0; l < count; ++l) {
        const int n = caster.CastWithLinearIndex(rays[l].origin_W, rays[l].direction_W,
                                                 rays[l].length_m, &single);
        ASSERT_EQ(batch.size[l], n) << "lane " << l << " o = " << rays[l].origin_W.transpose()
                                    << " u = " << rays[l].direction_W.transpose();
        ASSERT_EQ(batch.left_bounds[l], single.left_bounds) << "lane " << l;
        for (int k = 0; k < n; ++k) {
          // Bit for bit: the same operations in every lane.
          ASSERT_EQ(batch.distance_m[RayBatch::At(k, l)], single.distance_m[k])
              << "lane " << l << " k = " << k;
          ASSERT_EQ(batch.linear_index[RayBatch::At(k, l)], single.linear_index[k])
              << "lane " << l << " k = " << k;
        }
        longest = std::max(longest, n);
      }
      ASSERT_EQ(batch.longest, longest);
    }
  }
}

// The paper's map: batches of random rays from one origin per batch (a scan), from a different
// origin per ray, from origins on faces, edges and corners, and from outside the map.
TEST(RayCaster, BatchesMatchSingleRaysInPaperMap) {
  const GridGeometry g = GridGeometry::Fixed(MapLimits{});
  std::mt19937 rng(7);
  const Eigen::Vector3d lo(-4.0, -6.0, -0.15);
  const Eigen::Vector3d hi(4.0, 6.0, 1.5);
  Eigen::Vector3d scan_origin = RandomOrigin(rng, g, lo, hi, 0);
  ExpectBatchesMatchSingleRays(
      g, 4.0, 300, rng,
      [&](int l) {
        if (l == 0) scan_origin = RandomOrigin(rng, g, lo, hi, static_cast<int>(rng() % 4));
        return rng() % 3 == 0 ? scan_origin : RandomOrigin(rng, g, lo, hi, l % 4);
      },
      [&](int l) { return l % 2 == 0 ? RandomUnit(rng) : RandomSpecialDirection(rng); });
  if (HasFatalFailure()) return;
  // Origins outside the bounds give empty lanes next to full ones.
  ExpectBatchesMatchSingleRays(
      g, 4.0, 40, rng,
      [&](int l) {
        return l % 3 == 1 ? Eigen::Vector3d(0.0, 0.0, 2.0) : RandomOrigin(rng, g, lo, hi, 0);
      },
      [&](int) { return RandomUnit(rng); });
}

// alpha = 0.125 on a bounded map: exact ties (rays through edges and corners, along grid planes,
// starting on boundaries) in every lane.
TEST(RayCaster, BatchesStepTiedAxesTogether) {
  MapLimits limits;
  limits.min_m = Eigen::Vector3d(-2.0, -2.0, -1.0);
  limits.max_m = Eigen::Vector3d(2.0, 2.0, 1.0);
  limits.resolution_m = 0.125;
  const GridGeometry g = GridGeometry::Fixed(limits);
  std::mt19937 rng(9);
  ExpectBatchesMatchSingleRays(
      g, 3.0, 400, rng,
      [&](int l) {
        return RandomOrigin(rng, g, Eigen::Vector3d(-1.5, -1.5, -0.8),
                            Eigen::Vector3d(1.5, 1.5, 0.8), 1 + l % 3);
      },
      [&](int) { return RandomSpecialDirection(rng); });
}

// A window of an unbounded lattice (GridGeometry::WithBounds, the growing map's CastLattice):
// against the oracle on the window (linear indices from its lower corner, which lies at negative
// indices), and batches against single rays; rays that stay inside the window get exactly the
// unbounded lattice's cells and d_k.
TEST(RayCaster, WindowsOfAnUnboundedLattice) {
  const GridGeometry lattice = GridGeometry::Unbounded(Eigen::Vector3d(0.01, -0.02, 0.03), 0.075);
  const GridGeometry window = lattice.WithBounds(CellIndex{-64, -72, -40}, CellIndex{0, 56, 88});
  EXPECT_TRUE(window.bounded());
  EXPECT_TRUE(RayCaster(window).LinearIndexable());
  RayCells scratch(4.0, window.resolution_m());
  RayCells whole(4.0, window.resolution_m());
  std::mt19937 rng(13);
  const Eigen::Vector3d lo(-4.8, -5.4, -3.0), hi(0.0, 4.2, 6.6);
  int inside = 0;
  for (int n = 0; n < 2000; ++n) {
    const Eigen::Vector3d o = RandomOrigin(rng, window, lo, hi, n % 4);
    const Eigen::Vector3d u = n % 2 ? RandomUnit(rng) : RandomSpecialDirection(rng);
    ExpectMatchesOracle(window, o, u, 4.0, &scratch);
    if (HasFatalFailure()) return;
    if (scratch.size > 0 && !scratch.left_bounds) {
      ++inside;
      ASSERT_EQ(RayCaster(lattice).Cast(o, u, 4.0, &whole), scratch.size);
      for (int k = 0; k < scratch.size; ++k) {
        ASSERT_EQ(whole.cells[k], scratch.cells[k]);
        ASSERT_EQ(whole.distance_m[k], scratch.distance_m[k]);
      }
    }
  }
  EXPECT_GT(inside, 100);
  ExpectBatchesMatchSingleRays(
      window, 4.0, 200, rng, [&](int l) { return RandomOrigin(rng, window, lo, hi, l % 4); },
      [&](int) { return RandomUnit(rng); });
}

TEST(RayCaster, BatchRejectsBadInput) {
  const GridGeometry g = GridGeometry::Fixed(MapLimits{});
  const RayCaster caster(g);
  RayBatch batch(4.0, g.resolution_m());
  const kernels::Kernels& k = kernels::Best();
  RaySegment rays[lanes::kLanes + 1];
  EXPECT_THROW(caster.CastBatch(rays, lanes::kLanes + 1, &batch, k), std::invalid_argument);
  EXPECT_THROW(caster.CastBatch(rays, -1, &batch, k), std::invalid_argument);
  rays[0].length_m = 5.0;  // longer than the scratch
  EXPECT_THROW(caster.CastBatch(rays, 1, &batch, k), std::invalid_argument);
  rays[0].length_m = 1.0;
  rays[0].direction_W = Eigen::Vector3d(1.0, 1.0, 0.0);  // not unit
  EXPECT_THROW(caster.CastBatch(rays, 1, &batch, k), std::invalid_argument);
  const RayCaster unbounded(GridGeometry::Unbounded(Eigen::Vector3d::Zero(), 0.1));
  rays[0].direction_W = Eigen::Vector3d::UnitX();
  EXPECT_THROW(unbounded.CastBatch(rays, 1, &batch, k), std::invalid_argument);
}

TEST(RayCaster, EndsAtMapLimits) {
  MapLimits limits;
  limits.min_m = Eigen::Vector3d(0.0, 0.0, 0.0);
  limits.max_m = Eigen::Vector3d(1.0, 0.5, 0.3);
  limits.resolution_m = 0.1;
  const GridGeometry g = GridGeometry::Fixed(limits);
  RayCells scratch(4.0, g.resolution_m());
  std::mt19937 rng(11);
  for (int n = 0; n < 3000; ++n) {
    const Eigen::Vector3d o = RandomOrigin(rng, g, Eigen::Vector3d(-0.05, -0.05, -0.05),
                                           Eigen::Vector3d(1.05, 0.55, 0.35), n % 4);
    const Eigen::Vector3d u = (n % 2) ? RandomUnit(rng) : RandomSpecialDirection(rng);
    ExpectMatchesOracle(g, o, u, 4.0, &scratch);
    if (HasFatalFailure()) return;
  }
  EXPECT_EQ(
      RayCaster(g).Cast(Eigen::Vector3d(-0.01, 0.2, 0.1), Eigen::Vector3d::UnitX(), 1.0, &scratch),
      0);
}

// A known answer: along +x from a cell centre, d_k = distance to each chord midpoint; the first
// chord is half a cell long, then whole cells, the last one clipped at L.
TEST(RayCaster, AxisAlignedRayHasKnownDistances) {
  const GridGeometry g = GridGeometry::Unbounded(Eigen::Vector3d::Zero(), 0.25);
  RayCells scratch(1.0, 0.25);
  const int n = RayCaster(g).Cast(Eigen::Vector3d(0.125, 0.125, 0.125), Eigen::Vector3d::UnitX(),
                                  1.0, &scratch);
  ASSERT_EQ(n, 5);
  const double expected[] = {0.0625, 0.25, 0.5, 0.75, 0.9375};
  for (int k = 0; k < n; ++k) {
    EXPECT_EQ(scratch.cells[k], (CellIndex{k, 0, 0}));
    EXPECT_DOUBLE_EQ(scratch.distance_m[k], expected[k]);
  }
}

// One scratch cast alternately on two lattices from the same origins (the scratch remembers the
// last origin's cell, keyed on the lattice): every ray still matches its own lattice's oracle.
TEST(RayCaster, ScratchReusedAcrossLatticesAndOrigins) {
  const GridGeometry a = GridGeometry::Fixed(MapLimits{});
  MapLimits coarse;
  coarse.resolution_m = 0.1;
  const GridGeometry b = GridGeometry::Fixed(coarse);
  const GridGeometry c = GridGeometry::Unbounded(Eigen::Vector3d(0.01, 0.02, 0.03), 0.075);
  RayCells scratch(4.0, 0.075);
  std::mt19937 rng(3);
  for (int n = 0; n < 600; ++n) {
    const Eigen::Vector3d o = RandomOrigin(rng, a, Eigen::Vector3d(-2.0, -2.0, 0.0),
                                           Eigen::Vector3d(2.0, 2.0, 1.4), n % 3);
    const Eigen::Vector3d u = RandomUnit(rng);
    for (const GridGeometry* g : {&a, &b, &c, &a}) {
      ExpectMatchesOracle(*g, o, u, 4.0, &scratch);
      if (HasFatalFailure()) return;
    }
  }
}

TEST(RayCaster, RejectsBadInput) {
  const GridGeometry g = GridGeometry::Fixed(MapLimits{});
  RayCells scratch(4.0, g.resolution_m());
  const RayCaster caster(g);
  EXPECT_THROW(caster.Cast(Eigen::Vector3d::Zero(), Eigen::Vector3d(1.0, 1.0, 0.0), 1.0, &scratch),
               std::invalid_argument);
  EXPECT_THROW(caster.Cast(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(), 5.0, &scratch),
               std::invalid_argument);
}

}  // namespace
}  // namespace kestrel
