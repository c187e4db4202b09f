#include "sim/sensors.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

namespace kestrel {
namespace {

// Camera at the origin looking along +x_W: optical z -> +x_W, optical x (right) -> -y_W,
// optical y (down) -> -z_W.
Pose3 CameraLookingAlongX(const Eigen::Vector3d& p) {
  Eigen::Matrix3d R_WS;
  R_WS.col(0) = -Eigen::Vector3d::UnitY();
  R_WS.col(1) = -Eigen::Vector3d::UnitZ();
  R_WS.col(2) = Eigen::Vector3d::UnitX();
  Pose3 X_WS;
  X_WS.p = p;
  X_WS.q = Eigen::Quaterniond(R_WS);
  return X_WS;
}

World WallAt(double x_m) {
  World w;
  w.map_min_m = Eigen::Vector3d(-10, -10, -10);
  w.map_max_m = Eigen::Vector3d(10, 10, 10);
  w.boxes.push_back(
      WorldBox{"wall", {x_m + 0.5, 0, 0}, {0.5, 50, 50}, Eigen::Quaterniond::Identity()});
  return w;
}

struct Moments {
  double mean{0}, std{0};
  size_t n{0};
};

Moments MomentsOf(const std::vector<double>& x) {
  Moments m;
  m.n = x.size();
  for (double v : x) m.mean += v;
  m.mean /= static_cast<double>(m.n);
  double ss = 0;
  for (double v : x) ss += (v - m.mean) * (v - m.mean);
  m.std = std::sqrt(ss / static_cast<double>(m.n - 1));
  return m;
}

// Sample mean within 5 standard errors of `mean`, sample std within 5 of its standard errors
// (sigma / sqrt(2n) for near-normal data) of `sigma`.
void ExpectMoments(const std::vector<double>& x, double mean, double sigma) {
  const Moments m = MomentsOf(x);
  const double n = static_cast<double>(m.n);
  EXPECT_NEAR(m.mean, mean, 5.0 * sigma / std::sqrt(n)) << "n = " << m.n;
  EXPECT_NEAR(m.std, sigma, 5.0 * sigma / std::sqrt(2.0 * n)) << "n = " << m.n;
}

TEST(SimRandom, GaussianHasStandardMoments) {
  SimRandom rng(42);
  std::vector<double> x(1000000);
  for (double& v : x) v = rng.Gaussian();
  ExpectMoments(x, 0.0, 1.0);
  double m4 = 0;
  for (double v : x) m4 += v * v * v * v;
  m4 /= static_cast<double>(x.size());
  EXPECT_NEAR(m4, 3.0, 5.0 * std::sqrt(96.0 / static_cast<double>(x.size())));  // var(x^4) = 96
  std::vector<double> u(1000000);
  for (double& v : u) v = rng.Uniform();
  ExpectMoments(u, 0.5, std::sqrt(1.0 / 12.0));
  SimRandom a(7), b(7);
  for (int i = 0; i < 1000; ++i) ASSERT_EQ(a.Gaussian(), b.Gaussian());
}

// Per-pixel geometry against the pinhole formula on a slanted plane: depth
// z = (n.p0 - n.o) / (n . R_WS d_S) with d_S = ((u - cx)/fx, (v - cy)/fy, 1).
TEST(DepthCamera, SlantedWallGivesPinholeDepths) {
  World w;
  w.map_min_m = Eigen::Vector3d(-10, -10, -10);
  w.map_max_m = Eigen::Vector3d(10, 10, 10);
  const Eigen::Vector3d n = -Eigen::Vector3d(0.9, 0.3, 0.2).normalized();
  const Eigen::Vector3d p0(2.0, 0.0, 0.0);
  w.planes.push_back(WorldPlane{"slant", n, n.dot(p0)});
  const WorldRayCaster caster(w);
  DepthCameraConfig config = DepthCameraConfig::WithResolution(160, 120);
  config.noise = false;
  const DepthCamera camera(config);
  EXPECT_NEAR(camera.fx_px(), 80.0 / std::tan(29.0 * M_PI / 180), 1e-12);
  EXPECT_NEAR(camera.fy_px(), 60.0 / std::tan(22.5 * M_PI / 180), 1e-12);
  EXPECT_EQ(camera.cx_px(), 79.5);
  EXPECT_EQ(camera.cy_px(), 59.5);
  const Pose3 X_WS = CameraLookingAlongX(Eigen::Vector3d(0.1, -0.2, 0.3));
  std::vector<double> depth;
  camera.RenderTrueDepth(caster, X_WS, &depth);
  SimRandom rng(1);
  std::vector<uint16_t> counts;
  camera.Render(caster, X_WS, &rng, &counts);
  int in_range = 0;
  for (int v = 0; v < 120; ++v) {
    for (int u = 0; u < 160; ++u) {
      const Eigen::Vector3d d_S((u - camera.cx_px()) / camera.fx_px(),
                                (v - camera.cy_px()) / camera.fy_px(), 1.0);
      const double z = (n.dot(p0) - n.dot(X_WS.p)) / n.dot(X_WS.q * d_S);
      const size_t i = static_cast<size_t>(v) * 160 + u;
      const double expected = z <= config.range_max_m ? z : std::numeric_limits<double>::infinity();
      if (std::isfinite(expected)) {
        ASSERT_NEAR(depth[i], z, 1e-12) << u << "," << v;
      } else {
        ASSERT_EQ(depth[i], expected) << u << "," << v;
      }
      const bool valid = z >= config.range_min_m && z <= config.range_max_m;
      in_range += valid ? 1 : 0;
      ASSERT_EQ(counts[i], valid ? static_cast<uint16_t>(std::lround(z / 0.001)) : 0)
          << u << "," << v;
    }
  }
  EXPECT_GT(in_range, 1000);
}

// A face-on wall at 2 m reads 2000 mm everywhere; walls nearer than 0.5 m or beyond 8 m read 0
// (the default range: a real Xtion reports depth past its model's z_max of 4 m).
TEST(DepthCamera, FaceOnWallReadsItsDistanceAndRangeLimitsGiveZero) {
  DepthCameraConfig config = DepthCameraConfig::WithResolution(80, 60);
  config.noise = false;
  const DepthCamera camera(config);
  const Pose3 X_WS = CameraLookingAlongX(Eigen::Vector3d::Zero());
  SimRandom rng(3);
  std::vector<uint16_t> counts;
  for (const auto& [wall_m, expected] : std::vector<std::pair<double, uint16_t>>{
           {2.0, 2000}, {0.3, 0}, {4.5, 4500}, {8.0, 8000}, {8.5, 0}}) {
    const World w = WallAt(wall_m);
    const WorldRayCaster caster(w);
    camera.Render(caster, X_WS, &rng, &counts);
    for (uint16_t c : counts) ASSERT_EQ(c, expected) << "wall at " << wall_m;
  }
}

// Axial noise, quantisation and dropouts match the model: residuals have mean 0 and standard
// deviation sqrt(sigma(z)^2 + q^2/12) (1 mm rounding), dropouts the configured fraction.
TEST(DepthCamera, NoiseStatisticsMatchTheModel) {
  for (double wall_m : {1.0, 2.0, 3.5}) {
    SCOPED_TRACE(wall_m);
    const World w = WallAt(wall_m);
    const WorldRayCaster caster(w);
    DepthCameraConfig config = DepthCameraConfig::WithResolution(320, 240);
    config.dropout_probability = 0.05;
    const DepthCamera camera(config);
    SimRandom rng(99);
    std::vector<uint16_t> counts;
    std::vector<double> residual;
    size_t dropped = 0, total = 0;
    for (int frame = 0; frame < 2; ++frame) {
      camera.Render(caster, CameraLookingAlongX(Eigen::Vector3d::Zero()), &rng, &counts);
      for (uint16_t c : counts) {
        ++total;
        if (c == 0) {
          ++dropped;
        } else {
          residual.push_back(c * 0.001 - wall_m);
        }
      }
    }
    const double sigma = camera.SigmaAt(wall_m);
    EXPECT_NEAR(sigma, 0.0012 + 0.0019 * (wall_m - 0.4) * (wall_m - 0.4), 1e-15);
    ExpectMoments(residual, 0.0, std::sqrt(sigma * sigma + 1e-6 / 12.0));
    const double p = 0.05;
    EXPECT_NEAR(static_cast<double>(dropped) / total, p,
                5.0 * std::sqrt(p * (1 - p) / static_cast<double>(total)));
  }
}

// Same seed, same frames, bit for bit, whatever the thread count; another seed differs.
TEST(DepthCamera, SameSeedGivesIdenticalFrames) {
  const World w = WallAt(2.5);
  const WorldRayCaster caster(w);
  DepthCameraConfig config = DepthCameraConfig::WithResolution(320, 240);
  config.num_threads = 1;
  const DepthCamera one(config);
  config.num_threads = 3;
  const DepthCamera three(config);
  const Pose3 X_WS = CameraLookingAlongX(Eigen::Vector3d(0, 0.1, 0.2));
  SimRandom a(5), b(5), c(6);
  std::vector<uint16_t> fa, fb, fc;
  for (int frame = 0; frame < 3; ++frame) {
    one.Render(caster, X_WS, &a, &fa);
    three.Render(caster, X_WS, &b, &fb);
    (void)c.NextBits();
    three.Render(caster, X_WS, &c, &fc);
    EXPECT_EQ(fa, fb);
    EXPECT_NE(fa, fc);
  }
}

// A rectangular room around the LIDAR: every beam reads the exact distance to the wall it meets.
TEST(PlanarLidar, BoxRoomGivesExactRanges) {
  World w;
  w.map_min_m = Eigen::Vector3d(-5, -5, -1);
  w.map_max_m = Eigen::Vector3d(5, 5, 2);
  const double x0 = -2.0, x1 = 3.0, y0 = -1.5, y1 = 2.5;
  const Eigen::Quaterniond I = Eigen::Quaterniond::Identity();
  w.boxes.push_back(WorldBox{"w", {x0 - 0.05, 0.5, 0.5}, {0.05, 3, 1}, I});
  w.boxes.push_back(WorldBox{"e", {x1 + 0.05, 0.5, 0.5}, {0.05, 3, 1}, I});
  w.boxes.push_back(WorldBox{"s", {0.5, y0 - 0.05, 0.5}, {3, 0.05, 1}, I});
  w.boxes.push_back(WorldBox{"n", {0.5, y1 + 0.05, 0.5}, {3, 0.05, 1}, I});
  const WorldRayCaster caster(w);
  for (PlanarLidarConfig config : {PlanarLidarConfig::Urg04lx(), PlanarLidarConfig::Utm30lx()}) {
    SCOPED_TRACE(config.model);
    config.noise = false;
    config.quantum_m = 0.0;
    const PlanarLidar lidar(config);
    Pose3 X_WS;
    X_WS.p = Eigen::Vector3d(0.3, 0.2, 0.5);
    const double yaw = 0.4;
    X_WS.q = QuaternionFromYaw(yaw);
    SimRandom rng(1);
    std::vector<float> ranges;
    lidar.Scan(caster, X_WS, &rng, &ranges);
    ASSERT_EQ(static_cast<int>(ranges.size()), config.num_beams);
    for (int i = 0; i < config.num_beams; ++i) {
      const double psi = yaw + config.angle_min_rad + i * config.angle_step_rad;
      const double c = std::cos(psi), s = std::sin(psi);
      double r = std::numeric_limits<double>::infinity();
      if (c > 0) r = std::min(r, (x1 - X_WS.p.x()) / c);
      if (c < 0) r = std::min(r, (x0 - X_WS.p.x()) / c);
      if (s > 0) r = std::min(r, (y1 - X_WS.p.y()) / s);
      if (s < 0) r = std::min(r, (y0 - X_WS.p.y()) / s);
      ASSERT_NEAR(ranges[static_cast<size_t>(i)], r, 2e-6 * r) << i;
    }
  }
  EXPECT_EQ(PlanarLidarConfig::Urg04lx().num_beams, 682);
  EXPECT_NEAR(PlanarLidarConfig::Urg04lx().angle_step_rad * 681, 239.4 * M_PI / 180, 1e-3);
  EXPECT_NEAR(PlanarLidarConfig::Utm30lx().angle_step_rad * 1080, 1.5 * M_PI, 1e-12);
}

// No wall within range reads 0 ("no return"); a wall nearer than range_min reads NaN.
TEST(PlanarLidar, NoReturnIsZeroAndTooNearIsNan) {
  PlanarLidarConfig config = PlanarLidarConfig::Utm30lx();
  config.noise = false;
  const PlanarLidar lidar(config);
  SimRandom rng(1);
  std::vector<float> ranges;
  const World near = WallAt(0.05);
  lidar.Scan(WorldRayCaster(near), Pose3{}, &rng, &ranges);
  EXPECT_TRUE(std::isnan(ranges[540]));  // beam 540 looks along +x
  EXPECT_EQ(ranges[0], 0.0f);            // -135 deg: nothing there
  const World far = WallAt(40.0);
  lidar.Scan(WorldRayCaster(far), Pose3{}, &rng, &ranges);
  for (float r : ranges) EXPECT_EQ(r, 0.0f);
}

// Range noise: (measured - true) / sigma(true) is standard normal; dropouts read NaN at the
// configured rate.
TEST(PlanarLidar, NoiseStatisticsMatchTheModel) {
  const World w = WallAt(3.0);
  const WorldRayCaster caster(w);
  PlanarLidarConfig config = PlanarLidarConfig::Urg04lx();
  config.quantum_m = 0.0;
  config.dropout_probability = 0.1;
  const PlanarLidar lidar(config);
  PlanarLidarConfig exact = config;
  exact.noise = false;
  const PlanarLidar truth(exact);
  SimRandom rng(8);
  std::vector<float> ranges, true_ranges;
  truth.Scan(caster, Pose3{}, &rng, &true_ranges);
  std::vector<double> z;
  size_t dropped = 0, total = 0;
  for (int scan = 0; scan < 100; ++scan) {
    lidar.Scan(caster, Pose3{}, &rng, &ranges);
    for (size_t i = 0; i < ranges.size(); ++i) {
      // Returns within 5 sigma of the range limits are clamped to them: left out.
      if (true_ranges[i] <= 0.0f || std::isnan(true_ranges[i]) ||
          true_ranges[i] > config.range_max_m - 5.0 * lidar.SigmaAt(config.range_max_m)) {
        continue;
      }
      ++total;
      if (std::isnan(ranges[i])) {
        ++dropped;
        continue;
      }
      z.push_back((ranges[i] - true_ranges[i]) / lidar.SigmaAt(true_ranges[i]));
    }
  }
  ASSERT_GT(z.size(), 10000u);
  // Float storage adds ~1e-7 m of rounding: negligible against sigma >= 10 mm.
  ExpectMoments(z, 0.0, 1.0);
  EXPECT_NEAR(static_cast<double>(dropped) / total, 0.1,
              5.0 * std::sqrt(0.09 / static_cast<double>(total)));
}

// Motion capture: Gaussian position and rotation noise of the configured size, latency exactly
// as configured, dropouts at the configured long-run rate in bursts of the configured mean length.
TEST(MotionCapture, NoiseLatencyAndDropoutsMatchTheModel) {
  MotionCaptureConfig config;
  config.position_sigma_m = 0.002;
  config.orientation_sigma_rad = 0.01;
  config.latency_s = 0.0125;
  config.dropout_probability = 0.1;
  config.mean_dropout_samples = 5.0;
  MotionCapture mocap(config);
  Pose3 truth;
  truth.p = Eigen::Vector3d(1, 2, 0.8);
  truth.q = QuaternionFromYaw(0.7);
  SimRandom rng(11);
  constexpr int kSamples = 200000;
  std::vector<double> dx, dy, rz;
  int invalid = 0, bursts = 0;
  bool previous_valid = true;
  for (int k = 0; k < kSamples; ++k) {
    const int64_t utime = 1000000 + 10000LL * k;
    const MotionCaptureSample s = mocap.Measure(utime, truth, &rng);
    ASSERT_EQ(s.utime, utime);
    ASSERT_EQ(s.deliver_utime, utime + 12500);
    if (!s.valid) {
      ++invalid;
      bursts += previous_valid ? 1 : 0;
    }
    previous_valid = s.valid;
    dx.push_back(s.X_WB.p.x() - truth.p.x());
    dy.push_back(s.X_WB.p.y() - truth.p.y());
    const Eigen::AngleAxisd e(truth.q.conjugate() * s.X_WB.q);
    rz.push_back((e.angle() * e.axis()).z());
  }
  ExpectMoments(dx, 0.0, 0.002);
  ExpectMoments(dy, 0.0, 0.002);
  ExpectMoments(rz, 0.0, 0.01);
  // Bursts make samples correlated: the fraction's standard error grows by sqrt(2L - 1).
  EXPECT_NEAR(static_cast<double>(invalid) / kSamples, 0.1, 5.0 * std::sqrt(0.09 * 9.0 / kSamples));
  EXPECT_NEAR(static_cast<double>(invalid) / bursts, 5.0, 0.35);  // ~5 standard errors
}

// IMU at rest and accelerating: gyro = bias + noise, accelerometer = R^T (a + g e3) + bias +
// noise, with the configured sigmas.
TEST(Imu, MeasuresSpecificForceAndRateWithConfiguredNoise) {
  ImuConfig config;
  config.gyro_bias_walk_radps_sqrt_s = 0.0;
  config.accel_bias_walk_mps2_sqrt_s = 0.0;
  SimRandom rng(21);
  Imu imu(config, &rng);
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Eigen::Vector3d w_B(0.1, -0.2, 0.3);
  const Eigen::Vector3d a_W(1.0, 0.0, 0.0);
  // With gravity along -z_W and body x = world x, body y = world z, body z = -world y:
  // R^T (1, 0, g) = (1, g, 0).
  const Eigen::Vector3d f_B(1.0, 9.81, 0.0);
  std::vector<double> gx, fy;
  for (int k = 0; k < 100000; ++k) {
    const SimulatedImuSample s = imu.Measure(2000LL * k, R, w_B, a_W, 0.002, &rng);
    gx.push_back(s.angular_velocity_radps.x());
    fy.push_back(s.specific_force_mps2.y());
  }
  ExpectMoments(gx, w_B.x() + imu.gyro_bias_radps().x(), config.gyro_noise_sigma_radps);
  ExpectMoments(fy, f_B.y() + imu.accel_bias_mps2().y(), config.accel_noise_sigma_mps2);
  // Noise-free: exact.
  ImuConfig exact;
  exact.gyro_noise_sigma_radps = exact.accel_noise_sigma_mps2 = 0.0;
  exact.gyro_bias_sigma_radps = exact.accel_bias_sigma_mps2 = 0.0;
  exact.gyro_bias_walk_radps_sqrt_s = exact.accel_bias_walk_mps2_sqrt_s = 0.0;
  Imu ideal(exact, &rng);
  const SimulatedImuSample s = ideal.Measure(0, R, w_B, a_W, 0.002, &rng);
  EXPECT_TRUE(s.specific_force_mps2.isApprox(f_B, 1e-12)) << s.specific_force_mps2.transpose();
  EXPECT_EQ(s.angular_velocity_radps, w_B);
  // Level and still: reads +g on z.
  const SimulatedImuSample level =
      ideal.Measure(0, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(),
                    Eigen::Vector3d::Zero(), 0.002, &rng);
  EXPECT_EQ(level.specific_force_mps2, Eigen::Vector3d(0, 0, 9.81));
}

TEST(SensorConfigs, RejectOutOfRangeValues) {
  DepthCameraConfig d;
  d.hfov_deg = 190;
  EXPECT_THROW(d.Validate(), std::invalid_argument);
  PlanarLidarConfig l;
  l.num_beams = 0;
  EXPECT_THROW(l.Validate(), std::invalid_argument);
  MotionCaptureConfig m;
  m.dropout_probability = 1.0;
  EXPECT_THROW(m.Validate(), std::invalid_argument);
  ImuConfig i;
  i.rate_hz = 0;
  EXPECT_THROW(i.Validate(), std::invalid_argument);
}

}  // namespace
}  // namespace kestrel
