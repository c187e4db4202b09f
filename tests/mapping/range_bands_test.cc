// Range bands (mapping/range_bands.h, docs/algorithms.md §3.8): the window's nearest range
// against brute force, what a band does to a reading, and the defect they exist for: a depth
// camera whose mount is half a degree off, looking at a floor frame after frame, frees floor
// cells without bands and a twentieth as many with them.
#include "mapping/range_bands.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <vector>

#include "common/se3.h"
#include "mapping/occupancy_map.h"
#include "mapping/scan_integrator.h"

namespace kestrel {
namespace {

TEST(RangeBands, WindowMinEqualsBruteForce) {
  std::mt19937 rng(7);
  std::vector<double> scratch;
  for (int trial = 0; trial < 200; ++trial) {
    const int w = 1 + static_cast<int>(rng() % 12), h = 1 + static_cast<int>(rng() % 9);
    const int ku = static_cast<int>(rng() % 4), kv = static_cast<int>(rng() % 4);
    std::vector<double> r(static_cast<size_t>(w * h));
    for (double& x : r) {
      x = rng() % 4 == 0 ? std::nan("") : std::uniform_real_distribution<double>(0.1, 9.0)(rng);
    }
    std::vector<double> nearest(r.size(), -1.0);
    WindowMin(r.data(), w, h, ku, kv, nearest.data(), &scratch);
    for (int v = 0; v < h; ++v) {
      for (int u = 0; u < w; ++u) {
        double expected = std::numeric_limits<double>::infinity();
        for (int j = std::max(0, v - kv); j <= std::min(h - 1, v + kv); ++j) {
          for (int i = std::max(0, u - ku); i <= std::min(w - 1, u + ku); ++i) {
            const double x =
                r[static_cast<size_t>(i) + static_cast<size_t>(w) * static_cast<size_t>(j)];
            if (!std::isnan(x)) expected = std::min(expected, x);
          }
        }
        ASSERT_EQ(nearest[static_cast<size_t>(u + w * v)], expected) << u << ", " << v;
      }
    }
  }
  EXPECT_THROW(WindowMin(nullptr, 2, 2, 1, 1, nullptr, &scratch), std::invalid_argument);
}

TEST(RangeBands, HalfWidthAndReadings) {
  EXPECT_EQ(BandWindowHalfWidth(0.0, 580.0), 0);
  EXPECT_EQ(BandWindowHalfWidth(0.0175, 72.0), 2);    // 1.26 pixels: the next whole pixel
  EXPECT_EQ(BandWindowHalfWidth(0.0175, 580.0), 11);  // 10.15
  EXPECT_EQ(BandWindowHalfWidth(0.01, 100.0), 1);     // exactly one pixel
  EXPECT_THROW(static_cast<void>(BandWindowHalfWidth(-0.1, 1.0)), std::invalid_argument);
  EXPECT_THROW(static_cast<void>(BandWindowHalfWidth(0.1, 0.0)), std::invalid_argument);
  const Reading ret{ReadingKind::kReturn, 3.0};
  EXPECT_DOUBLE_EQ(WithRangeBand(ret, 2.25, 4.0).below_m, 0.75);
  EXPECT_EQ(WithRangeBand(ret, 3.0, 4.0).below_m, 0.0);
  EXPECT_FALSE(WithRangeBand(ret, 2.25, 4.0).surface_unknown);  // no limit by default
  EXPECT_TRUE(WithRangeBand(ret, 2.25, 4.0, 0.5).surface_unknown);
  EXPECT_FALSE(WithRangeBand(ret, 2.75, 4.0, 0.5).surface_unknown);
  const Reading none{ReadingKind::kNoReturn, 0.0};
  EXPECT_EQ(WithRangeBand(none, 3.5, 4.0).kind, ReadingKind::kInvalid);  // a surface within delta
  EXPECT_EQ(WithRangeBand(none, 4.0, 4.0).kind, ReadingKind::kNoReturn);
  EXPECT_EQ(WithRangeBand(none, std::numeric_limits<double>::infinity(), 4.0).kind,
            ReadingKind::kNoReturn);
  EXPECT_EQ(WithRangeBand(Reading{}, 1.0, 4.0).kind, ReadingKind::kInvalid);
}

// Counts of the floor's cells (centre below z = 0) and of the air's cells (centre 0.3-0.9 m up)
// that a map holds below half the prior.
struct Freed {
  int floor = 0;
  int air = 0;
};

// A camera 1 m above a floor (z = 0, a cell face), pitched 20 degrees down, 80 x 60 pixels as in
// the CI sensor profile; its true mount is pitched `error_rad` up from the one the map is told,
// so every believed ray dips into the floor's top cells before its range. 30 frames of the same
// view (the error is the same in every frame).
Freed FlyOverFloor(double error_rad, double direction_uncertainty_rad,
                   double band_surface_max_m = std::numeric_limits<double>::infinity()) {
  MapLimits limits;
  limits.min_m = Eigen::Vector3d(-1.0, -3.0, -0.3);
  limits.max_m = Eigen::Vector3d(6.5, 3.0, 1.5);
  auto map = MakeExactDenseMap(limits, OccupancyLimits{}, 4.0);
  SensorModelConfig config = SensorModelConfig::Xtion();
  config.direction_uncertainty_rad = direction_uncertainty_rad;
  config.band_surface_max_m = band_surface_max_m;
  const SensorModel xtion(config);
  // Optical frame: z forward, x right, y down; looking along +x, pitched down by 20 degrees.
  Eigen::Matrix3d level;
  level.col(0) = -Eigen::Vector3d::UnitY();
  level.col(1) = -Eigen::Vector3d::UnitZ();
  level.col(2) = Eigen::Vector3d::UnitX();
  const auto pitched_down = [&](double rad) {
    return Eigen::Matrix3d(Eigen::AngleAxisd(rad, Eigen::Vector3d::UnitY()) * level);
  };
  Pose3 believed;
  believed.p = Eigen::Vector3d(0.0, 0.0, 1.0);
  believed.q = Eigen::Quaterniond(pitched_down(20.0 * M_PI / 180.0));
  const Eigen::Matrix3d R_true = pitched_down(20.0 * M_PI / 180.0 - error_rad);
  const DepthIntrinsics in{72.0, 72.0, 39.5, 29.5};
  std::vector<uint16_t> depth(size_t{80} * 60, 0);
  for (int v = 0; v < 60; ++v) {
    for (int u = 0; u < 80; ++u) {
      const Eigen::Vector3d ray_S((u - in.cx) / in.fx, (v - in.cy) / in.fy, 1.0);
      const Eigen::Vector3d dir = R_true * ray_S;  // not unit: its z-component is per unit depth
      if (dir.z() >= 0.0) continue;
      const double axial = believed.p.z() / -dir.z();  // depth along the optical axis to z = 0
      if (axial < 8.0) {
        depth[static_cast<size_t>(u) + size_t{80} * static_cast<size_t>(v)] =
            static_cast<uint16_t>(std::lround(axial * 1000.0));
      }
    }
  }
  ScanIntegrator integrator(map.get());
  for (int frame = 0; frame < 30; ++frame) {
    integrator.IntegrateDepthImage(believed, in, depth.data(), 80, 60, 0.001, xtion);
  }
  Freed freed;
  const GridGeometry& g = map->grid().geometry();
  const CellIndex& dims = map->grid().dims();
  for (int z = 0; z < dims.z; ++z) {
    for (int y = 0; y < dims.y; ++y) {
      for (int x = 0; x < dims.x; ++x) {
        const CellIndex c{x, y, z};
        const double centre_z = g.CenterOf(c).z();
        if (map->ProbabilityAt(c) >= 0.05) continue;
        if (centre_z < 0.0) ++freed.floor;
        if (centre_z > 0.3 && centre_z < 0.9) ++freed.air;
      }
    }
  }
  return freed;
}

// The predicted band (the explorer's, docs/algorithms.md §3.8 "Predicted bands") against the
// nearest range, found by brute force, that rays within delta of a ray meeting a plane read.
TEST(RangeBands, PredictedBandIsTheNearestRangeOnThePlaneWithinDelta) {
  SensorModelConfig model = SensorModelConfig::Xtion();
  model.z_max_m = 100.0;
  for (const double delta : {0.002, 0.0175, 0.1}) {
    model.direction_uncertainty_rad = delta;
    for (const double phi_deg : {0.0, 0.05, 5.0, 30.0, 60.0, 80.0, 88.0}) {
      const double phi = phi_deg * M_PI / 180.0;
      const double z = 3.0;
      const double plane = z * std::cos(phi);  // its distance from the origin
      double nearest = std::numeric_limits<double>::infinity();
      for (int i = -20000; i <= 20000; ++i) {  // rays within delta of the ray, in its plane
        const double theta = phi + delta * i / 20000.0;
        if (std::abs(theta) < M_PI / 2) nearest = std::min(nearest, plane / std::cos(theta));
      }
      const Reading r = PredictedBandedReturn(model, z, std::cos(phi));
      EXPECT_EQ(r.kind, ReadingKind::kReturn);
      EXPECT_NEAR(r.z_m - r.below_m, nearest, 1e-6 * z) << delta << " " << phi_deg;
      EXPECT_FALSE(r.surface_unknown);  // no band_surface_max_m
    }
  }
  // A band wider than band_surface_max_m says only "nothing nearer"; delta 0 is the plain return.
  model.direction_uncertainty_rad = 0.0175;
  model.band_surface_max_m = 0.1;
  const Reading grazing = PredictedBandedReturn(model, 3.0, std::cos(80.0 * M_PI / 180.0));
  EXPECT_GT(grazing.below_m, 0.1);
  EXPECT_TRUE(grazing.surface_unknown);
  EXPECT_FALSE(PredictedBandedReturn(model, 3.0, 1.0).has_band());
  model.direction_uncertainty_rad = 0.0;
  EXPECT_FALSE(PredictedBandedReturn(model, 3.0, 0.01).has_band());
}

// The window's angle in whole samples: the CI camera's rows (f_y = 30 / tan(22.5 deg)) and the
// URG-04LX's beams for delta = 1 degree, and an exact multiple of the spacing.
TEST(RangeBands, BandWindowAngleIsWholeSamples) {
  const double fy = 30.0 / std::tan(22.5 * M_PI / 180.0);   // 72.43 px/rad
  EXPECT_DOUBLE_EQ(BandWindowAngle(0.0175, fy), 2.0 / fy);  // 1.27 rows -> 2
  const double step = 2.0 * M_PI / 1024.0;
  EXPECT_DOUBLE_EQ(BandWindowAngle(0.0175, 1.0 / step), 3.0 * step);  // 2.85 beams -> 3
  EXPECT_DOUBLE_EQ(BandWindowAngle(0.5, 4.0), 0.5);
  EXPECT_EQ(BandWindowAngle(0.0, fy), 0.0);
  EXPECT_THROW((void)BandWindowAngle(-0.1, fy), std::invalid_argument);
}

TEST(RangeBands, AMountHalfADegreeOffFreesFewFloorCellsWithBands) {
  const Freed exact_mount = FlyOverFloor(0.0, 0.0);
  const Freed plain = FlyOverFloor(0.5 * M_PI / 180.0, 0.0);
  const Freed banded = FlyOverFloor(0.5 * M_PI / 180.0, 0.0175);
  const Freed surface = FlyOverFloor(0.5 * M_PI / 180.0, 0.0175, 0.1);
  std::printf(
      "floor cells freed: exact mount %d, plain %d, banded %d, surface within 0.1 m %d; air %d, "
      "%d, %d, %d\n",
      exact_mount.floor, plain.floor, banded.floor, surface.floor, exact_mount.air, plain.air,
      banded.air, surface.air);
  // Without bands the floor's top cells are freed by rays that never entered them (382 when
  // measured); with the true mount a handful at the edge of the range (3).
  EXPECT_GT(plain.floor, 200);
  EXPECT_LE(exact_mount.floor, 10);
  // With bands a twentieth of that or less (15 when measured, all 3.8-4 m away, at the edge of
  // the range), and the air in front of the floor is learned as well as without.
  EXPECT_LE(banded.floor, plain.floor / 20);
  EXPECT_GT(banded.air, plain.air * 9 / 10);
  EXPECT_GT(banded.air, 5000);
  // Those few lie just behind returns from the floor at the edge of the range, whose band is
  // wide: the cells behind an uncertain surface lose a little each frame (the surface is then
  // more likely nearer). A band wider than 0.1 m updates nothing from its near end on: none.
  EXPECT_EQ(surface.floor, 0);
  EXPECT_GT(surface.air, plain.air * 9 / 10);
}

// Off (0, the default), a scan gives the map its rays give one by one without bands (the path
// that never looks at neighbours), bit for bit; with bands the map differs.
TEST(RangeBands, OffIsTheMapWithoutBandsBitForBit) {
  std::vector<float> ranges(181);
  for (size_t i = 0; i < ranges.size(); ++i) {
    ranges[i] = i % 17 == 3
                    ? std::numeric_limits<float>::infinity()
                    : static_cast<float>(1.5 + 0.8 * std::sin(0.2 * static_cast<double>(i)));
  }
  Pose3 X_WS;
  X_WS.p = Eigen::Vector3d(0.1, 0.2, 0.7);
  const double step = M_PI / 180.0;
  const auto scan_hash = [&](double delta) {
    auto map = MakeExactDenseMap(MapLimits{}, OccupancyLimits{}, 4.0);
    SensorModelConfig config = SensorModelConfig::Hokuyo();
    config.direction_uncertainty_rad = delta;
    ScanIntegrator(map.get()).IntegratePlanarScan(X_WS, -M_PI / 2, step, ranges.data(), 181,
                                                  SensorModel(config));
    return map->Hash();
  };
  auto by_ray = MakeExactDenseMap(MapLimits{}, OccupancyLimits{}, 4.0);
  const SensorModel plain(SensorModelConfig::Hokuyo());
  ScanIntegrator integrator(by_ray.get());
  for (int i = 0; i < 181; ++i) {
    const double a = -M_PI / 2 + i * step;
    integrator.IntegrateRay(X_WS.p, Eigen::Vector3d(std::cos(a), std::sin(a), 0.0), ranges[i],
                            plain);
  }
  EXPECT_EQ(scan_hash(0.0), by_ray->Hash());
  EXPECT_NE(scan_hash(0.02), by_ray->Hash());
}

}  // namespace
}  // namespace kestrel
