// The driver state machine and its clock model without any I/O: a scripted sensor answers with
// replies written out by hand, and synthetic clocks with known offset and drift.
#include "drivers/hokuyo/hokuyo_driver.h"

#include <cmath>
#include <random>
#include <string>

#include <gtest/gtest.h>

namespace kestrel {
namespace {

TEST(SensorClockUnwrapper, CountsWrapsOfThe24BitClock) {
  SensorClockUnwrapper u;
  EXPECT_EQ(u.Unwrap(16777000), 16777000);
  EXPECT_EQ(u.Unwrap(16777215), 16777215);
  EXPECT_EQ(u.Unwrap(5), 16777216 + 5);
  EXPECT_EQ(u.Unwrap(8000000), 16777216 + 8000000);
  EXPECT_EQ(u.Unwrap(7999990), 16777216 + 7999990);  // a small step back is not a wrap
  EXPECT_EQ(u.Unwrap(16000000), 16777216 + 16000000);
  EXPECT_EQ(u.Unwrap(100), 2 * 16777216 + 100);
  EXPECT_EQ(u.wraps(), 2);
}

// Round trips with asymmetric delays: the median of (midpoint - sensor time) recovers the
// offset even when a few replies are very late.
TEST(HokuyoClockModel, MedianOfRoundTripsRecoversOffset) {
  const double true_offset_us = 1.7e15 - 12345678.9;  // host minus sensor
  HokuyoClockModel model(1000000, 60, 0.002);
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> delay(100, 400);
  int64_t host = 1700000000000000;
  for (int i = 0; i < 15; ++i) {
    const int64_t send = host;
    const int64_t up = delay(rng) + (i % 5 == 0 ? 20000 : 0);  // every 5th: 20 ms late
    const double sensor_read_us = static_cast<double>(send + up) - true_offset_us;
    const int64_t sensor_ms = static_cast<int64_t>(std::floor(sensor_read_us / 1000.0));
    const int64_t receive = send + up + delay(rng);
    model.AddSyncSample(send, receive, sensor_ms);
    host = receive + 3000;
  }
  ASSERT_TRUE(model.FinishSync());
  // Error budget: the 1 ms quantisation (+-0.5 ms) plus half the delay asymmetry (<= 0.15 ms).
  EXPECT_NEAR(model.offset_us(), true_offset_us, 650.0);
  EXPECT_EQ(model.drift_ppm(), 0.0);
}

// Streaming samples from a sensor clock running 800 ppm fast, with random latency on top of a
// constant 20 ms: the drift estimate converges, and stamps follow the true host time.
TEST(HokuyoClockModel, TracksDriftFromMinimumLatency) {
  const double drift = 800e-6;
  const double offset0_us = 5e12;
  HokuyoClockModel model(1000000, 60, 0.002);
  // host(t) = t; sensor_us(t) = (t - offset0) * (1 + drift).
  const auto sensor_ms_at = [&](double host_us) {
    return static_cast<int64_t>(std::floor((host_us - offset0_us) * (1.0 + drift) / 1000.0));
  };
  const double t0 = 6e12;
  for (int i = 0; i < 5; ++i) {
    const double send = t0 + i * 1000.0;
    model.AddSyncSample(static_cast<int64_t>(send), static_cast<int64_t>(send + 200.0),
                        sensor_ms_at(send + 100.0));
  }
  ASSERT_TRUE(model.FinishSync());
  std::mt19937 rng(5);
  std::exponential_distribution<double> jitter(1.0 / 2000.0);
  double worst_late_error_us = 0.0;
  for (int k = 0; k < 40 * 20; ++k) {  // 20 s at 40 Hz
    const double first_step_host = t0 + 10000.0 + k * 25000.0;
    const int64_t sensor_ms = sensor_ms_at(first_step_host);
    const double receive = first_step_host + 20000.0 + jitter(rng);
    model.AddStreamSample(sensor_ms, static_cast<int64_t>(receive));
    if (k > 40 * 15) {
      const double error = static_cast<double>(model.HostUtime(sensor_ms)) - first_step_host;
      worst_late_error_us = std::max(worst_late_error_us, std::abs(error));
    }
  }
  EXPECT_NEAR(model.drift_ppm(), 800.0, 60.0);
  // Without drift tracking the error would reach 800e-6 * 20 s = 16 ms.
  EXPECT_LT(worst_late_error_us, 1500.0);
}

// A scripted sensor: the start-up commands in order, each answered by hand-written bytes.
class ScriptedSensor : public ::testing::Test {
 protected:
  ScriptedSensor() : driver_(MakeConfig()) {}
  static HokuyoConfig MakeConfig() {
    HokuyoConfig c;
    c.clock_sync_samples = 3;
    c.clock_sync_spacing_s = 0.0;
    c.command_retries = 1;
    c.reply_timeout_s = 0.5;
    return c;
  }
  // Expects the driver to have written exactly `command` + LF, then answers `reply`.
  void Expect(const std::string& command, const std::string& reply) {
    EXPECT_EQ(driver_.TakeOutput(), command + "\n");
    driver_.OnWritten(now_);
    now_ += 1000;
    driver_.OnBytes(reply, now_);
  }
  HokuyoDriver driver_;
  int64_t now_{1000000};
};

// A parameter line "KEY:value;S" with its sum over "KEY:value" (the codec's golden tests pin
// SumChar to the specification; this helper is a second, independent writing of the rule).
std::string Line(const std::string& text) {
  unsigned sum = 0;
  for (const char c : text) sum += static_cast<unsigned char>(c);
  return text + ";" + static_cast<char>((sum & 63u) + 48u) + "\n";
}

TEST_F(ScriptedSensor, RunsTheStartUpSequenceAndDecodesAScan) {
  driver_.Start(now_);
  Expect("SCIP2.0", "SCIP2.0\n0\n\n");
  Expect("TM2", "TM2\n03S\n\n");  // "03": was not in time-adjust mode; '0'+'3' = 99 -> 'S'
  Expect("QT", "QT\n00P\n\n");
  Expect("PP", "PP\n00P\n" + Line("MODL:URG-04LX") + Line("DMIN:20") + Line("DMAX:5600") +
                   Line("ARES:1024") + Line("AMIN:44") + Line("AMAX:725") + Line("AFRT:384") +
                   Line("SCAN:600") + "\n");
  EXPECT_EQ(driver_.model().ares, 1024);
  Expect("VV", "VV\n00P\n" + Line("SERI:H0001") + "\n");
  EXPECT_EQ(driver_.version().at("SERI"), "H0001");
  Expect("TM0", "TM0\n00P\n\n");
  // Three TM1 round trips; time stamp "m2@0" (16000000 ms), sum '?'.
  for (int i = 0; i < 3; ++i) Expect("TM1", "TM1\n00P\nm2@0?\n\n");
  Expect("TM2", "TM2\n00P\n\n");
  EXPECT_EQ(driver_.state(), HokuyoDriver::State::kStartingStream);
  Expect("MD0044072501000", "MD0044072501000\n00P\n\n");
  EXPECT_EQ(driver_.state(), HokuyoDriver::State::kStreaming);
  EXPECT_TRUE(driver_.clock().synced());
  // Hand-built scan would need 682 values; check the wrong-length scan is counted, not used.
  driver_.OnBytes("MD0044072501000\n99b\nm2@0?\n1Dh1Dhj\n\n", now_);
  EXPECT_TRUE(driver_.TakeScans().empty());
  const auto events = driver_.TakeEvents();
  ASSERT_FALSE(events.empty());
  EXPECT_EQ(events.back().kind, "scip_decode");
  EXPECT_FALSE(driver_.needs_reopen());
}

// Scans of a stream left running arrive before the QT echo: they are skipped, not errors.
TEST_F(ScriptedSensor, SkipsScansOfAStreamLeftRunning) {
  driver_.Start(now_);
  Expect("SCIP2.0", "MD0044004501000\n99b\nm2@0?\n1Dh1Dhj\n\nSCIP2.0\n0Ee\n\n");
  Expect("TM2", "TM2\n03S\n\n");
  EXPECT_EQ(driver_.TakeOutput(), "QT\n");
  driver_.OnBytes("MD0044004501000\n99b\nm2@0?\n1Dh1Dhj\n\nQT\n00P\n\n", now_);
  EXPECT_EQ(driver_.state(), HokuyoDriver::State::kReadingParameters);
  EXPECT_EQ(driver_.skipped_replies(), 2);
  EXPECT_TRUE(driver_.TakeEvents().empty());
}

// No answer: one retry after reply_timeout_s, then a request to reopen the port.
TEST_F(ScriptedSensor, RetriesThenAsksToReopen) {
  driver_.Start(now_);
  EXPECT_EQ(driver_.TakeOutput(), "SCIP2.0\n");
  driver_.OnTick(now_ + 400000);
  EXPECT_EQ(driver_.TakeOutput(), "");
  driver_.OnTick(now_ + 600000);
  EXPECT_EQ(driver_.TakeOutput(), "SCIP2.0\n");
  EXPECT_FALSE(driver_.needs_reopen());
  driver_.OnTick(now_ + 1200000);
  EXPECT_TRUE(driver_.needs_reopen());
  EXPECT_NE(driver_.reopen_reason().find("SCIP2.0"), std::string::npos);
}

// An error status to the stream command is an error, with its meaning in the reason.
TEST_F(ScriptedSensor, ErrorStatusAsksToReopen) {
  driver_.Start(now_);
  Expect("SCIP2.0", "SCIP2.0\n0\n\n");
  Expect("TM2", "TM2\n00P\n\n");
  // '0' + 'E' = 48 + 69 = 117; 117 & 63 = 53; 53 + 48 = 101 = 'e'. 'U' is a wrong sum.
  Expect("QT", "QT\n0EU\n\n");
  EXPECT_FALSE(driver_.needs_reopen());  // a parse error, not a reply
  driver_.OnBytes("QT\n0Ee\n\n", now_);
  EXPECT_TRUE(driver_.needs_reopen());
  EXPECT_NE(driver_.reopen_reason().find("0E"), std::string::npos);
}

TEST(HokuyoConfig, ValidateNamesKeyValueAndRange) {
  HokuyoConfig c;
  EXPECT_NO_THROW(c.Validate());
  c.scan_skip = 12;
  try {
    c.Validate();
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("scan_skip = 12"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("[0, 9]"), std::string::npos) << e.what();
  }
  c = HokuyoConfig{};
  c.reopen_backoff_max_s = 0.01;
  EXPECT_THROW(c.Validate(), ConfigError);
  c = HokuyoConfig{};
  c.profile = "LMS200";
  EXPECT_THROW(c.Validate(), ConfigError);
}

std::string SourceRoot() { return KESTREL_SOURCE_ROOT; }

TEST(HokuyoConfig, ShippedFilesLoad) {
  for (const char* name : {"config/drivers/hokuyo.yaml", "config/drivers/hokuyo_utm30lx.yaml"}) {
    const ConfigNode node = ConfigNode::LoadFile(SourceRoot() + name);
    const HokuyoConfig c = LoadHokuyoConfig(node);
    EXPECT_NO_THROW(node.CheckNoUnknownKeys()) << name;
    EXPECT_EQ(c.channel, "SCAN_HOKUYO");
  }
  const ConfigNode bad = ConfigNode::FromString("scan_timeout_s: -1\n", "test.yaml");
  EXPECT_THROW(static_cast<void>(LoadHokuyoConfig(bad)), ConfigError);
}

}  // namespace
}  // namespace kestrel
