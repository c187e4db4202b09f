// kestrel-hokuyo's node against the emulator through a real pseudo-terminal, scans and
// heartbeats over memq://: the start-up sequence the sensor received, streaming rate, angles
// and ranges against geometry computed here, clock offset against the emulator's truth, and
// recovery from every injected fault (bad sums, garbage, stall, hang-up and replug).
#include "drivers/hokuyo/hokuyo_node.h"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/lcm_decode.h"
#include "drivers/hokuyo/emulator.h"
#include "kestrel/heartbeat_t.hpp"
#include "kestrel/planar_scan_t.hpp"

namespace kestrel {
namespace {

using Steady = std::chrono::steady_clock;

class HokuyoNodeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char dir_template[] = "/tmp/kestrel_hokuyo_node_XXXXXX";
    ASSERT_NE(mkdtemp(dir_template), nullptr);
    dir_ = dir_template;
    subs_.Add<planar_scan_t>(
        "SCAN_HOKUYO", [this](const std::string&, const planar_scan_t& m) { scans_.push_back(m); },
        nullptr);
    subs_.Add<heartbeat_t>(
        "HEARTBEAT_HOKUYO",
        [this](const std::string&, const heartbeat_t& m) { heartbeats_.push_back(m); }, nullptr);
  }
  void TearDown() override {
    node_.reset();
    emulator_.reset();
    ::unlink((dir_ + "/ttyHOKUYO").c_str());
    ::rmdir(dir_.c_str());
  }
  void StartEmulator(HokuyoEmulatorOptions options) {
    options.link_path = dir_ + "/ttyHOKUYO";
    emulator_ = std::make_unique<HokuyoEmulator>(options);
  }
  void StartNode(HokuyoConfig config) {
    config.port = dir_ + "/ttyHOKUYO";
    config.reopen_backoff_max_s = 0.5;
    node_ = std::make_unique<HokuyoNode>(lcm_, config, clock_);
  }
  // Polls node and LCM until `done` or `seconds` pass; returns whether `done` held.
  bool RunUntil(double seconds, const std::function<bool()>& done) {
    const auto end = Steady::now() + std::chrono::duration<double>(seconds);
    int64_t next_heartbeat = clock_.NowUtime() + 200000;
    while (Steady::now() < end) {
      node_->Poll(10);
      lcm_.handleTimeout(0);
      if (clock_.NowUtime() >= next_heartbeat) {
        node_->PublishHeartbeat();
        lcm_.handleTimeout(0);
        next_heartbeat += 200000;
      }
      if (done && done()) return true;
    }
    return false;
  }
  void RunFor(double seconds) { RunUntil(seconds, nullptr); }
  bool WaitForScans(size_t n, double seconds) {
    return RunUntil(seconds, [&] { return scans_.size() >= n; });
  }
  double LastHeartbeatValue(const std::string& name) const {
    if (heartbeats_.empty()) return -1.0;
    for (const named_value_t& v : heartbeats_.back().values) {
      if (v.name == name) return v.value;
    }
    return 0.0;
  }

  std::string dir_;
  lcm::LCM lcm_{"memq://"};
  GuardedSubscriptions subs_{lcm_};
  WallClock clock_;
  std::unique_ptr<HokuyoEmulator> emulator_;
  std::unique_ptr<HokuyoNode> node_;
  std::vector<planar_scan_t> scans_;
  std::vector<heartbeat_t> heartbeats_;
};

// The commands a URG-04LX (powered up in SCIP 1.1, left in time-adjust mode) received, in order.
TEST_F(HokuyoNodeTest, StartUpSequenceIsWhatTheSensorReceives) {
  HokuyoEmulatorOptions options;
  options.model = Urg04lxModel();
  options.start_in_time_adjust_mode = true;
  StartEmulator(options);
  HokuyoConfig config;
  config.clock_sync_samples = 5;
  StartNode(config);
  ASSERT_TRUE(WaitForScans(1, 5.0));
  std::vector<std::string> expected = {"SCIP2.0", "TM2", "QT", "PP", "VV", "TM0"};
  for (int i = 0; i < 5; ++i) expected.push_back("TM1");
  expected.push_back("TM2");
  expected.push_back("MD0044072501000");
  EXPECT_EQ(emulator_->received_commands(), expected);
  EXPECT_EQ(node_->opens(), 1);
  EXPECT_EQ(node_->drops().total(), 0);
}

