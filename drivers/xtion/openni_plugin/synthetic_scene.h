#pragma once
/// @file
/// The frame sources of Kestrel's OpenNI2 test plugin, kept free of OpenNI so they can be unit
/// tested: an analytic scene (a plane "wall" seen by a pinhole camera, so the depth of every pixel
/// is a closed-form expression) and a folder of raw u16 frames.
///
/// Camera convention (shared with kestrel-xtion, drivers/xtion/xtion_pure.h): optical frame S
/// (z forward, x right, y down); for a w x h image with horizontal / vertical field of view
/// hfov / vfov: fx = (w/2) / tan(hfov/2), fy = (h/2) / tan(vfov/2), cx = (w-1)/2, cy = (h-1)/2
/// (pixel centres at integer coordinates, the optical axis through the image centre).

#include <cstdint>
#include <string>
#include <vector>

namespace kestrel::oni_plugin {

/// Xtion / PS1080 field of view: 58 x 45 degrees (docs/protocols.md §2.1), in radians.
inline constexpr double kHorizontalFovRad = 58.0 * 3.14159265358979323846 / 180.0;
inline constexpr double kVerticalFovRad = 45.0 * 3.14159265358979323846 / 180.0;
/// Largest depth the plugin reports, metres (PS1080 reports up to 10000 mm); farther is 0.
inline constexpr double kMaxDepthM = 10.0;

/// A plane wall in front of the camera: the points X_S with n . X_S = distance_m, where
/// n = (sin(tilt) cos(pitch), sin(pitch), cos(tilt) cos(pitch)) (the wall's normal turned by
/// tilt_rad about the camera's y axis and by pitch_rad towards +y).
/// Frame k moves the wall back by step_m * (k mod period_frames), so stale frames are visible.
/// Columns u < dead_columns report 0 ("no return"), like the PS1080's blind left edge.
struct WallScene {
  double distance_m{2.0};  ///< wall distance along its normal at frame 0, metres, > 0
  double tilt_rad{0.3};    ///< rotation of the wall about the camera y axis, |tilt| < pi/2
  double pitch_rad{0.15};  ///< tilt of the normal towards +y (down), |pitch| < pi/2
  double step_m{0.001};    ///< per-frame recession, metres, >= 0
  int period_frames{50};   ///< the recession repeats every period_frames frames, >= 1
  int dead_columns{8};     ///< left columns that report no return, >= 0
};

/// Wall distance of frame `frame_index` (0-based), metres.
[[nodiscard]] double WallDistanceM(const WallScene& scene, int64_t frame_index);

/// Fills `out` (width*height counts, row-major) with the depth of `scene` at frame `frame_index`:
/// count = round(z / depth_scale_m) where z is the optical-axis depth of the wall along the
/// pixel's ray; 0 where the ray misses the wall, z > kMaxDepthM, the count exceeds 65535, or
/// u < dead_columns.
/// @throws std::invalid_argument on a non-positive size or scale.
void RenderWall(const WallScene& scene, int width, int height, double depth_scale_m,
                int64_t frame_index, std::vector<uint16_t>* out);

/// Raw u16 frames (little-endian, row-major, any byte count) read from `*.raw` files of a folder,
/// in name order, served cyclically.
class RawFrameFolder {
 public:
  /// Reads every `*.raw` regular file in `dir`. @throws std::runtime_error if none is found.
  explicit RawFrameFolder(const std::string& dir);
  /// Copies frame (frame_index mod count) into `out` if it holds exactly width*height pixels;
  /// returns false (and leaves `out` untouched) otherwise.
  bool Fill(int width, int height, int64_t frame_index, std::vector<uint16_t>* out) const;
  [[nodiscard]] int size() const { return static_cast<int>(frames_.size()); }

 private:
  std::vector<std::vector<uint16_t>> frames_;
};

}  // namespace kestrel::oni_plugin
