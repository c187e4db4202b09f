// kestrel-xtion's node against Kestrel's OpenNI2 plugin through the real libOpenNI2. Each case
// runs as its own ctest inside with_oni_plugin.sh (a mount namespace whose OpenNI.ini loads only
// the plugin), with the plugin's environment (scene, clock offset, faults) set by CMake; the
// oracles read the same variables. Messages are received over memq:// through guarded decoding.
#include <sys/stat.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/clock.h"
#include "common/lcm_decode.h"
#include "drivers/xtion/xtion_node.h"
#include "kestrel/heartbeat_t.hpp"
#include "lcmtypes/message_codecs.h"
#include "tests/drivers/xtion/wall_oracle.h"

namespace kestrel {
namespace {

// The pixels of a received image (the shared codec), failing the test if they do not decode.
std::vector<uint16_t> Pixels(const depth_image_t& m) {
  std::vector<uint16_t> counts;
  EXPECT_EQ(DecodeDepthPixels(m, &counts), "");
  return counts;
}

constexpr double kDeg = M_PI / 180.0;
// Stated tolerance: a published host stamp is within 50 ms of the moment the test handled the
// message (typically < 2 ms; the margin is for a loaded CI machine). The smoothed offset itself
// is checked to 30 ms.
constexpr int64_t kHandledToleranceUs = 50000;

double EnvDouble(const char* name, double fallback) {
  const char* v = std::getenv(name);
  return v != nullptr ? std::atof(v) : fallback;
}

double HeartbeatValue(const heartbeat_t& hb, const std::string& name) {
  for (const auto& v : hb.values) {
    if (v.name == name) return v.value;
  }
  ADD_FAILURE() << "heartbeat has no value " << name;
  return -1.0;
}

// What the test saw on memq://.
struct Capture {
  std::vector<depth_image_t> images;
  std::vector<int64_t> receive_utime;  // WallClock time when each image was handled
  std::vector<heartbeat_t> heartbeats;
  int64_t decode_errors{0};
};

class XtionOpenNi : public ::testing::Test {
 protected:
  XtionOpenNi() : lcm_("memq://"), subs_(lcm_) {
    subs_.Add<depth_image_t>(
        "DEPTH_XTION",
        [this](const std::string&, const depth_image_t& m) {
          capture_.images.push_back(m);
          capture_.receive_utime.push_back(clock_.NowUtime());
        },
        [this](const std::string&, const std::string&) { ++capture_.decode_errors; });
    subs_.Add<heartbeat_t>(
        "HEARTBEAT_XTION",
        [this](const std::string&, const heartbeat_t& m) { capture_.heartbeats.push_back(m); },
        [this](const std::string&, const std::string&) { ++capture_.decode_errors; });
  }

  // Runs the node for `seconds` of wall time: Poll, deliver messages, heartbeat every 0.5 s.
  void Run(XtionNode& node, double seconds) {
    const int64_t end = clock_.NowUtime() + SecondsToUtime(seconds);
    int64_t next_heartbeat = clock_.NowUtime() + 500000;
    while (clock_.NowUtime() < end) {
      node.Poll(10);
      while (lcm_.handleTimeout(0) > 0) {
      }
      if (clock_.NowUtime() >= next_heartbeat) {
        node.PublishHeartbeat();
        next_heartbeat += 500000;
      }
    }
    node.PublishHeartbeat();
    while (lcm_.handleTimeout(0) > 0) {
    }
  }

  // The analytic scene of device `device_index` as the plugin's environment describes it.
  static test::WallOracle Wall(int device_index, int64_t frame) {
    return test::WallOracle{EnvDouble("KESTREL_ONI_WALL_M", 2.0) + 0.25 * device_index +
                                0.001 * static_cast<double>(frame % 50),
                            EnvDouble("KESTREL_ONI_WALL_TILT_DEG", 17.0) * kDeg,
                            EnvDouble("KESTREL_ONI_WALL_PITCH_DEG", 8.0) * kDeg, 8};
  }

