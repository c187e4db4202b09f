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
      drops_(clock),
      epoch_(NewPublisherEpoch()),
      next_heartbeat_utime_(clock.NowUtime() + 1000000),
      wall_at_heartbeat_(std::chrono::steady_clock::now()),
      utime_at_heartbeat_(clock.NowUtime()) {
  auto on_error = [this](const std::string& channel, const std::string& reason) {
    Reject("malformed", channel, reason);
  };
  for (size_t k = 0; k < simulator_->num_vehicles(); ++k) {
    const SimConfig& c = simulator_->config();
    VehicleChannels ch;
    ch.pose = c.ChannelOf(k, c.pose_channel);
    ch.imu = c.ChannelOf(k, c.imu_channel);
    ch.depth = c.SensorChannelOf(k, c.depth_channel);
    ch.scan = c.SensorChannelOf(k, c.scan_channel);
    ch.truth = c.ChannelOf(k, c.truth_channel);
    ch.motor = c.ChannelOf(k, c.motor_channel);
    ch.trajectory = c.ChannelOf(k, c.trajectory_channel);
    if (c.mode == "dynamic") {
      subscriptions_.Add<motor_command_t>(
          ch.motor,
          [this, k](const std::string&, const motor_command_t& msg) { OnMotorCommand(k, msg); },
          on_error);
    } else {
      subscriptions_.Add<trajectory_t>(
          ch.trajectory,
          [this, k](const std::string&, const trajectory_t& msg) { OnTrajectory(k, msg); },
          on_error);
    }
    channels_.push_back(ch);
  }
  heartbeat_.SetDropValues(drops_);
  heartbeat_.SetState(heartbeat_t::STATE_OK);
}

void SimNode::Reject(const std::string& kind, const std::string& channel,
                     const std::string& reason) {
  ++rejected_;
  drops_.Count(kind, channel + ": " + reason);
  heartbeat_.SetDropValues(drops_);
  heartbeat_.SetLastError(channel + ": " + reason);
  heartbeat_.SetValue("rejected_messages", static_cast<double>(rejected_));
}

void SimNode::OnMotorCommand(size_t k, const motor_command_t& msg) {
  if (msg.num_motors != 4) {
    Reject("refused", channels_[k].motor,
           "num_motors = " + std::to_string(msg.num_motors) + ", expected 4");
    return;
  }
  const Eigen::Vector4d thrust(msg.thrust_N[0], msg.thrust_N[1], msg.thrust_N[2], msg.thrust_N[3]);
  if (!simulator_->SetMotorCommand(thrust, msg.armed, k)) {
    Reject("refused", channels_[k].motor, "non-finite thrust");
  }
}

void SimNode::OnTrajectory(size_t k, const trajectory_t& msg) {
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
    Reject("refused", channels_[k].trajectory, error);
    return;
  }
  simulator_->SetTrajectory(*trajectory, k);
}

void SimNode::Step() {
  simulator_->Step();
  clock_.SetUtime(simulator_->utime());
  for (size_t k = 0; k < simulator_->num_vehicles(); ++k) Publish(k);
}

void SimNode::PublishHeartbeat() {
  const Simulator& sim = *simulator_;
  const int64_t now = sim.utime();
  const auto wall = std::chrono::steady_clock::now();
  const double wall_s = std::chrono::duration<double>(wall - wall_at_heartbeat_).count();
  if (wall_s > 0.0) real_time_factor_ = UtimeToSeconds(now - utime_at_heartbeat_) / wall_s;
  wall_at_heartbeat_ = wall;
  utime_at_heartbeat_ = now;
  next_heartbeat_utime_ += 1000000;
  heartbeat_.SetValue("real_time_factor", real_time_factor_);
  int collisions = sim.inter_vehicle_collision_count();
  for (size_t k = 0; k < sim.num_vehicles(); ++k) collisions += sim.vehicle(k).collision_count();
  heartbeat_.SetValue("collisions", collisions);
  if (sim.num_vehicles() > 1) {
    heartbeat_.SetValue("inter_vehicle_collisions", sim.inter_vehicle_collision_count());
  }
  heartbeat_.Publish();
}

void SimNode::Publish(size_t k) {
  const Simulator& sim = *simulator_;
  const SimConfig& config = sim.config();
  const SimFrame& frame = sim.frame(k);
  VehicleChannels& ch = channels_[k];
  for (const MotionCaptureSample& s : frame.poses) {
    pose_t msg;
    msg.utime = s.utime;
    msg.seq = ch.pose_seq++;
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
    lcm_.publish(ch.pose, &msg);
  }
  if (frame.imu.has_value()) {
    imu_t msg;
    msg.utime = frame.imu->utime;
    msg.seq = ch.imu_seq++;
    msg.epoch = epoch_;
    msg.sensor_name = "imu";
    for (int a = 0; a < 3; ++a) {
      msg.angular_velocity_radps[a] = frame.imu->angular_velocity_radps[a];
      msg.specific_force_mps2[a] = frame.imu->specific_force_mps2[a];
    }
    lcm_.publish(ch.imu, &msg);
  }
  if (frame.depth) {
    const DepthCamera& camera = sim.camera();
    depth_image_t msg;
    msg.utime = sim.depth_utime(k);
    msg.seq = ch.depth_seq++;
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
    EncodeDepthPixels(sim.depth_counts(k), depth_image_t::ENCODING_RAW_U16, 0, &msg);
    lcm_.publish(ch.depth, &msg);
  }
  if (frame.scan) {
    const PlanarLidarConfig& lidar = config.lidar;
    planar_scan_t msg;
    msg.utime = sim.scan_utime(k);
    msg.seq = ch.scan_seq++;
    msg.epoch = epoch_;
    msg.sensor_name = config.lidar_sensor_name;
    msg.angle_min_rad = static_cast<float>(lidar.angle_min_rad);
    msg.angle_step_rad = static_cast<float>(lidar.angle_step_rad);
    msg.time_step_s = 0.0f;  // all beams from one pose
    msg.range_min_m = static_cast<float>(lidar.range_min_m);
    msg.range_max_m = static_cast<float>(lidar.range_max_m);
    msg.ranges_m = sim.scan_ranges(k);
    msg.num_ranges = static_cast<int32_t>(msg.ranges_m.size());
    msg.num_intensities = 0;
    lcm_.publish(ch.scan, &msg);
  }
  const int64_t now = sim.utime();
  if (k == 0 && now >= next_heartbeat_utime_) PublishHeartbeat();
  if (frame.truth) {
    const QuadrotorState& s = sim.vehicle(k).state();
    sim_truth_t msg;
    msg.utime = now;
    msg.seq = ch.truth_seq++;
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
    // Contacts with the world and with the other vehicles.
    msg.in_collision =
        static_cast<int8_t>(sim.vehicle(k).in_collision() || sim.touches_another_vehicle(k));
    msg.collision_count = sim.vehicle(k).collision_count() + sim.vehicle_collision_count(k);
    msg.seed = config.seed;
    msg.real_time_factor = real_time_factor_;
    lcm_.publish(ch.truth, &msg);
  }
}

}  // namespace kestrel
