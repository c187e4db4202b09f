#pragma once
/// @file
/// A deterministic synthetic sensor stream for mapper tests: the vehicle turns in place at
/// (0, 0, 0.8) inside a box room (x -3..3, y -4..4, z 0..2.5 m); depth images (exact ray-plane
/// depths, 1 mm counts, 0 beyond 4 m) and planar scans (0 = no return beyond 4 m) are rendered
/// from the true pose; poses at 100 Hz. Messages come out in time order with sequence numbers
/// and one publisher epoch, as a recorded log replays them (the same epoch every time).

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <Eigen/Core>

#include "common/se3.h"
#include "kestrel/depth_image_t.hpp"
#include "kestrel/planar_scan_t.hpp"
#include "kestrel/pose_t.hpp"

namespace kestrel::testing {

/// Distance along unit `d` from `o` to the inside of the box room, +inf if none.
inline double RoomHit(const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  const Eigen::Vector3d lo(-3.0, -4.0, 0.0), hi(3.0, 4.0, 2.5);
  double best = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (d[a] > 1e-12) best = std::min(best, (hi[a] - o[a]) / d[a]);
    if (d[a] < -1e-12) best = std::min(best, (lo[a] - o[a]) / d[a]);
  }
  return best;
}

struct StreamEvent {
  enum class Kind { kPose, kDepth, kScan } kind;
  pose_t pose;
  depth_image_t depth;
  planar_scan_t scan;
  int64_t utime;
};

/// The vehicle's pose at time t (s): yaw 0.6 rad/s, slight bob.
inline Pose3 TruePose(double t) {
  Pose3 X_WB;
  X_WB.p = Eigen::Vector3d(0.3 * std::sin(0.2 * t), 0.0, 0.8 + 0.05 * std::sin(t));
  X_WB.q = QuaternionFromYaw(0.6 * t);
  return X_WB;
}

/// The publisher epoch of the synthetic stream (a recording: fixed, so replays match).
inline constexpr int64_t kStreamEpoch = 0x5eed0001;

/// Renders `seconds` of stream: poses at 100 Hz, depth (w x h) at 10 Hz, scans (181 beams) at
/// 10 Hz, with the given extrinsics, every message of publisher epoch `epoch`. Sensor stamps fall
/// between pose stamps.
inline std::vector<StreamEvent> MakeStream(double seconds, const Pose3& X_BS_depth,
                                           const Pose3& X_BS_scan, int w = 32, int h = 24,
                                           int64_t start_utime = 1000000,
                                           int64_t epoch = kStreamEpoch) {
  std::vector<StreamEvent> events;
  const double fx = (w / 2.0) / std::tan(0.5 * 58.0 * M_PI / 180.0);
  const double fy = (h / 2.0) / std::tan(0.5 * 45.0 * M_PI / 180.0);
  int64_t pose_seq = 0, depth_seq = 0, scan_seq = 0;
  for (int k = 0; k <= static_cast<int>(seconds * 100); ++k) {
    const double t = k * 0.01;
    const int64_t utime = start_utime + k * 10000;
    StreamEvent pe{StreamEvent::Kind::kPose, {}, {}, {}, utime};
    const Pose3 X_WB = TruePose(t);
    pe.pose.utime = utime;
    pe.pose.seq = pose_seq++;
    pe.pose.epoch = epoch;
    pe.pose.frame_id = "world";
    pe.pose.child_frame_id = "kestrel";
    pe.pose.valid = true;
    for (int a = 0; a < 3; ++a) pe.pose.position_m[a] = X_WB.p[a];
    pe.pose.orientation_wxyz[0] = X_WB.q.w();
    pe.pose.orientation_wxyz[1] = X_WB.q.x();
    pe.pose.orientation_wxyz[2] = X_WB.q.y();
    pe.pose.orientation_wxyz[3] = X_WB.q.z();
    pe.pose.has_velocity = false;
    events.push_back(pe);
    if (k % 10 == 5) {  // sensors at 10 Hz, stamped 3 ms after a pose
      const int64_t s_utime = utime + 3000;
      const Pose3 X_WB_s = TruePose(t + 0.003);
      StreamEvent de{StreamEvent::Kind::kDepth, {}, {}, {}, s_utime};
      depth_image_t& img = de.depth;
      img.utime = s_utime;
      img.seq = depth_seq++;
      img.epoch = epoch;
      img.sensor_name = "xtion";
      img.width = w;
      img.height = h;
      img.fx_px = fx;
      img.fy_px = fy;
      img.cx_px = (w - 1) / 2.0;
      img.cy_px = (h - 1) / 2.0;
      img.depth_scale_m = 0.001;
      img.range_min_m = 0.5;
      img.range_max_m = 4.0;
      img.encoding = depth_image_t::ENCODING_RAW_U16;
      img.data.resize(static_cast<size_t>(w * h * 2));
      const Pose3 X_WS = X_WB_s * X_BS_depth;
      for (int v = 0; v < h; ++v) {
        for (int u = 0; u < w; ++u) {
          const Eigen::Vector3d ray_S((u - img.cx_px) / fx, (v - img.cy_px) / fy, 1.0);
          const Eigen::Vector3d d_W = (X_WS.q * ray_S).normalized();
          const double range = RoomHit(X_WS.p, d_W);
          const double z = range / ray_S.norm();
          const uint16_t count = z < 4.0 ? static_cast<uint16_t>(std::lround(z * 1000)) : 0;
          img.data[2 * (v * w + u)] = static_cast<uint8_t>(count & 0xff);
          img.data[2 * (v * w + u) + 1] = static_cast<uint8_t>(count >> 8);
        }
      }
      img.data_size = static_cast<int32_t>(img.data.size());
      events.push_back(de);

      StreamEvent se{StreamEvent::Kind::kScan, {}, {}, {}, s_utime + 1000};
      planar_scan_t& scan = se.scan;
      scan.utime = s_utime + 1000;
      scan.seq = scan_seq++;
      scan.epoch = epoch;
      scan.sensor_name = "hokuyo";
      scan.angle_min_rad = static_cast<float>(-M_PI / 2);
      scan.angle_step_rad = static_cast<float>(M_PI / 180);
      scan.range_min_m = 0.02f;
      scan.range_max_m = 5.6f;
      const Pose3 X_WL = TruePose(t + 0.004) * X_BS_scan;
      for (int i = 0; i < 181; ++i) {
        const double angle = scan.angle_min_rad + i * scan.angle_step_rad;
        const Eigen::Vector3d d_W = X_WL.q * Eigen::Vector3d(std::cos(angle), std::sin(angle), 0);
        const double range = RoomHit(X_WL.p, d_W);
        scan.ranges_m.push_back(range < 4.0 ? static_cast<float>(range) : 0.0f);
      }
      scan.num_ranges = 181;
      scan.num_intensities = 0;
      events.push_back(se);
    }
  }
  return events;
}

}  // namespace kestrel::testing
