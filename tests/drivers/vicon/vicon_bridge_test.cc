// The bridge core: SI conversion and stamping, frame gaps, repeats, late frames and restarts,
// time-outs publishing valid = false (never the last pose), occlusion and unknown objects.
#include "drivers/vicon/vicon_bridge.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/config.h"

namespace kestrel {
namespace {

constexpr double kPi = 3.14159265358979323846;

ViconConfig TwoObjects() {
  ViconConfig config;
  config.objects = {{"kestrel", "POSE_VICON", ""}, {"wand", "POSE_WAND", "wand_tip"}};
  config.latency_s = 0.004;
  config.timeout_s = 0.1;
  config.invalid_repeat_period_s = 0.05;
  return config;
}

std::vector<uint8_t> Datagram(uint32_t frame_number, const std::vector<ViconObject>& objects) {
  ViconFrame frame;
  frame.frame_number = frame_number;
  frame.objects = objects;
  return EncodeViconDatagram(frame);
}

const ViconObject kKestrel{"kestrel", {1500.0, -250.0, 1000.0}, {0.0, 0.0, kPi / 2}};

struct Feed {
  ViconBridge bridge;
  std::vector<ViconPoseOutput> out;
  explicit Feed(const ViconConfig& config) : bridge(config) {}
  ViconPacketError Send(uint32_t frame, const std::vector<ViconObject>& objects, int64_t utime) {
    out.clear();
    const std::vector<uint8_t> d = Datagram(frame, objects);
    std::string reason;
    return bridge.HandleDatagram(d.data(), d.size(), utime, &out, &reason);
  }
};

TEST(ViconBridge, ConvertsToSiAndStampsReceiveTimeMinusLatency) {
  Feed f(TwoObjects());
  ASSERT_EQ(f.Send(10, {kKestrel}, 2000000), ViconPacketError::kNone);
  ASSERT_EQ(f.out.size(), 1u);
  const pose_t& p = f.out[0].pose;
  EXPECT_EQ(f.out[0].channel, "POSE_VICON");
  EXPECT_EQ(p.utime, 2000000 - 4000);
  EXPECT_TRUE(p.valid);
  EXPECT_FALSE(p.has_velocity);
  EXPECT_EQ(p.frame_id, "world");
  EXPECT_EQ(p.child_frame_id, "kestrel");
  EXPECT_DOUBLE_EQ(p.position_m[0], 1.5);
  EXPECT_DOUBLE_EQ(p.position_m[1], -0.25);
  EXPECT_DOUBLE_EQ(p.position_m[2], 1.0);
  // Rz(90 deg): (cos 45, 0, 0, sin 45).
  EXPECT_NEAR(p.orientation_wxyz[0], std::sqrt(0.5), 1e-15);
  EXPECT_NEAR(p.orientation_wxyz[1], 0.0, 1e-15);
  EXPECT_NEAR(p.orientation_wxyz[2], 0.0, 1e-15);
  EXPECT_NEAR(p.orientation_wxyz[3], std::sqrt(0.5), 1e-15);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(p.velocity_mps[i], 0.0);
    EXPECT_EQ(p.angular_velocity_radps[i], 0.0);
  }
}

TEST(ViconBridge, EachObjectOnItsChannelWithItsFrameIdAndSequence) {
  Feed f(TwoObjects());
  const ViconObject wand{"wand", {0, 0, 10}, {0.1, 0, 0}};
  f.Send(1, {wand, kKestrel}, 1000);
  ASSERT_EQ(f.out.size(), 2u);
  EXPECT_EQ(f.out[0].channel, "POSE_WAND");
  EXPECT_EQ(f.out[0].pose.child_frame_id, "wand_tip");
  EXPECT_EQ(f.out[0].pose.seq, 0);
  f.Send(2, {wand, kKestrel}, 2000);
  EXPECT_EQ(f.out[0].pose.seq, 1);
  EXPECT_EQ(f.out[1].pose.seq, 1);
}

TEST(ViconBridge, CountsGapsAsDropsAndIgnoresRepeats) {
  Feed f(TwoObjects());
  f.Send(100, {kKestrel}, 1000);
  f.Send(101, {kKestrel}, 2000);
  EXPECT_EQ(f.out.size(), 1u);
  f.Send(105, {kKestrel}, 3000);  // 102, 103, 104 missing
  EXPECT_EQ(f.out.size(), 1u);
  EXPECT_EQ(f.bridge.stats().frames_dropped, 3);
  f.Send(105, {kKestrel}, 4000);  // repeat: nothing published
  EXPECT_TRUE(f.out.empty());
  EXPECT_EQ(f.bridge.stats().frames_repeated, 1);
  f.Send(103, {kKestrel}, 5000);  // late (reordered): ignored
  EXPECT_TRUE(f.out.empty());
  EXPECT_EQ(f.bridge.stats().frames_late, 1);
  EXPECT_EQ(f.bridge.stats().frames_dropped, 3);
  EXPECT_EQ(f.bridge.stats().frames_accepted, 3);
}

TEST(ViconBridge, FrameNumberWrapsModulo2To32) {
  Feed f(TwoObjects());
  f.Send(0xfffffffeu, {kKestrel}, 1000);
  f.Send(0xffffffffu, {kKestrel}, 2000);
  f.Send(1u, {kKestrel}, 3000);  // 0 missing
  EXPECT_EQ(f.out.size(), 1u);
  EXPECT_EQ(f.bridge.stats().frames_dropped, 1);
  EXPECT_EQ(f.bridge.stats().stream_restarts, 0);
}

TEST(ViconBridge, LargeJumpsAreRestartsNotDrops) {
  ViconConfig config = TwoObjects();
  config.max_frame_gap = 50;
  config.reorder_window_frames = 10;
  Feed f(config);
  f.Send(1000, {kKestrel}, 1000);
  f.Send(5, {kKestrel}, 2000);  // Tracker restarted: far back, accepted
  EXPECT_EQ(f.out.size(), 1u);
  f.Send(6, {kKestrel}, 3000);
  f.Send(500, {kKestrel}, 4000);  // 493 missing > 50: restart
  EXPECT_EQ(f.out.size(), 1u);
  EXPECT_EQ(f.bridge.stats().stream_restarts, 2);
  EXPECT_EQ(f.bridge.stats().frames_dropped, 0);
}

TEST(ViconBridge, TimeoutPublishesInvalidNeverTheLastPose) {
  Feed f(TwoObjects());
  std::vector<ViconPoseOutput> out;
  // Before anything arrives both objects are invalid.
  f.bridge.CheckTimeouts(0, &out);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_FALSE(out[0].pose.valid);
  f.Send(1, {kKestrel}, 1000000);
  EXPECT_TRUE(f.bridge.object_valid(0));
  out.clear();
  f.bridge.CheckTimeouts(1100000, &out);  // exactly timeout_s later: still valid
  for (const auto& o : out) EXPECT_NE(o.channel, "POSE_VICON");
  out.clear();
  f.bridge.CheckTimeouts(1100001, &out);  // just past: invalid
  ASSERT_EQ(out.size(), 1u);              // kestrel timed out; wand's repeat was 1 us ago
  const pose_t& lost = out[0].pose;
  EXPECT_EQ(out[0].channel, "POSE_VICON");
  EXPECT_FALSE(lost.valid);
  EXPECT_EQ(lost.utime, 1100001);
  EXPECT_EQ(lost.position_m[0], 0.0);
  EXPECT_EQ(lost.orientation_wxyz[0], 1.0);
  EXPECT_FALSE(f.bridge.object_valid(0));
  EXPECT_EQ(f.bridge.stats().timeouts, 1);
  // Repeated every invalid_repeat_period_s (0.05 s) while lost.
  out.clear();
  f.bridge.CheckTimeouts(1140000, &out);
  EXPECT_TRUE(out.empty());
  f.bridge.CheckTimeouts(1150001, &out);
  EXPECT_EQ(out.size(), 2u);
  // Back again: valid at once.
  f.Send(2, {kKestrel}, 1200000);
  ASSERT_EQ(f.out.size(), 1u);
  EXPECT_TRUE(f.out[0].pose.valid);
  EXPECT_TRUE(f.bridge.object_valid(0));
}

TEST(ViconBridge, ZeroPoseIsOcclusionAndUnknownNamesAreSkipped) {
  Feed f(TwoObjects());
  f.Send(1, {{"kestrel", {0, 0, 0}, {0, 0, 0}}, {"stranger", {1, 2, 3}, {0, 0, 0}}}, 1000);
  EXPECT_TRUE(f.out.empty());
  EXPECT_EQ(f.bridge.stats().occluded, 1);
  EXPECT_EQ(f.bridge.stats().unconfigured_objects, 1);
  ViconConfig config = TwoObjects();
  config.zero_pose_is_occluded = false;
  Feed g(config);
  g.Send(1, {{"kestrel", {0, 0, 0}, {0, 0, 0}}}, 1000);
  EXPECT_EQ(g.out.size(), 1u);
}

TEST(ViconBridge, MalformedDatagramsAreCountedByKindAndDropped) {
  Feed f(TwoObjects());
  std::vector<uint8_t> d = Datagram(1, {kKestrel});
  d[5] = 9;  // unknown item id
  std::vector<ViconPoseOutput> out;
  std::string reason;
  EXPECT_EQ(f.bridge.HandleDatagram(d.data(), d.size(), 1000, &out, &reason),
            ViconPacketError::kUnknownItemId);
  EXPECT_TRUE(out.empty());
  EXPECT_NE(reason.find("id 9"), std::string::npos) << reason;
  EXPECT_EQ(f.bridge.HandleDatagram(d.data(), 3, 1000, &out, &reason), ViconPacketError::kTooShort);
  EXPECT_EQ(f.bridge.stats().malformed, 2);
  EXPECT_EQ(f.bridge.stats().malformed_by_kind.at("unknown_item_id"), 1);
  EXPECT_EQ(f.bridge.stats().malformed_by_kind.at("too_short"), 1);
  // A malformed datagram does not disturb frame tracking.
  f.Send(2, {kKestrel}, 2000);
  EXPECT_EQ(f.out.size(), 1u);
  EXPECT_EQ(f.bridge.stats().frames_dropped, 0);
}

TEST(ViconBridge, ExtrinsicOrderIsSelectable) {
  ViconConfig config = TwoObjects();
  config.euler_order = "xyz_extrinsic";
  Feed f(config);
  f.Send(1, {{"kestrel", {1, 1, 1}, {kPi / 2, 0, kPi / 2}}}, 1000);
  ASSERT_EQ(f.out.size(), 1u);
  const double* q = f.out[0].pose.orientation_wxyz;
  const Eigen::Quaterniond quat(q[0], q[1], q[2], q[3]);
  // Rz(90) Rx(90): body x stays on x under Rx, then turns to y.
  EXPECT_TRUE((quat * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY(), 1e-12));
}

TEST(ViconConfig, ValidateNamesFieldValueAndRange) {
  ViconConfig config;
  config.timeout_s = 0.0;
  EXPECT_THROW(
      {
        try {
          config.Validate();
        } catch (const std::invalid_argument& e) {
          EXPECT_NE(std::string(e.what()).find("vicon.timeout_s = 0, accepted (0, 10]"),
                    std::string::npos)
              << e.what();
          throw;
        }
      },
      std::invalid_argument);
  config = ViconConfig{};
  config.objects = {{"a", "X", ""}, {"a", "Y", ""}};
  EXPECT_THROW(config.Validate(), std::invalid_argument);
  config.objects = {{std::string(24, 'n'), "X", ""}};
  EXPECT_THROW(config.Validate(), std::invalid_argument);
  config = ViconConfig{};
  config.bind_address = "localhost";
  EXPECT_THROW(config.Validate(), std::invalid_argument);
}

TEST(ViconConfig, LoadsYamlAndRejectsBadValues) {
  const ConfigNode node = ConfigNode::FromString(
      "port: 52000\nlatency_s: 0.01\nobjects:\n  - {name: quad, channel: POSE_Q}\n"
      "  - {name: box}\neuler_order: xyz_extrinsic\n",
      "test.yaml");
  const ViconConfig config = LoadViconConfig(node);
  node.CheckNoUnknownKeys();
  EXPECT_EQ(config.port, 52000);
  EXPECT_DOUBLE_EQ(config.latency_s, 0.01);
  ASSERT_EQ(config.objects.size(), 2u);
  EXPECT_EQ(config.objects[0].channel, "POSE_Q");
  EXPECT_EQ(config.objects[1].channel, "POSE_VICON");
  EXPECT_EQ(config.euler_order_enum(), ViconEulerOrder::kExtrinsicXyz);
  EXPECT_THROW((void)LoadViconConfig(ConfigNode::FromString("port: 70000\n", "t.yaml")),
               ConfigError);
  EXPECT_THROW((void)LoadViconConfig(ConfigNode::FromString("objects: []\n", "t.yaml")),
               ConfigError);
  EXPECT_THROW((void)LoadViconEmitterConfig(
                   ConfigNode::FromString("destination_address: 192.168.1.5\n", "t.yaml")),
               ConfigError);
}

// The shipped files load, leave no key unread, and equal the struct defaults where they should.
TEST(ViconConfig, ShippedFilesLoad) {
  const ConfigNode bridge_node =
      ConfigNode::LoadFile(std::string(KESTREL_SOURCE_DIR) + "/config/drivers/vicon.yaml");
  const ViconConfig bridge = LoadViconConfig(bridge_node);
  bridge_node.CheckNoUnknownKeys();
  EXPECT_EQ(bridge.port, 51001);
  ASSERT_EQ(bridge.objects.size(), 1u);
  EXPECT_EQ(bridge.objects[0].channel, "POSE_VICON");
  EXPECT_EQ(bridge.euler_order_enum(), ViconEulerOrder::kIntrinsicXyz);
  const ConfigNode emitter_node =
      ConfigNode::LoadFile(std::string(KESTREL_SOURCE_DIR) + "/config/drivers/vicon_emitter.yaml");
  const ViconEmitterConfig emitter = LoadViconEmitterConfig(emitter_node);
  emitter_node.CheckNoUnknownKeys();
  EXPECT_EQ(emitter.port, bridge.port);
  EXPECT_EQ(emitter.object_name, bridge.objects[0].name);
  EXPECT_TRUE(IsLoopbackAddress(emitter.destination_address));
}

TEST(ViconConfig, LoopbackMeans127Slash8) {
  EXPECT_TRUE(IsLoopbackAddress("127.0.0.1"));
  EXPECT_TRUE(IsLoopbackAddress("127.255.0.9"));
  EXPECT_FALSE(IsLoopbackAddress("128.0.0.1"));
  EXPECT_FALSE(IsLoopbackAddress("0.0.0.0"));
  EXPECT_FALSE(IsLoopbackAddress("localhost"));
  EXPECT_FALSE(IsLoopbackAddress("::1"));
}

}  // namespace
}  // namespace kestrel
