#include "sim/sim_node.h"

#include <cstring>

#include "common/check.h"
#include "common/identity.h"
#include "kestrel/depth_image_t.hpp"
#include "kestrel/imu_t.hpp"
#include "kestrel/planar_scan_t.hpp"
#include "kestrel/pose_t.hpp"
#include "kestrel/sim_truth_t.hpp"
#include "lcmtypes/message_codecs.h"

namespace kestrel {

SimNode::SimNode(lcm::LCM& lcm, const SimConfig& config, SimClock& clock)
    : lcm_(lcm),
      clock_(clock),
      simulator_(std::make_unique<Simulator>(config, clock.NowUtime())),
      subscriptions_(lcm),
      heartbeat_(lcm, clock, "kestrel-sim", config.heartbeat_channel),
      epoch_(NewPublisherEpoch()),
      next_heartbeat_utime_(clock.NowUtime() + 1000000),
      wall_at_heartbeat_(std::chrono::steady_clock::now()),
      utime_at_heartbeat_(clock.NowUtime()) {
  auto on_error = [this](const std::string& channel, const std::string& reason) {
    Reject(channel, reason);
  };
  if (config.mode == "dynamic") {
    subscriptions_.Add<motor_command_t>(
        config.motor_channel,
        [this](const std::string&, const motor_command_t& msg) { OnMotorCommand(msg); }, on_error);
  } else {
    subscriptions_.Add<trajectory_t>(
        config.trajectory_channel,
        [this](const std::string&, const trajectory_t& msg) { OnTrajectory(msg); }, on_error);
  }
  heartbeat_.SetState(heartbeat_t::STATE_OK);
}

void SimNode::Reject(const std::string& channel, const std::string& reason) {
  ++rejected_;
  heartbeat_.SetLastError(channel + ": " + reason);
  heartbeat_.SetValue("rejected_messages", static_cast<double>(rejected_));
}

void SimNode::OnMotorCommand(const motor_command_t& msg) {
  if (msg.num_motors != 4) {
    Reject(simulator_->config().motor_channel,
           "num_motors = " + std::to_string(msg.num_motors) + ", expected 4");
    return;
  }
  const Eigen::Vector4d thrust(msg.thrust_N[0], msg.thrust_N[1], msg.thrust_N[2], msg.thrust_N[3]);
  if (!simulator_->SetMotorCommand(thrust, msg.armed)) {
    Reject(simulator_->config().motor_channel, "non-finite thrust");
  }
}

void SimNode::OnTrajectory(const trajectory_t& msg) {
  const int n = msg.num_segments;
  const int c = msg.num_coeffs;
  std::vector<double> x, y, z, yaw;
  for (int s = 0; s < n; ++s) {
    for (int j = 0; j < c; ++j) {
      x.push_back(msg.coeffs_x[static_cast<size_t>(s)][static_cast<size_t>(j)]);
      y.push_back(msg.coeffs_y[static_cast<size_t>(s)][static_cast<size_t>(j)]);
      z.push_back(msg.coeffs_z[static_cast<size_t>(s)][static_cast<size_t>(j)]);
      yaw.push_back(msg.coeffs_yaw[static_cast<size_t>(s)][static_cast<size_t>(j)]);
    }
  }
  std::string error;
  const auto trajectory = PiecewisePolynomialTrajectory::CreateFromFlat(
      UtimeToSeconds(msg.start_utime), msg.durations_s, c, x, y, z, yaw, &error);
  if (!trajectory.has_value()) {
    Reject(simulator_->config().trajectory_channel, error);
    return;
  }
  simulator_->SetTrajectory(*trajectory);
}

void SimNode::Step() {
  const SimFrame& frame = simulator_->Step();
  clock_.SetUtime(simulator_->utime());
  Publish(frame);
}

void SimNode::Publish(const SimFrame& frame) {
  const Simulator& sim = *simulator_;
  const SimConfig& config = sim.config();
  for (const MotionCaptureSample& s : frame.poses) {
    pose_t msg;
    msg.utime = s.utime;
    msg.seq = pose_seq_++;
    msg.epoch = epoch_;
    msg.frame_id = "world";
    msg.child_frame_id = "kestrel";
    msg.valid = static_cast<int8_t>(s.valid);
    for (int a = 0; a < 3; ++a) msg.position_m[a] = s.valid ? s.X_WB.p[a] : 0.0;
    msg.orientation_wxyz[0] = s.valid ? s.X_WB.q.w() : 1.0;
    msg.orientation_wxyz[1] = s.valid ? s.X_WB.q.x() : 0.0;
    msg.orientation_wxyz[2] = s.valid ? s.X_WB.q.y() : 0.0;
    msg.orientation_wxyz[3] = s.valid ? s.X_WB.q.z() : 0.0;
    msg.has_velocity = false;
    for (int a = 0; a < 3; ++a) msg.velocity_mps[a] = msg.angular_velocity_radps[a] = 0.0;
    lcm_.publish(config.pose_channel, &msg);
  }
  if (frame.imu.has_value()) {
    imu_t msg;
    msg.utime = frame.imu->utime;
    msg.seq = imu_seq_++;
    msg.epoch = epoch_;
    msg.sensor_name = "imu";
    for (int a = 0; a < 3; ++a) {
      msg.angular_velocity_radps[a] = frame.imu->angular_velocity_radps[a];
      msg.specific_force_mps2[a] = frame.imu->specific_force_mps2[a];
    }
    lcm_.publish(config.imu_channel, &msg);
  }
  if (frame.depth) {
    const DepthCamera& camera = sim.camera();
    depth_image_t msg;
    msg.utime = sim.depth_utime();
    msg.seq = depth_seq_++;
    msg.epoch = epoch_;
    msg.sensor_name = config.depth_sensor_name;
    msg.width = config.depth.width_px;
    msg.height = config.depth.height_px;
    msg.fx_px = camera.fx_px();
    msg.fy_px = camera.fy_px();
    msg.cx_px = camera.cx_px();
    msg.cy_px = camera.cy_px();
    msg.depth_scale_m = config.depth.depth_scale_m;
    msg.range_min_m = config.depth.range_min_m;
    msg.range_max_m = config.depth.range_max_m;
    EncodeDepthPixels(sim.depth_counts(), depth_image_t::ENCODING_RAW_U16, 0, &msg);
    lcm_.publish(config.depth_channel, &msg);
  }
  if (frame.scan) {
    const PlanarLidarConfig& lidar = config.lidar;
    planar_scan_t msg;
    msg.utime = sim.scan_utime();
    msg.seq = scan_seq_++;
    msg.epoch = epoch_;
    msg.sensor_name = config.lidar_sensor_name;
    msg.angle_min_rad = static_cast<float>(lidar.angle_min_rad);
    msg.angle_step_rad = static_cast<float>(lidar.angle_step_rad);
    msg.time_step_s = 0.0f;  // all beams from one pose
    msg.range_min_m = static_cast<float>(lidar.range_min_m);
    msg.range_max_m = static_cast<float>(lidar.range_max_m);
    msg.ranges_m = sim.scan_ranges();
    msg.num_ranges = static_cast<int32_t>(msg.ranges_m.size());
    msg.num_intensities = 0;
    lcm_.publish(config.scan_channel, &msg);
  }
  const int64_t now = sim.utime();
  if (now >= next_heartbeat_utime_) {
    const auto wall = std::chrono::steady_clock::now();
    const double wall_s = std::chrono::duration<double>(wall - wall_at_heartbeat_).count();
    if (wall_s > 0.0) real_time_factor_ = UtimeToSeconds(now - utime_at_heartbeat_) / wall_s;
    wall_at_heartbeat_ = wall;
    utime_at_heartbeat_ = now;
    next_heartbeat_utime_ += 1000000;
    heartbeat_.SetValue("real_time_factor", real_time_factor_);
    heartbeat_.SetValue("collisions", sim.vehicle().collision_count());
    heartbeat_.Publish();
  }
  if (frame.truth) {
    const QuadrotorState& s = sim.vehicle().state();
    sim_truth_t msg;
    msg.utime = now;
    msg.seq = truth_seq_++;
    msg.epoch = epoch_;
    for (int a = 0; a < 3; ++a) {
      msg.position_m[a] = s.p_W[a];
      msg.velocity_mps[a] = s.v_W[a];
      msg.angular_velocity_radps[a] = s.w_B[a];
    }
    msg.orientation_wxyz[0] = s.q_WB.w();
    msg.orientation_wxyz[1] = s.q_WB.x();
    msg.orientation_wxyz[2] = s.q_WB.y();
    msg.orientation_wxyz[3] = s.q_WB.z();
    for (int i = 0; i < 4; ++i) msg.rotor_thrust_N[i] = s.thrust_N[i];
    msg.in_collision = static_cast<int8_t>(sim.vehicle().in_collision());
    msg.collision_count = sim.vehicle().collision_count();
    msg.seed = config.seed;
    msg.real_time_factor = real_time_factor_;
    lcm_.publish(config.truth_channel, &msg);
  }
}

}  // namespace kestrel
