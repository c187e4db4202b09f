#include "exploration/projected_maps.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "mapping/grid.h"
#include "mapping/occupancy_updater.h"
#include "tests/exploration/test_input.h"

namespace kestrel {
namespace {

// A hand-made 3D grid: dims, origin, alpha, values (x fastest), all P_init at first.
struct HandGrid {
  Eigen::Vector3i dims;
  Eigen::Vector3d origin;
  double alpha;
  std::vector<float> values;
  HandGrid(Eigen::Vector3i d, Eigen::Vector3d o, double a, float fill)
      : dims(d), origin(o), alpha(a), values(static_cast<size_t>(d.prod()), fill) {}
  float& at(int i, int j, int k) {
    return values[static_cast<size_t>(i + dims.x() * (j + dims.y() * k))];
  }
  OccupancyGridView view() const { return test::GridView(dims, origin, alpha, values); }
};

ProjectionConfig SmallConfig() {
  ProjectionConfig c;
  c.collision_factor = 3;  // alpha_C = 0.3
  c.height_m = 0.45;       // band (0.3, 0.6): z cells 3, 4, 5 of a grid from z = 0
  c.p_init = 0.1;
  c.p_thresh = 0.3;
  c.collision_threshold = 0.05;
  c.floor_height_m = 0.1;  // z cell 0 ([0, 0.1)) is wholly below the floor
  c.p_min_entropy = 0.01;
  return c;
}

// Oracle for eqs. (12) and (16) by geometry instead of index ranges: every 3D cell whose centre
// lies in the collision cell's footprint and whose z interval overlaps the band; a footprint that
// leaves the map adds an unknown (P_init) cell.
void OracleCollision(const HandGrid& g, const ProjectionConfig& c, int kc, double* c_out,
                     double* b_out, int cx, int cy) {
  const double ac = kc * g.alpha;
  double mx = -1.0;
  double mn = 2.0;
  const double x0 = g.origin.x() + cx * ac, y0 = g.origin.y() + cy * ac;
  if (x0 + ac > g.origin.x() + g.dims.x() * g.alpha + 1e-12 ||
      y0 + ac > g.origin.y() + g.dims.y() * g.alpha + 1e-12) {
    mx = mn = c.p_init;
  }
  for (int k = 0; k < g.dims.z(); ++k) {
    const double z0 = g.origin.z() + k * g.alpha, z1 = z0 + g.alpha;
    const double overlap = std::min(z1, c.height_m + ac / 2) - std::max(z0, c.height_m - ac / 2);
    if (overlap <= 1e-9) continue;
    for (int j = 0; j < g.dims.y(); ++j) {
      for (int i = 0; i < g.dims.x(); ++i) {
        const double xc = g.origin.x() + (i + 0.5) * g.alpha;
        const double yc = g.origin.y() + (j + 0.5) * g.alpha;
        if (xc < x0 || xc >= x0 + ac || yc < y0 || yc >= y0 + ac) continue;
        const double p = g.values[static_cast<size_t>(i + g.dims.x() * (j + g.dims.y() * k))];
        mx = std::max(mx, p);
        mn = std::min(mn, p);
      }
    }
  }
  *c_out = mx;
  *b_out = mx >= c.p_thresh ? mx : mn;
}

// eq. (12): P(C_k) is the maximum over the footprint within the band, nothing outside it.
TEST(ProjectedMaps, CollisionIsMaxOverFootprintWithinBand) {
  HandGrid g({6, 6, 8}, {0, 0, 0}, 0.1, 0.01f);
  const ProjectionConfig c = SmallConfig();
  g.at(1, 1, 2) = 0.9f;  // just below the band (z [0.2, 0.3) touches 0.3 only)
  g.at(4, 4, 6) = 0.9f;  // just above ([0.6, 0.7))
  g.at(2, 0, 3) = 0.04f;
  g.at(3, 5, 5) = 0.2f;
  const CollisionProjection p = ProjectCollisionMaps(g.view(), c);
  ASSERT_EQ(p.collision.width, 2);
  ASSERT_EQ(p.collision.height, 2);
  EXPECT_NEAR(p.collision.resolution_m, 0.3, 1e-15);
  EXPECT_FLOAT_EQ(p.collision.at(0, 0), 0.04f);
  EXPECT_FLOAT_EQ(p.collision.at(1, 1), 0.2f);
  EXPECT_FLOAT_EQ(p.collision.at(1, 0), 0.01f);
  EXPECT_FLOAT_EQ(p.collision.at(0, 1), 0.01f);
  // eq. (13)
  EXPECT_TRUE(IsTraversable(p.collision.at(0, 0), c.collision_threshold));
  EXPECT_FALSE(IsTraversable(p.collision.at(1, 1), c.collision_threshold));
  EXPECT_TRUE(IsTraversable(0.05, 0.05));
  EXPECT_FALSE(IsTraversable(std::nextafter(0.05, 1.0), 0.05));
}

// eq. (16): B = C when C >= P_thresh, else the footprint's minimum.
TEST(ProjectedMaps, CombinedFollowsThreshold) {
  HandGrid g({6, 3, 8}, {0, 0, 0}, 0.1, 0.1f);
  const ProjectionConfig c = SmallConfig();
  g.at(0, 0, 4) = 0.05f;
  g.at(1, 1, 4) = 0.2f;  // cell (0,0): max 0.2 < 0.3 -> min 0.05
  g.at(3, 0, 4) = 0.02f;
  g.at(4, 1, 5) = 0.3f;  // cell (1,0): max exactly P_thresh -> 0.3
  const CollisionProjection p = ProjectCollisionMaps(g.view(), c);
  EXPECT_FLOAT_EQ(p.combined.at(0, 0), 0.05f);
  EXPECT_FLOAT_EQ(p.collision.at(0, 0), 0.2f);
  EXPECT_FLOAT_EQ(p.combined.at(1, 0), 0.3f);
}

// Random grids (alpha 0.075, odd sizes so the last collision cells stick out) against the
// geometric oracle for eqs. (12) and (16), several heights and k_C.
TEST(ProjectedMaps, CollisionAndCombinedMatchGeometricOracle) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 30; ++trial) {
    HandGrid g({7 + trial % 5, 5 + trial % 4, 12}, {-0.3, 0.2, -0.15}, 0.075, 0.1f);
    for (float& v : g.values) {
      const double r = u(rng);
      v = r < 0.3 ? 0.1f : static_cast<float>(r < 0.6 ? 0.01 * u(rng) : u(rng));
    }
    ProjectionConfig c = SmallConfig();
    c.collision_factor = 1 + trial % 4;
    c.height_m = -0.15 + 0.075 * (3 + trial % 6) + 0.01 * (trial % 3);
    c.floor_height_m = 0.0;
    const CollisionProjection p = ProjectCollisionMaps(g.view(), c);
    for (int cy = 0; cy < p.collision.height; ++cy) {
      for (int cx = 0; cx < p.collision.width; ++cx) {
        double co, bo;
        OracleCollision(g, c, c.collision_factor, &co, &bo, cx, cy);
        ASSERT_EQ(p.collision.at(cx, cy), co) << trial << " " << cx << " " << cy;
        ASSERT_EQ(p.combined.at(cx, cy), bo) << trial << " " << cx << " " << cy;
      }
    }
  }
}

