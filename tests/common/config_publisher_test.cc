// The effective configuration on the bus: params_t at start and on request, over memq://.
#include "common/config_publisher.h"

#include <unistd.h>

#include <cstdlib>

#include <gtest/gtest.h>

#include "common/identity.h"

namespace kestrel {
namespace {

class ConfigPublisherTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ::setenv(kRunIdEnvironmentVariable, "20261204T010203Z-0badcafe", 1);
    subscriptions_.Add<params_t>(
        "PARAMS_TEST", [this](const std::string&, const params_t& m) { got_.push_back(m); },
        nullptr);
    args_.config_path = "test.yaml";
    args_.overrides = {"sensor.name=hokuyo"};
    args_.command_line = {"kestrel-test", "--config", "test.yaml", "--set", "sensor.name=hokuyo"};
    config_.ApplyOverride(args_.overrides[0]);
    config_.Read("rate_hz", &rate_hz_);
    config_.Child("sensor").Read("name", &name_);
  }
  void TearDown() override { ::unsetenv(kRunIdEnvironmentVariable); }
  void Drain() {
    while (lcm_.handleTimeout(0) > 0) {
    }
  }
  void Request(const std::string& process) {
    params_request_t request{};
    request.source = "test";
    request.process = process;
    lcm_.publish(kParamsRequestChannel, &request);
    Drain();
  }

  lcm::LCM lcm_{"memq://"};
  SimClock clock_{7000000};
  GuardedSubscriptions subscriptions_{lcm_};
  std::vector<params_t> got_;
  ProcessArgs args_;
  ConfigNode config_ = ConfigNode::FromString("rate_hz: 15\nsensor:\n  name: xtion\n", "test.yaml");
  int rate_hz_{30};
  std::string name_;
};

TEST_F(ConfigPublisherTest, PublishesWhatTheProcessReadOnceAtStart) {
  const ConfigPublisher publisher(lcm_, clock_, "kestrel-test", "PARAMS_TEST", args_, config_);
  Drain();
  ASSERT_EQ(got_.size(), 1u);
  const params_t& m = got_[0];
  EXPECT_EQ(m.utime, 7000000);
  EXPECT_EQ(m.seq, 0);
  EXPECT_NE(m.epoch, 0);
  EXPECT_EQ(m.process, "kestrel-test");
  EXPECT_EQ(m.pid, static_cast<int32_t>(getpid()));
  EXPECT_FALSE(m.host.empty());
  EXPECT_EQ(m.run_id, "20261204T010203Z-0badcafe");
  EXPECT_EQ(m.config_file, "test.yaml");
  EXPECT_EQ(m.args, args_.command_line);
  EXPECT_EQ(m.num_args, 5);
  ASSERT_EQ(m.num_params, 2);
  EXPECT_EQ(m.params[0].key, "rate_hz");
  EXPECT_EQ(m.params[0].value, "15");
  EXPECT_EQ(m.params[0].source, param_t::SOURCE_FILE);
  EXPECT_EQ(m.params[1].key, "sensor.name");
  EXPECT_EQ(m.params[1].value, "hokuyo");
  EXPECT_EQ(m.params[1].source, param_t::SOURCE_OVERRIDE);
  EXPECT_EQ(m.params[1].file, "test.yaml");
  // The message's constants are the ConfigSource values it is filled from.
  EXPECT_EQ(param_t::SOURCE_DEFAULT, static_cast<int8_t>(ConfigSource::kDefault));
  EXPECT_EQ(param_t::SOURCE_FILE, static_cast<int8_t>(ConfigSource::kFile));
  EXPECT_EQ(param_t::SOURCE_OVERRIDE, static_cast<int8_t>(ConfigSource::kOverride));
}

TEST_F(ConfigPublisherTest, AnswersRequestsForItselfOrForEveryProcessOnly) {
  ConfigPublisher publisher(lcm_, clock_, "kestrel-test", "PARAMS_TEST", args_, config_);
  Drain();
  Request("kestrel-other");
  EXPECT_EQ(got_.size(), 1u);
  Request("");
  EXPECT_EQ(got_.size(), 2u);
  // A value read after the start is in the next answer.
  double late = 0.25;
  config_.Read("late_s", &late);
  clock_.AdvanceUtime(1000000);
  Request("kestrel-test");
  ASSERT_EQ(got_.size(), 3u);
  EXPECT_EQ(got_[2].seq, 2);
  EXPECT_EQ(got_[2].epoch, got_[0].epoch);
  EXPECT_EQ(got_[2].utime, 8000000);
  ASSERT_EQ(got_[2].num_params, 3);
  EXPECT_EQ(got_[2].params[2].key, "late_s");
  EXPECT_EQ(got_[2].params[2].value, "0.25");
  EXPECT_EQ(got_[2].params[2].source, param_t::SOURCE_DEFAULT);
  EXPECT_EQ(publisher.published(), 3);
}

TEST_F(ConfigPublisherTest, DropsAMalformedRequestAndCountsIt) {
  ConfigPublisher publisher(lcm_, clock_, "kestrel-test", "PARAMS_TEST", args_, config_);
  Drain();
  params_request_t request{};
  request.process = "";
  std::vector<uint8_t> bytes(static_cast<size_t>(request.getEncodedSize()));
  request.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  bytes.resize(bytes.size() - 3);  // cut inside the last string
  lcm_.publish(kParamsRequestChannel, bytes.data(), static_cast<unsigned>(bytes.size()));
  Drain();
  EXPECT_EQ(got_.size(), 1u);
  EXPECT_EQ(publisher.malformed_requests(), 1);
}

TEST(FormatParams, ListsValuesUnderTheirFilesWithTheSourceMarked) {
  params_t m{};
  m.process = "kestrel-sim";
  m.host = "base";
  m.pid = 42;
  m.run_id = "r1";
  m.args = {"kestrel-sim", "--set", "seed=3"};
  auto param = [](const char* file, const char* key, const char* value, int8_t source) {
    param_t p;
    p.file = file;
    p.key = key;
    p.value = value;
    p.source = source;
    return p;
  };
  m.params = {param("sim.yaml", "seed", "3", param_t::SOURCE_OVERRIDE),
              param("sim.yaml", "mode", "dynamic", param_t::SOURCE_FILE),
              param("paper.yaml", "mass_kg", "1.5", param_t::SOURCE_FILE),
              param("paper.yaml", "arm_m", "0.17", param_t::SOURCE_DEFAULT)};
  EXPECT_EQ(FormatParams(m),
            "kestrel-sim on base, pid 42, run r1\n"
            "  command: kestrel-sim --set seed=3\n"
            "  sim.yaml:\n"
            "    seed: 3                                 # override\n"
            "    mode: dynamic\n"
            "  paper.yaml:\n"
            "    mass_kg: 1.5\n"
            "    arm_m: 0.17                             # default\n");
}

TEST(ParamsChannel, FollowsTheHeartbeatChannel) {
  EXPECT_EQ(ParamsChannelFor("HEARTBEAT_MAPPER"), "PARAMS_MAPPER");
  EXPECT_EQ(ParamsChannelFor("HEARTBEAT_VICON_EMITTER"), "PARAMS_VICON_EMITTER");
  EXPECT_EQ(ParamsChannelFor("MY_STATUS"), "PARAMS_MY_STATUS");
  EXPECT_EQ(ParamsChannelFor("V2_HEARTBEAT_CONTROLLER"), "PARAMS_V2_CONTROLLER");
}

}  // namespace
}  // namespace kestrel