// A UTM-30LX left streaming by a previous session: QT stops it, its scans are skipped.
TEST_F(HokuyoNodeTest, StopsAStreamLeftRunning) {
  HokuyoEmulatorOptions options;
  options.model = Utm30lxModel();
  options.start_streaming = true;
  StartEmulator(options);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  StartNode(HokuyoConfig{});
  ASSERT_TRUE(WaitForScans(5, 5.0));
  const auto received = emulator_->received_commands();
  ASSERT_GE(received.size(), 4u);
  EXPECT_EQ(received[2], "QT");
  EXPECT_EQ(received.back(), "MD0000108001000");
  EXPECT_EQ(node_->opens(), 1);
}

// Scan counts over 3 s: 40 Hz for the UTM-30LX, half with scan_skip 1, 10 Hz for the URG-04LX
// (generous bounds: a count, not a timing assertion). Sequence numbers have no gaps.
TEST_F(HokuyoNodeTest, StreamsAtTheSensorScanRate) {
  struct Case {
    HokuyoModel model;
    int skip;
    double rate_hz;
  };
  for (const Case& c : {Case{Utm30lxModel(), 0, 40.0}, Case{Utm30lxModel(), 1, 20.0},
                        Case{Urg04lxModel(), 0, 10.0}}) {
    SCOPED_TRACE(c.model.name + " skip " + std::to_string(c.skip));
    scans_.clear();
    HokuyoEmulatorOptions options;
    options.model = c.model;
    StartEmulator(options);
    HokuyoConfig config;
    config.scan_skip = c.skip;
    StartNode(config);
    ASSERT_TRUE(WaitForScans(1, 5.0));
    const size_t first = scans_.size();
    const auto t0 = Steady::now();
    RunFor(3.0);
    const double seconds = std::chrono::duration<double>(Steady::now() - t0).count();
    const double rate = static_cast<double>(scans_.size() - first) / seconds;
    std::printf("[hokuyo] %s skip %d: %.2f scans/s over %.2f s\n", c.model.name.c_str(), c.skip,
                rate, seconds);
    EXPECT_GT(rate, 0.75 * c.rate_hz);
    EXPECT_LT(rate, 1.25 * c.rate_hz);
    for (size_t i = 1; i < scans_.size(); ++i) EXPECT_EQ(scans_[i].seq, scans_[i - 1].seq + 1);
    node_.reset();
    emulator_.reset();
  }
}

// A driver restarted (as the runner respawns it) counts seq from 0 again under a new epoch, so
// that consumers tell its scans from the ones before (docs/design.md §3.4); every scan of one
// driver carries the same epoch.
TEST_F(HokuyoNodeTest, ARestartedDriverStartsANewEpoch) {
  HokuyoEmulatorOptions options;
  options.model = Utm30lxModel();
  StartEmulator(options);
  StartNode(HokuyoConfig{});
  ASSERT_TRUE(WaitForScans(3, 5.0));
  const int64_t first_epoch = node_->epoch();
  EXPECT_NE(first_epoch, 0);
  for (const planar_scan_t& s : scans_) EXPECT_EQ(s.epoch, first_epoch);
  EXPECT_GT(scans_.back().seq, 0);
  node_.reset();
  scans_.clear();
  StartNode(HokuyoConfig{});
  ASSERT_TRUE(WaitForScans(1, 5.0));
  EXPECT_EQ(scans_.front().seq, 0);
  EXPECT_NE(scans_.front().epoch, 0);
  EXPECT_NE(scans_.front().epoch, first_epoch);
  EXPECT_EQ(scans_.front().epoch, node_->epoch());
}

