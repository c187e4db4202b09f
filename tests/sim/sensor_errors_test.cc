// Sensor error sources of the simulator (docs/design.md §7.13): the clean profile is the
// simulator without them bit for bit; extrinsic errors move the rendered geometry as the
// perturbed mount predicts; stamp offsets and jitter have the configured moments and are
// deterministic per seed; the motion-capture residual latency shifts the stamps; the depth lies
// on the disparity lattice; LIDAR beams across an edge read between the two surfaces.
#include <algorithm>
#include <cmath>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/config.h"
#include "kestrel/depth_image_t.hpp"
#include "kestrel/planar_scan_t.hpp"
#include "kestrel/pose_t.hpp"
#include "sim/sensor_errors.h"
#include "sim/sim_node.h"
#include "sim/simulator.h"

namespace kestrel {
namespace {

const std::string kRoot = KESTREL_SOURCE_DIR;

// A wall whose face is the plane x = x_m (solid beyond), tall and wide.
WorldBox WallBox(double x_m) {
  return WorldBox{"wall", {x_m + 0.5, 0, 0}, {0.5, 50, 50}, Eigen::Quaterniond::Identity()};
}

// A kinematic (still) vehicle at the origin, yaw 0, in front of a wall at x = wall_x_m, with a
// small noise-free depth camera: fast, and its geometry is analytic.
SimConfig WallConfig(double wall_x_m) {
  SimConfig c;
  c.world.map_min_m = Eigen::Vector3d(-20, -20, -20);
  c.world.map_max_m = Eigen::Vector3d(20, 20, 20);
  c.world.exploration_height_m = 0.0;
  c.world.boxes.push_back(WallBox(wall_x_m));
  c.mode = "kinematic";
  c.depth = DepthCameraConfig::WithResolution(80, 60);
  c.depth.noise = false;
  c.lidar.noise = false;
  return c;
}

// Steps until the first depth frame and scan have both been taken.
void StepToFirstDepthAndScan(Simulator* sim) {
  bool depth = false, scan = false;
  for (int i = 0; i < 1000 && !(depth && scan); ++i) {
    const SimFrame& f = sim->Step();
    depth = depth || f.depth;
    scan = scan || f.scan;
  }
  ASSERT_TRUE(depth && scan);
}

// --------------------------------------------------------------------- clean profile

SimConfig CiConfig(const std::string& extra_yaml) {
  ConfigNode root = ConfigNode::LoadFile(kRoot + "/config/sim/sim_ci.yaml");
  if (!extra_yaml.empty()) root.ApplyOverride(extra_yaml);
  return LoadSimConfig(root, kRoot);
}

// The clean profile (default or named) gives the depth frame and scan that the sensor models
// alone give from the vehicle file's mounts and the noise streams the simulator always used
// (seed * 8 + 1 for depth, + 2 for the LIDAR), stamped at capture: the behaviour before the
// error sources, bit for bit. The realistic profile changes them.
TEST(SensorErrors, CleanProfileIsTheSimulatorWithoutErrorsBitForBit) {
  const SimConfig by_default = CiConfig("");
  const SimConfig named = CiConfig("error_profile=clean");
  EXPECT_EQ(by_default.errors.profile, "clean");
  Simulator a(by_default, 1'000'000);
  Simulator b(named, 1'000'000);
  Simulator r(CiConfig("error_profile=realistic"), 1'000'000);
  int64_t depth_capture = 0, scan_capture = 0;
  std::vector<uint16_t> depth_a;
  std::vector<float> scan_a;
  Pose3 X_WB_depth, X_WB_scan;
  bool depth_seen = false, scan_seen = false;
  for (int i = 0; i < 200 && !(depth_seen && scan_seen); ++i) {
    const SimFrame& fa = a.Step();
    const SimFrame& fb = b.Step();
    r.Step();
    ASSERT_EQ(fa.depth, fb.depth);
    ASSERT_EQ(fa.scan, fb.scan);
    if (fa.depth && !depth_seen) {
      depth_seen = true;
      depth_capture = a.utime();
      depth_a = a.depth_counts();
      X_WB_depth = a.vehicle().state().pose();
      EXPECT_EQ(a.depth_counts(), b.depth_counts());
      EXPECT_EQ(a.depth_utime(), b.depth_utime());
      EXPECT_NE(a.depth_counts(), r.depth_counts());
      EXPECT_NE(a.depth_utime(), r.depth_utime());
    }
    if (fa.scan && !scan_seen) {
      scan_seen = true;
      scan_capture = a.utime();
      scan_a = a.scan_ranges();
      X_WB_scan = a.vehicle().state().pose();
      EXPECT_EQ(a.scan_ranges(), b.scan_ranges());
      EXPECT_EQ(a.scan_utime(), b.scan_utime());
      EXPECT_NE(a.scan_ranges(), r.scan_ranges());
      EXPECT_NE(a.scan_utime(), r.scan_utime());
    }
  }
  ASSERT_TRUE(depth_seen && scan_seen);
  EXPECT_EQ(a.depth_utime(), depth_capture);
  EXPECT_EQ(a.scan_utime(), scan_capture);
  // The same frame from the sensor models alone, as the simulator rendered it before.
  const uint64_t seed = static_cast<uint64_t>(by_default.seed);
  SimRandom depth_rng(MixSeed(seed * 8 + 1));
  SimRandom lidar_rng(MixSeed(seed * 8 + 2));
  std::vector<uint16_t> depth_expected;
  std::vector<float> scan_expected;
  DepthCamera(by_default.depth)
      .Render(a.caster(), X_WB_depth * by_default.vehicle.X_BS_xtion, &depth_rng, &depth_expected);
  PlanarLidar(by_default.lidar)
      .Scan(a.caster(), X_WB_scan * by_default.vehicle.X_BS_hokuyo, &lidar_rng, &scan_expected);
  EXPECT_EQ(depth_a, depth_expected);
  ASSERT_EQ(scan_a.size(), scan_expected.size());
  for (size_t i = 0; i < scan_a.size(); ++i) {
    // NaN (no information) compares unequal to itself: compare the bits.
    ASSERT_EQ(std::isnan(scan_a[i]), std::isnan(scan_expected[i])) << "beam " << i;
    if (!std::isnan(scan_a[i])) {
      ASSERT_EQ(scan_a[i], scan_expected[i]) << "beam " << i;
    }
  }
  // The true mounts are the vehicle file's, and Clean() is the default.
  EXPECT_EQ(a.true_X_BS_depth().p, by_default.vehicle.X_BS_xtion.p);
  EXPECT_EQ(a.true_X_BS_depth().q.coeffs(), by_default.vehicle.X_BS_xtion.q.coeffs());
  EXPECT_EQ(a.true_X_BS_lidar().p, by_default.vehicle.X_BS_hokuyo.p);
  EXPECT_EQ(a.true_X_BS_lidar().q.coeffs(), by_default.vehicle.X_BS_hokuyo.q.coeffs());
}

TEST(SensorErrors, ConfigRefusesUnknownKeysAndBadValuesNamingTheKey) {
  const auto load = [](const std::string& override_text) -> std::string {
    try {
      (void)CiConfig(override_text);
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(load("error_profile=noisy").find("error_profile"), std::string::npos);
  EXPECT_NE(load("errors.depth_time_jitter_ms=3").find("depth_time_jitter_ms"), std::string::npos);
  EXPECT_NE(load("errors.depth_time_jitter_s=-0.1").find("depth_time_jitter_s"), std::string::npos);
  EXPECT_NE(load("errors.lidar_mixed_pixel_subrays=1").find("lidar_mixed_pixel_subrays"),
            std::string::npos);
  EXPECT_NE(load("errors.depth_extrinsic_error_rad=[0, 0.5, 0]").find("depth_extrinsic_error_rad"),
            std::string::npos);
  EXPECT_EQ(load("errors.depth_time_offset_s=0.025"), "");
  // The overrides apply over the profile.
  const SimConfig c = CiConfig("error_profile=realistic");
  ConfigNode root = ConfigNode::LoadFile(kRoot + "/config/sim/sim_ci.yaml");
  root.ApplyOverride("error_profile=realistic");
  root.ApplyOverride("errors.depth_time_offset_s=0.025");
  const SimConfig overridden = LoadSimConfig(root, kRoot);
  EXPECT_EQ(overridden.errors.depth_time_offset_s, 0.025);
  EXPECT_EQ(overridden.errors.lidar_time_offset_s, c.errors.lidar_time_offset_s);
  EXPECT_TRUE(overridden.errors.lidar_mixed_pixels);
}

// --------------------------------------------------------------------- extrinsics

// Depth along the optical axis of pixel (u, v) of a camera at X_WS looking at the plane x = x_m.
double PlaneDepth(const DepthCamera& cam, const Pose3& X_WS, double x_m, int u, int v) {
  const Eigen::Vector3d d_S((u - cam.cx_px()) / cam.fx_px(), (v - cam.cy_px()) / cam.fy_px(), 1.0);
  const Eigen::Vector3d d_W = X_WS.rotation() * d_S;
  return (x_m - X_WS.p.x()) / d_W.x();
}

TEST(SensorErrors, ExtrinsicErrorRendersFromThePerturbedMount) {
  const double wall_x = 3.0;
  SimConfig c = WallConfig(wall_x);
  const Eigen::Vector3d t_err(0.004, -0.006, 0.01);  // S axes, m
  const Eigen::Vector3d w_err(0.0, 0.0087, 0.0);     // about the camera's y (down): pan, rad
  c.errors.depth_extrinsic_error_m = t_err;
  c.errors.depth_extrinsic_error_rad = w_err;
  c.errors.lidar_extrinsic_error_m = Eigen::Vector3d(0.01, 0.0, 0.0);    // 1 cm forward
  c.errors.lidar_extrinsic_error_rad = Eigen::Vector3d(0.0, 0.0, 0.02);  // yaw
  Simulator sim(c, 0);
  StepToFirstDepthAndScan(&sim);
  const Pose3 X_WB = sim.vehicle().state().pose();
  Pose3 X_err;
  X_err.p = t_err;
  X_err.q = Eigen::Quaterniond(Eigen::AngleAxisd(w_err.norm(), w_err.normalized()));
  const Pose3 X_WS_true = X_WB * c.vehicle.X_BS_xtion * X_err;
  const Pose3 X_WS_nominal = X_WB * c.vehicle.X_BS_xtion;
  const DepthCamera& cam = sim.camera();
  const std::vector<uint16_t>& counts = sim.depth_counts();
  int checked = 0, differing = 0;
  for (int v = 0; v < c.depth.height_px; v += 7) {
    for (int u = 0; u < c.depth.width_px; u += 7) {
      const double z_true = PlaneDepth(cam, X_WS_true, wall_x, u, v);
      const double z_nominal = PlaneDepth(cam, X_WS_nominal, wall_x, u, v);
      const double z = counts[static_cast<size_t>(v) * c.depth.width_px + u] * 0.001;
      EXPECT_NEAR(z, z_true, 0.0005 + 1e-9) << "pixel " << u << ", " << v;
      if (std::abs(z - z_nominal) > 0.005) ++differing;
      ++checked;
    }
  }
  EXPECT_GT(differing, checked / 2) << "the error should move most pixels by over 5 mm";
  // LIDAR: beam i against the wall from the perturbed mount.
  const Pose3 X_WL = X_WB * c.vehicle.X_BS_hokuyo;
  Pose3 X_err_l;
  X_err_l.p = Eigen::Vector3d(0.01, 0.0, 0.0);
  X_err_l.q = Eigen::Quaterniond(Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitZ()));
  const Pose3 X_WL_true = X_WL * X_err_l;
  const PlanarLidarConfig& lc = sim.lidar().config();
  const std::vector<float>& ranges = sim.scan_ranges();
  int beams = 0;
  for (int i = 0; i < lc.num_beams; ++i) {
    const double a = lc.angle_min_rad + i * lc.angle_step_rad;
    const Eigen::Vector3d d_W = X_WL_true.rotation() * Eigen::Vector3d(std::cos(a), std::sin(a), 0);
    if (d_W.x() < 0.8) continue;  // well within range, away from grazing
    const double r_true = (wall_x - X_WL_true.p.x()) / d_W.x();
    const double r_nominal = (wall_x - X_WL.p.x()) /
                             (X_WL.rotation() * Eigen::Vector3d(std::cos(a), std::sin(a), 0)).x();
    EXPECT_NEAR(ranges[static_cast<size_t>(i)], r_true, 0.0005 + 1e-6) << "beam " << i;
    if (std::abs(r_nominal - r_true) > 0.005) ++beams;
  }
  EXPECT_GT(beams, 10);
}

TEST(SensorErrors, RealisticExtrinsicErrorIsDrawnOncePerSeed) {
  SimConfig c = WallConfig(3.0);
  c.errors = SensorErrorsConfig::Realistic();
  Simulator a(c, 0), b(c, 0);
  c.seed = 2;
  Simulator other(c, 0);
  EXPECT_EQ(a.true_X_BS_depth().p, b.true_X_BS_depth().p);
  EXPECT_EQ(a.true_X_BS_depth().q.coeffs(), b.true_X_BS_depth().q.coeffs());
  EXPECT_EQ(a.true_X_BS_lidar().p, b.true_X_BS_lidar().p);
  EXPECT_NE(a.true_X_BS_depth().p, other.true_X_BS_depth().p);
  const Eigen::Vector3d dp = a.true_X_BS_depth().p - c.vehicle.X_BS_xtion.p;
  EXPECT_GT(dp.norm(), 0.0);
  EXPECT_LT(dp.norm(), 0.05);  // 5 mm sigma per axis: 10 sigma
  const double angle = a.true_X_BS_depth().q.angularDistance(c.vehicle.X_BS_xtion.q);
  EXPECT_GT(angle, 0.0);
  EXPECT_LT(angle, 0.1);
}

// --------------------------------------------------------------------- stamps

// Stamp minus capture time of every depth frame and scan, us.
struct StampStats {
  std::vector<int64_t> depth_us, scan_us;
};

StampStats CollectStampErrors(const SimConfig& c, int steps) {
  Simulator sim(c, 5'000'000);
  StampStats s;
  for (int i = 0; i < steps; ++i) {
    const SimFrame& f = sim.Step();
    if (f.depth) s.depth_us.push_back(sim.depth_utime() - sim.utime());
    if (f.scan) s.scan_us.push_back(sim.scan_utime() - sim.utime());
  }
  return s;
}

// Sample mean and std (s) within 5 standard errors (plus the 1 us stamp rounding).
void ExpectMoments(const std::vector<int64_t>& x_us, double mean, double sigma) {
  ASSERT_GT(x_us.size(), 100u);
  const double n = static_cast<double>(x_us.size());
  double m = 0;
  for (int64_t v : x_us) m += 1e-6 * static_cast<double>(v);
  m /= n;
  double ss = 0;
  for (int64_t v : x_us)
    ss += (1e-6 * static_cast<double>(v) - m) * (1e-6 * static_cast<double>(v) - m);
  const double sd = std::sqrt(ss / (n - 1));
  EXPECT_NEAR(m, mean, 5.0 * sigma / std::sqrt(n) + 1e-6) << "n = " << n;
  EXPECT_NEAR(sd, sigma, 5.0 * sigma / std::sqrt(2.0 * n) + 1e-6) << "n = " << n;
}

TEST(SensorErrors, StampOffsetAndJitterHaveTheConfiguredMoments) {
  SimConfig c = WallConfig(3.0);
  c.depth = DepthCameraConfig::WithResolution(8, 6);  // stamps only: tiny frames
  c.depth.rate_hz = 1000.0;
  c.lidar.num_beams = 8;
  c.lidar.rate_hz = 1000.0;
  c.mocap_enabled = false;
  c.imu_enabled = false;
  c.errors.depth_time_offset_s = 0.022;
  c.errors.depth_time_jitter_s = 0.004;
  c.errors.lidar_time_offset_s = -0.003;
  c.errors.lidar_time_jitter_s = 0.001;
  const StampStats s = CollectStampErrors(c, 4000);
  ExpectMoments(s.depth_us, 0.022, 0.004);
  ExpectMoments(s.scan_us, -0.003, 0.001);
  // No jitter: every stamp is capture + offset exactly.
  c.errors.depth_time_jitter_s = 0.0;
  const StampStats fixed = CollectStampErrors(c, 100);
  ASSERT_FALSE(fixed.depth_us.empty());
  for (int64_t e : fixed.depth_us) ASSERT_EQ(e, 22000);
}

TEST(SensorErrors, RealisticStampsAreDeterministicPerSeed) {
  SimConfig c = WallConfig(3.0);
  c.depth = DepthCameraConfig::WithResolution(8, 6);
  c.lidar.num_beams = 8;
  c.errors = SensorErrorsConfig::Realistic();
  const StampStats a = CollectStampErrors(c, 2000);
  const StampStats b = CollectStampErrors(c, 2000);
  c.seed = 7;
  const StampStats other = CollectStampErrors(c, 2000);
  ASSERT_FALSE(a.depth_us.empty());
  ASSERT_FALSE(a.scan_us.empty());
  EXPECT_EQ(a.depth_us, b.depth_us);
  EXPECT_EQ(a.scan_us, b.scan_us);
  EXPECT_NE(a.depth_us, other.depth_us);
  EXPECT_NE(a.scan_us, other.scan_us);
  // Realistic: the Xtion stamped well after capture (20 ms, sigma 3 ms).
  for (int64_t e : a.depth_us) EXPECT_GT(e, 0);
}

TEST(SensorErrors, MocapStampCarriesTheResidualLatency) {
  SimConfig c = WallConfig(3.0);
  c.depth_enabled = false;
  c.lidar_enabled = false;
  c.errors.mocap_residual_latency_s = 0.007;
  Simulator sim(c, 1'000'000);
  SimConfig clean_config = c;
  clean_config.errors = SensorErrorsConfig::Clean();
  Simulator clean(clean_config, 1'000'000);
  int poses = 0;
  for (int i = 0; i < 500; ++i) {
    const SimFrame& f = sim.Step();
    const SimFrame& g = clean.Step();
    ASSERT_EQ(f.poses.size(), g.poses.size());
    for (size_t j = 0; j < f.poses.size(); ++j) {
      const MotionCaptureSample& s = f.poses[j];
      EXPECT_EQ(s.utime - s.acquisition_utime, 7000);
      EXPECT_EQ(s.acquisition_utime % 10000, 0) << "acquired on the 100 Hz grid";
      EXPECT_EQ(s.acquisition_utime, g.poses[j].acquisition_utime);
      EXPECT_EQ(g.poses[j].utime, g.poses[j].acquisition_utime);
      EXPECT_EQ(s.deliver_utime, g.poses[j].deliver_utime);  // delivery is unchanged
      EXPECT_EQ(s.X_WB.p, g.poses[j].X_WB.p);                // so is the noise
      ++poses;
    }
  }
  EXPECT_GT(poses, 40);
}

// The stamp errors reach the messages: SimNode publishes the depth image, scan and pose with
// the stamps of the simulator (fixed offsets here, no jitter).
TEST(SensorErrors, PublishedStampsCarryTheOffsets) {
  SimConfig c = WallConfig(3.0);
  c.errors.depth_time_offset_s = 0.025;
  c.errors.lidar_time_offset_s = -0.004;
  c.errors.mocap_residual_latency_s = 0.006;
  lcm::LCM lcm("memq://");
  std::vector<int64_t> depth_stamps, scan_stamps, pose_stamps;
  struct Handler {
    std::vector<int64_t>* depth;
    std::vector<int64_t>* scan;
    std::vector<int64_t>* pose;
    void Depth(const lcm::ReceiveBuffer*, const std::string&, const depth_image_t* m) {
      depth->push_back(m->utime);
    }
    void Scan(const lcm::ReceiveBuffer*, const std::string&, const planar_scan_t* m) {
      scan->push_back(m->utime);
    }
    void Pose(const lcm::ReceiveBuffer*, const std::string&, const pose_t* m) {
      pose->push_back(m->utime);
    }
  } handler{&depth_stamps, &scan_stamps, &pose_stamps};
  lcm.subscribe(c.depth_channel, &Handler::Depth, &handler);
  lcm.subscribe(c.scan_channel, &Handler::Scan, &handler);
  lcm.subscribe(c.pose_channel, &Handler::Pose, &handler);
  SimClock clock(5'000'000);
  SimNode node(lcm, c, clock);
  std::vector<int64_t> depth_captures, scan_captures, pose_acquisitions;
  for (int i = 0; i < 400; ++i) {
    node.Step();
    const Simulator& sim = node.simulator();
    if (sim.frame(0).depth) depth_captures.push_back(sim.utime());
    if (sim.frame(0).scan) scan_captures.push_back(sim.utime());
    for (const MotionCaptureSample& s : sim.frame(0).poses) {
      pose_acquisitions.push_back(s.acquisition_utime);
    }
    while (lcm.handleTimeout(0) > 0) {
    }
  }
  ASSERT_EQ(depth_stamps.size(), depth_captures.size());
  ASSERT_EQ(scan_stamps.size(), scan_captures.size());
  ASSERT_EQ(pose_stamps.size(), pose_acquisitions.size());
  ASSERT_GE(depth_stamps.size(), 10u);
  ASSERT_GE(scan_stamps.size(), 3u);
  ASSERT_GE(pose_stamps.size(), 30u);
  for (size_t i = 0; i < depth_stamps.size(); ++i) {
    EXPECT_EQ(depth_stamps[i] - depth_captures[i], 25000);
  }
  for (size_t i = 0; i < scan_stamps.size(); ++i) {
    EXPECT_EQ(scan_stamps[i] - scan_captures[i], -4000);
  }
  for (size_t i = 0; i < pose_stamps.size(); ++i) {
    EXPECT_EQ(pose_stamps[i] - pose_acquisitions[i], 6000);
  }
}

// --------------------------------------------------------------------- disparity

// Depth camera looking along +x_W from the origin.
Pose3 CameraLookingAlongX() {
  Eigen::Matrix3d R_WS;
  R_WS.col(0) = -Eigen::Vector3d::UnitY();
  R_WS.col(1) = -Eigen::Vector3d::UnitZ();
  R_WS.col(2) = Eigen::Vector3d::UnitX();
  Pose3 X_WS;
  X_WS.q = Eigen::Quaterniond(R_WS);
  return X_WS;
}

TEST(SensorErrors, DisparityQuantisedDepthLiesOnTheLattice) {
  // A wall slanted in yaw so that depths sweep ~1.5 m to 4 m across the image; noise on.
  World w;
  w.map_min_m = Eigen::Vector3d(-20, -20, -20);
  w.map_max_m = Eigen::Vector3d(20, 20, 20);
  const double yaw = 0.6;
  w.boxes.push_back(WorldBox{"slanted",
                             {2.7, 0, 0},
                             {0.1, 50, 50},
                             Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()))});
  const WorldRayCaster caster(w, 0.5);
  DepthCameraConfig c = DepthCameraConfig::WithResolution(80, 60);  // fx ~ 72 px, not 580
  c.range_max_m = 4.0;  // the sweep's far end (the wall runs on beyond the default 8 m)
  c.disparity_focal_px = 580.0;
  c.disparity_baseline_m = 0.075;
  c.disparity_steps_per_px = 8;
  const DepthCamera cam(c);
  SimRandom rng(3);
  std::vector<uint16_t> counts;
  cam.Render(caster, CameraLookingAlongX(), &rng, &counts);
  const double fb = 580.0 * 0.075;
  std::set<uint16_t> far_values;
  int checked = 0;
  for (const uint16_t count : counts) {
    if (count == 0) continue;
    const double z = count * 0.001;
    const double k = std::round(8.0 * fb / z);
    EXPECT_LE(std::abs(z - fb / (k / 8.0)), 0.0005 + 1e-9) << "count " << count;
    if (z > 3.5) far_values.insert(count);
    ++checked;
  }
  EXPECT_GT(checked, 1000);
  // The lattice step near 4 m: f b / (k/8) for the two disparities around 4 m, ~46 mm apart.
  const double k4 = std::round(8.0 * fb / 4.0);
  const double step_4m = fb / ((k4 - 1) / 8.0) - fb / (k4 / 8.0);
  EXPECT_NEAR(step_4m, 0.046, 0.002);
  // The measured depths beyond 3.5 m take a handful of values ~ that far apart.
  ASSERT_GE(far_values.size(), 2u);
  EXPECT_LE(far_values.size(), 16u);
  const std::vector<uint16_t> far(far_values.begin(), far_values.end());
  for (size_t i = 1; i < far.size(); ++i) EXPECT_GE(far[i] - far[i - 1], 35);
  // Without the quantisation the same frame is not on the lattice (the test can fail).
  DepthCameraConfig plain = c;
  plain.disparity_focal_px = 0.0;
  SimRandom rng2(3);
  cam.Render(caster, CameraLookingAlongX(), &rng, &counts);  // keep rng in use
  DepthCamera(plain).Render(caster, CameraLookingAlongX(), &rng2, &counts);
  int off_lattice = 0;
  for (const uint16_t count : counts) {
    if (count == 0) continue;
    const double z = count * 0.001;
    const double k = std::round(8.0 * fb / z);
    if (std::abs(z - fb / (k / 8.0)) > 0.0005 + 1e-9) ++off_lattice;
  }
  EXPECT_GT(off_lattice, 100);
}

// --------------------------------------------------------------------- mixed pixels

TEST(SensorErrors, LidarBeamAcrossAnEdgeReadsBetweenTheSurfaces) {
  // A near box whose face is x = 1 for y < 0 (its edge at y = 0, on the beam at angle 0) in
  // front of a far wall at x = 4.
  World w;
  w.map_min_m = Eigen::Vector3d(-20, -20, -20);
  w.map_max_m = Eigen::Vector3d(20, 20, 20);
  w.boxes.push_back(WallBox(4.0));
  w.boxes.push_back(
      WorldBox{"near", {1.5, -1.0, 0}, {0.5, 1.0, 1.0}, Eigen::Quaterniond::Identity()});
  const WorldRayCaster caster(w, 0.5);
  PlanarLidarConfig c = PlanarLidarConfig::Urg04lx();
  c.noise = false;
  c.quantum_m = 0.0;
  c.num_beams = 201;
  c.angle_step_rad = 0.002;
  c.angle_min_rad = -100 * c.angle_step_rad;  // beam 100 at angle 0
  PlanarLidarConfig mixed = c;
  mixed.mixed_pixel_subrays = 5;
  mixed.beam_divergence_rad = 0.006;
  mixed.mixed_pixel_gap_m = 0.05;
  SimRandom rng(1);
  std::vector<float> plain_ranges, mixed_ranges;
  const Pose3 X_WS;  // at the origin, x forward
  PlanarLidar(c).Scan(caster, X_WS, &rng, &plain_ranges);
  PlanarLidar(mixed).Scan(caster, X_WS, &rng, &mixed_ranges);
  int between = 0;
  for (int i = 0; i < c.num_beams; ++i) {
    const double a = c.angle_min_rad + i * c.angle_step_rad;
    const double r = mixed_ranges[static_cast<size_t>(i)];
    if (std::abs(a) <= 0.5 * mixed.beam_divergence_rad) {
      // The footprint straddles the edge: strictly between the box face and the wall.
      const double r_near = 1.0 / std::cos(a), r_far = 4.0 / std::cos(a);
      EXPECT_GT(r, r_near + 0.05) << "beam " << i;
      EXPECT_LT(r, r_far - 0.05) << "beam " << i;
      ++between;
    } else if (std::abs(a) > 0.5 * mixed.beam_divergence_rad + 1e-6) {
      // Away from the edge: the central ray's range, bit for bit.
      EXPECT_EQ(r, plain_ranges[static_cast<size_t>(i)]) << "beam " << i;
    }
  }
  EXPECT_GE(between, 3);
  // The beam on the edge itself: near 2.5 m here (two sub-rays on each surface, one on the edge).
  EXPECT_GT(mixed_ranges[100], 1.5f);
  EXPECT_LT(mixed_ranges[100], 3.5f);
}

}  // namespace
}  // namespace kestrel
