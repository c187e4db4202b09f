#pragma once
/// @file
/// Deterministic, non-trivial instances of every Kestrel message (every array non-empty, every
/// field away from its default), for round-trip, multi-process and logger tests.
/// ForEachMessageType(visitor) calls visitor.template operator()<T>() for every top-level type.

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "kestrel/candidate_t.hpp"
#include "kestrel/command_t.hpp"
#include "kestrel/controller_status_t.hpp"
#include "kestrel/depth_image_t.hpp"
#include "kestrel/exploration_status_t.hpp"
#include "kestrel/grid_map_t.hpp"
#include "kestrel/heartbeat_t.hpp"
#include "kestrel/imu_t.hpp"
#include "kestrel/map3d_chunk_t.hpp"
#include "kestrel/map3d_delta_t.hpp"
#include "kestrel/map_decisions_t.hpp"
#include "kestrel/map_status_t.hpp"
#include "kestrel/motor_command_t.hpp"
#include "kestrel/named_value_t.hpp"
#include "kestrel/param_t.hpp"
#include "kestrel/params_request_t.hpp"
#include "kestrel/params_t.hpp"
#include "kestrel/planar_scan_t.hpp"
#include "kestrel/pose_t.hpp"
#include "kestrel/procman_command_t.hpp"
#include "kestrel/procman_order_t.hpp"
#include "kestrel/procman_status_t.hpp"
#include "kestrel/sim_truth_t.hpp"
#include "kestrel/trajectory_t.hpp"

namespace kestrel::testing {

/// A seeded source of values, so that sample k of a type is the same in every process.
class Filler {
 public:
  explicit Filler(uint64_t seed) : rng_(seed) {}
  double Real() { return std::uniform_real_distribution<double>(-100.0, 100.0)(rng_); }
  int64_t Int() { return static_cast<int64_t>(rng_() >> 1); }
  int32_t Small(int32_t lo, int32_t hi) {
    return std::uniform_int_distribution<int32_t>(lo, hi)(rng_);
  }
  std::string Text() { return "s" + std::to_string(rng_() % 100000) + "-kestrel"; }
  template <size_t N>
  void Reals(double (&a)[N]) {
    for (double& v : a) v = Real();
  }
  std::vector<uint8_t> Bytes(int n) {
    std::vector<uint8_t> b(static_cast<size_t>(n));
    for (auto& v : b) v = static_cast<uint8_t>(rng_());
    return b;
  }

