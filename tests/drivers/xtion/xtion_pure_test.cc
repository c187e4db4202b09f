// Unit tests of kestrel-xtion's pure pieces: intrinsics, device selection, clock offset filter,
// depth payload encoding, configuration.
#include "drivers/xtion/xtion_pure.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "common/config.h"
#include "drivers/xtion/xtion_config.h"
#include "drivers/xtion/xtion_node.h"
#include "lcmtypes/message_codecs.h"

namespace kestrel {
namespace {

constexpr double kDeg = M_PI / 180.0;

// The outer edges of the first and last pixel (u = -0.5 and u = w - 0.5) see exactly -hfov/2 and
// +hfov/2; the same for rows and vfov.
TEST(XtionIntrinsics, ImageEdgesSpanTheFieldOfView) {
  for (const auto& [w, h] : {std::pair{320, 240}, std::pair{640, 480}, std::pair{7, 3}}) {
    const double hfov = 58.0 * kDeg;
    const double vfov = 45.0 * kDeg;
    const PinholeIntrinsics k = IntrinsicsFromFov(w, h, hfov, vfov);
    EXPECT_NEAR(std::atan((-0.5 - k.cx_px) / k.fx_px), -hfov / 2, 1e-12);
    EXPECT_NEAR(std::atan((w - 0.5 - k.cx_px) / k.fx_px), hfov / 2, 1e-12);
    EXPECT_NEAR(std::atan((-0.5 - k.cy_px) / k.fy_px), -vfov / 2, 1e-12);
    EXPECT_NEAR(std::atan((h - 0.5 - k.cy_px) / k.fy_px), vfov / 2, 1e-12);
  }
}

// Known numbers (computed separately): 320 / tan(29 deg) = 577.2953, 240 / tan(22.5 deg) =
// 579.4113.
TEST(XtionIntrinsics, VgaFocalLengthMatchesHandComputation) {
  const PinholeIntrinsics k = IntrinsicsFromFov(640, 480, 58.0 * kDeg, 45.0 * kDeg);
  EXPECT_NEAR(k.fx_px, 577.2953, 1e-3);
  EXPECT_NEAR(k.fy_px, 579.4113, 1e-3);
  EXPECT_DOUBLE_EQ(k.cx_px, 319.5);
  EXPECT_DOUBLE_EQ(k.cy_px, 239.5);
}

TEST(XtionIntrinsics, RejectsBadInput) {
  EXPECT_THROW((void)IntrinsicsFromFov(0, 480, 1.0, 0.8), std::invalid_argument);
  EXPECT_THROW((void)IntrinsicsFromFov(640, 480, 0.0, 0.8), std::invalid_argument);
  EXPECT_THROW((void)IntrinsicsFromFov(640, 480, 1.0, M_PI), std::invalid_argument);
}

TEST(XtionDeviceSelector, ParsesTheFourForms) {
  EXPECT_EQ(ParseDeviceSelector("").kind, DeviceSelector::Kind::kFirst);
  const DeviceSelector index = ParseDeviceSelector("#3");
  EXPECT_EQ(index.kind, DeviceSelector::Kind::kIndex);
  EXPECT_EQ(index.index, 3);
  const DeviceSelector bus = ParseDeviceSelector("2@17");
  EXPECT_EQ(bus.kind, DeviceSelector::Kind::kBusAddress);
  EXPECT_EQ(bus.bus, 2);
  EXPECT_EQ(bus.address, 17);
  const DeviceSelector serial = ParseDeviceSelector("1208030088");
  EXPECT_EQ(serial.kind, DeviceSelector::Kind::kSerial);
  EXPECT_EQ(serial.serial, "1208030088");
  for (const char* bad : {"#", "#0", "#x", "#-1", "1@", "@2", "a@b", "1@2@3"}) {
    EXPECT_THROW((void)ParseDeviceSelector(bad), std::invalid_argument) << bad;
  }
}

TEST(XtionDeviceSelector, UriBusAddress) {
  EXPECT_EQ(UsbBusAddressOfUri("1d27/0600@1/10"), std::make_pair(1, 10));
  EXPECT_EQ(UsbBusAddressOfUri("1d27/0601@3/007"), std::make_pair(3, 7));
  EXPECT_FALSE(UsbBusAddressOfUri("/tmp/recording.oni").has_value());
  EXPECT_FALSE(UsbBusAddressOfUri("1d27/0600@1").has_value());
}

// Each selector picks the device a human reading the list would pick, or none.
TEST(XtionDeviceSelector, SelectsLikeOpenni2Camera) {
  const std::vector<DeviceListing> devices = {
      {"1d27/0600@1/10", "A100"}, {"1d27/0601@2/5", "B200"}, {"1d27/0600@2/50", "C300"}};
  auto pick = [&](const std::string& id) { return SelectDevice(ParseDeviceSelector(id), devices); };
  EXPECT_EQ(pick(""), 0u);
  EXPECT_EQ(pick("#1"), 0u);
  EXPECT_EQ(pick("#3"), 2u);
  EXPECT_FALSE(pick("#4").has_value());
  EXPECT_EQ(pick("2@5"), 1u);
  EXPECT_EQ(pick("2@50"), 2u);  // not confused with 2@5 by prefix
  EXPECT_FALSE(pick("1@5").has_value());
  EXPECT_EQ(pick("C300"), 2u);
  EXPECT_FALSE(pick("C30").has_value());
  EXPECT_FALSE(SelectDevice(ParseDeviceSelector(""), {}).has_value());
}

// The filter's offset is the median of the last `window` samples: checked against sorting.
TEST(XtionClockOffsetFilter, IsTheMedianOfTheWindow) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int64_t> latency(0, 20000);
  const int window = 9;
  ClockOffsetFilter filter(window, 1000000);
  std::vector<int64_t> all;
  const int64_t true_offset = 1'700'000'000'000'000;
  for (int i = 0; i < 100; ++i) {
    const int64_t device_us = 1'000'000 + 33'333 * i;
    const int64_t sample = true_offset + latency(rng);
    filter.AddSample(device_us, device_us + sample);
    all.push_back(sample);
    std::vector<int64_t> last(all.end() - std::min<int>(window, static_cast<int>(all.size())),
                              all.end());
    std::sort(last.begin(), last.end());
    ASSERT_EQ(filter.offset_us(), last[(last.size() - 1) / 2]) << i;
    EXPECT_EQ(filter.ToHostUtime(device_us), device_us + last[(last.size() - 1) / 2]);
  }
}

// One late frame (a 500 ms hiccup) does not move the median.
TEST(XtionClockOffsetFilter, IgnoresAnOutlier) {
  ClockOffsetFilter filter(5, 1000000);
  for (int i = 0; i < 5; ++i) filter.AddSample(i * 1000, i * 1000 + 100 + i);
  filter.AddSample(5000, 5000 + 500000);
  EXPECT_EQ(filter.offset_us(), 103);
}

// A jump larger than reset_us (device clock restarted) restarts the window at once.
TEST(XtionClockOffsetFilter, RestartsOnAClockJump) {
  ClockOffsetFilter filter(31, 500000);
  for (int i = 0; i < 31; ++i) filter.AddSample(1000000 + i, 5000000 + i);
  EXPECT_EQ(filter.offset_us(), 4000000);
  EXPECT_TRUE(filter.AddSample(10, 9000010));
  EXPECT_EQ(filter.size(), 1);
  EXPECT_EQ(filter.offset_us(), 9000000);
  EXPECT_EQ(filter.resets(), 1);
  EXPECT_THROW(ClockOffsetFilter(0, 1), std::invalid_argument);
}

// MakeDepthImage fills every field from the frame, intrinsics and config.
TEST(XtionDepthImage, CarriesScaleIntrinsicsAndPayload) {
  DepthFrame frame;
  frame.width = 3;
  frame.height = 2;
  frame.hundred_um = true;
  frame.counts = {1, 2, 3, 4, 5, 60000};
  XtionConfig config;
  config.encoding = "raw";
  const PinholeIntrinsics k{10.0, 11.0, 1.0, 0.5};
  const depth_image_t msg = MakeDepthImage(frame, k, 123456, 7, 0x5eed, config);
  EXPECT_EQ(msg.utime, 123456);
  EXPECT_EQ(msg.seq, 7);
  EXPECT_EQ(msg.epoch, 0x5eed);
  EXPECT_EQ(msg.sensor_name, "xtion");
  EXPECT_EQ(msg.width, 3);
  EXPECT_EQ(msg.height, 2);
  EXPECT_DOUBLE_EQ(msg.depth_scale_m, 1e-4);
  EXPECT_DOUBLE_EQ(msg.fy_px, 11.0);
  EXPECT_EQ(msg.encoding, depth_image_t::ENCODING_RAW_U16);
  EXPECT_EQ(msg.data_size, 12);
  std::vector<uint16_t> counts;
  EXPECT_EQ(DecodeDepthPixels(msg, &counts), "");
  EXPECT_EQ(counts, frame.counts);
  frame.hundred_um = false;
  config.encoding = "zlib";
  const depth_image_t z = MakeDepthImage(frame, k, 1, 1, 1, config);
  EXPECT_DOUBLE_EQ(z.depth_scale_m, 1e-3);
  EXPECT_EQ(z.encoding, depth_image_t::ENCODING_ZLIB_U16);
  EXPECT_EQ(static_cast<size_t>(z.data_size), z.data.size());
  EXPECT_EQ(DecodeDepthPixels(z, &counts), "");
  EXPECT_EQ(counts, frame.counts);
}

TEST(XtionConfig, ShippedFilesLoadWithoutUnknownKeys) {
  for (const char* name : {"xtion.yaml", "xtion_sim.yaml"}) {
    const ConfigNode root =
        ConfigNode::LoadFile(std::string(KESTREL_SOURCE_DIR) + "/config/drivers/" + name);
    const XtionConfig c = LoadXtionConfig(root);
    EXPECT_NO_THROW(root.CheckNoUnknownKeys()) << name;
    EXPECT_EQ(c.channel, "DEPTH_XTION");
  }
}

TEST(XtionConfig, RejectsUnsupportedModesAndValues) {
  auto load = [](const std::string& text) {
    return LoadXtionConfig(ConfigNode::FromString(text, "test.yaml"));
  };
  EXPECT_NO_THROW((void)load("{width: 320, height: 240, fps: 60}"));
  EXPECT_THROW((void)load("{width: 640, height: 480, fps: 60}"), ConfigError);
  EXPECT_THROW((void)load("{width: 320, height: 480}"), ConfigError);
  EXPECT_THROW((void)load("{pixel_format: depth_1_um}"), ConfigError);
  EXPECT_THROW((void)load("{encoding: jpeg}"), ConfigError);
  EXPECT_THROW((void)load("{device: '#0'}"), ConfigError);
  EXPECT_THROW((void)load("{range_min_m: 4.0, range_max_m: 3.0}"), ConfigError);
  try {
    (void)load("{width: 640, height: 480, fps: 60}");
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("width"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace kestrel
