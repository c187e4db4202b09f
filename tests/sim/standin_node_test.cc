// kestrel-sim-standin's node over memq:// (docs/design.md §7.11): relayed bytes, restarts, the
// seeded link loss, malformed device bytes, the heartbeat's counts.
#include "sim/standin_node.h"

#include <cmath>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "kestrel/depth_image_t.hpp"
#include "kestrel/heartbeat_t.hpp"
#include "kestrel/planar_scan_t.hpp"

namespace kestrel {
namespace {

const std::string kRoot = KESTREL_SOURCE_DIR;

// Records the raw bytes of every message on one channel.
class Recorder {
 public:
  Recorder(lcm::LCM& lcm, const std::string& channel) {
    lcm.subscribe(channel, &Recorder::Handle, this);
  }
  void Handle(const lcm::ReceiveBuffer* rbuf, const std::string&) {
    const auto* bytes = static_cast<const uint8_t*>(rbuf->data);
    messages.emplace_back(bytes, bytes + rbuf->data_size);
  }
  std::vector<std::vector<uint8_t>> messages;
};

planar_scan_t Scan(int64_t k) {
  planar_scan_t m{};
  m.utime = 1'000'000 + k * 100'000;
  m.seq = 1000 + k;  // the simulator's own numbering: the stand-in replaces it
  m.epoch = 4242;
  m.sensor_name = "hokuyo";
  m.angle_min_rad = -2.0f;
  m.angle_step_rad = 0.01f;
  m.time_step_s = 0.0f;
  m.range_min_m = 0.02f;
  m.range_max_m = 5.6f;
  m.num_ranges = 5;
  m.ranges_m = {1.0f, 2.5f, static_cast<float>(k), 0.0f, 3.25f};
  m.num_intensities = 0;
  return m;
}

depth_image_t Depth(int64_t k) {
  depth_image_t m{};
  m.utime = 2'000'000 + k * 66'667;
  m.seq = 7 + k;
  m.epoch = 99;
  m.sensor_name = "xtion";
  m.width = 2;
  m.height = 2;
  m.fx_px = m.fy_px = 50.0;
  m.cx_px = m.cy_px = 1.0;
  m.depth_scale_m = 0.001;
  m.range_min_m = 0.5;
  m.range_max_m = 4.0;
  m.encoding = depth_image_t::ENCODING_RAW_U16;
  m.data = {1, 2, 3, 4, 5, static_cast<uint8_t>(k), 7, 8};
  m.data_size = static_cast<int32_t>(m.data.size());
  return m;
}

StandinConfig ScanConfig(double drop_fraction, int64_t seed) {
  StandinConfig c;
  c.sensor = "scan";
  c.device_channel = "DEV_SCAN_HOKUYO";
  c.channel = "SCAN_HOKUYO";
  c.heartbeat_channel = "HEARTBEAT_STANDIN_SCAN";
  c.drop_fraction = drop_fraction;
  c.seed = seed;
  return c;
}

template <typename Message>
std::vector<uint8_t> Encode(const Message& m) {
  std::vector<uint8_t> bytes(static_cast<size_t>(m.getEncodedSize()));
  m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

void Drain(lcm::LCM& lcm) {
  while (lcm.handleTimeout(0) > 0) {
  }
}

// Bytes 16..31 of every numbered Kestrel message are seq and epoch (after fingerprint and utime).
void ExpectSameBytesButSeqEpoch(const std::vector<uint8_t>& sent, const std::vector<uint8_t>& got) {
  ASSERT_EQ(sent.size(), got.size());
  EXPECT_TRUE(std::equal(sent.begin(), sent.begin() + 16, got.begin()));
  EXPECT_TRUE(std::equal(sent.begin() + 32, sent.end(), got.begin() + 32));
}

// Each frame comes out on the driver channel with the same bytes but for seq (0, 1, 2, ...) and
// epoch (the stand-in's), for both sensors.
TEST(StandinNode, RelaysFramesUnchangedButSeqAndEpoch) {
  lcm::LCM lcm("memq://");
  SimClock clock(1'000'000);
  StandinNode scans(lcm, ScanConfig(0.0, 1), clock);
  StandinNode depth(lcm, StandinConfig{}, clock);
  Recorder scan_out(lcm, "SCAN_HOKUYO"), depth_out(lcm, "DEPTH_XTION");
  std::vector<std::vector<uint8_t>> scan_sent, depth_sent;
  for (int k = 0; k < 5; ++k) {
    scan_sent.push_back(Encode(Scan(k)));
    depth_sent.push_back(Encode(Depth(k)));
    lcm.publish("DEV_SCAN_HOKUYO", scan_sent.back().data(),
                static_cast<unsigned>(scan_sent.back().size()));
    lcm.publish("DEV_DEPTH_XTION", depth_sent.back().data(),
                static_cast<unsigned>(depth_sent.back().size()));
    Drain(lcm);
  }
  ASSERT_EQ(scan_out.messages.size(), 5U);
  ASSERT_EQ(depth_out.messages.size(), 5U);
  EXPECT_NE(scans.epoch(), depth.epoch());
  for (size_t k = 0; k < 5; ++k) {
    ExpectSameBytesButSeqEpoch(scan_sent[k], scan_out.messages[k]);
    ExpectSameBytesButSeqEpoch(depth_sent[k], depth_out.messages[k]);
    planar_scan_t s{};
    ASSERT_GT(
        s.decode(scan_out.messages[k].data(), 0, static_cast<int>(scan_out.messages[k].size())), 0);
    EXPECT_EQ(s.seq, static_cast<int64_t>(k));
    EXPECT_EQ(s.epoch, scans.epoch());
    depth_image_t d{};
    ASSERT_GT(
        d.decode(depth_out.messages[k].data(), 0, static_cast<int>(depth_out.messages[k].size())),
        0);
    EXPECT_EQ(d.seq, static_cast<int64_t>(k));
    EXPECT_EQ(d.epoch, depth.epoch());
  }
  EXPECT_EQ(scans.relayed(), 5);
  EXPECT_EQ(scans.drops().total(), 0);
}

// A stand-in started again (after a kill) has a new epoch and counts seq from 0 again.
TEST(StandinNode, RestartedStandinHasNewEpochAndSeqFromZero) {
  lcm::LCM lcm("memq://");
  SimClock clock(1'000'000);
  Recorder out(lcm, "SCAN_HOKUYO");
  int64_t first_epoch = 0;
  {
    StandinNode standin(lcm, ScanConfig(0.0, 1), clock);
    first_epoch = standin.epoch();
    for (int k = 0; k < 3; ++k) {
      const planar_scan_t frame = Scan(k);
      lcm.publish("DEV_SCAN_HOKUYO", &frame);
    }
    Drain(lcm);
  }
  StandinNode again(lcm, ScanConfig(0.0, 1), clock);
  for (int k = 3; k < 5; ++k) {
    const planar_scan_t frame = Scan(k);
    lcm.publish("DEV_SCAN_HOKUYO", &frame);
  }
  Drain(lcm);
  ASSERT_EQ(out.messages.size(), 5U);
  const int64_t expected_seq[] = {0, 1, 2, 0, 1};
  for (size_t i = 0; i < 5; ++i) {
    planar_scan_t s{};
    ASSERT_GT(s.decode(out.messages[i].data(), 0, static_cast<int>(out.messages[i].size())), 0);
    EXPECT_EQ(s.seq, expected_seq[i]) << i;
    EXPECT_EQ(s.epoch, i < 3 ? first_epoch : again.epoch()) << i;
    EXPECT_EQ(s.ranges_m[2], static_cast<float>(i)) << "frame order";
  }
  EXPECT_NE(again.epoch(), first_epoch);
}

// The utime of every frame relayed in one run of n frames at drop fraction p and seed.
std::vector<int64_t> RelayedFrames(double p, int64_t seed, int n) {
  lcm::LCM lcm("memq://");
  SimClock clock(1'000'000);
  StandinNode standin(lcm, ScanConfig(p, seed), clock);
  std::vector<int64_t> relayed;  // the device frame number of every frame relayed
  GuardedSubscriptions subs(lcm);
  subs.Add<planar_scan_t>(
      "SCAN_HOKUYO",
      [&](const std::string&, const planar_scan_t& m) { relayed.push_back(m.utime); }, nullptr);
  for (int k = 0; k < n; ++k) {
    {
      const planar_scan_t frame = Scan(k);
      lcm.publish("DEV_SCAN_HOKUYO", &frame);
    }
    Drain(lcm);
  }
  EXPECT_EQ(standin.device_frames(), n);
  EXPECT_EQ(standin.relayed(), static_cast<int64_t>(relayed.size()));
  EXPECT_EQ(standin.drops().count("link_loss") + standin.relayed(), n);
  return relayed;
}

// The link loss is a seeded Bernoulli draw per frame: over 2000 frames at 10 % the count lies
// within 4 standard deviations of 200; the same seed loses the same frames, another seed others.
TEST(StandinNode, DropFractionIsBinomialAndReproducibleForASeed) {
  const int n = 2000;
  const double p = 0.1;
  const auto a = RelayedFrames(p, 11, n);
  const auto b = RelayedFrames(p, 11, n);
  const auto c = RelayedFrames(p, 12, n);
  const double lost = n - static_cast<double>(a.size());
  const double sigma = std::sqrt(n * p * (1.0 - p));
  EXPECT_NEAR(lost, n * p, 4.0 * sigma);
  EXPECT_TRUE(a == b);
  EXPECT_FALSE(a == c);
  EXPECT_EQ(RelayedFrames(0.0, 11, 300).size(), 300U);
  EXPECT_EQ(RelayedFrames(1.0, 11, 300).size(), 0U);
}

// Malformed device bytes are counted by reason and never relayed; the heartbeat reports
// device_frames, relayed, dropped.malformed and dropped.link_loss exactly.
TEST(StandinNode, MalformedDeviceBytesAreCountedAndNotRelayed) {
  lcm::LCM lcm("memq://");
  SimClock clock(1'000'000);
  StandinNode standin(lcm, ScanConfig(0.0, 1), clock);
  Recorder out(lcm, "SCAN_HOKUYO");
  std::vector<heartbeat_t> beats;
  GuardedSubscriptions subs(lcm);
  subs.Add<heartbeat_t>(
      "HEARTBEAT_STANDIN_SCAN",
      [&](const std::string&, const heartbeat_t& m) { beats.push_back(m); }, nullptr);
  const std::vector<uint8_t> good = Encode(Scan(1));
  const char garbage[] = "not a scan";
  lcm.publish("DEV_SCAN_HOKUYO", garbage, sizeof(garbage));
  lcm.publish("DEV_SCAN_HOKUYO", good.data(), static_cast<unsigned>(good.size() - 3));  // cut
  std::vector<uint8_t> wrong_type = good;
  wrong_type[0] ^= 0xff;  // fingerprint
  lcm.publish("DEV_SCAN_HOKUYO", wrong_type.data(), static_cast<unsigned>(wrong_type.size()));
  lcm.publish("DEV_SCAN_HOKUYO", good.data(), static_cast<unsigned>(good.size()));
  Drain(lcm);
  EXPECT_EQ(out.messages.size(), 1U);
  EXPECT_EQ(standin.drops().count("malformed"), 3);
  EXPECT_EQ(standin.device_frames(), 1);
  standin.PublishHeartbeat();
  Drain(lcm);
  ASSERT_EQ(beats.size(), 1U);
  std::map<std::string, double> values;
  for (const auto& v : beats[0].values) values[v.name] = v.value;
  EXPECT_EQ(values["dropped.malformed"], 3.0);
  EXPECT_EQ(values["dropped.link_loss"], 0.0);
  EXPECT_EQ(values["relayed"], 1.0);
  EXPECT_EQ(values["device_frames"], 1.0);
  EXPECT_EQ(beats[0].state, heartbeat_t::STATE_OK);
}

// The shipped config loads for either sensor; bad values are refused naming the key.
TEST(StandinConfig, LoadsBothSensorsAndRefusesBadValues) {
  ConfigNode depth = ConfigNode::LoadFile(kRoot + "/config/sim/standin.yaml");
  const StandinConfig d = LoadStandinConfig(depth);
  EXPECT_EQ(d.sensor, "depth");
  EXPECT_EQ(d.device_channel, "DEV_DEPTH_XTION");
  EXPECT_EQ(d.channel, "DEPTH_XTION");
  EXPECT_EQ(d.drop_fraction, 0.0);
  ConfigNode scan = ConfigNode::LoadFile(kRoot + "/config/sim/standin.yaml");
  scan.ApplyOverride("sensor=scan");
  scan.ApplyOverride("drop_fraction=0.1");
  const StandinConfig s = LoadStandinConfig(scan);
  EXPECT_EQ(s.device_channel, "DEV_SCAN_HOKUYO");
  EXPECT_EQ(s.channel, "SCAN_HOKUYO");
  EXPECT_EQ(s.heartbeat_channel, "HEARTBEAT_STANDIN_SCAN");
  EXPECT_EQ(s.drop_fraction, 0.1);
  ConfigNode bad = ConfigNode::LoadFile(kRoot + "/config/sim/standin.yaml");
  bad.ApplyOverride("drop_fraction=1.5");
  try {
    (void)LoadStandinConfig(bad);
    FAIL() << "accepted drop_fraction 1.5";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("drop_fraction"), std::string::npos) << e.what();
  }
  ConfigNode unknown = ConfigNode::LoadFile(kRoot + "/config/sim/standin.yaml");
  unknown.ApplyOverride("sensor=imu");
  EXPECT_THROW((void)LoadStandinConfig(unknown), ConfigError);
}

}  // namespace
}  // namespace kestrel
