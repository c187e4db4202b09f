// The ledger of cells looked at without learning (exploration/unlearned_cells.h): marked after
// `looks` looks whose entropy did not drop, never while each look teaches something, read as
// certain by the gain's view, and located by region; the cells in view stop behind an occupied
// cell and skip the blind zone.
#include "exploration/unlearned_cells.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "mapping/occupancy_updater.h"

namespace kestrel {
namespace {

// A 20 x 20 x 10 lattice of 0.1 m cells at the origin, every cell at P_init.
class UnlearnedCellsTest : public ::testing::Test {
 protected:
  UnlearnedCellsTest() : p_(20 * 20 * 10, 0.1F) {
    view_.dims = Eigen::Vector3i(20, 20, 10);
    view_.origin_m = Eigen::Vector3d::Zero();
    view_.resolution_m = 0.1;
    view_.probability = p_.data();
  }
  static int32_t Index(int x, int y, int z) { return x + 20 * (y + 20 * z); }

  std::vector<float> p_;
  OccupancyGridView view_;
};

TEST_F(UnlearnedCellsTest, MarkedAfterLooksThatTeachNothing) {
  UnlearnedCellsConfig config;
  config.looks = 3;
  UnlearnedCells ledger(config);
  const std::vector<int32_t> view{Index(1, 1, 1), Index(2, 1, 1), Index(2, 1, 1)};
  ledger.Look(view_, view);
  ledger.Look(view_, view);
  EXPECT_EQ(ledger.count(), 0u) << "two looks of three";
  ledger.Look(view_, view);
  EXPECT_EQ(ledger.count(), 2u) << "a duplicate in one look counts once";
  EXPECT_TRUE(ledger.unlearned(Index(1, 1, 1)));
  EXPECT_FALSE(ledger.unlearned(Index(3, 1, 1)));
  // For good: learning later does not unmark (the gain has stopped chasing it).
  p_[Index(1, 1, 1)] = 0.01F;
  ledger.Look(view_, view);
  EXPECT_TRUE(ledger.unlearned(Index(1, 1, 1)));
}

// A cell whose entropy drops at each look is learning: never marked. One that swings back (a
// contested cell: free, occupied, free, ...) learns nothing over its streak and is marked.
TEST_F(UnlearnedCellsTest, LearningCellsStayContestedCellsGo) {
  UnlearnedCellsConfig config;
  config.looks = 4;
  UnlearnedCells ledger(config);
  const int32_t learning = Index(5, 5, 5), contested = Index(6, 5, 5);
  const float learning_p[] = {0.1F, 0.06F, 0.035F, 0.02F, 0.012F, 0.007F};
  const float contested_p[] = {0.4F, 0.7F, 0.35F, 0.65F, 0.45F, 0.6F};
  for (int k = 0; k < 6; ++k) {
    p_[learning] = learning_p[k];
    p_[contested] = contested_p[k];
    ledger.Look(view_, {learning, contested});
  }
  EXPECT_FALSE(ledger.unlearned(learning));
  EXPECT_TRUE(ledger.unlearned(contested));
  // Cells at the clamp are certain: never tracked.
  UnlearnedCellsConfig clamp = config;
  clamp.certain_probability = 0.03;
  UnlearnedCells certain(clamp);
  p_[Index(7, 5, 5)] = 0.03F;
  // The high clamp as the map stores it, the float 1 - P_min (0.9999F is below the double 0.9999).
  p_[Index(8, 5, 5)] = static_cast<float>(1.0 - 0.03);
  for (int k = 0; k < 10; ++k) certain.Look(view_, {Index(7, 5, 5), Index(8, 5, 5)});
  EXPECT_EQ(certain.count(), 0u);
  // A contested cell that touches the clamp between its swings is still marked: the looks at
  // the clamp count neither way.
  UnlearnedCells bouncing(clamp);
  const float swing[] = {0.25F, 0.03F, 0.3F, 0.03F, 0.25F, 0.03F, 0.3F, 0.28F};
  for (const float p : swing) {
    p_[Index(7, 5, 5)] = p;
    bouncing.Look(view_, {Index(7, 5, 5)});
  }
  EXPECT_TRUE(bouncing.unlearned(Index(7, 5, 5)));
  // A free cell nearly certain (P 0.005: 0.036 nats, less than the drop a look needs) is not
  // unlearned however often it is looked at.
  UnlearnedCells nearly(config);
  p_[Index(9, 5, 5)] = 0.005F;
  for (int k = 0; k < 10; ++k) nearly.Look(view_, {Index(9, 5, 5)});
  EXPECT_EQ(nearly.count(), 0u);
  UnlearnedCells map_clamp(config);
  p_[Index(8, 5, 5)] = static_cast<float>(1.0 - 1e-4);
  for (int k = 0; k < 10; ++k) map_clamp.Look(view_, {Index(8, 5, 5)});
  EXPECT_EQ(map_clamp.count(), 0u);
}

TEST_F(UnlearnedCellsTest, GainViewReadsThemAsCertainAndRegionsLocateThem) {
  UnlearnedCellsConfig config;
  config.looks = 2;
  UnlearnedCells ledger(config);
  std::vector<int32_t> view;
  for (int x = 2; x < 5; ++x) view.push_back(Index(x, 3, 4));  // a row of three at P_init
  p_[Index(10, 10, 2)] = 0.6F;
  view.push_back(Index(10, 10, 2));  // one alone, more likely occupied
  ledger.Look(view_, view);
  ledger.Look(view_, view);
  ASSERT_EQ(ledger.count(), 4u);
  std::vector<float> gain = p_;
  ledger.ApplyTo(&gain, 1e-4);
  EXPECT_EQ(gain[Index(3, 3, 4)], 1e-4F);
  EXPECT_EQ(gain[Index(10, 10, 2)], static_cast<float>(1.0 - 1e-4));
  EXPECT_EQ(gain[Index(0, 0, 0)], 0.1F) << "the rest as in the map";
  double total = 0.0;
  const std::vector<UnlearnedRegion> regions = ledger.Regions(view_, 10, &total);
  ASSERT_EQ(regions.size(), 2u);
  EXPECT_EQ(regions[0].cells, 3u);
  EXPECT_NEAR(regions[0].min_m.x(), 0.2, 1e-9);
  EXPECT_NEAR(regions[0].max_m.x(), 0.5, 1e-9);
  EXPECT_NEAR(regions[0].centroid_m.x(), 0.35, 1e-9);
  EXPECT_NEAR(regions[0].entropy_nats, 3 * BinaryEntropy(0.1), 1e-6);
  EXPECT_EQ(regions[1].cells, 1u);
  EXPECT_NEAR(total, 3 * BinaryEntropy(0.1) + BinaryEntropy(0.6), 1e-6);
  UnlearnedCellsConfig off = config;
  off.enabled = false;
  UnlearnedCells none(off);
  none.Look(view_, view);
  none.Look(view_, view);
  EXPECT_EQ(none.count(), 0u);
}

// A planar sensor along +x from (0.05, 1.05, 0.55): cells whose d_k reaches z_min (0.28 m) on, up
// to and including the first cell with P > 0.5, nothing behind it.
TEST_F(UnlearnedCellsTest, CellsInViewSkipTheBlindZoneAndStopBehindAWall) {
  VolumetricSensor lidar;
  lidar.model.z_min_m = 0.28;
  lidar.model.z_max_m = 1.6;
  lidar.horizontal_fov_rad = 0.01;  // one azimuth: straight ahead
  lidar.vertical_fov_rad = 0.0;
  lidar.rows = 1;
  p_[Index(10, 10, 5)] = 0.9F;  // the wall, 1.0 m ahead
  const std::vector<int32_t> cells =
      CellsInView(view_, {lidar}, Eigen::Vector3d(0.05, 1.05, 0.55), 0.0, 360, 3);
  ASSERT_FALSE(cells.empty());
  EXPECT_EQ(cells.front(), Index(3, 10, 5)) << "from the first cell beyond 0.28 m on";
  EXPECT_EQ(cells.back(), Index(10, 10, 5)) << "the wall, and nothing behind it";
  EXPECT_EQ(cells.size(), 8u);
  p_[Index(10, 10, 5)] = 0.1F;
  const std::vector<int32_t> open =
      CellsInView(view_, {lidar}, Eigen::Vector3d(0.05, 1.05, 0.55), 0.0, 360, 3);
  EXPECT_EQ(open.back(), Index(16, 10, 5)) << "to z_max (1.65 m at the cell's far edge)";
}

}  // namespace
}  // namespace kestrel
