#include "exploration/status_message.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace kestrel {
namespace {

// A status encodes and says what the replan decided: the candidates best first, the chosen
// one's index among them, the reasons joined, the goal at the exploration height.
TEST(StatusMessage, EncodesTheDecision) {
  PlanResult r;
  r.reason = "test";
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
  r.chosen = 1;
  r.timings.total_s = 0.01;
  StatusContext context;
  context.utime = 5;
  context.seq = 6;
  context.epoch = 77;
  context.mode = ExplorationMode::kTwoMap;
  context.state = ExplorerState::kExploring;
  context.reason = "replan period";
  context.map_entropy_nats = 123.0;
  context.height_m = 0.75;
  const exploration_status_t msg = ToStatusMessage(r, context);
  // Consistent sizes: the message encodes completely.
  std::vector<uint8_t> bytes(static_cast<size_t>(msg.getEncodedSize()));
  ASSERT_EQ(msg.encode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  EXPECT_EQ(msg.mode, "two_map");
  EXPECT_EQ(msg.state, exploration_status_t::STATE_EXPLORING);
  EXPECT_EQ(msg.reason, "replan period: test");
  EXPECT_EQ(msg.seq, 6);
  EXPECT_EQ(msg.epoch, 77);
  EXPECT_EQ(msg.map_entropy_nats, 123.0);
  EXPECT_EQ(msg.best_unweighted_gain_nats, 9.0);
  ASSERT_EQ(msg.num_candidates, 3);
  // Objectives 1.0, 1.5, 2.0: listed 2.0, 1.5, 1.0; the chosen one (1.5) is second.
  EXPECT_EQ(msg.candidates[0].objective, 2.0);
  EXPECT_EQ(msg.candidates[2].objective, 1.0);
  EXPECT_EQ(msg.chosen_index, 1);
  EXPECT_EQ(msg.goal_position_m[0], 1.0);
  EXPECT_EQ(msg.goal_position_m[1], -1.0);
  EXPECT_EQ(msg.goal_position_m[2], 0.75);
  EXPECT_EQ(msg.goal_yaw_rad, 0.5);
  EXPECT_EQ(msg.total_time_s, 0.01);
  // At most max_candidates, best first; the chosen one not among them: index -1.
  context.max_candidates = 1;
  const exploration_status_t capped = ToStatusMessage(r, context);
  EXPECT_EQ(capped.num_candidates, 1);
  EXPECT_EQ(capped.chosen_index, -1);
  EXPECT_EQ(capped.goal_position_m[0], 1.0);
  // No choice, no reason of its own: the context's reason and a zero goal.
  r.chosen = -1;
  r.reason.clear();
  const exploration_status_t none = ToStatusMessage(r, context);
  EXPECT_EQ(none.reason, "replan period");
  EXPECT_EQ(none.goal_position_m[0], 0.0);
  // Unlearned cells (exploration/unlearned_cells.h) are said after the reason.
  r.unlearned_cells = 412;
  EXPECT_EQ(ToStatusMessage(r, context).reason,
            "replan period; 412 unlearned cells read as certain (not chased)");
}

// H(map) is the sum of the cells' binary entropies; certain cells add nothing.
TEST(StatusMessage, MapEntropyIsTheSumOfCellEntropies) {
  const std::vector<float> p{0.5f, 0.1f, 0.0f, 1.0f};
  OccupancyGridView view;
  view.dims = Eigen::Vector3i(2, 2, 1);
  view.probability = p.data();
  const double q = static_cast<double>(0.1f);
  EXPECT_NEAR(MapEntropyNats(view), std::log(2.0) - q * std::log(q) - (1 - q) * std::log(1 - q),
              1e-12);
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