// A collision cell that sticks out of the map counts its missing part as unknown.
TEST(ProjectedMaps, CellStickingOutOfTheMapIsNotTraversable) {
  HandGrid g({7, 6, 8}, {0, 0, 0}, 0.1, 0.0f);
  const ProjectionConfig c = SmallConfig();
  const CollisionProjection p = ProjectCollisionMaps(g.view(), c);
  ASSERT_EQ(p.collision.width, 3);  // ceil(7 / 3)
  EXPECT_EQ(p.collision.at(1, 0), 0.0);
  EXPECT_EQ(p.collision.at(2, 0), c.p_init);
}

// eq. (11) and section 8: the default k_C is the smallest k with k alpha >= the diameter.
TEST(ProjectedMaps, DefaultCollisionFactor) {
  ProjectionConfig c;
  c.vehicle_diameter_m = 0.88;
  EXPECT_EQ(CollisionFactor(c, 0.075), 12);  // 11 * 0.075 = 0.825 < 0.88 <= 0.9
  c.vehicle_diameter_m = 0.9;
  EXPECT_EQ(CollisionFactor(c, 0.075), 12);  // exactly 12 cells
  c.vehicle_diameter_m = 0.2;
  EXPECT_EQ(CollisionFactor(c, 0.075), 3);
  c.collision_factor = 5;
  EXPECT_EQ(CollisionFactor(c, 0.075), 5);
}

