// Test helper for vicon_processes_test.sh: listens on an LCM URL for SECONDS and prints what
// kestrel-vicon published: "valid N invalid M last_valid B heartbeats H last_state S
// max_circle_error_m E" (the circle: the emitter's synthetic defaults, centre (0, 0, 1), r = 1).
// Usage: vicon_lcm_listener URL SECONDS
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "common/lcm_decode.h"
#include "kestrel/heartbeat_t.hpp"
#include "kestrel/pose_t.hpp"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: vicon_lcm_listener URL SECONDS\n");
    return 2;
  }
  lcm::LCM lcm(argv[1]);
  if (!lcm.good()) return 1;
  long valid = 0, invalid = 0, heartbeats = 0, malformed = 0;
  int last_state = -1;
  bool last_valid = false;
  double max_error_m = 0.0;
  kestrel::GuardedSubscriptions subs(lcm);
  subs.Add<kestrel::pose_t>(
      "POSE_VICON",
      [&](const std::string&, const kestrel::pose_t& p) {
        last_valid = p.valid;
        if (!p.valid) {
          ++invalid;
          return;
        }
        ++valid;
        const double r = std::hypot(p.position_m[0], p.position_m[1]);
        max_error_m = std::max({max_error_m, std::abs(r - 1.0), std::abs(p.position_m[2] - 1.0)});
      },
      [&](const std::string&, const std::string&) { ++malformed; });
  subs.Add<kestrel::heartbeat_t>(
      "HEARTBEAT_VICON",
      [&](const std::string&, const kestrel::heartbeat_t& h) {
        ++heartbeats;
        last_state = h.state;
      },
      [&](const std::string&, const std::string&) { ++malformed; });
  std::printf("ready\n");
  std::fflush(stdout);
  const auto end =
      std::chrono::steady_clock::now() + std::chrono::duration<double>(std::atof(argv[2]));
  while (std::chrono::steady_clock::now() < end) lcm.handleTimeout(50);
  std::printf(
      "valid %ld invalid %ld last_valid %d heartbeats %ld last_state %d malformed %ld "
      "max_circle_error_m %.3g\n",
      valid, invalid, last_valid ? 1 : 0, heartbeats, last_state, malformed, max_error_m);
  return 0;
}
