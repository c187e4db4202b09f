#include "drivers/xtion/openni_plugin/synthetic_scene.h"

#include <dirent.h>
#include <sys/stat.h>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <stdexcept>

namespace kestrel::oni_plugin {

double WallDistanceM(const WallScene& scene, int64_t frame_index) {
  const int64_t period = std::max(1, scene.period_frames);
  return scene.distance_m + scene.step_m * static_cast<double>(frame_index % period);
}

void RenderWall(const WallScene& scene, int width, int height, double depth_scale_m,
                int64_t frame_index, std::vector<uint16_t>* out) {
  if (width <= 0 || height <= 0 || !(depth_scale_m > 0.0)) {
    throw std::invalid_argument("RenderWall: width, height and depth_scale_m must be positive");
  }
  const double fx = 0.5 * width / std::tan(0.5 * kHorizontalFovRad);
  const double fy = 0.5 * height / std::tan(0.5 * kVerticalFovRad);
  const double cx = 0.5 * (width - 1);
  const double cy = 0.5 * (height - 1);
  const double nx = std::sin(scene.tilt_rad) * std::cos(scene.pitch_rad);
  const double ny = std::sin(scene.pitch_rad);
  const double nz = std::cos(scene.tilt_rad) * std::cos(scene.pitch_rad);
  const double d = WallDistanceM(scene, frame_index);
  out->assign(static_cast<size_t>(width) * height, 0);
  for (int v = 0; v < height; ++v) {
    for (int u = scene.dead_columns; u < width; ++u) {
      // Ray through the pixel with unit z: X = z * ((u-cx)/fx, (v-cy)/fy, 1); n . X = d.
      const double denom = nx * (u - cx) / fx + ny * (v - cy) / fy + nz;
      if (denom <= 0.0) continue;
      const double z = d / denom;
      if (z > kMaxDepthM) continue;
      const long count = std::lround(z / depth_scale_m);
      if (count > 65535) continue;  // beyond the pixel format's range: no return
      (*out)[static_cast<size_t>(v) * width + u] = static_cast<uint16_t>(count);
    }
  }
}

RawFrameFolder::RawFrameFolder(const std::string& dir) {
  std::vector<std::string> names;
  if (DIR* d = opendir(dir.c_str())) {
    while (const dirent* e = readdir(d)) {
      const std::string name = e->d_name;
      if (name.size() > 4 && name.compare(name.size() - 4, 4, ".raw") == 0) names.push_back(name);
    }
    closedir(d);
  }
  std::sort(names.begin(), names.end());
  for (const auto& name : names) {
    const std::string path = dir + "/" + name;
    struct stat st {};
    if (stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) continue;
    std::ifstream in(path, std::ios::binary);
    const std::vector<char> bytes((std::istreambuf_iterator<char>(in)),
                                  std::istreambuf_iterator<char>());
    std::vector<uint16_t> frame(bytes.size() / 2);
    for (size_t i = 0; i < frame.size(); ++i) {
      frame[i] = static_cast<uint16_t>(static_cast<unsigned char>(bytes[2 * i]) |
                                       (static_cast<unsigned char>(bytes[2 * i + 1]) << 8));
    }
    frames_.push_back(std::move(frame));
  }
  if (frames_.empty()) throw std::runtime_error("no *.raw frame files in '" + dir + "'");
}

bool RawFrameFolder::Fill(int width, int height, int64_t frame_index,
                          std::vector<uint16_t>* out) const {
  const auto& frame = frames_[static_cast<size_t>(frame_index % size())];
  if (width <= 0 || height <= 0 || frame.size() != static_cast<size_t>(width) * height) {
    return false;
  }
  *out = frame;
  return true;
}

}  // namespace kestrel::oni_plugin