// eq. (14): E takes the probability of the column's maximum-entropy cell, ignoring cells below
// the floor.
TEST(ProjectedMaps, EntropyTakesMaxEntropyCellAboveFloor) {
  HandGrid g({2, 1, 5}, {0, 0, 0}, 0.1, 0.1f);
  const ProjectionConfig c = SmallConfig();  // floor 0.1: z cell 0 ignored
  // Column (0, 0): 0.5 below the floor (ignored), then 0.2, 0.45, 0.7, 0.01.
  g.at(0, 0, 0) = 0.5f;
  g.at(0, 0, 1) = 0.2f;
  g.at(0, 0, 2) = 0.45f;
  g.at(0, 0, 3) = 0.7f;
  g.at(0, 0, 4) = 0.01f;
  // Column (1, 0): 0.3 and 0.7 have equal entropy: ties go to the lowest cell.
  g.at(1, 0, 1) = 0.3f;
  g.at(1, 0, 2) = 0.7f;
  g.at(1, 0, 3) = 0.1f;
  g.at(1, 0, 4) = 0.1f;
  const GridMap2D e = ProjectEntropyMap(g.view(), c);
  ASSERT_EQ(e.width, 2);
  EXPECT_NEAR(e.resolution_m, 0.1, 1e-15);
  EXPECT_FLOAT_EQ(e.at(0, 0), 0.45f);
  // H(0.3f) and H(0.7f) differ in the last bits of a float; the larger wins.
  const double h3 = BinaryEntropy(0.3f), h7 = BinaryEntropy(0.7f);
  EXPECT_FLOAT_EQ(e.at(1, 0), h7 > h3 ? 0.7f : 0.3f);
}

// eq. (15): a well-known column becomes P_min_E or 1 - P_min_E by its mean.
TEST(ProjectedMaps, EntropyPminCorrection) {
  HandGrid g({4, 1, 4}, {0, 0, 0}, 0.1, 0.1f);
  const ProjectionConfig c = SmallConfig();
  // (0,0): all near 0 -> P_min_E.
  for (int k = 1; k < 4; ++k) g.at(0, 0, k) = 0.002f;
  // (1,0): mostly occupied, max-entropy cell 0.995 has H < H(0.01), mean > 0.5 -> 1 - P_min_E.
  g.at(1, 0, 1) = 0.999f;
  g.at(1, 0, 2) = 0.995f;
  g.at(1, 0, 3) = 0.001f;
  // (2,0): one occupied among free cells, mean <= 0.5 -> P_min_E.
  g.at(2, 0, 1) = 0.9999f;
  g.at(2, 0, 2) = 0.0001f;
  g.at(2, 0, 3) = 0.0001f;
  // (3,0): a cell at exactly P_min_E's entropy is corrected too (<=), the below-floor 0.5 is not
  // seen.
  g.at(3, 0, 0) = 0.5f;
  g.at(3, 0, 1) = 0.01f;
  g.at(3, 0, 2) = 0.005f;
  g.at(3, 0, 3) = 0.005f;
  ProjectionConfig c2 = c;
  c2.p_min_entropy = static_cast<double>(0.01f);
  const GridMap2D e = ProjectEntropyMap(g.view(), c2);
  EXPECT_EQ(e.at(0, 0), c2.p_min_entropy);
  EXPECT_EQ(e.at(1, 0), 1.0 - c2.p_min_entropy);
  EXPECT_EQ(e.at(2, 0), c2.p_min_entropy);
  EXPECT_EQ(e.at(3, 0), c2.p_min_entropy);
  // Not corrected: a column whose maximum entropy exceeds H(P_min_E).
  g.at(0, 0, 2) = 0.02f;
  EXPECT_FLOAT_EQ(ProjectEntropyMap(g.view(), c2).at(0, 0), 0.02f);
}

// A ceiling inside the map: cells wholly above ceiling_height_m are ignored like those below the
// floor (the paper's map top lies below the ceiling).
TEST(ProjectedMaps, EntropyIgnoresCellsAboveCeiling) {
  HandGrid g({1, 1, 6}, {0, 0, 0}, 0.1, 0.001f);
  ProjectionConfig c = SmallConfig();  // floor 0.1: z cell 0 ignored
  g.at(0, 0, 5) = 0.7f;                // the ceiling, [0.5, 0.6)
  EXPECT_FLOAT_EQ(ProjectEntropyMap(g.view(), c).at(0, 0), 0.7f);
  c.ceiling_height_m = 0.5;
  EXPECT_EQ(ProjectEntropyMap(g.view(), c).at(0, 0), c.p_min_entropy);
  c.ceiling_height_m = 0.55;  // the cell straddles the ceiling: kept
  EXPECT_FLOAT_EQ(ProjectEntropyMap(g.view(), c).at(0, 0), 0.7f);
}