// Angles and ranges against the synthetic room computed here: walls at x = 4, y = 3, y = -1.5,
// x = -2 (m); the doorway (5..15 deg) and beyond DMAX give "no return" (0); the interference
// code (step % 101 == 50) gives NaN.
TEST_F(HokuyoNodeTest, PublishesAnglesAndRangesInTheScanContract) {
  HokuyoEmulatorOptions options;
  options.model = Urg04lxModel();
  StartEmulator(options);
  StartNode(HokuyoConfig{});
  ASSERT_TRUE(WaitForScans(1, 5.0));
  const planar_scan_t& s = scans_.back();
  EXPECT_EQ(s.sensor_name, "hokuyo");
  ASSERT_EQ(s.num_ranges, 725 - 44 + 1);
  EXPECT_EQ(s.num_intensities, 0);
  EXPECT_NEAR(s.angle_min_rad, (44 - 384) * 2.0 * M_PI / 1024.0, 1e-6);
  EXPECT_NEAR(s.angle_step_rad, 2.0 * M_PI / 1024.0, 1e-7);
  EXPECT_NEAR(s.time_step_s, 0.1 / 1024.0, 1e-9);
  EXPECT_FLOAT_EQ(s.range_min_m, 0.02f);
  EXPECT_FLOAT_EQ(s.range_max_m, 5.6f);
  const auto range_at_step = [&](int step) { return s.ranges_m[static_cast<size_t>(step - 44)]; };
  EXPECT_NEAR(range_at_step(384), 4.0, 1e-3);        // straight ahead: front wall
  EXPECT_NEAR(range_at_step(384 + 256), 3.0, 1e-3);  // +90 deg: left wall
  EXPECT_NEAR(range_at_step(384 - 256), 1.5, 1e-3);  // -90 deg: right wall
  // 30 deg: front wall at 4 / cos(30 deg) = 4.6188 m (y = 2.31 < 3).
  const int step30 = 384 + static_cast<int>(std::lround(30.0 / 360.0 * 1024.0));
  const double angle30 = (step30 - 384) * 2.0 * M_PI / 1024.0;
  EXPECT_NEAR(range_at_step(step30), 4.0 / std::cos(angle30), 1e-3);
  EXPECT_EQ(range_at_step(384 + 28), 0.0f);     // 9.8 deg: the doorway
  EXPECT_TRUE(std::isnan(range_at_step(151)));  // 151 % 101 == 50: interference
  int nan_count = 0;
  for (const float r : s.ranges_m) {
    EXPECT_FALSE(r < 0.0f);
    if (std::isnan(r)) ++nan_count;
  }
  EXPECT_EQ(nan_count, 7);  // steps 50, 151, ..., 656 within 44..725
}

TEST_F(HokuyoNodeTest, StreamsIntensitiesWithMe) {
  HokuyoEmulatorOptions options;
  options.model = Utm30lxModel();
  StartEmulator(options);
  HokuyoConfig config;
  config.intensities = true;
  config.profile = "UTM-30LX";
  StartNode(config);
  ASSERT_TRUE(WaitForScans(2, 5.0));
  const planar_scan_t& s = scans_.back();
  ASSERT_EQ(s.num_ranges, 1081);
  EXPECT_EQ(s.num_intensities, 1081);
  EXPECT_NEAR(s.angle_min_rad, -0.75 * M_PI, 1e-6);
  EXPECT_NEAR(s.ranges_m[0], 1.5 * std::sqrt(2.0), 1e-3);  // -135 deg: the right wall's corner
  EXPECT_EQ(emulator_->received_commands().back(), "ME0000108001000");
}

// A profile that does not match PP's MODL is refused (and retried with back-off).
TEST_F(HokuyoNodeTest, RefusesTheWrongModel) {
  HokuyoEmulatorOptions options;
  options.model = Urg04lxModel();
  StartEmulator(options);
  HokuyoConfig config;
  config.profile = "UTM-30LX";
  StartNode(config);
  RunFor(1.5);
  EXPECT_TRUE(scans_.empty());
  EXPECT_GE(node_->drops().count("reopen"), 1);
  ASSERT_FALSE(heartbeats_.empty());
  EXPECT_EQ(heartbeats_.back().state, heartbeat_t::STATE_DEGRADED);
  EXPECT_NE(heartbeats_.back().last_error.find("profile expects UTM-30LX"), std::string::npos)
      << heartbeats_.back().last_error;
}

