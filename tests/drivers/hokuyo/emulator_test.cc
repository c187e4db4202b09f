// The emulator spoken to through a real pty with the codec and a SerialPort: the SCIP 1.1
// switch, PP values (checked against docs/protocols.md §1.5's numbers, typed here), TM modes, the
// streaming rate, scan intervals, faults and hang-up.
#include "drivers/hokuyo/emulator.h"

#include <unistd.h>

#include <chrono>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "common/clock.h"
#include "drivers/hokuyo/scip_codec.h"
#include "drivers/serial/serial_port.h"

namespace kestrel {
namespace {

using Steady = std::chrono::steady_clock;

// A bare SCIP client: sends a line, collects parse events.
class Client {
 public:
  explicit Client(const std::string& path) : port_(path) {}
  void Send(const std::string& command) {
    ASSERT_EQ(port_.Write(scip::EncodeCommand(command), 1000).status, IoStatus::kOk);
  }
  // The next reply (or parse error) within timeout; nullopt on time-out.
  std::optional<scip::ParseEvent> Next(int timeout_ms = 2000) {
    const auto deadline = Steady::now() + std::chrono::milliseconds(timeout_ms);
    while (true) {
      if (auto event = parser_.Next()) return event;
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Steady::now()).count();
      if (left <= 0) return std::nullopt;
      std::string bytes;
      last_status_ = port_.Read(&bytes, 4096, static_cast<int>(left)).status;
      if (last_status_ == IoStatus::kDisconnected) return std::nullopt;
      parser_.Feed(bytes);
    }
  }
  // The next valid reply to `command` (skipping scans of a running stream).
  std::optional<scip::Reply> ReplyTo(const std::string& command, int timeout_ms = 2000) {
    const auto deadline = Steady::now() + std::chrono::milliseconds(timeout_ms);
    while (Steady::now() < deadline) {
      auto event = Next(timeout_ms);
      if (!event) return std::nullopt;
      if (event->reply && event->reply->command_text().substr(0, command.size()) == command) {
        return event->reply;
      }
    }
    return std::nullopt;
  }
  IoStatus last_status() const { return last_status_; }

