// The simulator's ray reach record (sim/ray_reach.h) and the depth of a point inside the solids
// (sim/world.h): what the claims of docs/algorithms.md §12.5 are measured against.
#include "sim/ray_reach.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>

#include "sim/simulator.h"
#include "sim/world.h"

namespace kestrel {
namespace {

// A ray marks exactly the cells the walk visits up to its length, each with its first time.
TEST(RayReach, MarksTheWalkedCellsWithTheirFirstTime) {
  const GridSpec grid = GridSpec::FromLimits({0, 0, 0}, {1, 1, 1}, 0.1);
  RayReach reach(grid);
  // Along x through the middle of row (y 5, z 5), from x = 0.05 to 0.44: cells 0..4.
  reach.AddRay({0.05, 0.55, 0.55}, {1, 0, 0}, 0.39, 2.0);
  EXPECT_EQ(reach.reached_cells(), 5u);
  for (int x = 0; x < 10; ++x) {
    const double t = reach.first_reach_s()[grid.IndexOf({x, 5, 5})];
    if (x <= 4) {
      EXPECT_EQ(t, 2.0) << x;
    } else {
      EXPECT_TRUE(std::isinf(t)) << x;
    }
  }
  reach.AddRay({0.05, 0.55, 0.55}, {1, 0, 0}, 0.7, 3.0);
  EXPECT_EQ(reach.first_reach_s()[grid.IndexOf({2, 5, 5})], 2.0) << "the first time stays";
  EXPECT_EQ(reach.first_reach_s()[grid.IndexOf({7, 5, 5})], 3.0);
  EXPECT_EQ(reach.reached_cells(), 8u);
  // Outside the grid: ignored.
  reach.AddRay({-5, -5, -5}, {1, 0, 0}, 1.0, 4.0);
  EXPECT_EQ(reach.reached_cells(), 8u);
}

// The file holds the record exactly; another file is refused with the line and the reason.
TEST(RayReach, FileRoundTripAndRefusals) {
  const GridSpec grid = GridSpec::FromLimits({-1, -2, -0.15}, {1, 2, 1.5}, 0.075);
  RayReach reach(grid);
  reach.AddRay({0, 0, 0.5}, Eigen::Vector3d(1, 1, 0.2).normalized(), 2.0, 1700000000.123456);
  char dir[] = "/tmp/kestrel-reach-XXXXXX";
  ASSERT_NE(mkdtemp(dir), nullptr);
  const std::string path = std::string(dir) + "/run.reach";
  std::string error;
  ASSERT_TRUE(WriteRayReachFile(path, reach, &error)) << error;
  const RayReach back = ReadRayReachFile(path);
  EXPECT_EQ(back.grid().dims, grid.dims);
  EXPECT_EQ(back.reached_cells(), reach.reached_cells());
  for (size_t i = 0; i < grid.size(); ++i) {
    const double a = reach.first_reach_s()[i], b = back.first_reach_s()[i];
    if (std::isinf(a)) {
      EXPECT_TRUE(std::isinf(b));
    } else {
      EXPECT_NEAR(a, b, 1e-6);
    }
  }
  std::ofstream(path) << "kestrel-ray-reach 1\ngrid 0 0 0 0.1 2 2 2\n9 1.0\n";
  try {
    (void)ReadRayReachFile(path);
    ADD_FAILURE() << "a cell outside the grid was read";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("line 3: cell 9 outside the grid"), std::string::npos)
        << e.what();
  }
  std::ofstream(path) << "kestrel-map 1\n";
  EXPECT_THROW((void)ReadRayReachFile(path), std::runtime_error);
  std::remove(path.c_str());
  rmdir(dir);
}

// Depth inside: the distance to the surface of the primitive the point is in, 0 outside.
TEST(DepthInsideObstacle, BoxesCylindersAndPlanes) {
  World w;
  WorldBox wall;
  wall.center_m = Eigen::Vector3d(1, 0, 1);
  wall.half_extents_m = Eigen::Vector3d(0.05, 2, 1);
  w.boxes.push_back(wall);
  WorldBox turned = wall;
  turned.center_m = Eigen::Vector3d(5, 0, 1);
  turned.q_WO = Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 4, Eigen::Vector3d::UnitZ()));
  w.boxes.push_back(turned);
  WorldCylinder pillar;
  pillar.center_xy_m = Eigen::Vector2d(3, 3);
  pillar.radius_m = 0.2;
  pillar.z_min_m = 0;
  pillar.z_max_m = 2;
  w.cylinders.push_back(pillar);
  w.planes.push_back(WorldPlane{"floor", Eigen::Vector3d::UnitZ(), 0.0});
  EXPECT_NEAR(DepthInsideObstacle(w, {1.0, 0, 1}), 0.05, 1e-12);
  EXPECT_NEAR(DepthInsideObstacle(w, {1.03, 0, 1}), 0.02, 1e-12);
  EXPECT_EQ(DepthInsideObstacle(w, {1.06, 0, 1}), 0.0);
  // 2 cm into the turned wall along its normal (the box's x axis at 45 deg).
  const Eigen::Vector3d normal(std::sqrt(0.5), std::sqrt(0.5), 0);
  EXPECT_NEAR(DepthInsideObstacle(w, Eigen::Vector3d(5, 0, 1) + 0.03 * normal), 0.02, 1e-12);
  EXPECT_NEAR(DepthInsideObstacle(w, {3.1, 3, 1}), 0.1, 1e-12);
  EXPECT_NEAR(DepthInsideObstacle(w, {3, 3, 1.95}), 0.05, 1e-12);
  EXPECT_NEAR(DepthInsideObstacle(w, {8, 8, -0.3}), 0.3, 1e-12);
  EXPECT_EQ(DepthInsideObstacle(w, {8, 8, 0.3}), 0.0);
}