// Stamps against the emulator's truth (host time of each scan's first step), with the sensor
// clock starting 2 s before its 24-bit wrap: the stamps must be continuous across the wrap.
TEST_F(HokuyoNodeTest, StampsScansAtTheFirstStepHostTimeAcrossTheWrap) {
  HokuyoEmulatorOptions options;
  options.model = Utm30lxModel();
  options.clock_offset_ms = (int64_t{1} << 24) - 2000;
  StartEmulator(options);
  StartNode(HokuyoConfig{});
  ASSERT_TRUE(WaitForScans(1, 5.0));
  RunFor(4.0);
  const std::vector<EmulatedScan> truth = emulator_->sent_scans();
  ASSERT_GT(truth.size(), 100u);
  std::vector<double> errors_us;
  for (const planar_scan_t& s : scans_) {
    double best = 1e18;
    for (const EmulatedScan& t : truth) {
      const double e = static_cast<double>(s.utime - t.first_step_utime);
      if (std::abs(e) < std::abs(best)) best = e;
    }
    errors_us.push_back(best);
  }
  for (size_t i = 1; i < scans_.size(); ++i) {
    const int64_t dt = scans_[i].utime - scans_[i - 1].utime;
    EXPECT_GT(dt, 15000) << i;  // 25 ms apart; a missed unwrap would jump by hours
    EXPECT_LT(dt, 35000) << i;
  }
  std::vector<double> sorted = errors_us;
  for (double& e : sorted) e = std::abs(e);
  std::sort(sorted.begin(), sorted.end());
  const double median = sorted[sorted.size() / 2];
  const double worst = sorted.back();
  std::printf(
      "[hokuyo] stamp error vs truth over %zu scans: median |e| %.0f us, max %.0f us; "
      "TM1 min round trip %.3f ms\n",
      sorted.size(), median, worst, LastHeartbeatValue("tm_min_round_trip_ms"));
  // The TM1 estimate itself against the emulator's true host - sensor offset (no drift here).
  const double offset_error_us =
      node_->driver().clock().offset_us() - emulator_->TrueOffsetUs(clock_.NowUtime());
  std::printf("[hokuyo] TM1 offset estimate - true offset: %.0f us\n", offset_error_us);
  EXPECT_LT(std::abs(offset_error_us), 1500.0);  // 1 ms clock resolution + round trip
  EXPECT_LT(median, 2000.0);
  EXPECT_LT(worst, 10000.0);  // well under half a scan period: the right scan was matched
}

// A sensor clock running 1000 ppm fast: after 7 s the offset alone would be 7 ms off; the drift
// tracked from the minimum latency keeps the late stamps within a few ms of the truth.
TEST_F(HokuyoNodeTest, TracksSensorClockDrift) {
  HokuyoEmulatorOptions options;
  options.model = Utm30lxModel();
  options.clock_drift_ppm = 1000.0;
  StartEmulator(options);
  HokuyoConfig config;
  config.drift_window_s = 0.5;
  StartNode(config);
  ASSERT_TRUE(WaitForScans(1, 5.0));
  RunFor(7.0);
  const std::vector<EmulatedScan> truth = emulator_->sent_scans();
  const double drift_ppm = node_->driver().clock().drift_ppm();
  double worst_late_us = 0.0;
  const int64_t late = scans_.back().utime - 1000000;
  for (const planar_scan_t& s : scans_) {
    if (s.utime < late) continue;
    double best = 1e18;
    for (const EmulatedScan& t : truth) {
      const double e = static_cast<double>(s.utime - t.first_step_utime);
      if (std::abs(e) < std::abs(best)) best = e;
    }
    worst_late_us = std::max(worst_late_us, std::abs(best));
  }
  std::printf(
      "[hokuyo] drift 1000 ppm: estimated %.1f ppm; max |stamp error| in the last 1 s "
      "%.0f us (untracked would be ~7000 us)\n",
      drift_ppm, worst_late_us);
  EXPECT_NEAR(drift_ppm, 1000.0, 300.0);
  EXPECT_LT(worst_late_us, 3000.0);
}

