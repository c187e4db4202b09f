// kestrel-imu's node against the VN-100 emulator on a real pseudo-terminal (termios, the bytes
// of docs/protocols.md §7), memq:// LCM and the wall clock.
#include "drivers/imu/imu_node.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <thread>

#include "drivers/imu/vn100_emulator.h"
#include "kestrel/imu_t.hpp"

namespace kestrel {
namespace {

class ImuNodeTest : public ::testing::Test {
 protected:
  ImuNodeTest()
      : link_("/tmp/kestrel-imu-test-" + std::to_string(::getpid()) + ".tty"),
        lcm_("memq://"),
        device_(link_) {
    config_.port = link_;
    config_.baud = 921600;
    subscription_ = lcm_.subscribe("IMU", &ImuNodeTest::OnImu, this);
  }
  void OnImu(const lcm::ReceiveBuffer*, const std::string&, const imu_t* m) {
    received_.push_back(*m);
  }
  // Runs the device at its 800 Hz base rate (device clock from 5 s) and the node for `seconds`.
  void Run(ImuNode& node, double seconds) {
    const auto end = std::chrono::steady_clock::now() +
                     std::chrono::microseconds(static_cast<int64_t>(seconds * 1e6));
    auto next = std::chrono::steady_clock::now();
    while (std::chrono::steady_clock::now() < end) {
      device_.Poll();
      while (std::chrono::steady_clock::now() >= next) {  // every sample due: the device's
                                                          // clock keeps the wall's pace
        Vn100Sample s;
        s.time_startup_ns = 5000000000ULL + 1250000ULL * static_cast<uint64_t>(samples_++);
        s.angular_rate_radps = {0.1F, 0.2F, 0.3F};
        s.accel_mps2 = {0.0F, 0.5F, -9.8F};
        device_.Sample(s);
        next += std::chrono::microseconds(1250);
      }
      node.Poll(0);
      while (lcm_.handleTimeout(0) > 0) {
      }
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
  }
  std::string link_;
  lcm::LCM lcm_;
  Vn100Emulator device_;
  ImuConfig config_;
  WallClock clock_;
  lcm::Subscription* subscription_;
  std::vector<imu_t> received_;
  int64_t samples_{0};
};

TEST_F(ImuNodeTest, ConfiguresTheDeviceAndPublishesItsSamplesInTheBodyFrame) {
  ImuNode node(lcm_, config_, clock_);
  Run(node, 1.0);
  ASSERT_TRUE(node.streaming());
  ASSERT_GE(device_.commands().size(), 2u);
  const auto line = [](const std::string& body) {
    const std::string command = Vn100Command(body);
    return command.substr(0, command.size() - 2);  // as received: without "\r\n"
  };
  EXPECT_EQ(device_.commands()[0], line("WRG,06,0")) << "asynchronous ASCII off first";
  EXPECT_EQ(device_.commands()[1], line("WRG,75,1,2,01,0121")) << "then binary output 1";
  EXPECT_EQ(device_.rate_divisor(), 2);
  // About 400 Hz for the time streamed (the first part of the second went to configuring).
  ASSERT_GT(received_.size(), 200u);
  EXPECT_LT(received_.size(), 420u);
  const imu_t& m = received_.back();
  EXPECT_EQ(m.sensor_name, "imu");
  EXPECT_NEAR(m.angular_velocity_radps[0], 0.1, 1e-6);
  EXPECT_NEAR(m.angular_velocity_radps[1], -0.2, 1e-6);
  EXPECT_NEAR(m.angular_velocity_radps[2], -0.3, 1e-6);
  EXPECT_NEAR(m.specific_force_mps2[1], -0.5, 1e-6);
  EXPECT_NEAR(m.specific_force_mps2[2], 9.8, 1e-5) << "+g up at rest";
  // The stamps follow the device clock: every other 1.25 ms sample, 2.5 ms apart, where the
  // minimum latency stays (it may only fall); never out of order, and near the host's time.
  int regular = 0;
  for (size_t i = 1; i < received_.size(); ++i) {
    ASSERT_GT(received_[i].utime, received_[i - 1].utime);
    ASSERT_EQ(received_[i].seq, received_[i - 1].seq + 1);
    if (received_[i].utime - received_[i - 1].utime == 2500) ++regular;
  }
  EXPECT_GT(regular, static_cast<int>(received_.size()) * 7 / 10);
  EXPECT_NEAR(static_cast<double>(received_.back().utime), static_cast<double>(clock_.NowUtime()),
              50000.0);
  EXPECT_EQ(node.drops().total(), 0) << node.drops().last_reason();
}

TEST_F(ImuNodeTest, GarbageOnTheLineIsCountedExactlyAndTheStreamGoesOn) {
  ImuNode node(lcm_, config_, clock_);
  Run(node, 0.5);
  ASSERT_TRUE(node.streaming());
  const size_t before = received_.size();
  device_.Inject(std::string("\x01\x02\x03", 3));
  device_.Inject("$VNYMR,1,2,3*00\r\n");
  Run(node, 0.3);
  device_.Inject(std::string("\x11\x12", 2));
  Run(node, 0.3);
  EXPECT_GT(received_.size(), before + 150) << "the stream went on";
  EXPECT_EQ(node.drops().count("garbage"), 2);
  EXPECT_EQ(node.drops().count("bad_checksum"), 1);
  EXPECT_EQ(node.drops().total(), 3);
}

TEST_F(ImuNodeTest, AnUnpluggedDeviceIsReopenedWithBackOffAndConfiguredAgain) {
  config_.reopen_backoff_min_s = 0.05;
  ImuNode node(lcm_, config_, clock_);
  Run(node, 0.4);
  ASSERT_TRUE(node.streaming());
  device_.Unplug();
  Run(node, 0.2);
  EXPECT_FALSE(node.streaming());
  device_.Plug();  // power-on: binary output off, ASCII on
  const size_t before = received_.size();
  Run(node, 0.8);
  EXPECT_TRUE(node.streaming());
  EXPECT_EQ(node.opens(), 2);
  EXPECT_GT(received_.size(), before + 100);
  EXPECT_GE(node.drops().count("reopen"), 1);
}

}  // namespace
}  // namespace kestrel
