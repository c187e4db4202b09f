// kestrel-motors' node (drivers/motors/motors_node.h) on a recording bus, a simulated clock and
// memq:// LCM; the socket bus against the ESC emulator.
#include "drivers/motors/motors_node.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <limits>
#include <thread>

#include "drivers/motors/esc_emulator.h"

namespace kestrel {
namespace {

// A bus that records every transfer and fails on demand: the node's bytes as the ESCs get them.
struct RecordingBus final : I2cBus {
  std::vector<std::vector<I2cMessage>>* transfers;
  bool* fail;
  RecordingBus(std::vector<std::vector<I2cMessage>>* t, bool* f) : transfers(t), fail(f) {}
  bool Transfer(std::vector<I2cMessage>* messages, std::string* error) override {
    transfers->push_back(*messages);
    if (*fail) {
      *error = "EIO (test)";
      return false;
    }
    for (I2cMessage& m : *messages) {
      if (m.read) m.data = {12, 255, 35};
    }
    return true;
  }
  [[nodiscard]] std::string name() const override { return "recording"; }
};

class MotorsNodeTest : public ::testing::Test {
 protected:
  MotorsNodeTest() : lcm_("memq://"), clock_(1000000) {
    map_.full_command_thrust_N = 25.0;
    map_.idle_command = 0.05;
    config_.status_hz = 0.0;
  }
  std::unique_ptr<MotorsNode> MakeNode() {
    return std::make_unique<MotorsNode>(lcm_, config_, map_, clock_, [this](const std::string&) {
      ++opens_;
      return std::make_unique<RecordingBus>(&transfers_, &fail_);
    });
  }
  void Command(bool armed, std::vector<double> thrust) {
    motor_command_t m{};
    m.utime = clock_.NowUtime();
    m.armed = armed;
    m.num_motors = static_cast<int32_t>(thrust.size());
    m.thrust_N = std::move(thrust);
    lcm_.publish("MOTOR_COMMAND", &m);
    while (lcm_.handleTimeout(0) > 0) {
    }
  }
  // The set points of the last transfer, decoded from its bytes.
  std::vector<int> LastSetPoints() const {
    std::vector<int> out;
    for (const I2cMessage& m : transfers_.back()) {
      out.push_back(*DecodeBlCtrlSetPoint(BlCtrlVersion::kV2, m.data));
    }
    return out;
  }
  lcm::LCM lcm_;
  SimClock clock_;
  EscMap map_;
  MotorsConfig config_;
  std::vector<std::vector<I2cMessage>> transfers_;
  bool fail_{false};
  int opens_{0};
};

TEST_F(MotorsNodeTest, WritesEachRotorAtItsAddressAndNeverSpinsBeforeAnArmedCommand) {
  auto node = MakeNode();
  node->Refresh();
  ASSERT_EQ(opens_, 1);
  ASSERT_EQ(transfers_.size(), 1u);
  ASSERT_EQ(transfers_[0].size(), 4u);
  for (size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(transfers_[0][i].address, 0x29 + i);
    EXPECT_FALSE(transfers_[0][i].read);
  }
  EXPECT_EQ(LastSetPoints(), (std::vector<int>{0, 0, 0, 0}));
  Command(false, {10, 10, 10, 10});
  node->Refresh();
  EXPECT_EQ(LastSetPoints(), (std::vector<int>{0, 0, 0, 0})) << "not armed: stopped";
  Command(true, {0.0, 6.25, 10.0, 25.0});
  // Written at once, then again at every refresh: u = sqrt(T / 25).
  const std::vector<int> expected = {103, 1024, 1295, 2047};  // idle ceil(0.05 * 2047) = 103
  EXPECT_EQ(LastSetPoints(), expected);
  node->Refresh();
  EXPECT_EQ(LastSetPoints(), expected);
  EXPECT_EQ(node->set_points(), expected);
}

TEST_F(MotorsNodeTest, MalformedWrongCountAndNaNAreDroppedAndCounted) {
  auto node = MakeNode();
  node->Refresh();
  Command(true, {8, 8, 8, 8});
  const std::vector<int> before = node->set_points();
  const size_t writes = transfers_.size();
  Command(true, {8, 8, 8});
  Command(true, {8, std::numeric_limits<double>::quiet_NaN(), 8, 8});
  const uint8_t garbage[5] = {1, 2, 3, 4, 5};
  lcm_.publish("MOTOR_COMMAND", garbage, sizeof(garbage));
  while (lcm_.handleTimeout(0) > 0) {
  }
  EXPECT_EQ(transfers_.size(), writes) << "nothing written for a bad command";
  EXPECT_EQ(node->set_points(), before);
  EXPECT_EQ(node->drops().count("wrong_motor_count"), 1);
  EXPECT_EQ(node->drops().count("non_finite"), 1);
  EXPECT_EQ(node->drops().count("malformed"), 1);
}

TEST_F(MotorsNodeTest, WatchdogStopsTheMotorsAfterTheTimeoutUntilAnArmedCommand) {
  config_.command_timeout_s = 0.5;
  auto node = MakeNode();
  node->Refresh();
  Command(true, {10, 10, 10, 10});
  clock_.AdvanceUtime(499000);
  node->Refresh();
  EXPECT_FALSE(node->watchdog_tripped());
  EXPECT_GT(LastSetPoints()[0], 0) << "held within the timeout";
  clock_.AdvanceUtime(2000);
  node->Refresh();
  EXPECT_TRUE(node->watchdog_tripped());
  EXPECT_EQ(node->watchdog_trips(), 1);
  EXPECT_EQ(LastSetPoints(), (std::vector<int>{0, 0, 0, 0}));
  clock_.AdvanceUtime(10000);
  Command(false, {10, 10, 10, 10});
  node->Refresh();
  EXPECT_TRUE(node->watchdog_tripped()) << "an unarmed command does not restart the motors";
  EXPECT_EQ(LastSetPoints(), (std::vector<int>{0, 0, 0, 0}));
  Command(true, {10, 10, 10, 10});
  EXPECT_FALSE(node->watchdog_tripped());
  EXPECT_GT(LastSetPoints()[0], 0);
}

TEST_F(MotorsNodeTest, ABusErrorStopsTheMotorsAndTheyWaitForAnArmedCommandAfterTheReopen) {
  auto node = MakeNode();
  node->Refresh();
  Command(true, {10, 10, 10, 10});
  ASSERT_GT(node->set_points()[0], 0);
  fail_ = true;
  const size_t before = transfers_.size();
  node->Refresh();
  EXPECT_EQ(node->bus_errors(), 1);
  EXPECT_FALSE(node->bus_open());
  ASSERT_EQ(transfers_.size(), before + 2) << "the failed write, then zeros";
  EXPECT_EQ(LastSetPoints(), (std::vector<int>{0, 0, 0, 0}));
  fail_ = false;
  node->Refresh();
  EXPECT_EQ(opens_, 1) << "reopened only after the back-off";
  clock_.AdvanceUtime(SecondsToUtime(config_.reopen_backoff_min_s) + 1);
  Command(true, {10, 10, 10, 10});  // the command stream goes on meanwhile
  node->Refresh();
  EXPECT_EQ(opens_, 2);
  EXPECT_EQ(LastSetPoints(), (std::vector<int>{0, 0, 0, 0}))
      << "after a reopen, zeros until the controller's next armed command";
  Command(true, {10, 10, 10, 10});
  EXPECT_GT(LastSetPoints()[0], 0);
}

// The socket bus to the emulator: the set points arrive exactly, the status comes back, an
// address with no ESC is a NACK, and the emulated ESCs stop on their own time-out.
TEST(SocketI2cBus, CarriesTheBytesToTheEmulatedEscsAndBack) {
  const std::string path = "/tmp/kestrel-esc-test-" + std::to_string(::getpid()) + ".sock";
  EscMap map;
  EscEmulator escs(BlCtrlVersion::kV2, {0x29, 0x2a, 0x2b, 0x2c}, map, 0.5);
  std::atomic<int64_t> now{0};
  I2cSocketServer server(path, [&](I2cMessage& m) { return escs.Handle(m, now.load()); });
  std::atomic<bool> stop{false};
  std::thread devices([&] {
    while (!stop) server.Poll(5);
  });
  {
    SocketI2cBus bus(path, 1000);
    std::vector<I2cMessage> write;
    const std::vector<int> set_points = {0, 1, 1234, 2047};
    for (size_t i = 0; i < 4; ++i) {
      write.push_back({static_cast<uint8_t>(0x29 + i), false,
                       EncodeBlCtrlSetPoint(BlCtrlVersion::kV2, set_points[i])});
    }
    std::string error;
    ASSERT_TRUE(bus.Transfer(&write, &error)) << error;
    EXPECT_EQ(escs.set_points(), set_points);
    EXPECT_TRUE(escs.TakeCompleteRefresh());
    EXPECT_FALSE(escs.TakeCompleteRefresh()) << "once per whole refresh";
    EXPECT_DOUBLE_EQ(escs.thrust_N()[3], map.full_command_thrust_N);
    std::vector<I2cMessage> read = {{0x2c, true, std::vector<uint8_t>(3, 0)}};
    ASSERT_TRUE(bus.Transfer(&read, &error)) << error;
    const auto status = DecodeBlCtrlStatus(read[0].data);
    ASSERT_TRUE(status.has_value());
    EXPECT_EQ(status->max_pwm, 255);
    EXPECT_NEAR(status->current_A, map.full_command_thrust_N, 0.05);
    std::vector<I2cMessage> nobody = {{0x30, false, {1, 2}}};
    EXPECT_FALSE(bus.Transfer(&nobody, &error));
    EXPECT_NE(error.find("NACK from address 0x30"), std::string::npos) << error;
    now = 400000;
    EXPECT_FALSE(escs.ApplyTimeout(now));
    now = 600000;
    EXPECT_TRUE(escs.ApplyTimeout(now)) << "an ESC without set points stops";
    EXPECT_EQ(escs.set_points(), (std::vector<int>{0, 0, 0, 0}));
  }
  stop = true;
  devices.join();
  EXPECT_EQ(server.malformed(), 0);
}

TEST(I2cRequest, MalformedDatagramsAreRefused) {
  std::vector<I2cMessage> messages;
  const std::vector<I2cMessage> sent = {{0x29, false, {0x9A, 0x02}}, {0x29, true, {0, 0, 0}}};
  const std::vector<uint8_t> good = EncodeI2cRequest(sent);
  EXPECT_EQ(good,
            (std::vector<uint8_t>{'K', 'I', '2', 'C', 2, 0x29, 0, 2, 0x9A, 0x02, 0x29, 1, 3}));
  ASSERT_TRUE(DecodeI2cRequest(good, &messages));
  ASSERT_EQ(messages.size(), 2u);
  EXPECT_EQ(messages[0].data, sent[0].data);
  EXPECT_EQ(messages[1].data.size(), 3u);
  for (size_t cut = 0; cut < good.size(); ++cut) {
    EXPECT_FALSE(
        DecodeI2cRequest(std::vector<uint8_t>(good.begin(), good.begin() + cut), &messages))
        << cut;
  }
  std::vector<uint8_t> long_address = good;
  long_address[5] = 0x80;
  EXPECT_FALSE(DecodeI2cRequest(long_address, &messages));
  EXPECT_THROW(static_cast<void>(OpenI2cBus("i2c-1")), std::invalid_argument);
  EXPECT_THROW(static_cast<void>(OpenI2cBus("/dev/kestrel-no-such-bus")), std::runtime_error);
}

}  // namespace
}  // namespace kestrel