// Random columns against a direct transcription of eqs. (14)-(15).
TEST(ProjectedMaps, EntropyMatchesOracleOnRandomGrids) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  HandGrid g({9, 8, 10}, {1.0, -2.0, -0.15}, 0.075, 0.1f);
  ProjectionConfig c;
  c.floor_height_m = 0.0;  // z cells 0, 1 ([-0.15, 0)) ignored
  for (int trial = 0; trial < 20; ++trial) {
    for (float& v : g.values) {
      const double r = u(rng);
      v = static_cast<float>(r < 0.4 ? 0.005 * u(rng) : (r < 0.6 ? 1.0 - 0.005 * u(rng) : u(rng)));
    }
    const GridMap2D e = ProjectEntropyMap(g.view(), c);
    for (int j = 0; j < 8; ++j) {
      for (int i = 0; i < 9; ++i) {
        std::vector<double> col;
        for (int k = 2; k < 10; ++k) col.push_back(g.at(i, j, k));
        double best = col[0];
        for (double p : col) best = BinaryEntropy(p) > BinaryEntropy(best) ? p : best;
        double mean = 0;
        for (double p : col) mean += p / col.size();
        if (BinaryEntropy(best) <= BinaryEntropy(c.p_min_entropy)) {
          best = mean <= 0.5 ? c.p_min_entropy : 1.0 - c.p_min_entropy;
        }
        ASSERT_NEAR(e.at(i, j), best, 1e-15) << i << " " << j;
      }
    }
  }
}

// Section 8: band cells at or below P_init within the radius count as free in C; cells outside
// the radius or above P_init (some evidence of occupancy) do not; B's minimum is unchanged.
TEST(ProjectedMaps, StartupZoneFreesUnseenBandCellsNearStart) {
  HandGrid g({9, 3, 8}, {0, 0, 0}, 0.1, 0.1f);  // all unknown
  const ProjectionConfig c = SmallConfig();
  g.at(1, 1, 4) = 0.10001f;  // seen, a little occupied, near: stays
  const StartupFreeZone zone{{0.45, 0.15}, 0.5};
  const CollisionProjection p = ProjectCollisionMaps(g.view(), c, zone);
  // Cell (0,0) covers x [0, 0.3): every band cell within 0.5 m but (1,1,4).
  EXPECT_FLOAT_EQ(p.collision.at(0, 0), 0.10001f);
  g.at(1, 1, 4) = 0.08f;  // grazed by free rays, above C_thresh: freed near the start
  EXPECT_EQ(ProjectCollisionMaps(g.view(), c, zone).collision.at(0, 0), 0.0);
  EXPECT_FLOAT_EQ(ProjectCollisionMaps(g.view(), c).collision.at(0, 0), 0.1f);  // no zone
  g.at(1, 1, 4) = 0.1f;
  const CollisionProjection q = ProjectCollisionMaps(g.view(), c, zone);
  EXPECT_EQ(q.collision.at(0, 0), 0.0);
  EXPECT_EQ(q.collision.at(1, 0), 0.0);  // x [0.3, 0.6): centres within 0.5 of x = 0.45
  // Cell (2, 0): x [0.6, 0.9), centres 0.65..0.85 -> 0.85 is 0.4 away in x, 0.1..0.2 in y:
  // distances up to sqrt(0.4^2 + 0.1^2) = 0.41 < 0.5 -> all free.
  EXPECT_EQ(q.collision.at(2, 0), 0.0);
  HandGrid far = g;
  const StartupFreeZone small{{0.45, 0.15}, 0.2};
  const CollisionProjection r = ProjectCollisionMaps(far.view(), c, small);
  EXPECT_FLOAT_EQ(r.collision.at(2, 0), 0.1f);  // 0.65 - 0.45 = 0.2 in x plus y offset > 0.2
  EXPECT_FLOAT_EQ(q.combined.at(0, 0), 0.1f);   // B's minimum still sees P_init
  // Radius alpha_C/2 + alpha_C/(2 tan(vfov/2)).
  EXPECT_NEAR(StartupFreeRadius(0.9, M_PI / 2), 0.45 + 0.45, 1e-12);
}

// The adapter reads mapping's dense grid in place.
TEST(ProjectedMaps, ViewOfDenseGrid) {
  MapLimits limits;
  limits.min_m = {-1.0, -1.0, -0.15};
  limits.max_m = {1.0, 0.5, 1.5};
  DenseGrid grid(limits, 0.1f);
  grid.Set({3, 4, 5}, 0.7f);
  const OccupancyGridView v = ViewOf(grid);
  EXPECT_EQ(v.dims, Eigen::Vector3i(27, 20, 22));
  EXPECT_FLOAT_EQ(v.At(3, 4, 5), 0.7f);
  EXPECT_FLOAT_EQ(v.At(0, 0, 0), 0.1f);
}

// Config ranges are enforced with the field's name.
TEST(ProjectedMaps, ConfigValidation) {
  ProjectionConfig c;
  c.p_thresh = 0.05;  // below P_init
  EXPECT_THROW(c.Validate(), std::invalid_argument);
  try {
    c.Validate();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("p_thresh"), std::string::npos);
  }
}

}  // namespace
}  // namespace kestrel