 private:
  std::mt19937_64 rng_;
};

inline void Fill(Filler& f, named_value_t* m) {
  m->name = f.Text();
  m->value = f.Real();
}
inline void Fill(Filler& f, candidate_t* m) {
  f.Reals(m->position_m);
  m->yaw_rad = f.Real();
  m->gain_nats = f.Real();
  m->distance_m = f.Real();
  m->bump = f.Real();
  m->objective = f.Real();
}
inline void Fill(Filler& f, pose_t* m) {
  m->utime = f.Int();
  m->seq = f.Int();
  m->epoch = f.Int();
  m->frame_id = f.Text();
  m->child_frame_id = f.Text();
  m->valid = true;
  f.Reals(m->position_m);
  f.Reals(m->orientation_wxyz);
  m->has_velocity = true;
  f.Reals(m->velocity_mps);
  f.Reals(m->angular_velocity_radps);
}
inline void Fill(Filler& f, imu_t* m) {
  m->utime = f.Int();
  m->seq = f.Int();
  m->epoch = f.Int();
  m->sensor_name = f.Text();
  f.Reals(m->angular_velocity_radps);
  f.Reals(m->specific_force_mps2);
}
inline void Fill(Filler& f, depth_image_t* m) {
  m->utime = f.Int();
  m->seq = f.Int();
  m->epoch = f.Int();
  m->sensor_name = f.Text();
  m->width = 16;
  m->height = 12;
  m->fx_px = f.Real();
  m->fy_px = f.Real();
  m->cx_px = f.Real();
  m->cy_px = f.Real();
  m->depth_scale_m = 1e-3;
  m->range_min_m = 0.5;
  m->range_max_m = 4.0;
  m->encoding = depth_image_t::ENCODING_RAW_U16;
  m->data = f.Bytes(m->width * m->height * 2);
  m->data_size = static_cast<int32_t>(m->data.size());
}
inline void Fill(Filler& f, planar_scan_t* m) {
  m->utime = f.Int();
  m->seq = f.Int();
  m->epoch = f.Int();
  m->sensor_name = f.Text();
  m->angle_min_rad = -2.09f;
  m->angle_step_rad = 0.00614f;
  m->time_step_s = 1e-4f;
  m->range_min_m = 0.02f;
  m->range_max_m = 5.6f;
  m->num_ranges = 682;
  m->ranges_m.resize(682);
  m->num_intensities = 682;
  m->intensities.resize(682);
  for (int i = 0; i < 682; ++i) {
    m->ranges_m[i] = static_cast<float>(f.Real());
    m->intensities[i] = static_cast<float>(f.Real());
  }
}
inline void Fill(Filler& f, map3d_chunk_t* m) {
  m->utime = f.Int();
  m->snapshot_id = f.Int();
  m->map_seq = f.Int();
  m->epoch = f.Int();
  m->chunk_index = 2;
  m->num_chunks = 5;
  f.Reals(m->origin_m);
  m->resolution_m = 0.075;
  m->dims[0] = 107;
  m->dims[1] = 160;
  m->dims[2] = 22;
  m->p_init = 0.1;
  m->block_edge = 8;
  m->encoding = map3d_chunk_t::ENCODING_FLOAT32;
  m->num_blocks = 3;
  m->block_index.assign(3, std::vector<int32_t>(3));
  for (auto& b : m->block_index)
    for (auto& v : b) v = f.Small(0, 20);
  m->data = f.Bytes(3 * 512 * 4);
  m->data_size = static_cast<int32_t>(m->data.size());
}
inline void Fill(Filler& f, map3d_delta_t* m) {
  m->utime = f.Int();
  m->seq = f.Int();
  m->epoch = f.Int();
  m->prev_seq = f.Int();
  m->base_snapshot_id = f.Int();
  f.Reals(m->origin_m);
  m->resolution_m = 0.075;
  m->num_cells = 40;
  m->cells.assign(40, std::vector<int32_t>(3));
  m->probabilities.resize(40);
  for (int i = 0; i < 40; ++i) {
    for (auto& v : m->cells[i]) v = f.Small(-500, 500);
    m->probabilities[i] = static_cast<float>(f.Real());
  }
  m->encoding = map3d_delta_t::ENCODING_CELLS;
  m->num_packed_cells = 0;
  m->data_size = 0;
  m->data.clear();
}
inline void Fill(Filler& f, grid_map_t* m) {
  m->utime = f.Int();
  m->seq = f.Int();
  m->epoch = f.Int();
  m->name = f.Text();
  m->origin_m[0] = f.Real();
  m->origin_m[1] = f.Real();
  m->height_m = f.Real();
  m->resolution_m = 0.225;
  m->width = 9;
  m->height = 7;
  m->num_values = 63;
  m->values.resize(63);
  for (auto& v : m->values) v = static_cast<float>(f.Real());
}
inline void Fill(Filler& f, exploration_status_t* m) {
  m->utime = f.Int();
  m->seq = f.Int();
  m->epoch = f.Int();
  m->mode = f.Text();
  m->state = exploration_status_t::STATE_EXPLORING;
  m->reason = f.Text();
  m->map_entropy_nats = f.Real();
  m->best_unweighted_gain_nats = f.Real();
  m->chosen_index = 1;
  f.Reals(m->goal_position_m);
  m->goal_yaw_rad = f.Real();
  m->num_candidates = 4;
  m->candidates.resize(4);
  for (auto& c : m->candidates) Fill(f, &c);
  m->projection_time_s = f.Real();
  m->gain_time_s = f.Real();
  m->dijkstra_time_s = f.Real();
  m->trajectory_time_s = f.Real();
  m->total_time_s = f.Real();
}
inline void Fill(Filler& f, trajectory_t* m) {
  m->utime = f.Int();
  m->seq = f.Int();
  m->epoch = f.Int();
  m->start_utime = f.Int();
  m->num_segments = 3;
  m->num_coeffs = 8;
  m->durations_s = {1.0, 2.5, 0.7};
  for (auto* c : {&m->coeffs_x, &m->coeffs_y, &m->coeffs_z, &m->coeffs_yaw}) {
    c->assign(3, std::vector<double>(8));
    for (auto& row : *c)
      for (auto& v : row) v = f.Real();
  }
}
inline void Fill(Filler& f, motor_command_t* m) {
  m->utime = f.Int();
  m->seq = f.Int();
  m->epoch = f.Int();
  m->armed = true;
  m->num_motors = 4;
  m->thrust_N = {f.Real(), f.Real(), f.Real(), f.Real()};
  m->total_thrust_N = f.Real();
  f.Reals(m->moment_Nm);
}
inline void Fill(Filler& f, controller_status_t* m) {
  m->utime = f.Int();
  m->seq = f.Int();
  m->epoch = f.Int();
  m->mode = controller_status_t::MODE_TRACK;
  m->reason = f.Text();
  f.Reals(m->position_m);
  f.Reals(m->velocity_mps);
  f.Reals(m->orientation_wxyz);
  f.Reals(m->e_x_m);
  f.Reals(m->e_v_mps);
  f.Reals(m->e_R);
  f.Reals(m->e_W_radps);
  m->thrust_N = f.Real();
  f.Reals(m->moment_Nm);
  m->pose_age_s = f.Real();
  m->trajectory_seq = f.Int();
  m->trajectory_epoch = f.Int();
  m->trajectory_done = true;
}
inline void Fill(Filler& f, command_t* m) {
  m->utime = f.Int();
  m->seq = f.Int();
  m->epoch = f.Int();
  m->source = f.Text();
  m->command = command_t::COMMAND_LAND;
  m->height_m = f.Real();
}
inline void Fill(Filler& f, sim_truth_t* m) {
  m->utime = f.Int();
  m->seq = f.Int();
  m->epoch = f.Int();
  f.Reals(m->position_m);
  f.Reals(m->orientation_wxyz);
  f.Reals(m->velocity_mps);
  f.Reals(m->angular_velocity_radps);
  f.Reals(m->rotor_thrust_N);
  m->in_collision = true;
  m->collision_count = f.Small(1, 9);
  m->seed = f.Int();
  m->real_time_factor = f.Real();
}
inline void Fill(Filler& f, heartbeat_t* m) {
  m->utime = f.Int();
  m->seq = f.Int();
  m->epoch = f.Int();
  m->process = f.Text();
  m->host = f.Text();
  m->pid = f.Small(2, 99999);
  m->state = heartbeat_t::STATE_DEGRADED;
  m->uptime_s = f.Real();
  m->last_error = f.Text();
  m->num_values = 3;
  m->values.resize(3);
  for (auto& v : m->values) Fill(f, &v);
}
inline void Fill(Filler& f, map_status_t* m) {
  m->utime = f.Int();
  m->seq = f.Int();
  m->epoch = f.Int();
  m->map_seq = f.Int();
  m->map_entropy_nats = f.Real();
  m->rays_per_s = f.Real();
  m->cell_updates_per_s = f.Real();
  m->scans_applied = f.Int();
  m->scans_skipped = f.Int();
  m->num_skip_reasons = 2;
  m->skip_reasons.resize(2);
  for (auto& v : m->skip_reasons) Fill(f, &v);
  m->queue_depth = f.Small(0, 9);
  m->backlog_s = f.Real();
  m->ray_decimation = 0.5;
  m->applied_every_message = false;
}

inline void Fill(Filler& f, map_decision_t* m) {
  m->channel = f.Text();
  m->epoch = f.Int();
  m->seq = f.Int();
  m->scan_utime = f.Int();
  m->action = map_decision_t::ACTION_SKIPPED;
  m->ray_stride = static_cast<int16_t>(f.Small(1, 16));
  m->reason = f.Text();
  f.Reals(m->position_m);
  f.Reals(m->orientation_wxyz);
}
inline void Fill(Filler& f, map_decisions_t* m) {
  m->utime = f.Int();
  m->seq = f.Int();
  m->epoch = f.Int();
  m->first_index = f.Int();
  m->num_decisions = 2;
  m->decisions.resize(2);
  for (auto& d : m->decisions) Fill(f, &d);
  m->num_lives = 2;
  m->life_epochs = {f.Int(), f.Int()};
  m->life_decisions = {f.Int(), f.Int()};
}

inline void Fill(Filler& f, param_t* m) {
  m->file = f.Text();
  m->key = f.Text();
  m->value = f.Text();
  m->source = param_t::SOURCE_OVERRIDE;
}
inline void Fill(Filler& f, params_t* m) {
  m->utime = f.Int();
  m->seq = f.Int();
  m->epoch = f.Int();
  m->process = f.Text();
  m->host = f.Text();
  m->pid = f.Small(2, 99999);
  m->run_id = f.Text();
  m->config_file = f.Text();
  m->num_args = 2;
  m->args = {f.Text(), f.Text()};
  m->num_params = 3;
  m->params.resize(3);
  for (auto& p : m->params) Fill(f, &p);
}
inline void Fill(Filler& f, params_request_t* m) {
  m->utime = f.Int();
  m->seq = f.Int();
  m->epoch = f.Int();
  m->source = f.Text();
  m->process = f.Text();
}

inline void Fill(Filler& f, procman_command_t* m) {
  m->id = f.Text();
  m->group = f.Text();
  m->exec = f.Text();
  m->desired_running = true;
  m->state = procman_command_t::STATE_RESPAWN_WAIT;
  m->pid = f.Small(2, 99999);
  m->exit_code = f.Small(-9, 3);
  m->restarts = f.Small(0, 9);
  m->cpu_percent = f.Real();
  m->rss_mb = f.Real();
  m->uptime_s = f.Real();
}
inline void Fill(Filler& f, procman_status_t* m) {
  m->utime = f.Int();
  m->seq = f.Int();
  m->epoch = f.Int();
  m->host = f.Text();
  m->sheet = f.Text();
  m->script = f.Text();
  m->num_commands = 3;
  m->commands.resize(3);
  for (auto& c : m->commands) Fill(f, &c);
}
inline void Fill(Filler& f, procman_order_t* m) {
  m->utime = f.Int();
  m->seq = f.Int();
  m->epoch = f.Int();
  m->source = f.Text();
  m->host = f.Text();
  m->action = procman_order_t::ACTION_RESTART;
  m->is_group = true;
  m->target = f.Text();
}

/// Sample number `index` of type T: the same in every process.
template <typename T>
T MakeSample(uint64_t index) {
  Filler f(index * 7919 + std::hash<std::string>{}(T::getTypeName()) % 1000003);
  T m;
  Fill(f, &m);
  return m;
}

/// Encodes a message into bytes.
template <typename T>
std::vector<uint8_t> Encode(const T& m) {
  std::vector<uint8_t> bytes(static_cast<size_t>(m.getEncodedSize()));
  m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

/// Calls visitor.template Visit<T>(channel) for every top-level Kestrel type, each on a channel
/// named after the type ("TEST_pose_t", ...).
template <typename Visitor>
void ForEachMessageType(Visitor&& v) {
  v.template Visit<pose_t>();
  v.template Visit<imu_t>();
  v.template Visit<depth_image_t>();
  v.template Visit<planar_scan_t>();
  v.template Visit<map3d_chunk_t>();
  v.template Visit<map3d_delta_t>();
  v.template Visit<grid_map_t>();
  v.template Visit<exploration_status_t>();
  v.template Visit<trajectory_t>();
  v.template Visit<motor_command_t>();
  v.template Visit<controller_status_t>();
  v.template Visit<command_t>();
  v.template Visit<sim_truth_t>();
  v.template Visit<heartbeat_t>();
  v.template Visit<map_status_t>();
  v.template Visit<map_decisions_t>();
  v.template Visit<procman_status_t>();
  v.template Visit<procman_order_t>();
  v.template Visit<params_t>();
  v.template Visit<params_request_t>();
}

/// Number of top-level types ForEachMessageType visits.
inline constexpr int kNumMessageTypes = 20;

}  // namespace kestrel::testing
