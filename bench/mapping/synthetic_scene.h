#pragma once
/// @file
/// Synthetic sensor frames for the mapping benchmarks: a closed room box inside the paper's map
/// (walls at x = +-3 m, y = +-3.5 m, floor z = -0.1 m, ceiling z = 1.45 m), sensors at 0.7 m
/// height at varied positions (|x| <= 1.5 m, |y| <= 2 m) and headings, so returns fall at
/// 0.5-4 m and a minority of rays (room corners) runs past 4 m. Depth images (Xtion-like
/// 58 x 45 deg field of view, uint16 mm) with rays beyond 4 m and every 23rd pixel set to 0
/// (no return); planar scans of 682 beams over 239.77 deg (Hokuyo URG-04LX), +inf beyond range.

#include <cstdint>
#include <vector>

#include "common/se3.h"
#include "mapping/scan_integrator.h"

namespace kestrel::bench {

/// One depth frame.
struct DepthFrame {
  Pose3 X_WS;                   ///< optical frame in W
  DepthIntrinsics intrinsics;   ///< pinhole, px
  int width{0};                 ///< px
  int height{0};                ///< px
  std::vector<uint16_t> depth;  ///< mm, row-major, 0 = no return
  double depth_scale_m{0.001};  ///< m per count
};

/// One planar scan.
struct ScanFrame {
  Pose3 X_WS;                   ///< LIDAR frame in W (x forward, z up)
  double angle_min_rad{0.0};    ///< first beam angle
  double angle_step_rad{0.0};   ///< beam spacing
  std::vector<float> ranges_m;  ///< m, +inf = no return
};

/// The room's range along a ray from o in direction u (unit), m (+inf if none).
[[nodiscard]] double RoomRange(const Eigen::Vector3d& o, const Eigen::Vector3d& u);

/// `count` depth frames of width x height from deterministic poses.
[[nodiscard]] std::vector<DepthFrame> MakeDepthFrames(int width, int height, int count);
/// `count` planar scans of 682 beams from deterministic poses.
[[nodiscard]] std::vector<ScanFrame> MakeScanFrames(int count);
/// The i-th deterministic sensor pose, body axes (x forward, z up).
[[nodiscard]] Pose3 BodyPose(int i);

}  // namespace kestrel::bench
