// The Xtion's minimum range is an axial depth: a surface nearer than 0.5 m along the optical axis
// reads 0, the same count as "nothing within range". An oblique pixel's ray is longer than its
// axial depth (up to 1.216 times at the corners of a 58 x 45 deg image), so a wall 0.45 m ahead
// lies up to 0.55 m along the corner rays: beyond a range limit of 0.5 m. A mapper whose z_min
// is 0.5 m then reads those zeros as "no return although the first occupied cell is in range"
// (likelihood p_miss) and erases the wall in front of a vehicle that flies up to it, exactly
// where the clearance matters. The shipped Xtion model's z_min covers the longest corner ray
// (docs/algorithms.md §3.4). This test flies the simulator's camera up to a wall and asserts the
// wall stays mapped with the shipped model, and is erased with z_min = 0.5 m and the zeros read
// as no-returns (so it can fail). The shipped model reads a 0 as no evidence at all: zeros from a
// door jamb in the blind zone then free nothing behind the wall.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "common/config.h"
#include "mapping/mapper_config.h"
#include "mapping/occupancy_map.h"
#include "mapping/scan_integrator.h"
#include "sim/sensors.h"
#include "sim/sim_random.h"
#include "sim/world.h"
#include "sim/world_ray_caster.h"

namespace kestrel {
namespace {

constexpr double kWallX = 1.0;  // the wall's near face, m

World WallWorld() {
  World w;
  w.map_min_m = Eigen::Vector3d(-1.0, -2.0, 0.0);
  w.map_max_m = Eigen::Vector3d(2.0, 2.0, 2.0);
  WorldBox wall;
  wall.name = "wall";
  wall.center_m = Eigen::Vector3d(kWallX + 0.1, 0.0, 1.0);
  wall.half_extents_m = Eigen::Vector3d(0.1, 2.0, 1.0);
  w.boxes.push_back(wall);
  return w;
}

/// The camera looking along +x_W (optical z forward, x right, y down) at height 1 m.
Pose3 CameraAt(double x_m) {
  Pose3 X_WS;
  X_WS.p = Eigen::Vector3d(x_m, 0.0, 1.0);
  X_WS.q = Eigen::Quaterniond(0.5, -0.5, 0.5, -0.5);  // z_S = x_W, x_S = -y_W, y_S = -z_W
  return X_WS;
}

SensorModelConfig ShippedXtionModel() {
  const MapperConfig c = LoadMapperConfig(
      ConfigNode::LoadFile(std::string(KESTREL_SOURCE_DIR) + "/config/mapper.yaml"));
  for (const MapperSensorConfig& s : c.sensors) {
    if (s.name == "xtion") return s.model;
  }
  ADD_FAILURE() << "config/mapper.yaml has no xtion sensor";
  return SensorModelConfig::Xtion();
}

/// Fraction of the wall's face cells in the close camera's view (|y| <= 0.2 m, |z - 1| <= 0.15 m)
/// that are occupied (P > 0.5) after 20 frames from 1.5 m and then 60 frames from 0.48 m
/// (axial), where every ray but the central ones is longer than 0.5 m.
double FaceOccupiedAfterCloseApproach(const SensorModelConfig& xtion, int close_frames = 60) {
  const World world = WallWorld();
  const WorldRayCaster caster(world);
  const DepthCamera camera(DepthCameraConfig::WithResolution(80, 60));
  const DepthCameraConfig& cc = camera.config();
  const double fx = 0.5 * cc.width_px / std::tan(0.5 * cc.hfov_deg * M_PI / 180.0);
  const double fy = 0.5 * cc.height_px / std::tan(0.5 * cc.vfov_deg * M_PI / 180.0);
  const DepthIntrinsics in{fx, fy, 0.5 * (cc.width_px - 1), 0.5 * (cc.height_px - 1)};
  MapLimits limits;
  limits.min_m = world.map_min_m;
  limits.max_m = world.map_max_m;
  auto map = MakeExactDenseMap(limits, OccupancyLimits{}, xtion.z_max_m);
  ScanIntegrator integrator(map.get());
  const SensorModel model(xtion);
  SimRandom rng(7);
  std::vector<uint16_t> counts;
  for (int i = 0; i < 20 + close_frames; ++i) {
    const Pose3 X_WS = CameraAt(i < 20 ? kWallX - 1.5 : kWallX - 0.48);
    camera.Render(caster, X_WS, &rng, &counts);
    integrator.IntegrateDepthImage(X_WS, in, counts.data(), cc.width_px, cc.height_px,
                                   cc.depth_scale_m, model);
  }
  int occupied = 0, total = 0;
  const GridGeometry& g = map->grid().geometry();
  for (double y = -0.2; y <= 0.2; y += g.resolution_m()) {
    for (double z = 0.85; z <= 1.15; z += g.resolution_m()) {
      const auto cell = g.CellOf(Eigen::Vector3d(kWallX + 0.01, y, z));
      if (!cell) continue;
      ++total;
      occupied += map->ProbabilityAt(*cell) > 0.5 ? 1 : 0;
    }
  }
  return total > 0 ? static_cast<double>(occupied) / total : 0.0;
}

TEST(NearWall, ShippedXtionModelKeepsTheWallTheCameraIsTooCloseToSee) {
  const SensorModelConfig shipped = ShippedXtionModel();
  // The longest ray of the image: its axial depth 0.5 m must lie within the model's z_min.
  const double corner = std::sqrt(1.0 + std::pow(std::tan(29.0 * M_PI / 180.0), 2) +
                                  std::pow(std::tan(22.5 * M_PI / 180.0), 2));
  EXPECT_GE(shipped.z_min_m, 0.5 * corner);
  EXPECT_GT(FaceOccupiedAfterCloseApproach(shipped, 0), 0.95);  // mapped from 1.5 m
  EXPECT_GT(FaceOccupiedAfterCloseApproach(shipped), 0.95);
}

// With a 0 read as "no return" (no_return_informs), a range limit of the axial minimum erases
// the wall the camera is too close to see; with the shipped rule a 0 is no evidence at all.
TEST(NearWall, RangeLimitOfTheAxialMinimumErasesTheWall) {
  SensorModelConfig axial = ShippedXtionModel();
  axial.z_min_m = 0.5;
  axial.no_return_informs = true;
  EXPECT_LT(FaceOccupiedAfterCloseApproach(axial), 0.5);
}

// The end of a thin wall (a door jamb) 0.3 m in front of the camera, nearer than its minimum:
// every pixel that meets it reads 0. The room behind the wall is out of every ray's reach. Read as
// "no return", the zeros free it within a few frames (each 0 multiplies the odds of every far cell
// by about q p_miss + 1 - q, q the belief that the blind zone is empty: docs/algorithms.md §3.4);
// with the shipped model (a 0 is no evidence) not one cell behind the wall becomes known free.
int CellsBehindTheJambKnownFree(const SensorModelConfig& xtion, int frames) {
  World world;
  world.map_min_m = Eigen::Vector3d(-1.0, -2.0, 0.0);
  world.map_max_m = Eigen::Vector3d(4.0, 3.0, 2.0);
  WorldBox jamb;  // the wall: x 0.3..0.4, from y = -0.2 north
  jamb.center_m = Eigen::Vector3d(0.35, 1.4, 1.0);
  jamb.half_extents_m = Eigen::Vector3d(0.05, 1.6, 1.0);
  world.boxes.push_back(jamb);
  WorldBox back;  // a far wall, so that the pixels past the jamb's end return
  back.center_m = Eigen::Vector3d(3.1, 0.5, 1.0);
  back.half_extents_m = Eigen::Vector3d(0.1, 2.5, 1.0);
  world.boxes.push_back(back);
  const WorldRayCaster caster(world);
  const DepthCamera camera(DepthCameraConfig::WithResolution(80, 60));
  const DepthCameraConfig& cc = camera.config();
  const DepthIntrinsics in{camera.fx_px(), camera.fy_px(), camera.cx_px(), camera.cy_px()};
  MapLimits limits;
  limits.min_m = world.map_min_m;
  limits.max_m = world.map_max_m;
  auto map = MakeExactDenseMap(limits, OccupancyLimits{}, xtion.z_max_m);
  ScanIntegrator integrator(map.get());
  const SensorModel model(xtion);
  SimRandom rng(11);
  std::vector<uint16_t> counts;
  const Pose3 X_WS = CameraAt(0.0);
  for (int i = 0; i < frames; ++i) {
    camera.Render(caster, X_WS, &rng, &counts);
    integrator.IntegrateDepthImage(X_WS, in, counts.data(), cc.width_px, cc.height_px,
                                   cc.depth_scale_m, model);
  }
  const GridGeometry& g = map->grid().geometry();
  int known_free = 0;
  for (double x = 0.5; x <= 2.9; x += g.resolution_m()) {
    for (double y = 0.1; y <= 2.5; y += g.resolution_m()) {
      for (double z = 0.5; z <= 1.5; z += g.resolution_m()) {
        const auto cell = g.CellOf(Eigen::Vector3d(x, y, z));
        if (cell && map->ProbabilityAt(*cell) < 0.05) ++known_free;  // P < P_init / 2
      }
    }
  }
  return known_free;
}

TEST(NearWall, ZerosFromAJambInTheBlindZoneFreeNothingBehindTheWall) {
  SensorModelConfig zero_is_no_return = ShippedXtionModel();
  zero_is_no_return.no_return_informs = true;
  EXPECT_GT(CellsBehindTheJambKnownFree(zero_is_no_return, 15), 1000)
      << "read as no return, the zeros free the room no ray reached";
  EXPECT_EQ(CellsBehindTheJambKnownFree(ShippedXtionModel(), 15), 0);
}

}  // namespace
}  // namespace kestrel
