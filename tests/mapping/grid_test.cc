#include "mapping/grid.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace kestrel {
namespace {

// The paper's simulation map: 8 m / 0.075 m rounds up to 107 cells, 12 m to 160, 1.65 m to 22.
TEST(GridGeometry, CountsRoundUpToWholeCells) {
  const GridGeometry g = GridGeometry::Fixed(MapLimits{});
  EXPECT_EQ(g.upper().x, 107);
  EXPECT_EQ(g.upper().y, 160);
  EXPECT_EQ(g.upper().z, 22);
  EXPECT_EQ(g.lower(), (CellIndex{0, 0, 0}));
}

// Cells are aligned to the lower limit and half-open: a point on a boundary belongs to the upper
// cell; the lower limit itself is cell 0 and anything below it is outside.
TEST(GridGeometry, CellOfIsHalfOpenAndAlignedToLowerLimit) {
  const GridGeometry g = GridGeometry::Fixed(MapLimits{});
  EXPECT_EQ(*g.CellOf(Eigen::Vector3d(-4.0, -6.0, -0.15)), (CellIndex{0, 0, 0}));
  EXPECT_FALSE(g.CellOf(Eigen::Vector3d(-4.0 - 1e-12, 0.0, 0.0)).has_value());
  EXPECT_FALSE(g.CellOf(Eigen::Vector3d(0.0, 0.0, std::nan(""))).has_value());
  for (int i = 0; i < 107; ++i) {
    const double b = g.Boundary(0, i);
    EXPECT_EQ(g.CellOf(Eigen::Vector3d(b, 0.0, 0.0))->x, i);
    if (i > 0) {
      EXPECT_EQ(g.CellOf(Eigen::Vector3d(std::nextafter(b, -10.0), 0.0, 0.0))->x, i - 1);
    }
  }
  // The last cell sticks out past max (8/0.075 is not whole): 4.01 is still inside.
  EXPECT_EQ(g.CellOf(Eigen::Vector3d(4.01, 0.0, 0.0))->x, 106);
  EXPECT_FALSE(g.CellOf(Eigen::Vector3d(g.Boundary(0, 107), 0.0, 0.0)).has_value());
}

// CenterOf and CellOf are inverse on cell centres, for random cells.
TEST(GridGeometry, CenterOfRoundTrips) {
  const GridGeometry g = GridGeometry::Fixed(MapLimits{});
  std::mt19937 rng(7);
  for (int n = 0; n < 1000; ++n) {
    const CellIndex c{static_cast<int32_t>(rng() % 107), static_cast<int32_t>(rng() % 160),
                      static_cast<int32_t>(rng() % 22)};
    const Eigen::Vector3d p = g.CenterOf(c);
    EXPECT_EQ(*g.CellOf(p), c);
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(p[a], g.Boundary(a, c[a]) + 0.0375, 1e-12);
    }
  }
}

TEST(MapLimits, ValidateNamesTheBadValue) {
  MapLimits limits;
  limits.resolution_m = -1.0;
  EXPECT_THROW(
      {
        try {
          limits.Validate();
        } catch (const std::invalid_argument& e) {
          EXPECT_NE(std::string(e.what()).find("resolution_m = -1"), std::string::npos);
          throw;
        }
      },
      std::invalid_argument);
  limits = MapLimits{};
  limits.max_m.z() = limits.min_m.z();
  EXPECT_THROW(limits.Validate(), std::invalid_argument);
  OccupancyLimits occ;
  occ.p_init = 0.0;
  EXPECT_THROW(occ.Validate(), std::invalid_argument);
}

// The growing grid with the fixed map's origin holds the same lattice; untouched cells read the
// initial value without allocating, and writes allocate one 8x8x8 block at a time, including at
// negative indices.
TEST(GrowingGrid, AllocatesBlocksOnFirstTouch) {
  GrowingGrid grid(Eigen::Vector3d(-4.0, -6.0, -0.15), 0.075, 0.1f);
  EXPECT_EQ(grid.Get(CellIndex{5, 5, 5}), 0.1f);
  EXPECT_EQ(grid.block_count(), 0u);
  grid.Set(CellIndex{5, 5, 5}, 0.7f);
  grid.Set(CellIndex{7, 0, 1}, 0.2f);  // same block
  EXPECT_EQ(grid.block_count(), 1u);
  grid.Set(CellIndex{-1, 0, 0}, 0.3f);  // block -1 along x
  EXPECT_EQ(grid.block_count(), 2u);
  EXPECT_EQ(grid.Get(CellIndex{5, 5, 5}), 0.7f);
  EXPECT_EQ(grid.Get(CellIndex{-1, 0, 0}), 0.3f);
  EXPECT_EQ(grid.Get(CellIndex{-2, 0, 0}), 0.1f);
  uint32_t index = 99;
  const GrowingGrid::Block* block = grid.FindOrCreateBlock(CellIndex{0, 0, 0}, &index);
  EXPECT_EQ(index, 0u);  // created first
  EXPECT_EQ(block->values[GrowingGrid::OffsetInBlock(CellIndex{7, 0, 1})], 0.2f);
  EXPECT_EQ(grid.block_count(), 2u);
  std::vector<CellIndex> origins;
  grid.ForEachBlock(
      [&](const CellIndex& origin, const GrowingGrid::Block&) { origins.push_back(origin); });
  ASSERT_EQ(origins.size(), 2u);
  EXPECT_EQ(origins[0], (CellIndex{-8, 0, 0}));  // ascending key order
  EXPECT_EQ(origins[1], (CellIndex{0, 0, 0}));
}

// Random writes through the blocks, the growing grid's Set and a dense grid agree cell by cell.
TEST(GrowingGrid, MatchesDenseGridOnRandomWrites) {
  const MapLimits limits;
  DenseGrid dense(limits, 0.1f);
  GrowingGrid growing(limits.min_m, limits.resolution_m, 0.1f);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> value(0.0f, 1.0f);
  for (int n = 0; n < 20000; ++n) {
    const CellIndex c{static_cast<int32_t>(rng() % 107), static_cast<int32_t>(rng() % 160),
                      static_cast<int32_t>(rng() % 22)};
    const float v = value(rng);
    dense.Set(c, v);
    if (n % 2 == 0) {
      const CellIndex block_origin{c.x & ~7, c.y & ~7, c.z & ~7};
      growing.FindOrCreateBlock(block_origin)->values[GrowingGrid::OffsetInBlock(c)] = v;
    } else {
      growing.Set(c, v);
    }
  }
  for (int z = 0; z < 22; ++z) {
    for (int y = 0; y < 160; ++y) {
      for (int x = 0; x < 107; ++x) {
        ASSERT_EQ(dense.Get(CellIndex{x, y, z}), growing.Get(CellIndex{x, y, z}));
      }
    }
  }
}

}  // namespace
}  // namespace kestrel
