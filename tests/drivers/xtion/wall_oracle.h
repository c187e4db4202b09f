#pragma once
// The test oracle for the plugin's synthetic wall, written from the geometry and independent of
// the plugin's RenderWall: intersect each pixel's viewing ray with the plane (Eigen), take the
// hit's z, and convert to counts. Shared by the unit and the OpenNI2 tests.
#include <Eigen/Dense>
#include <cmath>
#include <cstdint>
#include <vector>

namespace kestrel::test {

struct WallOracle {
  double distance_m;  // plane distance along its normal
  double tilt_rad;    // normal turned about y
  double pitch_rad;   // normal turned towards +y
  int dead_columns;   // left columns with no return

  // Expected counts of a width x height image at scale depth_scale_m, and in `ambiguous` the
  // pixels whose exact value lies within 1e-6 count of a rounding boundary (either answer is
  // right there).
  std::vector<uint16_t> Render(int width, int height, double depth_scale_m,
                               std::vector<bool>* ambiguous) const {
    const double hfov = 58.0 * M_PI / 180.0;
    const double vfov = 45.0 * M_PI / 180.0;
    const Eigen::Vector3d n(std::sin(tilt_rad) * std::cos(pitch_rad), std::sin(pitch_rad),
                            std::cos(tilt_rad) * std::cos(pitch_rad));
    std::vector<uint16_t> out(static_cast<size_t>(width) * height, 0);
    ambiguous->assign(out.size(), false);
    for (int v = 0; v < height; ++v) {
      for (int u = dead_columns; u < width; ++u) {
        // Ray direction from the pixel's angles: the image plane at z = 1 spans tan(fov/2)
        // across half the image width (pixel edges at -0.5 and w - 0.5).
        const double x = std::tan(hfov / 2) * (2.0 * (u + 0.5) / width - 1.0);
        const double y = std::tan(vfov / 2) * (2.0 * (v + 0.5) / height - 1.0);
        const Eigen::Vector3d dir = Eigen::Vector3d(x, y, 1.0).normalized();
        const double along = n.dot(dir);
        if (along <= 0.0) continue;
        const Eigen::Vector3d hit = dir * (distance_m / along);
        if (hit.z() > 10.0) continue;
        const double exact = hit.z() / depth_scale_m;
        const double frac = exact - std::floor(exact);
        (*ambiguous)[static_cast<size_t>(v) * width + u] = std::abs(frac - 0.5) < 1e-6;
        const long count = std::lround(exact);
        if (count > 65535) continue;
        out[static_cast<size_t>(v) * width + u] = static_cast<uint16_t>(count);
      }
    }
    return out;
  }
};

// Number of pixels where `got` differs from `want`, not counting ambiguous pixels off by one.
inline int64_t CountMismatches(const std::vector<uint16_t>& got, const std::vector<uint16_t>& want,
                               const std::vector<bool>& ambiguous) {
  if (got.size() != want.size()) return static_cast<int64_t>(std::max(got.size(), want.size()));
  int64_t bad = 0;
  for (size_t i = 0; i < got.size(); ++i) {
    const int diff = std::abs(static_cast<int>(got[i]) - static_cast<int>(want[i]));
    if (diff > (ambiguous[i] ? 1 : 0)) ++bad;
  }
  return bad;
}

}  // namespace kestrel::test