 private:
  SerialPort port_;
  scip::ReplyParser parser_;
  IoStatus last_status_{IoStatus::kOk};
};

TEST(HokuyoEmulator, Urg04lxStartsInScip11AndSwitches) {
  HokuyoEmulator emulator({});
  Client client(emulator.device_path());
  client.Send("VV");
  auto reply = client.ReplyTo("VV");
  ASSERT_TRUE(reply.has_value());
  EXPECT_EQ(reply->status, "E");  // SCIP 1.1 does not know VV
  client.Send("SCIP2.0");
  reply = client.ReplyTo("SCIP2.0");
  ASSERT_TRUE(reply.has_value());
  EXPECT_EQ(reply->status, "0");
  client.Send("SCIP2.0");
  reply = client.ReplyTo("SCIP2.0");
  ASSERT_TRUE(reply.has_value());
  EXPECT_EQ(reply->status, "0E");  // already SCIP 2.0
  client.Send("VV");
  reply = client.ReplyTo("VV");
  ASSERT_TRUE(reply.has_value());
  EXPECT_EQ(reply->status, "00");
  EXPECT_EQ(scip::ParseParameters(*reply).at("PROT"), "SCIP 2.0");
}

// PP values as docs/protocols.md §1.5 lists them (typed here, not from the emulator's tables).
TEST(HokuyoEmulator, ServesProtocolParametersOfBothProfiles) {
  struct Expected {
    HokuyoModel model;
    std::map<std::string, std::string> values;
  };
  const Expected cases[] = {
      {Urg04lxModel(),
       {{"DMIN", "20"},
        {"DMAX", "5600"},
        {"ARES", "1024"},
        {"AMIN", "44"},
        {"AMAX", "725"},
        {"AFRT", "384"},
        {"SCAN", "600"}}},
      {Utm30lxModel(),
       {{"DMIN", "23"},
        {"DMAX", "60000"},
        {"ARES", "1440"},
        {"AMIN", "0"},
        {"AMAX", "1080"},
        {"AFRT", "540"},
        {"SCAN", "2400"}}},
  };
  for (const Expected& c : cases) {
    HokuyoEmulatorOptions options;
    options.model = c.model;
    HokuyoEmulator emulator(options);
    Client client(emulator.device_path());
    client.Send("SCIP2.0");
    ASSERT_TRUE(client.ReplyTo("SCIP2.0").has_value());
    client.Send("PP");
    const auto reply = client.ReplyTo("PP");
    ASSERT_TRUE(reply.has_value());
    const auto params = scip::ParseParameters(*reply);
    for (const auto& [key, value] : c.values) EXPECT_EQ(params.at(key), value) << key;
  }
}

TEST(HokuyoEmulator, TimeAdjustModeGatesTm1AndMeasurement) {
  HokuyoEmulatorOptions options;
  options.model = Utm30lxModel();
  options.clock_offset_ms = 123456;
  HokuyoEmulator emulator(options);
  Client client(emulator.device_path());
  client.Send("TM1");
  EXPECT_EQ(client.ReplyTo("TM1")->status, "04");
  client.Send("TM0");
  EXPECT_EQ(client.ReplyTo("TM0")->status, "00");
  client.Send("MD0000108001000");
  EXPECT_EQ(client.ReplyTo("MD")->status, "0L");
  const int64_t before = WallClock().NowUtime();
  client.Send("TM1");
  const auto reply = client.ReplyTo("TM1");
  const int64_t after = WallClock().NowUtime();
  ASSERT_TRUE(reply.has_value());
  const auto t = scip::DecodeTimestamp(*reply);
  ASSERT_TRUE(t.has_value());
  EXPECT_GE(*t, emulator.SensorTimeMs(before));
  EXPECT_LE(*t, emulator.SensorTimeMs(after));
  EXPECT_GE(*t, 123456u);
  client.Send("TM2");
  EXPECT_EQ(client.ReplyTo("TM2")->status, "00");
  client.Send("TM2");
  EXPECT_EQ(client.ReplyTo("TM2")->status, "03");
}

// Counts scans over 2 s: about 2 s / period (generous bounds; this is not a timing test).
TEST(HokuyoEmulator, StreamsAtTheScanRateWithInterval) {
  for (const int interval : {0, 1}) {
    HokuyoEmulatorOptions options;
    options.model = Utm30lxModel();  // 40 Hz
    HokuyoEmulator emulator(options);
    Client client(emulator.device_path());
    client.Send("MD0000108001" + std::to_string(interval) + "00");
    ASSERT_EQ(client.ReplyTo("MD")->status, "00");
    int scans = 0;
    const auto end = Steady::now() + std::chrono::seconds(2);
    while (Steady::now() < end) {
      const auto event = client.Next(500);
      ASSERT_TRUE(event && event->reply);
      const auto scan = scip::DecodeScan(*event->reply);
      ASSERT_TRUE(scan.has_value());
      EXPECT_EQ(scan->ranges_mm.size(), 1081u);
      ++scans;
    }
    const double expected = 2.0 * 40.0 / (interval + 1);
    EXPECT_GT(scans, 0.7 * expected) << "interval " << interval;
    EXPECT_LT(scans, 1.3 * expected) << "interval " << interval;
  }
}

TEST(HokuyoEmulator, FiniteStreamCountsDownAndStops) {
  HokuyoEmulatorOptions options;
  options.model = Utm30lxModel();
  HokuyoEmulator emulator(options);
  Client client(emulator.device_path());
  client.Send("ME0100020001003");
  ASSERT_EQ(client.ReplyTo("ME")->status, "00");
  for (int remaining = 2; remaining >= 0; --remaining) {
    const auto event = client.Next();
    ASSERT_TRUE(event && event->reply);
    const auto scan = scip::DecodeScan(*event->reply);
    ASSERT_TRUE(scan.has_value());
    EXPECT_EQ(scan->remaining_scans, remaining);
    EXPECT_EQ(scan->ranges_mm.size(), 101u);
    EXPECT_EQ(scan->intensities.size(), 101u);
  }
  EXPECT_FALSE(client.Next(300).has_value());
}

// The 24-bit clock wraps: an offset 100 ms before the wrap gives small stamps soon after.
TEST(HokuyoEmulator, SensorClockWraps) {
  HokuyoEmulatorOptions options;
  options.clock_offset_ms = scip::kTimestampModulus - 100;
  HokuyoEmulator emulator(options);
  const int64_t now = WallClock().NowUtime();
  EXPECT_GE(emulator.SensorTimeMs(now), scip::kTimestampModulus - 100);
  EXPECT_LT(emulator.SensorTimeMs(now + 200000), 200u);
}

TEST(HokuyoEmulator, InjectedFaultsBreakExactlyTheNextReply) {
  HokuyoEmulatorOptions options;
  options.model = Utm30lxModel();
  HokuyoEmulator emulator(options);
  Client client(emulator.device_path());
  emulator.CorruptNextSums(1);
  client.Send("VV");
  auto event = client.Next();
  ASSERT_TRUE(event.has_value());
  EXPECT_EQ(event->error, scip::ParseError::kDataSum);
  client.Send("VV");
  event = client.Next();
  ASSERT_TRUE(event && event->reply);
  emulator.InjectGarbage("\x13zz\x7f");
  client.Send("PP");
  event = client.Next();
  ASSERT_TRUE(event.has_value());
  EXPECT_FALSE(event->reply.has_value());
  client.Send("PP");
  event = client.Next();
  ASSERT_TRUE(event && event->reply);
  emulator.Stall(300);
  client.Send("II");
  EXPECT_FALSE(client.Next(200).has_value());
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  client.Send("II");
  event = client.Next();
  ASSERT_TRUE(event && event->reply);
  EXPECT_EQ(event->reply->command(), "II");
}

TEST(HokuyoEmulator, HangUpClosesTheTtyAndReplugsBehindTheLink) {
  char dir_template[] = "/tmp/kestrel_hokuyo_XXXXXX";
  ASSERT_NE(mkdtemp(dir_template), nullptr);
  HokuyoEmulatorOptions options;
  options.link_path = std::string(dir_template) + "/ttyHOKUYO";
  HokuyoEmulator emulator(options);
  {
    Client client(emulator.device_path());
    emulator.HangUp(300);
    EXPECT_FALSE(client.Next(1000).has_value());
    EXPECT_EQ(client.last_status(), IoStatus::kDisconnected);
  }
  EXPECT_NE(access(options.link_path.c_str(), F_OK), 0);  // unplugged: the link is gone
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  EXPECT_EQ(emulator.plug_count(), 2);
  Client client(emulator.device_path());
  client.Send("SCIP2.0");
  const auto reply = client.ReplyTo("SCIP2.0");
  ASSERT_TRUE(reply.has_value());
  EXPECT_EQ(reply->status, "0");  // power-up state again: SCIP 1.1
  unlink(options.link_path.c_str());
  rmdir(dir_template);
}

}  // namespace
}  // namespace kestrel
