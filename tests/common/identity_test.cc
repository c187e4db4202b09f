// Publisher epochs and run ids (common/identity.h, docs/design.md §3.4 and §3.5).
#include "common/identity.h"

#include <cstdlib>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace kestrel {
namespace {

// Epochs are positive and never repeat within a process: two nodes never share one.
TEST(PublisherEpoch, PositiveAndDistinct) {
  std::set<int64_t> seen;
  for (int i = 0; i < 100000; ++i) {
    const int64_t e = NewPublisherEpoch();
    ASSERT_GT(e, 0);
    ASSERT_TRUE(seen.insert(e).second) << "epoch " << e << " drawn twice, at draw " << i;
  }
  // Spread over the 63 bits, not a counter: the high bits vary.
  std::set<int64_t> high;
  for (int64_t e : seen) high.insert(e >> 56);
  EXPECT_GT(high.size(), 100u);
}

// Seeded, the sequence is a function of the seed (kestrel-mission's same messages for the same
// seed); another seed gives another sequence.
TEST(PublisherEpoch, SeededSequencesRepeat) {
  auto draw = [](uint64_t seed) {
    SeedPublisherEpochs(seed);
    std::vector<int64_t> v;
    for (int i = 0; i < 5; ++i) v.push_back(NewPublisherEpoch());
    return v;
  };
  const std::vector<int64_t> a = draw(1), b = draw(1), c = draw(2);
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
  EXPECT_EQ(std::set<int64_t>(a.begin(), a.end()).size(), a.size());
  EXPECT_GT(draw(0)[0], 0);
}

TEST(RunId, FreshIdsAreValidAndDiffer) {
  const std::string a = NewRunId(), b = NewRunId();
  EXPECT_EQ(CheckRunId(a), "") << a;
  EXPECT_NE(a, b);
  EXPECT_EQ(a.size(), std::string("20240611T093012Z-5f3a9c01").size()) << a;
  EXPECT_EQ(CheckRunId("flight-7_2024.06:11+x"), "");
  EXPECT_NE(CheckRunId(""), "");
  EXPECT_NE(CheckRunId("a b"), "");
  EXPECT_NE(CheckRunId("../x/y"), "");
  EXPECT_NE(CheckRunId(std::string(129, 'a')), "");
}

// The runner's id: kept when set (every command and respawn sees it), made and exported when
// not, refused when unusable.
TEST(RunId, EnsureRunIdInEnvironment) {
  ASSERT_EQ(unsetenv(kRunIdEnvironmentVariable), 0);
  const std::string made = EnsureRunIdInEnvironment();
  EXPECT_EQ(CheckRunId(made), "");
  ASSERT_NE(std::getenv(kRunIdEnvironmentVariable), nullptr);
  EXPECT_EQ(std::string(std::getenv(kRunIdEnvironmentVariable)), made);
  EXPECT_EQ(EnsureRunIdInEnvironment(), made) << "a second call keeps the id";
  ASSERT_EQ(setenv(kRunIdEnvironmentVariable, "", 1), 0);
  EXPECT_NE(EnsureRunIdInEnvironment(), "") << "empty counts as unset";
  ASSERT_EQ(setenv(kRunIdEnvironmentVariable, "given-run", 1), 0);
  EXPECT_EQ(EnsureRunIdInEnvironment(), "given-run");
  ASSERT_EQ(setenv(kRunIdEnvironmentVariable, "bad id", 1), 0);
  EXPECT_THROW((void)EnsureRunIdInEnvironment(), std::invalid_argument);
  unsetenv(kRunIdEnvironmentVariable);
}

}  // namespace
}  // namespace kestrel
