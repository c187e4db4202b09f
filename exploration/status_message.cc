#include "exploration/status_message.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

namespace kestrel {

grid_map_t ToGridMapMessage(const GridMap2D& map, const std::string& name, int64_t utime,
                            int64_t seq, int64_t epoch) {
  grid_map_t msg{};
  msg.utime = utime;
  msg.seq = seq;
  msg.epoch = epoch;
  msg.name = name;
  msg.origin_m[0] = map.origin_m.x();
  msg.origin_m[1] = map.origin_m.y();
  msg.height_m = map.height_m;
  msg.resolution_m = map.resolution_m;
  msg.width = map.width;
  msg.height = map.height;
  msg.values.assign(map.values.begin(), map.values.end());
  msg.num_values = static_cast<int32_t>(msg.values.size());
  return msg;
}

exploration_status_t ToStatusMessage(const PlanResult& result, const StatusContext& context) {
  exploration_status_t msg{};
  msg.utime = context.utime;
  msg.seq = context.seq;
  msg.epoch = context.epoch;
  msg.mode = ModeName(context.mode);
  msg.state = static_cast<int8_t>(context.state);
  msg.reason = result.reason.empty() ? context.reason : context.reason + ": " + result.reason;
  if (result.unlearned_cells > 0) {
    msg.reason += "; " + std::to_string(result.unlearned_cells) +
                  " unlearned cells read as certain (not chased)";
  }
  msg.map_entropy_nats = context.map_entropy_nats;
  msg.best_unweighted_gain_nats = result.best_unweighted_gain_nats;
  std::vector<int> order(result.candidates.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return result.candidates[static_cast<size_t>(a)].objective() >
           result.candidates[static_cast<size_t>(b)].objective();
  });
  if (static_cast<int>(order.size()) > context.max_candidates) {
    order.resize(static_cast<size_t>(context.max_candidates));
  }
  msg.chosen_index = -1;
  for (size_t i = 0; i < order.size(); ++i) {
    const Candidate& c = result.candidates[static_cast<size_t>(order[i])];
    candidate_t m{};
    m.position_m[0] = c.position_m.x();
    m.position_m[1] = c.position_m.y();
    m.position_m[2] = context.height_m;
    m.yaw_rad = c.yaw_rad;
    m.gain_nats = c.gain_nats;
    m.distance_m = c.distance_m;
    m.bump = c.bump;
    m.objective = c.objective();
    msg.candidates.push_back(m);
    if (order[i] == result.chosen) msg.chosen_index = static_cast<int32_t>(i);
  }
  msg.num_candidates = static_cast<int32_t>(msg.candidates.size());
  if (result.chosen >= 0 && result.chosen < static_cast<int>(result.candidates.size())) {
    const Candidate& c = result.candidates[static_cast<size_t>(result.chosen)];
    msg.goal_position_m[0] = c.position_m.x();
    msg.goal_position_m[1] = c.position_m.y();
    msg.goal_position_m[2] = context.height_m;
    msg.goal_yaw_rad = c.yaw_rad;
  }
  msg.projection_time_s = result.timings.projection_s;
  msg.gain_time_s = result.timings.gain_s;
  msg.dijkstra_time_s = result.timings.dijkstra_s;
  msg.trajectory_time_s = result.timings.trajectory_s;
  msg.total_time_s = result.timings.total_s;
  return msg;
}

double MapEntropyNats(const OccupancyGridView& map) {
  double entropy = 0.0;
  const size_t n = static_cast<size_t>(map.dims.prod());
  for (size_t i = 0; i < n; ++i) {
    const double q = map.probability[i];
    if (q > 0 && q < 1) entropy += -q * std::log(q) - (1 - q) * std::log(1 - q);
  }
  return entropy;
}

}  // namespace kestrel