// The simulator's record in front of a wall: every depth pixel and beam marks the cells up to
// its first hit, the hit cell included, and never a cell beyond the wall's face.
TEST(RayReach, SimulatorMarksCellsUpToTheFirstHitOnly) {
  SimConfig config;
  config.world.map_min_m = Eigen::Vector3d(-20, -20, -20);
  config.world.map_max_m = Eigen::Vector3d(20, 20, 20);
  config.world.exploration_height_m = 0.0;
  WorldBox
      wall;  // its near face at x = 2.03 (inside a cell), wider and taller than the sensors see
  wall.center_m = Eigen::Vector3d(2.08, 0, 0);
  wall.half_extents_m = Eigen::Vector3d(0.05, 10, 10);
  config.world.boxes.push_back(wall);
  config.mode = "kinematic";
  config.depth = DepthCameraConfig::WithResolution(80, 60);
  Simulator sim(config, 0);
  const GridSpec grid = GridSpec::FromLimits({-1, -3, -2}, {4, 3, 2}, 0.075);
  RayReach reach(grid);
  sim.SetRayReach(&reach);
  int frames = 0, scans = 0;
  for (int i = 0; i < 1000 && scans == 0; ++i) {
    const SimFrame& f = sim.Step();
    frames += f.depth ? 1 : 0;
    scans += f.scan ? 1 : 0;
  }
  ASSERT_GT(frames, 0);
  ASSERT_EQ(scans, 1);
  EXPECT_EQ(reach.rays(), frames * 80 * 60 + config.lidar.num_beams) << "every pixel and beam";
  size_t beyond = 0, at_face = 0;
  for (size_t i = 0; i < grid.size(); ++i) {
    if (std::isinf(reach.first_reach_s()[i])) continue;
    const Eigen::AlignedBox3d box = grid.BoxOf(grid.CellOf(i));
    beyond += box.min().x() > 2.03 ? 1 : 0;
    at_face += box.min().x() < 2.03 && box.max().x() > 2.03 ? 1 : 0;
  }
  EXPECT_EQ(beyond, 0u) << "no cell beyond the first hit";
  // The camera's 58 x 45 deg at 2 m covers about 29 x 22 cells of the face.
  EXPECT_GT(at_face, 500u) << "the cells holding the hits are reached";
  EXPECT_GT(reach.reached_cells(), 5000u);
}

}  // namespace
}  // namespace kestrel
