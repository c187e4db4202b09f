// Real-time settings and the loop-timing histogram (common/realtime.h, docs/design.md §2.6).
#include "common/realtime.h"

#include <gtest/gtest.h>
#include <sched.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <random>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "common/config.h"

namespace kestrel {
namespace {

// The quantile read from the histogram is the exact order statistic, rounded up to its bin's
// upper edge (and never above the maximum): checked against the sorted samples.
TEST(LoopTiming, QuantilesMatchTheSortedSamplesToOneBin) {
  std::mt19937 rng(7);
  std::exponential_distribution<double> late(1.0 / 80.0);
  LoopTiming timing;
  std::vector<int64_t> samples;
  for (int i = 0; i < 20000; ++i) {
    const auto us = static_cast<int64_t>(late(rng)) + (i % 997 == 0 ? 30000 : 0);
    samples.push_back(us);
    timing.Record(us);
  }
  std::sort(samples.begin(), samples.end());
  EXPECT_EQ(timing.count(), 20000);
  EXPECT_EQ(timing.max_us(), samples.back());
  for (const double q : {0.01, 0.5, 0.9, 0.99, 0.999, 1.0}) {
    const auto rank = static_cast<size_t>(std::ceil(q * static_cast<double>(samples.size())));
    const int64_t exact = samples[rank - 1];
    const int64_t read = timing.QuantileUs(q);
    if (exact >= static_cast<int64_t>(LoopTiming::kBins) * LoopTiming::kBinUs) {
      EXPECT_EQ(read, samples.back()) << "q " << q << ": past the last bin, the maximum";
    } else {
      EXPECT_GE(read, exact) << "q " << q;
      EXPECT_LE(read, std::min<int64_t>((exact / LoopTiming::kBinUs + 1) * LoopTiming::kBinUs,
                                        samples.back()))
          << "q " << q;
    }
  }
}

TEST(LoopTiming, EarlyTicksCountAsOnTimeAndResetForgets) {
  LoopTiming timing;
  EXPECT_EQ(timing.QuantileUs(0.5), 0);
  timing.Record(-40);
  timing.Record(15);
  EXPECT_EQ(timing.bins()[0], 1);
  EXPECT_EQ(timing.bins()[1], 1);
  EXPECT_EQ(timing.QuantileUs(0.5), LoopTiming::kBinUs)
      << "the early tick is the median: its bin's upper edge";
  EXPECT_EQ(timing.QuantileUs(1.0), 15);
  EXPECT_THROW(static_cast<void>(timing.QuantileUs(0.0)), std::invalid_argument);
  timing.Reset();
  EXPECT_EQ(timing.count(), 0);
  EXPECT_EQ(timing.max_us(), 0);
  EXPECT_EQ(timing.bins()[1], 0);
}

TEST(LoopTiming, CsvHasOneRowPerBinUpToTheLastUsed) {
  LoopTiming a, b;
  a.Record(5);
  a.Record(5);
  b.Record(25);
  const std::string csv = LoopTimingCsv({"late", "age"}, {&a, &b});
  EXPECT_EQ(csv, "bin_start_us,late,age\n0,2,0\n10,0,0\n20,0,1\n");
  EXPECT_THROW(static_cast<void>(LoopTimingCsv({"late"}, {&a, &b})), std::invalid_argument);
}

TEST(RealtimeConfig, ReadsTheSectionAndRefusesOutOfRange) {
  const ConfigNode none = ConfigNode::FromString("rate_hz: 400\n", "none");
  const RealtimeConfig off = ReadRealtimeConfig(none);
  EXPECT_EQ(off.fifo_priority, 0);
  EXPECT_FALSE(off.lock_memory);
  EXPECT_TRUE(off.cpus.empty());
  const ConfigNode set = ConfigNode::FromString(
      "realtime: {fifo_priority: 80, lock_memory: true, cpus: [1, 3]}\n", "set");
  const RealtimeConfig on = ReadRealtimeConfig(set);
  EXPECT_EQ(on.fifo_priority, 80);
  EXPECT_TRUE(on.lock_memory);
  EXPECT_EQ(on.cpus, (std::vector<int>{1, 3}));
  set.CheckNoUnknownKeys();
  EXPECT_THROW(
      ReadRealtimeConfig(ConfigNode::FromString("realtime: {fifo_priority: 100}\n", "high")),
      std::exception);
  EXPECT_THROW(ReadRealtimeConfig(ConfigNode::FromString("realtime: {cpus: [1.5]}\n", "half")),
               std::exception);
  RealtimeConfig negative;
  negative.fifo_priority = -1;
  EXPECT_THROW(negative.Validate(), std::invalid_argument);
}

// nice: read and range-checked; applied in a child (it is per thread and only ever raised
// without privileges), where getpriority then reads it.
TEST(RealtimeConfig, NiceIsReadCheckedAndApplied) {
  EXPECT_EQ(ReadRealtimeConfig(ConfigNode::FromString("realtime: {nice: -10}\n", "n")).nice, -10);
  EXPECT_THROW(ReadRealtimeConfig(ConfigNode::FromString("realtime: {nice: 20}\n", "n")),
               std::exception);
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    RealtimeConfig c;
    c.nice = 7;
    const RealtimeOutcome outcome = ApplyRealtime(c);
    errno = 0;
    const int now = getpriority(PRIO_PROCESS, 0);
    const bool ok = outcome.niced && now == 7 && outcome.warnings.empty() &&
                    outcome.Summary(c) == "normal scheduling at nice 7, memory not locked, any CPU";
    _exit(ok ? 0 : 3);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
}

// Nothing requested: nothing changes and nothing is reported.
TEST(ApplyRealtime, NothingRequestedChangesNothing) {
  const int policy = sched_getscheduler(0);
  const RealtimeOutcome outcome = ApplyRealtime(RealtimeConfig{});
  EXPECT_FALSE(outcome.fifo);
  EXPECT_FALSE(outcome.memory_locked);
  EXPECT_FALSE(outcome.affinity);
  EXPECT_TRUE(outcome.warnings.empty());
  EXPECT_EQ(sched_getscheduler(0), policy);
  EXPECT_EQ(outcome.Summary(RealtimeConfig{}), "normal scheduling, memory not locked, any CPU");
}

// The affinity is applied to the calling thread, or refused with a warning; restored after.
TEST(ApplyRealtime, AffinityIsInForceOrAWarning) {
  cpu_set_t before;
  ASSERT_EQ(sched_getaffinity(0, sizeof(before), &before), 0);
  int first = -1;
  for (int cpu = 0; cpu < CPU_SETSIZE && first < 0; ++cpu) {
    if (CPU_ISSET(cpu, &before)) first = cpu;
  }
  ASSERT_GE(first, 0);
  RealtimeConfig config;
  config.cpus = {first};
  const RealtimeOutcome outcome = ApplyRealtime(config);
  ASSERT_TRUE(outcome.affinity) << (outcome.warnings.empty() ? "" : outcome.warnings.front());
  cpu_set_t now;
  ASSERT_EQ(sched_getaffinity(0, sizeof(now), &now), 0);
  EXPECT_EQ(CPU_COUNT(&now), 1);
  EXPECT_TRUE(CPU_ISSET(first, &now));
  EXPECT_EQ(outcome.Summary(config).find("CPUs " + std::to_string(first)) != std::string::npos,
            true)
      << outcome.Summary(config);
  ASSERT_EQ(sched_setaffinity(0, sizeof(before), &before), 0);
}

// SCHED_FIFO: in force (checked with the kernel) where the process may, else refused with the
// cause and the remedy and the policy unchanged. Restored to SCHED_OTHER after.
TEST(ApplyRealtime, FifoIsInForceOrARefusalThatSaysWhy) {
  const int policy = sched_getscheduler(0);
  RealtimeConfig config;
  config.fifo_priority = 10;
  const RealtimeOutcome outcome = ApplyRealtime(config);
  if (outcome.fifo) {
    EXPECT_EQ(sched_getscheduler(0), SCHED_FIFO);
    sched_param param{};
    ASSERT_EQ(sched_getparam(0, &param), 0);
    EXPECT_EQ(param.sched_priority, 10);
    EXPECT_TRUE(outcome.warnings.empty());
    EXPECT_EQ(outcome.Summary(config).rfind("SCHED_FIFO 10", 0), 0u);
    sched_param normal{};
    ASSERT_EQ(sched_setscheduler(0, SCHED_OTHER, &normal), 0);
  } else {
    EXPECT_EQ(sched_getscheduler(0), policy);
    ASSERT_EQ(outcome.warnings.size(), 1u);
    EXPECT_NE(outcome.warnings[0].find("SCHED_FIFO 10 refused"), std::string::npos);
    EXPECT_NE(outcome.warnings[0].find("CAP_SYS_NICE"), std::string::npos);
  }
}

}  // namespace
}  // namespace kestrel