// Bad sums and garbage in the stream: each breaks one scan, counted, with no reopen.
TEST_F(HokuyoNodeTest, SurvivesBadSumsAndGarbageWithoutReopening) {
  HokuyoEmulatorOptions options;
  options.model = Utm30lxModel();
  StartEmulator(options);
  StartNode(HokuyoConfig{});
  ASSERT_TRUE(WaitForScans(5, 5.0));
  for (int i = 0; i < 5; ++i) {
    emulator_->CorruptNextSums(2);
    RunFor(0.2);
    emulator_->InjectGarbage(std::string("\x00\xff\n\nZZ garbage\n", 15));
    RunFor(0.2);
  }
  const size_t before = scans_.size();
  ASSERT_TRUE(WaitForScans(before + 20, 3.0));
  EXPECT_EQ(node_->opens(), 1);
  EXPECT_GE(node_->drops().count("scip_parse"), 15);
  EXPECT_EQ(node_->drops().count("reopen"), 0);
  node_->PublishHeartbeat();
  lcm_.handleTimeout(0);
  EXPECT_EQ(heartbeats_.back().state, heartbeat_t::STATE_OK);
  EXPECT_GE(LastHeartbeatValue("drops_scip_parse"), 15.0);
}

// The sensor stops answering for 2 s: the scan time-out reopens the port, probes fail until the
// sensor answers again, then streaming resumes. All of it is in the heartbeat.
TEST_F(HokuyoNodeTest, RecoversFromASensorThatStopsAnswering) {
  HokuyoEmulatorOptions options;
  options.model = Utm30lxModel();
  StartEmulator(options);
  StartNode(HokuyoConfig{});
  ASSERT_TRUE(WaitForScans(5, 5.0));
  emulator_->Stall(2000);
  RunFor(1.5);
  EXPECT_EQ(heartbeats_.back().state, heartbeat_t::STATE_DEGRADED);
  EXPECT_GE(node_->drops().count("reopen"), 1);
  const size_t before = scans_.size();
  ASSERT_TRUE(WaitForScans(before + 20, 8.0));
  EXPECT_GE(node_->opens(), 2);
  RunFor(0.3);
  EXPECT_EQ(heartbeats_.back().state, heartbeat_t::STATE_OK);
  EXPECT_GE(LastHeartbeatValue("drops_timeout"), 1.0);
  EXPECT_GE(LastHeartbeatValue("drops_reopen"), 1.0);
}

// Unplug (the pty closes, the link disappears) and replug 1 s later: the node sees the hang-up,
// retries the open with back-off while the device is absent, and streams again after.
TEST_F(HokuyoNodeTest, ReconnectsAfterUnplugAndReplug) {
  HokuyoEmulatorOptions options;
  options.model = Urg04lxModel();
  StartEmulator(options);
  StartNode(HokuyoConfig{});
  ASSERT_TRUE(WaitForScans(3, 5.0));
  emulator_->HangUp(1000);
  ASSERT_TRUE(RunUntil(2.0, [&] { return !node_->port_open(); }));
  RunFor(0.5);
  EXPECT_EQ(heartbeats_.back().state, heartbeat_t::STATE_DEGRADED);
  EXPECT_GE(node_->drops().count("disconnected"), 1);
  const size_t before = scans_.size();
  ASSERT_TRUE(WaitForScans(before + 10, 8.0));
  EXPECT_EQ(emulator_->plug_count(), 2);
  EXPECT_GE(node_->opens(), 2);
  EXPECT_GE(node_->drops().count("open_failed"), 1);  // the device was absent for a while
  // After the replug the URG-04LX is in SCIP 1.1 again: the start-up ran again from the probe.
  const auto received = emulator_->received_commands();
  EXPECT_GE(std::count(received.begin(), received.end(), "SCIP2.0"), 2);
}

}  // namespace
}  // namespace kestrel
