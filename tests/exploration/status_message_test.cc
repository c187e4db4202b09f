#include "exploration/status_message.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace kestrel {
namespace {

// A status encodes and says what the replan decided.
TEST(StatusMessage, EncodesTheDecision) {
  PlanResult r;
  r.reason = "test";
  r.end_test_gain_nats = 7.5;
  r.best_unweighted_gain_nats = 9.0;
  for (int i = 0; i < 3; ++i) {
    Candidate c;
    c.position_m = Eigen::Vector2d(i, -i);
    c.yaw_rad = 0.5 * i;
    c.gain_nats = 2.0 + i;
    c.distance_m = 1.0 + i;
    c.bump = 0.5;
    r.candidates.push_back(c);
  }
  r.chosen = 2;
  r.timings.total_s = 0.01;
  const exploration_status_t msg = ToStatusMessage(
      r, ExplorationMode::kTwoMap, exploration_status_t::STATE_EXPLORING, 123.0, 0.75, 5, 6, 77);
  // Consistent sizes: the message encodes completely.
  std::vector<uint8_t> bytes(static_cast<size_t>(msg.getEncodedSize()));
  ASSERT_EQ(msg.encode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  const exploration_status_t& back = msg;
  EXPECT_EQ(back.mode, "two_map");
  EXPECT_EQ(back.seq, 6);
  EXPECT_EQ(back.epoch, 77);
  EXPECT_EQ(back.num_candidates, 3);
  EXPECT_EQ(back.chosen_index, 2);
  EXPECT_EQ(back.best_unweighted_gain_nats, 7.5);  // the end-test gain in two-map mode
  EXPECT_EQ(back.goal_position_m[0], 2.0);
  EXPECT_EQ(back.goal_position_m[2], 0.75);
  EXPECT_EQ(back.candidates[1].objective, 1.5);
  EXPECT_EQ(back.total_time_s, 0.01);
  r.chosen = -1;
  EXPECT_TRUE(std::isnan(
      ToStatusMessage(r, ExplorationMode::kCombined, 0, 0.0, 0.75, 0, 0, 1).goal_position_m[0]));
}

// A 2D map message has the map's geometry and values.
TEST(StatusMessage, GridMapMessage) {
  GridMap2D g = GridMap2D::Filled({-4.0, -6.0}, 0.9, 0.75, 9, 14, 0.1);
  g.at(3, 4) = 0.7;
  const grid_map_t m = ToGridMapMessage(g, "collision", 1, 2, 99);
  EXPECT_EQ(m.seq, 2);
  EXPECT_EQ(m.epoch, 99);
  EXPECT_EQ(m.width, 9);
  EXPECT_EQ(m.height, 14);
  EXPECT_EQ(m.num_values, 126);
  EXPECT_FLOAT_EQ(m.values[static_cast<size_t>(3 + 9 * 4)], 0.7f);
  EXPECT_EQ(m.origin_m[1], -6.0);
  EXPECT_EQ(m.name, "collision");
}

}  // namespace
}  // namespace kestrel
