// The bridge node over LCM (memq://): malformed messages are counted by channel and dropped
// before they reach the scene; a viewer started mid-run waits for a snapshot without counting
// the deltas before it as errors; with several vehicles each one's channels reach its own part
// of the scene.
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>
#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "viewer/bridge/viewer_node.h"

namespace kestrel {
namespace {

ViewerConfig TestConfig() {
  ViewerConfig c;
  c.port = 0;  // any free loopback port
  return c;
}

void Drain(lcm::LCM& lcm) {
  while (lcm.handleTimeout(0) > 0) {
  }
}

pose_t ValidPose() {
  pose_t m{};
  m.utime = 1000;
  m.frame_id = "world";
  m.child_frame_id = "kestrel";
  m.valid = true;
  m.position_m[2] = 1.0;
  m.orientation_wxyz[0] = 1.0;
  return m;
}

// Garbage, a truncated message and a message of another type are counted by channel as
// malformed; none reaches the scene, and a good message afterwards does.
TEST(ViewerNode, MalformedMessagesAreCountedAndDropped) {
  lcm::LCM lcm("memq://");
  SimClock clock;
  ViewerNode node(lcm, TestConfig(), "", clock);
  const std::string garbage(100, '\x5a');
  lcm.publish("MAP3D", garbage.data(), static_cast<unsigned>(garbage.size()));
  lcm.publish("MAP3D_DELTA", garbage.data(), static_cast<unsigned>(garbage.size()));
  const pose_t pose = ValidPose();
  std::vector<uint8_t> bytes(static_cast<size_t>(pose.getEncodedSize()));
  ASSERT_EQ(pose.encode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  lcm.publish("POSE_VICON", bytes.data(), static_cast<unsigned>(bytes.size() / 2));  // truncated
  lcm.publish("TRAJECTORY", &pose);  // a pose where a trajectory belongs
  Drain(lcm);
  EXPECT_EQ(node.dropped().count("malformed MAP3D"), 1);
  EXPECT_EQ(node.dropped().count("malformed MAP3D_DELTA"), 1);
  EXPECT_EQ(node.dropped().count("malformed POSE_VICON"), 1);
  EXPECT_EQ(node.dropped().count("malformed TRAJECTORY"), 1);
  EXPECT_EQ(node.messages_received(), 0);
  EXPECT_EQ(node.scene().path_points(), 0u);
  lcm.publish("POSE_VICON", &pose);
  Drain(lcm);
  EXPECT_EQ(node.messages_received(), 1);
  EXPECT_EQ(node.scene().path_points(), 1u);
  node.Tick();  // no page connected: nothing to send, nothing fails
  EXPECT_EQ(node.server().clients(), 0);
}

// Deltas before the first snapshot are expected when the viewer starts mid-run: counted apart,
// not as refused input.
TEST(ViewerNode, DeltasBeforeTheFirstSnapshotAreNotErrors) {
  lcm::LCM lcm("memq://");
  SimClock clock;
  ViewerNode node(lcm, TestConfig(), "", clock);
  map3d_delta_t delta{};
  delta.seq = 5;
  delta.prev_seq = 4;
  delta.resolution_m = 0.075;
  lcm.publish("MAP3D_DELTA", &delta);
  lcm.publish("MAP3D_DELTA", &delta);
  Drain(lcm);
  EXPECT_EQ(node.deltas_before_snapshot(), 2);
  EXPECT_EQ(node.dropped().total(), 0);
}

// Two vehicles (V1_, V2_): each one's pose, trajectory, exploration and 2D-map channels reach
// its own part of the scene; the unprefixed channels of a one-vehicle run are not listened to.
TEST(ViewerNode, EachVehicleListensToItsOwnChannels) {
  lcm::LCM lcm("memq://");
  SimClock clock;
  ViewerConfig config = TestConfig();
  config.vehicle_prefixes = {"V1_", "V2_"};
  ViewerNode node(lcm, config, "", clock);
  pose_t pose = ValidPose();
  pose.position_m[0] = 1.0;
  lcm.publish("V1_POSE_VICON", &pose);
  pose.position_m[0] = 2.0;
  lcm.publish("V1_POSE_VICON", &pose);
  pose.position_m[0] = -3.0;
  lcm.publish("V2_POSE_VICON", &pose);
  pose.position_m[0] = 99.0;
  lcm.publish("POSE_VICON", &pose);  // no such vehicle here
  exploration_status_t status{};
  status.seq = 4;
  status.state = exploration_status_t::STATE_DONE;
  status.chosen_index = -1;
  lcm.publish("V2_EXPLORATION_STATUS", &status);
  grid_map_t grid{};
  grid.width = 1;
  grid.height = 1;
  grid.num_values = 1;
  grid.values = {0.5f};
  grid.resolution_m = 0.3;
  lcm.publish("V2_MAP2D_COLLISION", &grid);
  lcm.publish("MAP2D_COLLISION", &grid);  // no such vehicle here
  Drain(lcm);
  EXPECT_EQ(node.messages_received(), 5);
  EXPECT_EQ(node.dropped().total(), 0);
  ASSERT_EQ(node.scene().vehicle_count(), 2u);
  EXPECT_EQ(node.scene().path_points(0), 2u);
  EXPECT_EQ(node.scene().path_points(1), 1u);
  int poses = 0, explorations = 0;
  std::vector<std::string> grids;
  for (const ViewerFrame& f : node.scene().SnapshotFrames()) {
    if (f.binary) {
      if (f.bytes[0] == 2) grids.push_back(f.bytes.substr(56, f.bytes[2]));
      continue;
    }
    const YAML::Node m = YAML::Load(f.bytes);
    const std::string type = m["type"].as<std::string>();
    if (type == "pose") {
      ++poses;
      EXPECT_DOUBLE_EQ(m["p"][0].as<double>(), m["vehicle"].as<int>() == 0 ? 2.0 : -3.0);
    } else if (type == "exploration") {
      ++explorations;
      EXPECT_EQ(m["vehicle"].as<int>(), 1);
      EXPECT_EQ(m["seq"].as<int>(), 4);
    }
  }
  EXPECT_EQ(poses, 2);
  EXPECT_EQ(explorations, 1);
  EXPECT_EQ(grids, std::vector<std::string>{"V2_MAP2D_COLLISION"});
}

}  // namespace
}  // namespace kestrel
