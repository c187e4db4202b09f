// Heartbeats over memq:// and the rate-limited drop counter.
#include "common/heartbeat.h"

#include <map>

#include <gtest/gtest.h>

#include "common/lcm_decode.h"
#include "common/log.h"

namespace kestrel {
namespace {

// Drops by reason become dropped.<reason> values (spaces as '_'); the listed reasons appear even
// at 0 (docs/design.md §7.11).
TEST(Heartbeat, SetDropValuesReportsEveryReason) {
  lcm::LCM lcm("memq://");
  SimClock clock(0);
  Heartbeat hb(lcm, clock, "kestrel-test", "HEARTBEAT_TEST");
  std::vector<heartbeat_t> got;
  GuardedSubscriptions subs(lcm);
  subs.Add<heartbeat_t>(
      "HEARTBEAT_TEST", [&](const std::string&, const heartbeat_t& m) { got.push_back(m); },
      nullptr);
  DropCounter drops(clock);
  hb.SetDropValues(drops);
  hb.Publish();
  drops.Count("invalid pose", "lost");
  drops.Count("malformed", "POSE: cut");
  drops.Count("malformed", "POSE: cut");
  hb.SetDropValues(drops);
  hb.Publish();
  while (lcm.handleTimeout(0) > 0) {
  }
  ASSERT_EQ(got.size(), 2u);
  ASSERT_EQ(got[0].num_values, 1);
  EXPECT_EQ(got[0].values[0].name, "dropped.malformed");
  EXPECT_EQ(got[0].values[0].value, 0.0);
  std::map<std::string, double> values;
  for (const auto& v : got[1].values) values[v.name] = v.value;
  EXPECT_EQ(values.size(), 2u);
  EXPECT_EQ(values["dropped.malformed"], 2.0);
  EXPECT_EQ(values["dropped.invalid_pose"], 1.0);
}

TEST(Heartbeat, PublishesStateUptimeAndValues) {
  lcm::LCM lcm("memq://");
  SimClock clock(5000000);
  Heartbeat hb(lcm, clock, "kestrel-test", "HEARTBEAT_TEST");
  std::vector<heartbeat_t> got;
  GuardedSubscriptions subs(lcm);
  subs.Add<heartbeat_t>(
      "HEARTBEAT_TEST", [&](const std::string&, const heartbeat_t& m) { got.push_back(m); },
      nullptr);
  hb.SetState(heartbeat_t::STATE_DEGRADED);
  hb.SetValue("scans_dropped", 3);
  hb.SetLastError("no device");
  clock.AdvanceUtime(2500000);
  hb.Publish();
  hb.Publish();
  while (lcm.handleTimeout(0) > 0) {
  }
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0].process, "kestrel-test");
  EXPECT_EQ(got[0].state, int8_t{heartbeat_t::STATE_DEGRADED});
  EXPECT_DOUBLE_EQ(got[0].uptime_s, 2.5);
  EXPECT_EQ(got[0].last_error, "no device");
  ASSERT_EQ(got[0].num_values, 1);
  EXPECT_EQ(got[0].values[0].name, "scans_dropped");
  EXPECT_EQ(got[0].values[0].value, 3.0);
  EXPECT_EQ(got[1].seq, got[0].seq + 1);
  EXPECT_NE(got[0].epoch, 0);
  EXPECT_EQ(got[0].epoch, hb.epoch());
  EXPECT_EQ(got[1].epoch, got[0].epoch);
}

// Two heartbeats (two publishers) in one process carry different epochs.
TEST(Heartbeat, TwoPublishersHaveDifferentEpochs) {
  lcm::LCM lcm("memq://");
  SimClock clock;
  Heartbeat a(lcm, clock, "kestrel-a", "HEARTBEAT_TEST");
  Heartbeat b(lcm, clock, "kestrel-b", "HEARTBEAT_TEST");
  std::vector<heartbeat_t> got;
  GuardedSubscriptions subs(lcm);
  subs.Add<heartbeat_t>(
      "HEARTBEAT_TEST", [&](const std::string&, const heartbeat_t& m) { got.push_back(m); },
      nullptr);
  a.Publish();
  b.Publish();
  while (lcm.handleTimeout(0) > 0) {
  }
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0].seq, got[1].seq) << "both count from 0";
  EXPECT_NE(got[0].epoch, got[1].epoch);
  EXPECT_NE(got[0].epoch, 0);
  EXPECT_NE(got[1].epoch, 0);
}

TEST(DropCounter, CountsEveryDropByKind) {
  SimClock clock;
  DropCounter drops(clock, 1.0);
  for (int i = 0; i < 1000; ++i) drops.Count("malformed", "bad length");
  drops.Count("nan_pose", "position is NaN");
  EXPECT_EQ(drops.count("malformed"), 1000);
  EXPECT_EQ(drops.count("nan_pose"), 1);
  EXPECT_EQ(drops.count("other"), 0);
  EXPECT_EQ(drops.total(), 1001);
  EXPECT_EQ(drops.last_reason(), "nan_pose: position is NaN");
}

}  // namespace
}  // namespace kestrel
