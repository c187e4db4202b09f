// Unit tests of the OpenNI2 plugin's OpenNI-free pieces: the synthetic wall against a geometric
// oracle, the raw frame folder, and the environment configuration.
#include <cstdio>
#include <fstream>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "drivers/xtion/openni_plugin/lcm_frame_source.h"
#include "drivers/xtion/openni_plugin/plugin_config.h"
#include "drivers/xtion/openni_plugin/synthetic_scene.h"
#include "tests/drivers/xtion/wall_oracle.h"

namespace kestrel::oni_plugin {
namespace {

// Every pixel of the rendered wall equals the ray-plane intersection, for both pixel formats,
// several frames and both image sizes.
TEST(XtionPluginScene, WallMatchesRayPlaneOracle) {
  WallScene scene;
  scene.distance_m = 1.7;
  scene.tilt_rad = 0.4;
  scene.pitch_rad = -0.2;
  for (const auto& [w, h] : {std::pair{320, 240}, std::pair{640, 480}}) {
    for (const double scale : {1e-3, 1e-4}) {
      for (const int64_t k : {0, 1, 49, 50, 77}) {
        std::vector<uint16_t> got;
        RenderWall(scene, w, h, scale, k, &got);
        const test::WallOracle oracle{1.7 + 0.001 * static_cast<double>(k % 50), 0.4, -0.2, 8};
        std::vector<bool> ambiguous;
        const auto want = oracle.Render(w, h, scale, &ambiguous);
        EXPECT_EQ(test::CountMismatches(got, want, ambiguous), 0)
            << w << "x" << h << " scale " << scale << " frame " << k;
        EXPECT_EQ(got[static_cast<size_t>(h / 2) * w + 3], 0);  // dead band
      }
    }
  }
}

// A wall seen edge-on beyond the field of view leaves no return, and far walls are cut at 10 m
// (and at 65535 counts = 6.5535 m in 100 um).
TEST(XtionPluginScene, FarAndGrazingWallsGiveNoReturn) {
  WallScene scene;
  scene.distance_m = 8.0;
  scene.tilt_rad = 0.0;
  scene.pitch_rad = 0.0;
  scene.dead_columns = 0;
  std::vector<uint16_t> img;
  RenderWall(scene, 320, 240, 1e-3, 0, &img);
  EXPECT_EQ(img[120 * 320 + 160], 8000);
  RenderWall(scene, 320, 240, 1e-4, 0, &img);
  EXPECT_EQ(img[120 * 320 + 160], 0);
  scene.distance_m = 0.5;
  scene.tilt_rad = 1.4;  // normal almost along x: the left half of the image misses the wall
  RenderWall(scene, 320, 240, 1e-3, 0, &img);
  EXPECT_EQ(img[120 * 320 + 0], 0);
  EXPECT_THROW(RenderWall(scene, 0, 240, 1e-3, 0, &img), std::invalid_argument);
}

TEST(XtionPluginFiles, ServesRawFramesInNameOrderCyclically) {
  char dir_template[] = "/tmp/kestrel-xtion-files.XXXXXX";
  const std::string dir = mkdtemp(dir_template);
  auto write = [&](const std::string& name, const std::vector<uint8_t>& bytes) {
    std::ofstream(dir + "/" + name, std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes.data()),
               static_cast<std::streamsize>(bytes.size()));
  };
  write("b.raw", {0x02, 0x00, 0x03, 0x00});
  write("a.raw", {0x34, 0x12, 0xff, 0xff});
  write("notes.txt", {0x01});
  const RawFrameFolder folder(dir);
  EXPECT_EQ(folder.size(), 2);
  std::vector<uint16_t> out;
  ASSERT_TRUE(folder.Fill(2, 1, 0, &out));
  EXPECT_EQ(out, (std::vector<uint16_t>{0x1234, 0xffff}));
  ASSERT_TRUE(folder.Fill(1, 2, 3, &out));
  EXPECT_EQ(out, (std::vector<uint16_t>{2, 3}));
  EXPECT_FALSE(folder.Fill(3, 1, 0, &out));
  EXPECT_EQ(out, (std::vector<uint16_t>{2, 3}));  // untouched
  for (const char* name : {"a.raw", "b.raw", "notes.txt"}) std::remove((dir + "/" + name).c_str());
  EXPECT_THROW(RawFrameFolder{dir}, std::runtime_error);
  std::remove(dir.c_str());
}

TEST(XtionPluginConfig, ReadsAndChecksTheEnvironment) {
  std::map<std::string, std::string> env;
  auto read = [&] {
    return ReadPluginConfig([&](const char* name) -> const char* {
      const auto it = env.find(name);
      return it == env.end() ? nullptr : it->second.c_str();
    });
  };
  PluginConfig c = read();
  EXPECT_EQ(c.source, "synthetic");
  EXPECT_EQ(c.num_devices, 1);
  EXPECT_FALSE(c.clock_offset_given);
  env = {{"KESTREL_ONI_SOURCE", "files:/data/frames"},
         {"KESTREL_ONI_DEVICES", "3"},
         {"KESTREL_ONI_WALL_M", "1.25"},
         {"KESTREL_ONI_WALL_TILT_DEG", "-10"},
         {"KESTREL_ONI_CLOCK_OFFSET_US", "-1700000000000000"},
         {"KESTREL_ONI_FAULT_LOSS_AFTER_FRAMES", "45"},
         {"KESTREL_ONI_FAULT_LOSS_MS", "700"}};
  c = read();
  EXPECT_EQ(c.source, "files");
  EXPECT_EQ(c.files_dir, "/data/frames");
  EXPECT_EQ(c.num_devices, 3);
  EXPECT_DOUBLE_EQ(c.wall.distance_m, 1.25);
  EXPECT_NEAR(c.wall.tilt_rad, -10.0 * M_PI / 180.0, 1e-15);
  EXPECT_TRUE(c.clock_offset_given);
  EXPECT_EQ(c.clock_offset_us, -1700000000000000);
  EXPECT_EQ(c.loss_after_frames, 45);
  EXPECT_EQ(c.loss_duration_ms, 700);
  for (const auto& [name, value] :
       std::vector<std::pair<std::string, std::string>>{{"KESTREL_ONI_SOURCE", "lcm"},
                                                        {"KESTREL_ONI_DEVICES", "0"},
                                                        {"KESTREL_ONI_DEVICES", "2x"},
                                                        {"KESTREL_ONI_WALL_M", "nan"},
                                                        {"KESTREL_ONI_FAULT_LOSS_MS", "-1"}}) {
    env = {{name, value}};
    EXPECT_THROW((void)read(), std::invalid_argument) << name << "=" << value;
  }
  env = {{"KESTREL_ONI_FAULT_SKIP_EVERY", "1"}};
  EXPECT_THROW((void)read(), std::invalid_argument);
  env = {{"KESTREL_ONI_FAULT_SKIP_EVERY", "4"}, {"KESTREL_ONI_MIRROR_DEFAULT", "1"}};
  c = read();
  EXPECT_EQ(c.skip_every_frames, 4);
  EXPECT_TRUE(c.mirror_default);
  EXPECT_EQ(DeviceUri(2), "1d27/0600@1/12");
  EXPECT_EQ(DeviceSerial(1), "KXT0000001");
}

// 100 um counts to 1 mm and back: integer arithmetic as the oracle; out of range becomes 0.
TEST(XtionPluginLcm, RescalesCountsBetweenPixelFormats) {
  std::vector<uint16_t> hundred_um;
  for (uint32_t c = 0; c <= 65535; c += 7) hundred_um.push_back(static_cast<uint16_t>(c));
  const auto mm = RescaleCounts(hundred_um, 1e-4, 1e-3);
  for (size_t i = 0; i < hundred_um.size(); ++i) {
    const uint32_t c = hundred_um[i];
    const uint32_t rest = c % 10;
    if (rest == 5) continue;  // a tie: either neighbour is right
    EXPECT_EQ(mm[i], c / 10 + (rest > 5 ? 1 : 0)) << c;
  }
  const auto back = RescaleCounts({0, 1, 6553, 6554, 9000}, 1e-3, 1e-4);
  EXPECT_EQ(back, (std::vector<uint16_t>{0, 10, 65530, 0, 0}));
}

}  // namespace
}  // namespace kestrel::oni_plugin
