// The kestrel-xtion executable end to end: in a private network namespace (LCM multicast on
// loopback) and the OpenNI2 plugin's mount namespace, it streams the analytic wall on
// DEPTH_XTION with heartbeats, lists devices, rejects a bad configuration with exit code 2, and
// exits 0 on SIGTERM after a last heartbeat.
#include <sys/wait.h>
#include <unistd.h>
#include <csignal>
#include <cstdio>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/clock.h"
#include "common/lcm_decode.h"
#include "drivers/xtion/xtion_pure.h"
#include "kestrel/depth_image_t.hpp"
#include "kestrel/heartbeat_t.hpp"
#include "lcmtypes/message_codecs.h"
#include "tests/drivers/xtion/wall_oracle.h"

namespace kestrel {
namespace {

constexpr char kUrl[] = "udpm://239.255.76.67:7667?ttl=0";

// Runs `command` through the shell and returns its stdout and exit status.
std::pair<std::string, int> Shell(const std::string& command) {
  std::string out;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return {"", -1};
  char buffer[512];
  while (fgets(buffer, sizeof(buffer), pipe) != nullptr) out += buffer;
  const int status = pclose(pipe);
  return {out, WIFEXITED(status) ? WEXITSTATUS(status) : -1};
}

TEST(XtionProcess, ListsTheDevices) {
  const auto [out, code] = Shell(std::string(KESTREL_XTION_BIN) + " --list");
  EXPECT_EQ(code, 0);
  EXPECT_EQ(out, "1d27/0600@1/10 serial=KXT0000000\n1d27/0600@1/11 serial=KXT0000001\n");
}

TEST(XtionProcess, RejectsABadModeWithExitCodeTwo) {
  const auto [out, code] =
      Shell(std::string(KESTREL_XTION_BIN) + " --set fps=60 2>&1");  // VGA@60 does not exist
  EXPECT_EQ(code, 2);
  EXPECT_NE(out.find("fps"), std::string::npos) << out;
}

TEST(XtionProcess, StreamsOverUdpAndStopsCleanly) {
  lcm::LCM lcm(kUrl);
  ASSERT_TRUE(lcm.good());
  GuardedSubscriptions subs(lcm);
  std::vector<depth_image_t> images;
  std::vector<heartbeat_t> heartbeats;
  int64_t errors = 0;
  subs.Add<depth_image_t>(
      "DEPTH_XTION", [&](const std::string&, const depth_image_t& m) { images.push_back(m); },
      [&](const std::string&, const std::string&) { ++errors; });
  subs.Add<heartbeat_t>(
      "HEARTBEAT_XTION", [&](const std::string&, const heartbeat_t& m) { heartbeats.push_back(m); },
      [&](const std::string&, const std::string&) { ++errors; });
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    execl(KESTREL_XTION_BIN, KESTREL_XTION_BIN, "--config",
          KESTREL_SOURCE_DIR "/config/drivers/xtion_sim.yaml", "--lcm-url", kUrl,
          static_cast<char*>(nullptr));
    _exit(127);
  }
  WallClock clock;
  const int64_t end = clock.NowUtime() + 3'000'000;
  while (clock.NowUtime() < end) lcm.handleTimeout(50);
  ASSERT_EQ(kill(pid, SIGTERM), 0);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  for (int i = 0; i < 10; ++i) lcm.handleTimeout(20);  // the last heartbeat
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  EXPECT_EQ(errors, 0);
  EXPECT_GE(images.size(), 50u);  // 90 nominal minus start-up (OpenNI2 init, device open)
  EXPECT_LE(images.size(), 92u);
  const test::WallOracle wall0{2.0, 17.0 * M_PI / 180.0, 8.0 * M_PI / 180.0, 8};
  ASSERT_FALSE(images.empty());
  for (const auto& m : images) {
    ASSERT_EQ(m.width, 320);
    ASSERT_EQ(m.encoding, depth_image_t::ENCODING_ZLIB_U16);
  }
  // The last image is the plugin's default wall (2 m, 17 deg, 8 deg) at some frame of its cycle.
  std::vector<uint16_t> counts;
  ASSERT_EQ(DecodeDepthPixels(images.back(), &counts), "");
  bool matched = false;
  for (int k = 0; k < 50 && !matched; ++k) {
    test::WallOracle wall = wall0;
    wall.distance_m += 0.001 * k;
    std::vector<bool> ambiguous;
    matched =
        test::CountMismatches(counts, wall.Render(320, 240, 1e-3, &ambiguous), ambiguous) == 0;
  }
  EXPECT_TRUE(matched);
  ASSERT_GE(heartbeats.size(), 2u);
  EXPECT_EQ(heartbeats.back().process, "kestrel-xtion");
  EXPECT_EQ(heartbeats.back().state, heartbeat_t::STATE_OK);
  double published = -1.0;
  for (const auto& v : heartbeats.back().values) {
    if (v.name == "frames_published") published = v.value;
  }
  EXPECT_EQ(published,
            static_cast<double>(images.size()));  // the last heartbeat came after SIGTERM
}

}  // namespace
}  // namespace kestrel
