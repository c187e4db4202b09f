// Several vehicles in one simulation (docs/design.md §7.10): the first vehicle of a multi-vehicle
// run is a one-vehicle run bit for bit, each vehicle flies on its own commands and channels,
// contacts between vehicles are counted once per episode, and bad vehicle lists are refused.
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/lcm_decode.h"
#include "kestrel/heartbeat_t.hpp"
#include "kestrel/motor_command_t.hpp"
#include "kestrel/sim_truth_t.hpp"
#include "sim/sim_node.h"
#include "sim/simulator.h"

namespace kestrel {
namespace {

const std::string kRoot = KESTREL_SOURCE_DIR;

SimConfig Config(int num_vehicles) {
  SimConfig c = LoadSimConfig(ConfigNode::LoadFile(kRoot + "/config/sim/sim.yaml"), kRoot);
  c.depth = DepthCameraConfig::WithResolution(80, 60);
  c.mocap.dropout_probability = 0.05;
  c.vehicles.clear();
  for (int k = 0; k < num_vehicles; ++k) {
    SimVehicleConfig v;
    v.prefix = num_vehicles == 1 ? "" : "V" + std::to_string(k + 1) + "_";
    v.start_offset_m = Eigen::Vector3d(0, 1.0 * k, 0);
    c.vehicles.push_back(v);
  }
  return c;
}

Eigen::Vector4d HoverThrust(const SimConfig& c) {
  return Eigen::Vector4d::Constant(c.vehicle.mass_kg * 9.81 / 4.0);
}

TEST(MultiVehicle, TheFirstVehicleIsAOneVehicleRunBitForBit) {
  Simulator one(Config(1), 1'000'000);
  Simulator three(Config(3), 1'000'000);
  const Eigen::Vector4d climb = 1.1 * HoverThrust(one.config());
  int depth_frames = 0, scans = 0, poses = 0, imu = 0;
  for (int i = 0; i < 1500; ++i) {
    one.SetMotorCommand(climb, true);
    three.SetMotorCommand(climb, true, 0);
    three.SetMotorCommand(1.2 * climb, true, 1);  // the others fly otherwise
    const SimFrame& a = one.Step();
    const SimFrame& b = three.Step();
    ASSERT_EQ(a.depth, b.depth);
    ASSERT_EQ(a.scan, b.scan);
    ASSERT_EQ(a.imu.has_value(), b.imu.has_value());
    ASSERT_EQ(a.poses.size(), b.poses.size());
    if (a.depth) {
      ++depth_frames;
      ASSERT_EQ(one.depth_counts(), three.depth_counts(0)) << "step " << i;
    }
    if (a.scan) {
      ++scans;
      ASSERT_EQ(one.scan_ranges(), three.scan_ranges(0)) << "step " << i;
    }
    if (a.imu) {
      ++imu;
      ASSERT_EQ(a.imu->specific_force_mps2, b.imu->specific_force_mps2);
    }
    for (size_t p = 0; p < a.poses.size(); ++p) {
      ++poses;
      ASSERT_EQ(a.poses[p].X_WB.p, b.poses[p].X_WB.p);
      ASSERT_EQ(a.poses[p].valid, b.poses[p].valid);
    }
  }
  EXPECT_GT(depth_frames, 10);
  EXPECT_GT(scans, 10);
  EXPECT_GT(poses, 100);
  EXPECT_GT(imu, 100);
  EXPECT_EQ(one.vehicle().state().p_W, three.vehicle(0).state().p_W);
  // The other vehicles: their own places and their own noise.
  EXPECT_NE(three.vehicle(1).state().p_W.z(), three.vehicle(0).state().p_W.z());
  EXPECT_NEAR(three.vehicle(2).state().p_W.y() - three.vehicle(0).state().p_W.y(), 2.0, 1e-9);
  EXPECT_NE(three.depth_counts(2), three.depth_counts(0));
}

TEST(MultiVehicle, ContactsBetweenVehiclesAreCountedOncePerEpisode) {
  SimConfig c = Config(2);
  c.mode = "kinematic";
  Simulator sim(c, 0);
  const auto place = [&](size_t k, const Eigen::Vector3d& p) {
    QuadrotorState s;
    s.p_W = p;
    sim.SetVehicleState(s, k);
  };
  const Eigen::Vector3d a(2, -2, 1);
  place(0, a);
  place(1, a + Eigen::Vector3d(c.vehicle.diameter_m + 0.05, 0, 0));
  sim.Step();
  EXPECT_EQ(sim.inter_vehicle_collision_count(), 0);
  EXPECT_FALSE(sim.touches_another_vehicle(0));
  place(1, a + Eigen::Vector3d(c.vehicle.diameter_m - 0.05, 0, 0));
  sim.Step();
  sim.Step();
  EXPECT_EQ(sim.inter_vehicle_collision_count(), 1) << "one episode, however long";
  EXPECT_TRUE(sim.touches_another_vehicle(0));
  EXPECT_TRUE(sim.touches_another_vehicle(1));
  EXPECT_EQ(sim.vehicle_collision_count(1), 1);
  place(1, a + Eigen::Vector3d(0, 0, c.vehicle_height_m + 0.05));  // right above: apart
  sim.Step();
  EXPECT_FALSE(sim.touches_another_vehicle(0));
  place(1, a + Eigen::Vector3d(0.1, 0.1, 0.5 * c.vehicle_height_m));
  sim.Step();
  EXPECT_EQ(sim.inter_vehicle_collision_count(), 2);
  EXPECT_EQ(sim.vehicle(0).collision_count(), 0) << "not a contact with the world";
}

TEST(MultiVehicle, RefusesBadVehicleLists) {
  const auto refused = [](SimConfig c, const std::string& words) {
    try {
      c.Validate();
      ADD_FAILURE() << "accepted (" << words << ")";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  SimConfig c = Config(2);
  c.vehicles.clear();
  refused(c, "accepted: 1 to 4");
  refused(Config(5), "5 listed; accepted: 1 to 4");
  c = Config(2);
  c.vehicles[1].prefix = c.vehicles[0].prefix;
  refused(c, "share the prefix");
  c = Config(2);
  c.vehicles[1].prefix = "V 2";
  refused(c, "letters, digits and '_'");
  c = Config(2);
  c.vehicles[1].start_offset_m = Eigen::Vector3d(0.1, 0, 0);
  refused(c, "closer than the");
  // Four vehicles 1 m apart in a line would put the fourth inside paper_sim's divider (refused
  // since starts are checked against the world): the fourth beside the first.
  c = Config(4);
  c.vehicles[3].start_offset_m = Eigen::Vector3d(1.0, 0, 0);
  EXPECT_NO_THROW(c.Validate());

  ConfigNode yaml = ConfigNode::LoadFile(kRoot + "/config/sim/sim.yaml");
  yaml.ApplyOverride(
      "vehicles=[{prefix: A_, start_offset_m: [0, 0, 0]}, "
      "{prefix: B_, start_offset_m: [0, 1.5, 0]}]");
  const SimConfig loaded = LoadSimConfig(yaml, kRoot);
  ASSERT_EQ(loaded.vehicles.size(), 2U);
  EXPECT_EQ(loaded.ChannelOf(1, loaded.pose_channel), "B_POSE_VICON");
  EXPECT_EQ(loaded.vehicles[1].start_offset_m, Eigen::Vector3d(0, 1.5, 0));
  ConfigNode unknown = ConfigNode::LoadFile(kRoot + "/config/sim/sim.yaml");
  unknown.ApplyOverride("vehicles=[{prefix: A_, colour: red}]");
  EXPECT_THROW((void)LoadSimConfig(unknown, kRoot), ConfigError);
}

// Records every message's channel.
struct ChannelCounts {
  void handleMessage(const lcm::ReceiveBuffer*, const std::string& channel) { ++count[channel]; }
  std::map<std::string, int> count;
};

// A start with an obstacle inside the vehicle's clearance (half its diameter) at the exploration
// height flies nowhere ("known fraction: nan of 0 observable cells"): the simulator's config, which
// kestrel-sim and kestrel-mission load, refuses it naming the obstacle, its distance and the
// clearance; each vehicle's start is checked.
TEST(SimConfig, RefusesAStartInsideAnObstaclesClearance) {
  SimConfig c = Config(1);
  ASSERT_FALSE(StartClearanceProblem(c.world, Eigen::Vector3d::Zero(), 0.5 * c.vehicle.diameter_m));
  const Eigen::Vector3d s(c.world.start_X_WB.p.x(), c.world.start_X_WB.p.y(),
                          c.world.exploration_height_m);
  WorldBox crate;
  crate.name = "crate";
  crate.center_m = s + Eigen::Vector3d(0.4, 0.0, 0.0);
  crate.half_extents_m = Eigen::Vector3d::Constant(0.1);  // its near face 0.3 m from the start
  c.world.boxes.push_back(crate);
  try {
    c.Validate();
    ADD_FAILURE() << "accepted a start 0.3 m from a box";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    for (const std::string& words : {std::string("box 'crate'"), std::string("lies 0.3 m"),
                                     std::string("clearance of 0.44 m")}) {
      EXPECT_NE(what.find(words), std::string::npos) << what;
    }
  }
  // A second vehicle's start beside the crate, the first one's clear of it.
  SimConfig two = Config(2);
  crate.center_m = s + Eigen::Vector3d(0.0, 1.0 + 0.4, 0.0);
  two.world.boxes.push_back(crate);
  try {
    two.Validate();
    ADD_FAILURE() << "accepted vehicles[1] 0.3 m from a box";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("sim vehicles[1]: "), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("box 'crate'"), std::string::npos) << e.what();
  }
  // 0.5 m away: clear.
  crate.center_m = s + Eigen::Vector3d(0.0, 1.0 + 0.6, 0.0);
  two.world.boxes.back() = crate;
  EXPECT_NO_THROW(two.Validate());
}

TEST(MultiVehicle, EachVehicleHasItsOwnChannels) {
  lcm::LCM lcm("memq://");
  SimClock clock(0);
  const SimConfig c = Config(2);
  SimNode node(lcm, c, clock);
  ChannelCounts counts;
  lcm.subscribe(".*", &ChannelCounts::handleMessage, &counts);
  std::vector<sim_truth_t> truth2;
  GuardedSubscriptions subs(lcm);
  subs.Add<sim_truth_t>(
      "V2_SIM_TRUTH", [&](const std::string&, const sim_truth_t& m) { truth2.push_back(m); },
      nullptr);
  motor_command_t up{};
  up.num_motors = 4;
  up.armed = 1;
  up.thrust_N.assign(4, 1.2 * HoverThrust(c)[0]);
  for (int i = 0; i < 1200; ++i) {
    up.utime = clock.NowUtime();
    lcm.publish("V2_MOTOR_COMMAND", &up);  // only the second vehicle is commanded
    node.Step();
    while (lcm.handleTimeout(0) > 0) {
    }
  }
  for (const char* prefix : {"V1_", "V2_"}) {
    for (const char* ch : {"POSE_VICON", "IMU", "DEPTH_XTION", "SCAN_HOKUYO", "SIM_TRUTH"}) {
      EXPECT_GT(counts.count[std::string(prefix) + ch], 0) << prefix << ch;
    }
  }
  EXPECT_EQ(counts.count["POSE_VICON"], 0) << "no unprefixed vehicle channel";
  EXPECT_EQ(counts.count["HEARTBEAT_SIM"], 1) << "one heartbeat for the simulator";
  EXPECT_EQ(counts.count["V1_POSE_VICON"], counts.count["V2_POSE_VICON"]);
  EXPECT_GT(node.simulator().vehicle(1).state().p_W.z(), 0.3) << "the commanded vehicle rose";
  EXPECT_LT(node.simulator().vehicle(0).state().p_W.z(), 0.01) << "the other stayed down";
  ASSERT_FALSE(truth2.empty());
  EXPECT_EQ(truth2.back().position_m[2], node.simulator().vehicle(1).state().p_W.z());
  for (size_t i = 1; i < truth2.size(); ++i) EXPECT_EQ(truth2[i].seq, truth2[i - 1].seq + 1);
}

}  // namespace
}  // namespace kestrel
