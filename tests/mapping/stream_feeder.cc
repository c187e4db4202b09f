// stream_feeder: publishes the synthetic mapper stream (synthetic_stream.h) over LCM in time
// order, paced at SPEED x real time, for multi-process mapper tests.
//   stream_feeder URL SECONDS SPEED
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <thread>

#include <lcm/lcm-cpp.hpp>

#include "mapping/mapper_config.h"
#include "tests/mapping/synthetic_stream.h"

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: stream_feeder URL SECONDS SPEED\n");
    return 2;
  }
  lcm::LCM lcm(argv[1]);
  if (!lcm.good()) return 1;
  const double seconds = std::atof(argv[2]);
  const double speed = std::atof(argv[3]);
  const auto sensors = kestrel::DefaultMapperSensors();
  const auto events = kestrel::testing::MakeStream(seconds, sensors[0].X_BS, sensors[1].X_BS);
  const auto start = std::chrono::steady_clock::now();
  for (const auto& e : events) {
    const double t = static_cast<double>(e.utime - events.front().utime) * 1e-6 / speed;
    std::this_thread::sleep_until(start + std::chrono::microseconds(static_cast<int64_t>(t * 1e6)));
    using Kind = kestrel::testing::StreamEvent::Kind;
    if (e.kind == Kind::kPose) lcm.publish("POSE_VICON", &e.pose);
    if (e.kind == Kind::kDepth) lcm.publish("DEPTH_XTION", &e.depth);
    if (e.kind == Kind::kScan) lcm.publish("SCAN_HOKUYO", &e.scan);
  }
  return 0;
}
