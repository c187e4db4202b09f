// The drivers' reopen schedule (common/reopen_backoff.h).
#include "common/reopen_backoff.h"

#include <gtest/gtest.h>

#include <stdexcept>

namespace kestrel {
namespace {

TEST(ReopenBackoff, DoublesUpToTheLongestDelayAndStartsAfreshOnceItWorks) {
  ReopenBackoff b(0.1, 0.5, "test");
  EXPECT_TRUE(b.Due(0)) << "the first attempt at once";
  b.Failed(1000000);
  EXPECT_EQ(b.next_utime(), 1100000);
  EXPECT_FALSE(b.Due(1099999));
  EXPECT_TRUE(b.Due(1100000));
  b.Failed(1100000);
  EXPECT_EQ(b.next_utime(), 1300000);
  b.Failed(1300000);
  EXPECT_EQ(b.next_utime(), 1700000);
  b.Failed(1700000);
  EXPECT_EQ(b.next_utime(), 2200000) << "capped at 0.5 s";
  b.Succeeded();
  b.Failed(3000000);
  EXPECT_EQ(b.next_utime(), 3100000);
  EXPECT_THROW(ReopenBackoff(0.0, 1.0, "x"), std::invalid_argument);
  EXPECT_THROW(ReopenBackoff(2.0, 1.0, "x"), std::invalid_argument);
}

}  // namespace
}  // namespace kestrel
