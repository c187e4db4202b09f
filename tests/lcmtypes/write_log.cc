// write_log: writes a small LCM log with lcm::LogFile (no network), for the Python types test:
// sample 0 of every top-level Kestrel type on TEST_<type> (sample_messages.h), then a pose, a
// heartbeat with a nested named value and a map status with known values. Prints the expected
// decoding, one "CHANNEL field=value" line per check, on stdout.
//   write_log LOG
#include <cstdio>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "tests/lcmtypes/sample_messages.h"

namespace {

struct Writer {
  lcm::LogFile* log;
  int64_t* utime;

  template <typename T>
  void Write(const std::string& channel, const T& msg) {
    const std::vector<uint8_t> bytes = kestrel::testing::Encode(msg);
    lcm::LogEvent event;
    event.eventnum = 0;
    event.timestamp = *utime;
    event.channel = channel;
    event.datalen = static_cast<int32_t>(bytes.size());
    event.data = const_cast<uint8_t*>(bytes.data());
    log->writeEvent(&event);
    *utime += 10000;
  }

  template <typename T>
  void Visit() {
    const T msg = kestrel::testing::MakeSample<T>(0);
    const std::string channel = std::string("TEST_") + T::getTypeName();
    Write(channel, msg);
    std::printf("%s utime=%lld\n", channel.c_str(), static_cast<long long>(msg.utime));
  }
};

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: write_log LOG\n");
    return 2;
  }
  lcm::LogFile log(argv[1], "w");
  if (!log.good()) return 1;
  int64_t utime = 1000000;
  Writer writer{&log, &utime};
  kestrel::testing::ForEachMessageType(writer);

  kestrel::pose_t pose{};
  pose.utime = 1234567;
  pose.seq = 42;
  pose.epoch = 4611686018427387904;  // 2^62: the Python type reads the full 64 bits
  pose.frame_id = "world";
  pose.child_frame_id = "kestrel";
  pose.valid = true;
  pose.position_m[0] = 1.5;
  pose.position_m[1] = -2.25;
  pose.position_m[2] = 0.75;
  pose.orientation_wxyz[0] = 1.0;
  writer.Write("POSE_VICON", pose);
  std::printf(
      "POSE_VICON seq=42\nPOSE_VICON epoch=4611686018427387904\n"
      "POSE_VICON child_frame_id='kestrel'\n"
      "POSE_VICON position_m=[1.5, -2.25, 0.75]\nPOSE_VICON valid=True\n");

  kestrel::heartbeat_t heartbeat{};
  heartbeat.utime = 2000000;
  heartbeat.process = "kestrel-mapper";
  heartbeat.pid = 4242;
  heartbeat.state = kestrel::heartbeat_t::STATE_DEGRADED;
  heartbeat.uptime_s = 12.5;
  kestrel::named_value_t value;
  value.name = "rays_per_s";
  value.value = 123.25;
  heartbeat.values.push_back(value);
  heartbeat.num_values = 1;
  writer.Write("HEARTBEAT_MAPPER", heartbeat);
  std::printf(
      "HEARTBEAT_MAPPER process='kestrel-mapper'\nHEARTBEAT_MAPPER pid=4242\n"
      "HEARTBEAT_MAPPER state=2\nHEARTBEAT_MAPPER uptime_s=12.5\n"
      "HEARTBEAT_MAPPER values=[{name='rays_per_s' value=123.25}]\n");

  kestrel::map_status_t status{};
  status.utime = 3000000;
  status.map_seq = 77;
  status.map_entropy_nats = 93147.125;
  status.applied_every_message = true;
  writer.Write("MAP_STATUS", status);
  std::printf(
      "MAP_STATUS map_seq=77\nMAP_STATUS map_entropy_nats=93147.125\n"
      "MAP_STATUS applied_every_message=True\n");
  return 0;
}
