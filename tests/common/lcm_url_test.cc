// The LCM URL's receive buffer sized to the host (docs/design.md §7.6).
#include "common/lcm_url.h"

#include <gtest/gtest.h>

namespace kestrel {
namespace {

constexpr int64_t kStockRmemMax = 212992;  // Debian 12's kernel

TEST(PlanReceiveBuffer, AsksForWhatTheHostGrants) {
  const ReceiveBufferPlan plan =
      PlanReceiveBuffer("udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304", kStockRmemMax);
  EXPECT_EQ(plan.url, "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=212992");
  EXPECT_EQ(plan.asked_bytes, 4194304);
  EXPECT_EQ(plan.request_bytes, kStockRmemMax);
  EXPECT_EQ(plan.granted_bytes, 2 * kStockRmemMax);
  EXPECT_TRUE(plan.resized);
}

TEST(PlanReceiveBuffer, KeepsARequestTheHostGrantsAndEveryOtherPart) {
  const std::string url = "udpm://239.255.76.67:7667?recv_buf_size=106496&ttl=1";
  const ReceiveBufferPlan plan = PlanReceiveBuffer(url, kStockRmemMax);
  EXPECT_EQ(plan.url, url);
  EXPECT_FALSE(plan.resized);
  EXPECT_EQ(plan.request_bytes, 106496);
  EXPECT_EQ(plan.granted_bytes, 212992);
  // First parameter, resized, with the rest kept.
  EXPECT_EQ(PlanReceiveBuffer("udpm://239.255.76.67:7667?recv_buf_size=8388608&ttl=1", 4194304).url,
            "udpm://239.255.76.67:7667?recv_buf_size=4194304&ttl=1");
}

TEST(PlanReceiveBuffer, LeavesOtherUrlsAlone) {
  for (const std::string url :
       {"", "memq://", "udpm://239.255.76.67:7667", "udpm://239.255.76.67:7667?ttl=0",
        "udpm://239.255.76.67:7667?ttl=0&my_recv_buf_size=4194304",
        "udpm://239.255.76.67:7667?recv_buf_size=lots",
        "udpm://239.255.76.67:7667?recv_buf_size=", "file:///tmp/x.lcmlog?recv_buf_size=4194304"}) {
    const ReceiveBufferPlan plan = PlanReceiveBuffer(url, kStockRmemMax);
    EXPECT_EQ(plan.url, url);
    EXPECT_FALSE(plan.resized) << url;
    EXPECT_EQ(plan.asked_bytes, -1) << url;
  }
  // An unknown host limit keeps the URL and knows no grant.
  const ReceiveBufferPlan unknown =
      PlanReceiveBuffer("udpm://239.255.76.67:7667?recv_buf_size=4194304", -1);
  EXPECT_FALSE(unknown.resized);
  EXPECT_EQ(unknown.granted_bytes, -1);
}

TEST(EffectiveLcmUrl, TheOptionOrTheEnvironment) {
  ::setenv("LCM_DEFAULT_URL", "udpm://239.255.76.67:7667?ttl=1", 1);
  EXPECT_EQ(EffectiveLcmUrl(""), "udpm://239.255.76.67:7667?ttl=1");
  EXPECT_EQ(EffectiveLcmUrl("memq://"), "memq://");
  ::unsetenv("LCM_DEFAULT_URL");
  EXPECT_EQ(EffectiveLcmUrl(""), "");
}

}  // namespace
}  // namespace kestrel
