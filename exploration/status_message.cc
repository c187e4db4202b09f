#include "exploration/status_message.h"

#include <limits>

namespace kestrel {

grid_map_t ToGridMapMessage(const GridMap2D& map, const std::string& name, int64_t utime,
                            int64_t seq, int64_t epoch) {
  grid_map_t msg;
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
  msg.num_values = static_cast<int32_t>(map.values.size());
  msg.values.assign(map.values.begin(), map.values.end());
  return msg;
}

exploration_status_t ToStatusMessage(const PlanResult& result, ExplorationMode mode, int8_t state,
                                     double map_entropy_nats, double height_m, int64_t utime,
                                     int64_t seq, int64_t epoch) {
  exploration_status_t msg;
  msg.utime = utime;
  msg.seq = seq;
  msg.epoch = epoch;
  msg.mode = ModeName(mode);
  msg.state = state;
  msg.reason = result.reason;
  msg.map_entropy_nats = map_entropy_nats;
  msg.best_unweighted_gain_nats = mode == ExplorationMode::kFrontier
                                      ? result.best_unweighted_gain_nats
                                      : result.end_test_gain_nats;
  msg.chosen_index = result.chosen;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  msg.goal_position_m[0] = msg.goal_position_m[1] = msg.goal_position_m[2] = nan;
  msg.goal_yaw_rad = nan;
  if (result.chosen >= 0) {
    const Candidate& goal = result.candidates[static_cast<size_t>(result.chosen)];
    msg.goal_position_m[0] = goal.position_m.x();
    msg.goal_position_m[1] = goal.position_m.y();
    msg.goal_position_m[2] = height_m;
    msg.goal_yaw_rad = goal.yaw_rad;
  }
  msg.num_candidates = static_cast<int32_t>(result.candidates.size());
  msg.candidates.reserve(result.candidates.size());
  for (const Candidate& c : result.candidates) {
    candidate_t m;
    m.position_m[0] = c.position_m.x();
    m.position_m[1] = c.position_m.y();
    m.position_m[2] = height_m;
    m.yaw_rad = c.yaw_rad;
    m.gain_nats = c.gain_nats;
    m.distance_m = c.distance_m;
    m.bump = c.bump;
    m.objective = c.objective();
    msg.candidates.push_back(m);
  }
  msg.projection_time_s = result.timings.projection_s;
  msg.gain_time_s = result.timings.gain_s;
  msg.dijkstra_time_s = result.timings.dijkstra_s;
  msg.trajectory_time_s = result.timings.trajectory_s;
  msg.total_time_s = result.timings.total_s;
  return msg;
}

}  // namespace kestrel
