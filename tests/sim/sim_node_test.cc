#include "sim/sim_node.h"

#include <cmath>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/identity.h"
#include "kestrel/depth_image_t.hpp"
#include "kestrel/heartbeat_t.hpp"
#include "kestrel/imu_t.hpp"
#include "kestrel/planar_scan_t.hpp"
#include "kestrel/pose_t.hpp"
#include "kestrel/sim_truth_t.hpp"

namespace kestrel {
namespace {

const std::string kRoot = KESTREL_SOURCE_DIR;

SimConfig SmallConfig(int64_t seed) {
  SimConfig c = LoadSimConfig(ConfigNode::LoadFile(kRoot + "/config/sim/sim.yaml"), kRoot);
  c.seed = seed;
  c.depth = DepthCameraConfig::WithResolution(80, 60);
  c.mocap.dropout_probability = 0.05;
  return c;
}

// Records every message on every channel as raw bytes, in arrival order.
class Recorder {
 public:
  explicit Recorder(lcm::LCM& lcm) { lcm.subscribe(".*", &Recorder::Handle, this); }
  void Handle(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    const auto* bytes = static_cast<const uint8_t*>(rbuf->data);
    messages.emplace_back(channel, std::vector<uint8_t>(bytes, bytes + rbuf->data_size));
    ++count[channel];
  }
  std::vector<std::pair<std::string, std::vector<uint8_t>>> messages;
  std::map<std::string, int> count;
};

// Runs `steps` lockstep steps, hovering on MOTOR_COMMAND, and returns every message published
// except the wall-clock-dependent ones (heartbeats; the truth's real_time_factor is zeroed).
std::vector<std::pair<std::string, std::vector<uint8_t>>> RunHovering(
    const SimConfig& config, int steps, std::map<std::string, int>* count) {
  lcm::LCM lcm("memq://");
  Recorder recorder(lcm);
  SimClock clock(5'000'000);
  SeedPublisherEpochs(77);  // the node's epoch, like every other field, repeats (as in missions)
  SimNode node(lcm, config, clock);
  const RotorGeometry geometry = ComputeRotorGeometry(config.vehicle);
  for (int k = 0; k < steps; ++k) {
    if (k % 5 == 0) {
      motor_command_t cmd;
      cmd.utime = clock.NowUtime();
      cmd.seq = k;
      cmd.armed = true;
      cmd.num_motors = 4;
      const double z = node.simulator().vehicle().state().p_W.z();
      const double vz = node.simulator().vehicle().state().v_W.z();
      const double f = config.vehicle.mass_kg * (kGravity_mps2 + 4.0 * (1.0 - z) - 3.0 * vz);
      const Eigen::Vector4d t = geometry.mixer_inverse * Eigen::Vector4d(f, 0, 0, 0);
      cmd.thrust_N.resize(4);
      for (int i = 0; i < 4; ++i) cmd.thrust_N[static_cast<size_t>(i)] = t[i];
      cmd.total_thrust_N = f;
      cmd.moment_Nm[0] = cmd.moment_Nm[1] = cmd.moment_Nm[2] = 0.0;
      lcm.publish(config.motor_channel, &cmd);
    }
    while (lcm.handleTimeout(0) > 0) {
    }
    node.Step();
  }
  while (lcm.handleTimeout(0) > 0) {
  }
  std::vector<std::pair<std::string, std::vector<uint8_t>>> out;
  for (auto& [channel, bytes] : recorder.messages) {
    if (channel == config.heartbeat_channel || channel == config.motor_channel) continue;
    if (channel == config.truth_channel) {
      sim_truth_t truth;
      EXPECT_EQ(truth.decode(bytes.data(), 0, static_cast<int>(bytes.size())),
                static_cast<int>(bytes.size()));
      truth.real_time_factor = 0.0;
      bytes.resize(static_cast<size_t>(truth.getEncodedSize()));
      truth.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
    }
    out.emplace_back(channel, bytes);
  }
  if (count != nullptr) *count = recorder.count;
  EXPECT_EQ(node.rejected_messages(), 0);
  return out;
}

// Same seed, same messages byte for byte; another seed changes the noisy streams.
TEST(SimNode, SameSeedGivesIdenticalMessages) {
  const auto a = RunHovering(SmallConfig(3), 600, nullptr);
  const auto b = RunHovering(SmallConfig(3), 600, nullptr);
  const auto c = RunHovering(SmallConfig(4), 600, nullptr);
  ASSERT_EQ(a.size(), b.size());
  EXPECT_TRUE(a == b);
  EXPECT_FALSE(a == c);
}

// Every stream the simulator publishes in the drivers' place carries the node's epoch, and two
// simulators in one process have different epochs.
TEST(SimNode, EveryStreamCarriesTheNodesEpoch) {
  const SimConfig config = SmallConfig(5);
  std::vector<int64_t> node_epochs;
  for (int n = 0; n < 2; ++n) {
    lcm::LCM lcm("memq://");
    SimClock clock(1'000'000);
    SimNode node(lcm, config, clock);
    std::map<std::string, std::vector<int64_t>> epochs;
    auto on = [&](const std::string& channel, int64_t epoch) { epochs[channel].push_back(epoch); };
    GuardedSubscriptions subs(lcm);
    subs.Add<pose_t>(
        "POSE_VICON", [&](const std::string& c, const pose_t& m) { on(c, m.epoch); }, nullptr);
    subs.Add<imu_t>(
        "IMU", [&](const std::string& c, const imu_t& m) { on(c, m.epoch); }, nullptr);
    subs.Add<depth_image_t>(
        "DEPTH_XTION", [&](const std::string& c, const depth_image_t& m) { on(c, m.epoch); },
        nullptr);
    subs.Add<planar_scan_t>(
        "SCAN_HOKUYO", [&](const std::string& c, const planar_scan_t& m) { on(c, m.epoch); },
        nullptr);
    subs.Add<sim_truth_t>(
        "SIM_TRUTH", [&](const std::string& c, const sim_truth_t& m) { on(c, m.epoch); }, nullptr);
    for (int k = 0; k < 300; ++k) {
      node.Step();
      while (lcm.handleTimeout(0) > 0) {
      }
    }
    EXPECT_NE(node.epoch(), 0);
    ASSERT_EQ(epochs.size(), 5u);
    for (const auto& [channel, list] : epochs) {
      ASSERT_FALSE(list.empty()) << channel;
      for (int64_t e : list) ASSERT_EQ(e, node.epoch()) << channel;
    }
    node_epochs.push_back(node.epoch());
  }
  EXPECT_NE(node_epochs[0], node_epochs[1]);
}

// One simulated second publishes each stream at its configured rate: IMU 500, truth 100,
// motion capture 100 (one still in flight: 10 ms latency), depth 30, scans 10; the
// vehicle climbs off the floor under the hover loop.
TEST(SimNode, PublishesEveryStreamAtItsRate) {
  std::map<std::string, int> count;
  const SimConfig config = SmallConfig(1);
  (void)RunHovering(config, 1000, &count);
  EXPECT_EQ(count["IMU"], 500);
  EXPECT_EQ(count["SIM_TRUTH"], 100);
  EXPECT_EQ(count["POSE_VICON"], 99);  // taken at 10..1000 ms; the last is still in flight
  EXPECT_EQ(count["DEPTH_XTION"], 30);
  EXPECT_EQ(count["SCAN_HOKUYO"], 10);
  EXPECT_GE(count["HEARTBEAT_SIM"], 1);
}

// The messages carry what the drivers send: depth intrinsics and sizes, scan geometry, poses
// stamped at acquisition and delivered after the latency, truth of the vehicle.
TEST(SimNode, MessagesCarryTheDriverFields) {
  lcm::LCM lcm("memq://");
  const SimConfig config = SmallConfig(2);
  SimClock clock(1'000'000);
  SimNode node(lcm, config, clock);
  depth_image_t depth;
  planar_scan_t scan;
  std::vector<std::pair<int64_t, int64_t>> pose_times;  // (stamp, clock at delivery)
  struct Handler {
    depth_image_t* depth;
    planar_scan_t* scan;
    std::vector<std::pair<int64_t, int64_t>>* pose_times;
    SimClock* clock;
    void Depth(const lcm::ReceiveBuffer*, const std::string&, const depth_image_t* m) {
      *depth = *m;
    }
    void Scan(const lcm::ReceiveBuffer*, const std::string&, const planar_scan_t* m) { *scan = *m; }
    void Pose(const lcm::ReceiveBuffer*, const std::string&, const pose_t* m) {
      pose_times->emplace_back(m->utime, clock->NowUtime());
    }
  } handler{&depth, &scan, &pose_times, &clock};
  lcm.subscribe("DEPTH_XTION", &Handler::Depth, &handler);
  lcm.subscribe("SCAN_HOKUYO", &Handler::Scan, &handler);
  lcm.subscribe("POSE_VICON", &Handler::Pose, &handler);
  for (int k = 0; k < 200; ++k) {
    node.Step();
    while (lcm.handleTimeout(0) > 0) {
    }
  }
  EXPECT_EQ(depth.width, 80);
  EXPECT_EQ(depth.height, 60);
  EXPECT_EQ(depth.data_size, 80 * 60 * 2);
  EXPECT_EQ(depth.encoding, depth_image_t::ENCODING_RAW_U16);
  EXPECT_EQ(depth.sensor_name, "xtion");
  EXPECT_DOUBLE_EQ(depth.fx_px, node.simulator().camera().fx_px());
  EXPECT_DOUBLE_EQ(depth.cx_px, 39.5);
  EXPECT_DOUBLE_EQ(depth.depth_scale_m, 0.001);
  // The frame bytes are the simulator's counts, little-endian.
  const std::vector<uint16_t>& counts = node.simulator().depth_counts();
  for (size_t i = 0; i < counts.size(); ++i) {
    ASSERT_EQ(depth.data[2 * i] | (depth.data[2 * i + 1] << 8), counts[i]);
  }
  EXPECT_EQ(scan.num_ranges, 682);
  EXPECT_EQ(scan.sensor_name, "hokuyo");
  EXPECT_FLOAT_EQ(scan.angle_step_rad, static_cast<float>(2 * M_PI / 1024));
  ASSERT_FALSE(pose_times.empty());
  for (const auto& [stamp, delivered] : pose_times) EXPECT_EQ(delivered - stamp, 10000);
}

// Hovering under the altitude loop, the IMU reads about +g along z_B (bias and noise of the
// config), motion capture reads the true position to its noise, and the vehicle holds 1 m; when
// the commands stop, the rotors stop after the time-out and the vehicle falls back to the floor.
TEST(SimNode, HoverReadsGravityAndMotorTimeoutLands) {
  lcm::LCM lcm("memq://");
  SimConfig config = SmallConfig(9);
  config.motor_command_timeout_s = 0.5;  // a stock ESC watchdog (the sheets hold 1.5 s)
  SimClock clock(0);
  SimNode node(lcm, config, clock);
  std::vector<double> specific_force_z;
  std::vector<double> pose_error;
  struct Handler {
    std::vector<double>* fz;
    std::vector<double>* err;
    SimNode* node;
    void Imu(const lcm::ReceiveBuffer*, const std::string&, const imu_t* m) {
      fz->push_back(m->specific_force_mps2[2]);
    }
    void Pose(const lcm::ReceiveBuffer*, const std::string&, const pose_t* m) {
      if (m->valid) err->push_back(m->position_m[2] - node->simulator().vehicle().state().p_W.z());
    }
  } handler{&specific_force_z, &pose_error, &node};
  const RotorGeometry geometry = ComputeRotorGeometry(config.vehicle);
  for (int k = 0; k < 4500; ++k) {
    if (k % 5 == 0 && k < 3000) {
      const QuadrotorState& s = node.simulator().vehicle().state();
      const double f =
          config.vehicle.mass_kg * (kGravity_mps2 + 4.0 * (1.0 - s.p_W.z()) - 3.0 * s.v_W.z());
      const Eigen::Vector4d t = geometry.mixer_inverse * Eigen::Vector4d(f, 0, 0, 0);
      motor_command_t cmd;
      cmd.utime = clock.NowUtime();
      cmd.seq = k;
      cmd.armed = true;
      cmd.num_motors = 4;
      cmd.total_thrust_N = f;
      cmd.moment_Nm[0] = cmd.moment_Nm[1] = cmd.moment_Nm[2] = 0.0;
      cmd.thrust_N.resize(4);
      for (int i = 0; i < 4; ++i) cmd.thrust_N[static_cast<size_t>(i)] = t[i];
      lcm.publish(config.motor_channel, &cmd);
    }
    if (k == 2500) {  // listen during the hover only
      lcm.subscribe(config.imu_channel, &Handler::Imu, &handler);
      lcm.subscribe(config.pose_channel, &Handler::Pose, &handler);
    }
    if (k == 3000) {
      EXPECT_NEAR(node.simulator().vehicle().state().p_W.z(), 1.0, 0.05);  // loop settling
    }
    while (lcm.handleTimeout(0) > 0) {
    }
    node.Step();
  }
  ASSERT_GT(specific_force_z.size(), 200u);
  double mean = 0;
  for (size_t i = 0; i < 200; ++i) mean += specific_force_z[i] / 200;
  EXPECT_NEAR(mean, kGravity_mps2, 0.2);  // bias ~N(0, 0.03^2), noise 0.02 / sqrt(200)
  ASSERT_GT(pose_error.size(), 40u);
  for (size_t i = 0; i < 40; ++i) EXPECT_LT(std::abs(pose_error[i]), 0.01);  // sigma 0.5 mm + lag
  // Rotors stopped 0.5 s after the last command: a 1 m drop lands at 4.4 m/s, a crash.
  EXPECT_TRUE(node.simulator().vehicle().on_ground());
  EXPECT_EQ(node.simulator().vehicle().collision_count(), 1);
  EXPECT_EQ(node.simulator().vehicle().last_collision(), "floor");
}

// A scenario can start the vehicle in the air; SIM_TRUTH reports the true state: a drop from
// 1.2 m with the rotors off follows the closed form of m zdd = -m g - c zd (linear drag c).
TEST(SimNode, TruthFollowsAVehicleStartedInTheAir) {
  lcm::LCM lcm("memq://");
  const SimConfig config = SmallConfig(1);
  SimClock clock(0);
  SimNode node(lcm, config, clock);
  QuadrotorState start;
  start.p_W = Eigen::Vector3d(0.0, -1.5, 1.2);
  node.mutable_simulator().SetVehicleState(start);
  sim_truth_t last;
  last.position_m[2] = -1.0;
  struct Handler {
    sim_truth_t* last;
    void Truth(const lcm::ReceiveBuffer*, const std::string&, const sim_truth_t* m) { *last = *m; }
  } handler{&last};
  lcm.subscribe(config.truth_channel, &Handler::Truth, &handler);
  for (int k = 0; k < 300; ++k) {
    node.Step();
    while (lcm.handleTimeout(0) > 0) {
    }
  }
  EXPECT_EQ(last.utime, 300000);
  const double m = config.vehicle.mass_kg, c = config.vehicle.linear_drag_Ns_per_m.z();
  const double g = kGravity_mps2, t = 0.3;
  EXPECT_NEAR(last.position_m[2], 1.2 - (m * g / c) * (t - (m / c) * (1 - std::exp(-c * t / m))),
              1e-9);
  EXPECT_NEAR(last.velocity_mps[2], -(m * g / c) * (1 - std::exp(-c * t / m)), 1e-9);
  EXPECT_EQ(last.seed, 1);
  EXPECT_FALSE(last.in_collision);
}

// Malformed or impossible commands are counted and ignored: the vehicle stays on the floor.
TEST(SimNode, RejectsBadMotorCommands) {
  lcm::LCM lcm("memq://");
  const SimConfig config = SmallConfig(1);
  SimClock clock(0);
  SimNode node(lcm, config, clock);
  motor_command_t cmd;
  cmd.utime = 0;
  cmd.seq = 0;
  cmd.armed = true;
  cmd.num_motors = 3;
  cmd.total_thrust_N = 90.0;
  cmd.moment_Nm[0] = cmd.moment_Nm[1] = cmd.moment_Nm[2] = 0.0;
  cmd.thrust_N.resize(3, 30.0);
  lcm.publish(config.motor_channel, &cmd);
  const char garbage[] = "not an lcm message";
  lcm.publish(config.motor_channel, garbage, sizeof(garbage));
  for (int k = 0; k < 100; ++k) {
    while (lcm.handleTimeout(0) > 0) {
    }
    node.Step();
  }
  EXPECT_EQ(node.rejected_messages(), 2);
  EXPECT_TRUE(node.simulator().vehicle().on_ground());
}

// Malformed bytes on the command channel are counted exactly, by reason, in the heartbeat
// (dropped.malformed; docs/design.md §7.11); a decoded but unusable command is dropped.refused.
TEST(SimNode, HeartbeatCountsMalformedMessagesByReason) {
  lcm::LCM lcm("memq://");
  const SimConfig config = SmallConfig(1);
  SimClock clock(0);
  SimNode node(lcm, config, clock);
  std::vector<heartbeat_t> beats;
  GuardedSubscriptions subs(lcm);
  subs.Add<heartbeat_t>(
      config.heartbeat_channel,
      [&](const std::string&, const heartbeat_t& m) { beats.push_back(m); }, nullptr);
  motor_command_t cmd{};
  cmd.num_motors = 3;
  cmd.thrust_N.resize(3, 1.0);
  std::vector<uint8_t> good(static_cast<size_t>(cmd.getEncodedSize()));
  cmd.encode(good.data(), 0, static_cast<int>(good.size()));
  const int sent = 7;
  for (int i = 0; i < sent; ++i) {
    std::vector<uint8_t> bad = good;
    bad.resize(static_cast<size_t>(i) * 3);  // truncated, down to nothing
    lcm.publish(config.motor_channel, bad.data(), static_cast<unsigned>(bad.size()));
  }
  lcm.publish(config.motor_channel, &cmd);  // well-formed, 3 motors: refused
  for (int k = 0; k < 1100; ++k) {
    while (lcm.handleTimeout(0) > 0) {
    }
    node.Step();
  }
  while (lcm.handleTimeout(0) > 0) {
  }
  ASSERT_FALSE(beats.empty());
  std::map<std::string, double> values;
  for (const auto& v : beats.back().values) values[v.name] = v.value;
  EXPECT_EQ(values["dropped.malformed"], sent);
  EXPECT_EQ(values["dropped.refused"], 1.0);
  EXPECT_EQ(values["rejected_messages"], sent + 1.0);
  EXPECT_EQ(node.drops().count("malformed"), sent);
}

// Kinematic mode follows TRAJECTORY: after the trajectory's end the vehicle is at its end point.
TEST(SimNode, KinematicModeFollowsTrajectoryMessages) {
  lcm::LCM lcm("memq://");
  SimConfig config = SmallConfig(1);
  config.mode = "kinematic";
  SimClock clock(2'000'000);
  SimNode node(lcm, config, clock);
  trajectory_t traj;
  traj.utime = clock.NowUtime();
  traj.seq = 1;
  traj.start_utime = clock.NowUtime();
  traj.num_segments = 1;
  traj.num_coeffs = 2;
  traj.durations_s = {1.0};
  const Eigen::Vector3d s = config.world.start_X_WB.p;
  traj.coeffs_x = {{s.x(), 0.2}};
  traj.coeffs_y = {{s.y(), 0.0}};
  traj.coeffs_z = {{1.0, 0.0}};
  traj.coeffs_yaw = {{0.0, 0.5}};
  lcm.publish(config.trajectory_channel, &traj);
  for (int k = 0; k < 1500; ++k) {
    while (lcm.handleTimeout(0) > 0) {
    }
    node.Step();
  }
  const QuadrotorState& state = node.simulator().vehicle().state();
  EXPECT_TRUE(state.p_W.isApprox(Eigen::Vector3d(s.x() + 0.2, s.y(), 1.0), 1e-12));
  EXPECT_NEAR(YawOf(state.q_WB), 0.5, 1e-9);
  EXPECT_EQ(node.rejected_messages(), 0);
}

// sensor_device_prefix moves the depth images and scans, byte for byte, to the device channels
// (docs/design.md §7.11); every other message is unchanged and none goes out on the driver
// channels.
TEST(SimNode, SensorDevicePrefixMovesOnlyDepthAndScan) {
  const SimConfig plain = SmallConfig(6);
  SimConfig device = plain;
  device.sensor_device_prefix = "DEV_";
  std::map<std::string, int> plain_count, device_count;
  const auto a = RunHovering(plain, 400, &plain_count);
  const auto b = RunHovering(device, 400, &device_count);
  ASSERT_EQ(a.size(), b.size());
  int moved = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    const bool sensor = a[i].first == plain.depth_channel || a[i].first == plain.scan_channel;
    EXPECT_EQ(b[i].first, (sensor ? "DEV_" : "") + a[i].first) << i;
    EXPECT_TRUE(a[i].second == b[i].second) << "message " << i << " on " << a[i].first;
    moved += sensor ? 1 : 0;
  }
  EXPECT_GT(plain_count[plain.depth_channel], 0);
  EXPECT_GT(plain_count[plain.scan_channel], 0);
  EXPECT_EQ(moved, plain_count[plain.depth_channel] + plain_count[plain.scan_channel]);
  EXPECT_EQ(device_count.count(plain.depth_channel), 0U);
  EXPECT_EQ(device_count.count(plain.scan_channel), 0U);
}

// A scheduled motion-capture outage: the poses acquired inside it go out invalid, as the Vicon
// bridge publishes a lost body (zero position, identity orientation, no velocity); every other
// pose is the one a run without outage publishes, byte for byte.
TEST(SimNode, MocapOutagePublishesInvalidPosesForItsDuration) {
  SimConfig plain = SmallConfig(7);
  plain.mocap.dropout_probability = 0.0;
  SimConfig outage = plain;
  outage.mocap_outage_at_s = 0.2;
  outage.mocap_outage_s = 0.1;
  const auto a = RunHovering(plain, 600, nullptr);
  const auto b = RunHovering(outage, 600, nullptr);
  ASSERT_EQ(a.size(), b.size());
  const int64_t begin = 5'000'000 + 200'000, end = begin + 100'000;  // RunHovering starts at 5 s
  int invalid = 0, valid = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].first, b[i].first);
    if (a[i].first != plain.pose_channel) {
      EXPECT_TRUE(a[i].second == b[i].second) << i;
      continue;
    }
    pose_t p{};
    ASSERT_EQ(p.decode(b[i].second.data(), 0, static_cast<int>(b[i].second.size())),
              static_cast<int>(b[i].second.size()));
    if (p.utime >= begin && p.utime < end) {
      ++invalid;
      EXPECT_FALSE(p.valid) << p.utime;
      EXPECT_EQ(p.position_m[0], 0.0);
      EXPECT_EQ(p.position_m[2], 0.0);
      EXPECT_EQ(p.orientation_wxyz[0], 1.0);
      EXPECT_FALSE(p.has_velocity);
    } else {
      ++valid;
      EXPECT_TRUE(p.valid) << p.utime;
      EXPECT_TRUE(a[i].second == b[i].second) << "pose at " << p.utime;
    }
  }
  EXPECT_EQ(invalid, 10);  // 100 Hz for 0.1 s
  EXPECT_GT(valid, 40);
}

