#include "bench/mapping/synthetic_scene.h"

#include <cmath>
#include <limits>

namespace kestrel::bench {

double RoomRange(const Eigen::Vector3d& o, const Eigen::Vector3d& u) {
  const double lo[3] = {-3.0, -3.5, -0.1};
  const double hi[3] = {3.0, 3.5, 1.45};
  double best = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (u[a] > 0.0) best = std::min(best, (hi[a] - o[a]) / u[a]);
    if (u[a] < 0.0) best = std::min(best, (lo[a] - o[a]) / u[a]);
  }
  return best;
}

Pose3 BodyPose(int i) {
  Pose3 X;
  X.p = Eigen::Vector3d(-1.5 + 0.3 * (i % 11), -2.0 + 0.4 * ((i * 7) % 11), 0.7);
  X.q = QuaternionFromYaw(0.9 * i);
  return X;
}

std::vector<DepthFrame> MakeDepthFrames(int width, int height, int count) {
  std::vector<DepthFrame> frames;
  const double kDeg = M_PI / 180.0;
  // Body (x fwd, y left, z up) to optical (z fwd, x right, y down).
  Eigen::Matrix3d R_BS;
  R_BS.col(0) = -Eigen::Vector3d::UnitY();
  R_BS.col(1) = -Eigen::Vector3d::UnitZ();
  R_BS.col(2) = Eigen::Vector3d::UnitX();
  for (int f = 0; f < count; ++f) {
    DepthFrame frame;
    const Pose3 X_WB = BodyPose(f);
    frame.X_WS.p = X_WB.p;
    frame.X_WS.q = Eigen::Quaterniond(X_WB.rotation() * R_BS).normalized();
    frame.width = width;
    frame.height = height;
    frame.intrinsics.fx = 0.5 * width / std::tan(29.0 * kDeg);
    frame.intrinsics.fy = 0.5 * height / std::tan(22.5 * kDeg);
    frame.intrinsics.cx = 0.5 * (width - 1);
    frame.intrinsics.cy = 0.5 * (height - 1);
    frame.depth.resize(static_cast<size_t>(width) * static_cast<size_t>(height));
    const Eigen::Matrix3d R_WS = frame.X_WS.rotation();
    for (int v = 0; v < height; ++v) {
      for (int u = 0; u < width; ++u) {
        const Eigen::Vector3d ray_S((u - frame.intrinsics.cx) / frame.intrinsics.fx,
                                    (v - frame.intrinsics.cy) / frame.intrinsics.fy, 1.0);
        const double range = RoomRange(frame.X_WS.p, R_WS * ray_S.normalized());
        const double depth_m = range / ray_S.norm();
        const size_t i =
            static_cast<size_t>(v) * static_cast<size_t>(width) + static_cast<size_t>(u);
        const bool dropout = i % 23 == 0;
        frame.depth[i] =
            (dropout || range >= 4.0) ? 0 : static_cast<uint16_t>(std::lround(depth_m * 1000.0));
      }
    }
    frames.push_back(std::move(frame));
  }
  return frames;
}

std::vector<ScanFrame> MakeScanFrames(int count) {
  std::vector<ScanFrame> frames;
  const double kStep = 239.77 / 681.0 * M_PI / 180.0;
  for (int f = 0; f < count; ++f) {
    ScanFrame frame;
    frame.X_WS = BodyPose(f + 1000);
    frame.X_WS.p.z() = 0.6;
    frame.angle_min_rad = -0.5 * 681 * kStep;
    frame.angle_step_rad = kStep;
    const Eigen::Matrix3d R = frame.X_WS.rotation();
    for (int i = 0; i < 682; ++i) {
      const double a = frame.angle_min_rad + i * kStep;
      const double range =
          RoomRange(frame.X_WS.p, R * Eigen::Vector3d(std::cos(a), std::sin(a), 0));
      frame.ranges_m.push_back(range >= 4.0 ? std::numeric_limits<float>::infinity()
                                            : static_cast<float>(range));
    }
    frames.push_back(std::move(frame));
  }
  return frames;
}

}  // namespace kestrel::bench