  // Checks that every image equals the wall of `device_index` at some frame of its 50-frame
  // cycle, pixel for pixel; returns the number of images that match none.
  static int CountImagesOffTheWall(const std::vector<depth_image_t>& images, int device_index) {
    struct Expected {
      std::vector<uint16_t> counts;
      std::vector<bool> ambiguous;
    };
    std::map<std::pair<int, double>, std::vector<Expected>> cache;  // (width, scale) -> frames
    int off = 0;
    for (const auto& m : images) {
      auto& frames = cache[{m.width, m.depth_scale_m}];
      if (frames.empty()) {
        for (int k = 0; k < 50; ++k) {
          Expected e;
          e.counts = Wall(device_index, k).Render(m.width, m.height, m.depth_scale_m, &e.ambiguous);
          frames.push_back(std::move(e));
        }
      }
      const auto counts = Pixels(m);
      bool matched = false;
      for (const auto& e : frames) {
        if (test::CountMismatches(counts, e.counts, e.ambiguous) == 0) {
          matched = true;
          break;
        }
      }
      if (!matched) ++off;
    }
    return off;
  }

  WallClock clock_;
  lcm::LCM lcm_;
  GuardedSubscriptions subs_;
  Capture capture_;
};

XtionConfig Config(int width, int height, int fps, const std::string& format,
                   const std::string& encoding) {
  XtionConfig c;
  c.width = width;
  c.height = height;
  c.fps = fps;
  c.pixel_format = format;
  c.encoding = encoding;
  return c;
}

// QVGA@30, 1 mm, raw, with the device clock 1e15 us behind the host: about 90 frames in 3 s of
// the right size and scale, each equal to the analytic wall, intrinsics from the 58 x 45 deg
// field of view, time stamps on the host clock (offset estimate within 30 ms of the truth).
TEST_F(XtionOpenNi, StreamsTheAnalyticWallOnHostTime) {
  ASSERT_NE(std::getenv("KESTREL_ONI_CLOCK_OFFSET_US"), nullptr);
  const int64_t device_minus_host_us = std::atoll(std::getenv("KESTREL_ONI_CLOCK_OFFSET_US"));
  XtionNode node(lcm_, Config(320, 240, 30, "depth_1_mm", "raw"), clock_);
  Run(node, 3.0);
  const auto& images = capture_.images;
  EXPECT_EQ(capture_.decode_errors, 0);
  EXPECT_GE(images.size(), 60u);  // 90 nominal; generous for a loaded 2-core machine
  EXPECT_LE(images.size(), 92u);
  ASSERT_FALSE(images.empty());
  const PinholeIntrinsics k = IntrinsicsFromFov(320, 240, 58.0 * kDeg, 45.0 * kDeg);
  for (size_t i = 0; i < images.size(); ++i) {
    const auto& m = images[i];
    ASSERT_EQ(m.width, 320);
    ASSERT_EQ(m.height, 240);
    EXPECT_EQ(m.seq, static_cast<int64_t>(i));
    EXPECT_EQ(m.epoch, node.epoch());
    EXPECT_EQ(m.encoding, depth_image_t::ENCODING_RAW_U16);
    EXPECT_EQ(m.data_size, 320 * 240 * 2);
    EXPECT_DOUBLE_EQ(m.depth_scale_m, 1e-3);
    EXPECT_EQ(m.sensor_name, "xtion");
    EXPECT_NEAR(m.fx_px, k.fx_px, 1e-4);  // FOV arrives as float from OpenNI2
    EXPECT_NEAR(m.fy_px, k.fy_px, 1e-4);
    EXPECT_DOUBLE_EQ(m.cx_px, 159.5);
    EXPECT_DOUBLE_EQ(m.cy_px, 119.5);
    // Host time: within 50 ms of the moment the test handled the message (the device clock is
    // 1e15 us away, so an unconverted stamp would miss by 31 years).
    EXPECT_LT(std::llabs(capture_.receive_utime[i] - m.utime), kHandledToleranceUs) << i;
  }
  EXPECT_NE(node.epoch(), 0);
  EXPECT_EQ(CountImagesOffTheWall(images, 0), 0);
  // The smoothed offset is host - device = -(device - host) plus the median arrival latency.
  const int64_t excess_us = node.clock_offset_us() + device_minus_host_us;
  EXPECT_GE(excess_us, 0);
  EXPECT_LT(excess_us, 30000);
  // Frame spacing on the host clock follows the device's 30 Hz (mean over the run).
  const double mean_dt_us = static_cast<double>(images.back().utime - images.front().utime) /
                            static_cast<double>(images.size() - 1);
  EXPECT_NEAR(mean_dt_us, 33333.0, 1500.0);
  int64_t worst_us = 0;
  for (size_t i = 0; i < images.size(); ++i) {
    worst_us = std::max<int64_t>(worst_us, std::llabs(capture_.receive_utime[i] - images[i].utime));
  }
  std::printf(
      "[figures] frames %zu in 3 s; offset estimate - true offset %lld us; "
      "max |handled - utime| %lld us; mean spacing %.1f us\n",
      images.size(), static_cast<long long>(excess_us), static_cast<long long>(worst_us),
      mean_dt_us);
  ASSERT_FALSE(capture_.heartbeats.empty());
  const heartbeat_t& hb = capture_.heartbeats.back();
  EXPECT_EQ(hb.state, heartbeat_t::STATE_OK);
  EXPECT_EQ(HeartbeatValue(hb, "frames_published"), static_cast<double>(images.size()));
  EXPECT_EQ(HeartbeatValue(hb, "device_losses"), 0.0);
  EXPECT_NEAR(HeartbeatValue(hb, "clock_offset_us"), static_cast<double>(node.clock_offset_us()),
              1.0);
}

// VGA@30 in 100 um, zlib-compressed: the payload inflates to the wall at 0.1 mm resolution.
TEST_F(XtionOpenNi, StreamsVgaHundredMicronsCompressed) {
  XtionNode node(lcm_, Config(640, 480, 30, "depth_100_um", "zlib"), clock_);
  Run(node, 2.0);
  const auto& images = capture_.images;
  EXPECT_GE(images.size(), 35u);  // 60 nominal
  EXPECT_LE(images.size(), 62u);
  for (const auto& m : images) {
    ASSERT_EQ(m.width, 640);
    ASSERT_EQ(m.height, 480);
    EXPECT_EQ(m.encoding, depth_image_t::ENCODING_ZLIB_U16);
    EXPECT_DOUBLE_EQ(m.depth_scale_m, 1e-4);
    EXPECT_LT(m.data_size, 640 * 480 * 2);  // a smooth wall compresses
    EXPECT_DOUBLE_EQ(m.cx_px, 319.5);
  }
  EXPECT_EQ(CountImagesOffTheWall(images, 0), 0);
}

// QVGA@60: about 120 frames in 2 s.
TEST_F(XtionOpenNi, StreamsQvgaAtSixtyHertz) {
  XtionNode node(lcm_, Config(320, 240, 60, "depth_1_mm", "zlib"), clock_);
  Run(node, 2.0);
  EXPECT_GE(capture_.images.size(), 70u);
  EXPECT_LE(capture_.images.size(), 122u);
  const auto& m = capture_.images.back();
  EXPECT_EQ(m.width, 320);
  const double mean_dt_us =
      static_cast<double>(capture_.images.back().utime - capture_.images.front().utime) /
      static_cast<double>(capture_.images.size() - 1);
  EXPECT_NEAR(mean_dt_us, 16667.0, 1500.0);
  EXPECT_EQ(CountImagesOffTheWall(capture_.images, 0), 0);
}

// With three devices announced (walls at +0 / +0.25 / +0.5 m), each selector form streams the
// device it names: the images match that device's wall and no other.
class XtionOpenNiSelect : public XtionOpenNi {
 protected:
  void Check(const std::string& device_id, int expected_index) {
    XtionConfig c = Config(320, 240, 30, "depth_1_mm", "zlib");
    c.device = device_id;
    XtionNode node(lcm_, c, clock_);
    Run(node, 1.5);
    ASSERT_GE(capture_.images.size(), 20u) << device_id;
    EXPECT_EQ(CountImagesOffTheWall(capture_.images, expected_index), 0) << device_id;
    for (int other = 0; other < 3; ++other) {
      if (other == expected_index) continue;
      EXPECT_EQ(CountImagesOffTheWall({capture_.images.back()}, other), 1) << device_id;
    }
  }
};

TEST_F(XtionOpenNiSelect, ByIndex) { Check("#2", 1); }
TEST_F(XtionOpenNiSelect, ByBusAddress) { Check("1@12", 2); }
TEST_F(XtionOpenNiSelect, BySerial) { Check("KXT0000001", 1); }
TEST_F(XtionOpenNiSelect, FirstByDefault) { Check("", 0); }

// A serial that no device has: nothing is published, the node keeps retrying with back-off and
// says so in its heartbeat.
TEST_F(XtionOpenNiSelect, UnknownSerialDegradesAndRetries) {
  XtionConfig c = Config(320, 240, 30, "depth_1_mm", "zlib");
  c.device = "NOSUCHSERIAL";
  c.reopen_initial_s = 0.1;
  c.reopen_max_s = 0.4;
  XtionNode node(lcm_, c, clock_);
  Run(node, 2.0);
  EXPECT_TRUE(capture_.images.empty());
  // Attempts at 0, 0.1, 0.3, 0.7, 1.1, 1.5, 1.9 s: back-off 0.1 doubling to 0.4.
  EXPECT_GE(node.stats().reopen_failures, 5);
  EXPECT_LE(node.stats().reopen_failures, 8);
  ASSERT_FALSE(capture_.heartbeats.empty());
  EXPECT_EQ(capture_.heartbeats.back().state, heartbeat_t::STATE_DEGRADED);
  EXPECT_NE(capture_.heartbeats.back().last_error.find("NOSUCHSERIAL"), std::string::npos);
}

// The plugin drops the device after N frames for M ms (environment). The node notices, closes,
// reopens with the same mode when the device returns, and frames resume; the heartbeat counts
// one loss.
TEST_F(XtionOpenNi, RecoversFromDeviceLoss) {
  const int64_t loss_after = std::atoll(std::getenv("KESTREL_ONI_FAULT_LOSS_AFTER_FRAMES"));
  const double loss_s = EnvDouble("KESTREL_ONI_FAULT_LOSS_MS", 0.0) * 1e-3;
  ASSERT_GT(loss_after, 0);
  XtionConfig c = Config(320, 240, 30, "depth_1_mm", "zlib");
  c.reopen_initial_s = 0.1;
  c.reopen_max_s = 0.4;
  XtionNode node(lcm_, c, clock_);
  Run(node, loss_after / 30.0 + loss_s + 2.0);
  const auto& images = capture_.images;
  // The gap: the longest spacing between consecutive images is at least the outage.
  size_t gap_at = 0;
  int64_t gap_us = 0;
  for (size_t i = 1; i < images.size(); ++i) {
    if (images[i].utime - images[i - 1].utime > gap_us) {
      gap_us = images[i].utime - images[i - 1].utime;
      gap_at = i;
    }
  }
  EXPECT_GE(gap_us, SecondsToUtime(loss_s));
  EXPECT_LT(gap_us, SecondsToUtime(loss_s + 1.5));  // + back-off (<= 0.4 s) + open
  EXPECT_GE(static_cast<int64_t>(gap_at),
            loss_after - 5);  // before: the N frames (some at start-up)
  EXPECT_LE(static_cast<int64_t>(gap_at), loss_after);
  EXPECT_GE(images.size() - gap_at, 40u);  // after: about 2 s at 30 Hz
  for (const auto& m : images) {
    ASSERT_EQ(m.width, 320);  // mode restored
    ASSERT_DOUBLE_EQ(m.depth_scale_m, 1e-3);
  }
  EXPECT_EQ(CountImagesOffTheWall(images, 0), 0);
  // The device clock restarted at 1 s on return; host stamps stay right (the offset window is
  // restarted on reopen).
  for (size_t i = 0; i < images.size(); ++i) {
    EXPECT_LT(std::llabs(capture_.receive_utime[i] - images[i].utime), kHandledToleranceUs) << i;
  }
  EXPECT_EQ(node.stats().device_losses, 1);
  EXPECT_GE(node.stats().reopen_attempts, 1);
  EXPECT_TRUE(node.streaming());
  // The heartbeats tell the story: degraded during the outage, one loss counted, OK at the end.
  bool saw_degraded = false;
  for (const auto& hb : capture_.heartbeats) {
    if (hb.state == heartbeat_t::STATE_DEGRADED) saw_degraded = true;
  }
  EXPECT_TRUE(saw_degraded);
  const heartbeat_t& last = capture_.heartbeats.back();
  EXPECT_EQ(last.state, heartbeat_t::STATE_OK);
  EXPECT_EQ(HeartbeatValue(last, "device_losses"), 1.0);
  EXPECT_EQ(HeartbeatValue(last, "frames_published"), static_cast<double>(images.size()));
}

// The plugin's streams fall silent for M ms after N frames while the device stays connected and
// no OpenNI2 event says so (a USB hiccup): the node's frame time-out declares a stall, reopens,
// and frames resume.
TEST_F(XtionOpenNi, RecoversFromASilentStall) {
  const int64_t stall_after = std::atoll(std::getenv("KESTREL_ONI_FAULT_STALL_AFTER_FRAMES"));
  const double stall_s = EnvDouble("KESTREL_ONI_FAULT_STALL_MS", 0.0) * 1e-3;
  ASSERT_GT(stall_after, 0);
  XtionConfig c = Config(320, 240, 30, "depth_1_mm", "zlib");
  c.frame_timeout_s = 0.4;
  c.reopen_initial_s = 0.1;
  XtionNode node(lcm_, c, clock_);
  Run(node, stall_after / 30.0 + stall_s + 1.5);
  EXPECT_GE(node.stats().stalls, 1);
  EXPECT_EQ(node.stats().device_losses, node.stats().stalls);
  EXPECT_TRUE(node.streaming());
  const auto& images = capture_.images;
  ASSERT_GE(images.size(), static_cast<size_t>(stall_after));
  // Frames after the silence: about 1.5 s at 30 Hz.
  const int64_t resumed_after =
      images[static_cast<size_t>(stall_after) - 1].utime + SecondsToUtime(stall_s);
  size_t after = 0;
  for (const auto& m : images) after += m.utime >= resumed_after ? 1 : 0;
  EXPECT_GE(after, 25u);
  EXPECT_EQ(CountImagesOffTheWall(images, 0), 0);
  EXPECT_EQ(capture_.heartbeats.back().state, heartbeat_t::STATE_OK);
  EXPECT_GE(HeartbeatValue(capture_.heartbeats.back(), "stalls"), 1.0);
}

// A device clock running 2 % fast (KESTREL_ONI_CLOCK_DRIFT_PPM=20000; 34.0 ms between frames on
// the device clock for 33.3 ms on the host): the sliding median follows, so host stamps keep
// the host's spacing and stay near arrival; a frozen offset would stretch them to 34.0 ms and
// drift 80 ms away over the run.
TEST_F(XtionOpenNi, TracksADriftingDeviceClock) {
  ASSERT_STREQ(std::getenv("KESTREL_ONI_CLOCK_DRIFT_PPM"), "20000");
  XtionNode node(lcm_, Config(320, 240, 30, "depth_1_mm", "zlib"), clock_);
  Run(node, 4.0);
  const auto& images = capture_.images;
  ASSERT_GE(images.size(), 80u);
  const double mean_dt_us = static_cast<double>(images.back().utime - images.front().utime) /
                            static_cast<double>(images.size() - 1);
  EXPECT_NEAR(mean_dt_us, 33333.0, 300.0);
  // The window is 31 frames (about 1 s): the median lags by about half of it, 0.5 s x 2 % = 10 ms.
  for (size_t i = images.size() / 2; i < images.size(); ++i) {
    EXPECT_LT(std::llabs(capture_.receive_utime[i] - images[i].utime), 25000) << i;
  }
  EXPECT_EQ(node.stats().offset_resets, 0);
}

// A device that starts mirrored (KESTREL_ONI_MIRROR_DEFAULT=1): the node turns mirroring off,
// so the images are the unmirrored wall (the wall is tilted about y, so a mirror image differs).
TEST_F(XtionOpenNi, TurnsOffADefaultMirror) {
  ASSERT_STREQ(std::getenv("KESTREL_ONI_MIRROR_DEFAULT"), "1");
  XtionNode node(lcm_, Config(320, 240, 30, "depth_1_mm", "zlib"), clock_);
  Run(node, 1.0);
  ASSERT_GE(capture_.images.size(), 15u);
  EXPECT_EQ(CountImagesOffTheWall(capture_.images, 0), 0);
}

// Frames the device never delivers (every 5th index, KESTREL_ONI_FAULT_SKIP_EVERY=5) are counted
// as drops from the frame-index gaps: one drop per four frames published.
TEST_F(XtionOpenNi, CountsSkippedFramesAsDrops) {
  ASSERT_STREQ(std::getenv("KESTREL_ONI_FAULT_SKIP_EVERY"), "5");
  XtionNode node(lcm_, Config(320, 240, 30, "depth_1_mm", "zlib"), clock_);
  Run(node, 2.0);
  const auto published = static_cast<double>(capture_.images.size());
  ASSERT_GE(published, 30.0);
  const auto dropped = static_cast<double>(node.stats().frames_dropped);
  EXPECT_NEAR(dropped, published / 4.0, 1.5);
  EXPECT_EQ(HeartbeatValue(capture_.heartbeats.back(), "frames_dropped"), dropped);
  // 24 Hz on the host clock: spacing is 5/4 of 33.3 ms on average.
  const double mean_dt_us =
      static_cast<double>(capture_.images.back().utime - capture_.images.front().utime) /
      (published - 1.0);
  EXPECT_NEAR(mean_dt_us, 41667.0, 3000.0);
  EXPECT_EQ(CountImagesOffTheWall(capture_.images, 0), 0);
}

// Frames from a folder (KESTREL_ONI_SOURCE=files:DIR, written here before OpenNI2 starts) come
// out unchanged and in order.
TEST_F(XtionOpenNi, ServesFramesFromFiles) {
  const std::string source = std::getenv("KESTREL_ONI_SOURCE");
  ASSERT_EQ(source.rfind("files:", 0), 0u);
  const std::string dir = source.substr(6);
  mkdir(dir.c_str(), 0755);
  std::vector<std::vector<uint16_t>> frames(3, std::vector<uint16_t>(320 * 240));
  for (size_t f = 0; f < frames.size(); ++f) {
    for (size_t i = 0; i < frames[f].size(); ++i) {
      frames[f][i] = static_cast<uint16_t>((i * 7 + f * 1000) % 60000);
    }
    std::ofstream out(dir + "/frame" + std::to_string(f) + ".raw", std::ios::binary);
    depth_image_t raw;
    EncodeDepthPixels(frames[f], depth_image_t::ENCODING_RAW_U16, 0, &raw);
    const std::vector<uint8_t>& bytes = raw.data;
    out.write(reinterpret_cast<const char*>(bytes.data()),
              static_cast<std::streamsize>(bytes.size()));
  }
  XtionNode node(lcm_, Config(320, 240, 30, "depth_1_mm", "zlib"), clock_);
  Run(node, 1.0);
  ASSERT_GE(capture_.images.size(), 10u);
  // The plugin serves file i % 3 as its frame i (frame index i + 1); a frame OpenNI2 skipped
  // shows as an index gap, counted by the node, so the order holds when nothing was dropped.
  for (size_t i = 0; i < capture_.images.size(); ++i) {
    const auto& m = capture_.images[i];
    const auto counts = Pixels(m);
    if (node.stats().frames_dropped == 0) {
      EXPECT_EQ(counts, frames[i % 3]) << i;
    } else {
      EXPECT_TRUE(counts == frames[0] || counts == frames[1] || counts == frames[2]) << i;
    }
  }
  for (size_t f = 0; f < frames.size(); ++f) {
    std::remove((dir + "/frame" + std::to_string(f) + ".raw").c_str());
  }
  rmdir(dir.c_str());
}

// KESTREL_ONI_SOURCE=lcm:URL: depth_image_t sent on the plugin's channel (as the simulator does)
// come out of OpenNI2 and kestrel-xtion converted to the stream's format (sent in 100 um, zlib;
// streamed in 1 mm), one frame per message, with the sender's time base (device clock = sender
// utime) mapped to host time; a frame of the wrong size is dropped by the plugin.
TEST_F(XtionOpenNi, ServesFramesFromLcm) {
  const std::string source = std::getenv("KESTREL_ONI_SOURCE");
  ASSERT_EQ(source.rfind("lcm:", 0), 0u);
  lcm::LCM sender(source.substr(4));
  ASSERT_TRUE(sender.good());
  const char* channel = std::getenv("KESTREL_ONI_LCM_CHANNEL");
  ASSERT_NE(channel, nullptr);
  XtionNode node(lcm_, Config(320, 240, 30, "depth_1_mm", "raw"), clock_);
  for (int i = 0; i < 20 && !node.streaming(); ++i) node.Poll(10);
  ASSERT_TRUE(node.streaming());
  // Frame f: counts 10 q + r (r in {0, 3, 6}) at 100 um, i.e. q or q + 1 mm, never a tie.
  auto sent_counts = [](int f, int width, int height) {
    std::vector<uint16_t> c(static_cast<size_t>(width) * height);
    for (size_t i = 0; i < c.size(); ++i) {
      c[i] = static_cast<uint16_t>(((i * 13 + static_cast<size_t>(f) * 101) % 4000) * 10 +
                                   (i % 3) * 3);
    }
    return c;
  };
  auto expected_mm = [](const std::vector<uint16_t>& c) {
    std::vector<uint16_t> mm(c.size());
    for (size_t i = 0; i < c.size(); ++i)
      mm[i] = static_cast<uint16_t>(c[i] / 10 + (c[i] % 10 >= 5));
    return mm;
  };
  const int kFrames = 45;
  const int64_t sender_t0_us = 5'000'000;
  // Frames go out on an absolute 30 Hz schedule, so the sender's clock runs at the host's rate
  // (as a camera's does, up to drift) while starting 5 s after an arbitrary epoch.
  const int64_t host_t0_us = clock_.NowUtime();
  for (int f = 0; f < kFrames; ++f) {
    const bool wrong_size = f == 20;
    depth_image_t m;
    m.utime = sender_t0_us + int64_t{33333} * f;
    m.seq = f;
    m.sensor_name = "xtion";
    m.width = wrong_size ? 640 : 320;
    m.height = wrong_size ? 480 : 240;
    m.depth_scale_m = 1e-4;
    m.encoding = depth_image_t::ENCODING_ZLIB_U16;
    EncodeDepthPixels(sent_counts(f, m.width, m.height), depth_image_t::ENCODING_ZLIB_U16, 1, &m);
    sender.publish(channel, &m);
    const int64_t until = host_t0_us + int64_t{33333} * (f + 1);
    while (clock_.NowUtime() < until) {
      node.Poll(5);
      while (lcm_.handleTimeout(0) > 0) {
      }
    }
  }
  Run(node, 0.3);
  const auto& images = capture_.images;
  EXPECT_GE(images.size(), static_cast<size_t>(kFrames - 1 - 10));  // a few lost under load
  EXPECT_LE(images.size(), static_cast<size_t>(kFrames - 1));       // frame 20 dropped
  int previous = -1;
  for (size_t k = 0; k < images.size(); ++k) {
    const auto& m = images[k];
    ASSERT_EQ(m.width, 320);
    ASSERT_DOUBLE_EQ(m.depth_scale_m, 1e-3);
    const auto counts = Pixels(m);
    int which = -1;
    for (int f = previous + 1; f < kFrames && which < 0; ++f) {
      if (f != 20 && counts == expected_mm(sent_counts(f, 320, 240))) which = f;
    }
    ASSERT_GE(which, 0) << "image " << k << " matches no later sent frame";
    if (k > 0) {
      // Host stamps keep the sender's spacing (offset applied, not arrival jitter).
      const int64_t sent_dt = int64_t{33333} * (which - previous);
      EXPECT_NEAR(static_cast<double>(m.utime - images[k - 1].utime), static_cast<double>(sent_dt),
                  15000.0);
    }
    EXPECT_LT(std::llabs(capture_.receive_utime[k] - m.utime), kHandledToleranceUs) << k;
    previous = which;
  }
}

}  // namespace
}  // namespace kestrel