// The shipped config loads; a bad value is refused naming the file and key.
TEST(SimConfig, LoadsTheShippedFileAndRefusesBadValues) {
  const SimConfig c = LoadSimConfig(ConfigNode::LoadFile(kRoot + "/config/sim/sim.yaml"), kRoot);
  EXPECT_EQ(c.world.name, "paper_sim");
  EXPECT_EQ(c.depth.width_px, 320);
  EXPECT_EQ(c.lidar.num_beams, 682);
  ConfigNode bad = ConfigNode::LoadFile(kRoot + "/config/sim/sim.yaml");
  bad.ApplyOverride("depth.rate_hz=-3");
  try {
    (void)LoadSimConfig(bad, kRoot);
    FAIL() << "accepted a negative rate";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("depth.rate_hz"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("sim.yaml"), std::string::npos) << e.what();
  }
  ConfigNode unknown = ConfigNode::LoadFile(kRoot + "/config/sim/sim.yaml");
  unknown.ApplyOverride("lidar.colour=red");
  EXPECT_THROW((void)LoadSimConfig(unknown, kRoot), ConfigError);
  ConfigNode utm = ConfigNode::LoadFile(kRoot + "/config/sim/sim.yaml");
  utm.ApplyOverride("lidar.model=utm-30lx");
  utm.ApplyOverride("depth.resolution=vga");
  const SimConfig u = LoadSimConfig(utm, kRoot);
  EXPECT_EQ(u.lidar.num_beams, 1081);
  EXPECT_EQ(u.depth.width_px, 640);
  const SimConfig ci =
      LoadSimConfig(ConfigNode::LoadFile(kRoot + "/config/sim/sim_ci.yaml"), kRoot);
  EXPECT_EQ(ci.depth.width_px, 80);
  EXPECT_EQ(ci.depth.rate_hz, 15.0);
  EXPECT_EQ(ci.speed_factor, 0.0);
  EXPECT_EQ(ci.sensor_device_prefix, "");
  EXPECT_LT(ci.mocap_outage_at_s, 0.0);
  ConfigNode chaos = ConfigNode::LoadFile(kRoot + "/config/sim/sim_ci.yaml");
  chaos.ApplyOverride("sensor_device_prefix=DEV_");
  chaos.ApplyOverride("mocap.outage_at_s=20");
  chaos.ApplyOverride("mocap.outage_s=1");
  const SimConfig x = LoadSimConfig(chaos, kRoot);
  EXPECT_EQ(x.SensorChannelOf(0, x.depth_channel), "DEV_DEPTH_XTION");
  EXPECT_EQ(x.mocap_outage_at_s, 20.0);
  EXPECT_EQ(x.mocap_outage_s, 1.0);
  ConfigNode bad_prefix = ConfigNode::LoadFile(kRoot + "/config/sim/sim_ci.yaml");
  bad_prefix.ApplyOverride("sensor_device_prefix=DEV-");
  EXPECT_THROW((void)LoadSimConfig(bad_prefix, kRoot), ConfigError);
}

}  // namespace
}  // namespace kestrel
