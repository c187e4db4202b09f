#include "sim/ray_reach.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace kestrel {

RayReach::RayReach(const GridSpec& grid)
    : grid_(grid), first_reach_s_(grid.size(), std::numeric_limits<double>::infinity()) {}

RayReach::RayReach(const GridSpec& grid, std::vector<double> first_reach_s)
    : grid_(grid), first_reach_s_(std::move(first_reach_s)) {
  if (first_reach_s_.size() != grid_.size()) {
    throw std::invalid_argument("RayReach: " + std::to_string(first_reach_s_.size()) +
                                " times for a grid of " + std::to_string(grid_.size()) + " cells");
  }
  for (const double t : first_reach_s_) reached_ += std::isfinite(t) ? 1 : 0;
}

void RayReach::AddRay(const Eigen::Vector3d& o_W, const Eigen::Vector3d& u_W, double length_m,
                      double time_s) {
  ++rays_;
  if (!(length_m > 0.0)) return;
  WalkCells(grid_, o_W, u_W, length_m, [&](size_t index, double /*t_enter_m*/) {
    double& first = first_reach_s_[index];
    if (std::isinf(first)) {
      first = time_s;
      ++reached_;
    }
  });
}

bool WriteRayReachFile(const std::string& path, const RayReach& reach, std::string* error) {
  std::ofstream out(path);
  if (!out) {
    if (error != nullptr) *error = "cannot write " + path;
    return false;
  }
  const GridSpec& g = reach.grid();
  char line[160];
  std::snprintf(line, sizeof(line), "kestrel-ray-reach 1\ngrid %.17g %.17g %.17g %.17g %d %d %d\n",
                g.min_m.x(), g.min_m.y(), g.min_m.z(), g.resolution_m, g.dims.x(), g.dims.y(),
                g.dims.z());
  out << line;
  const std::vector<double>& t = reach.first_reach_s();
  for (size_t i = 0; i < t.size(); ++i) {
    if (!std::isfinite(t[i])) continue;
    std::snprintf(line, sizeof(line), "%zu %.6f\n", i, t[i]);
    out << line;
  }
  out.flush();
  if (!out) {
    if (error != nullptr) *error = "cannot write " + path;
    return false;
  }
  return true;
}

RayReach ReadRayReachFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open the ray reach file");
  std::string line;
  int number = 0;
  const auto fail = [&](const std::string& why) {
    throw std::runtime_error(path + ": line " + std::to_string(number) + ": " + why);
  };
  ++number;
  if (!std::getline(in, line) || line != "kestrel-ray-reach 1") {
    fail("not a ray reach file (expected \"kestrel-ray-reach 1\")");
  }
  ++number;
  GridSpec grid;
  std::string tag;
  if (!std::getline(in, line) ||
      !(std::istringstream(line) >> tag >> grid.min_m.x() >> grid.min_m.y() >> grid.min_m.z() >>
        grid.resolution_m >> grid.dims.x() >> grid.dims.y() >> grid.dims.z()) ||
      tag != "grid" || !(grid.resolution_m > 0) || (grid.dims.array() <= 0).any() ||
      grid.size() > (size_t{1} << 32)) {
    fail("expected \"grid min_x min_y min_z resolution nx ny nz\"");
  }
  std::vector<double> times(grid.size(), std::numeric_limits<double>::infinity());
  while (std::getline(in, line)) {
    ++number;
    size_t index = 0;
    double time_s = 0;
    if (!(std::istringstream(line) >> index >> time_s)) fail("expected \"cell_index time_s\"");
    if (index >= times.size()) fail("cell " + std::to_string(index) + " outside the grid");
    if (!std::isfinite(time_s)) fail("a time that is not finite");
    times[index] = time_s;
  }
  return RayReach(grid, std::move(times));
}

}  // namespace kestrel
