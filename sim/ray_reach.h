#pragma once
/// @file
/// Which cells of a grid the simulator's sensor rays physically reached in a flight, and when
/// (docs/algorithms.md §12.5): every ray from the sensor's true pose (its true mount, its true
/// acquisition time) to its true first hit, or to the sensor's range when nothing is hit, marks
/// the cells it passes through, the hit cell included. A map cell known free that no such ray
/// reached is a claim no reading could support; one known free before its first reach was freed
/// by something other than a ray that got there.
///
/// The record is what the simulator knows and the mapper does not: it is written by the
/// simulator (Simulator::SetRayReach), saved beside a flight's log (WriteRayReachFile) and read
/// by the scorers (kestrel-map-score, kestrel-fidelity, kestrel-mission's summary).

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "sim/ground_truth.h"

namespace kestrel {

/// First-reach times of the cells of a grid. Not thread-safe.
class RayReach {
 public:
  /// Nothing reached yet on `grid`.
  explicit RayReach(const GridSpec& grid);

  /// Marks the cells the segment o + t u, t in [0, length_m], passes through (unit u), with
  /// time_s where the cell had no earlier time. Parts of the segment outside the grid are
  /// ignored.
  void AddRay(const Eigen::Vector3d& o_W, const Eigen::Vector3d& u_W, double length_m,
              double time_s);

  [[nodiscard]] const GridSpec& grid() const { return grid_; }
  /// Per cell (GridSpec::IndexOf): the time it was first reached, s (+inf: never).
  [[nodiscard]] const std::vector<double>& first_reach_s() const { return first_reach_s_; }
  /// Cells reached at all.
  [[nodiscard]] size_t reached_cells() const { return reached_; }
  /// Rays added.
  [[nodiscard]] int64_t rays() const { return rays_; }

  /// A record with these times (a file's contents). @throws std::invalid_argument when
  /// first_reach_s does not hold one time per cell of grid.
  RayReach(const GridSpec& grid, std::vector<double> first_reach_s);

 private:
  GridSpec grid_;
  std::vector<double> first_reach_s_;
  size_t reached_{0};
  int64_t rays_{0};
};

/// Writes `reach` to `path` (text header "kestrel-ray-reach 1", the grid, then one line per
/// reached cell: index and time). Returns false with *error on failure.
bool WriteRayReachFile(const std::string& path, const RayReach& reach, std::string* error);
/// Reads a file WriteRayReachFile wrote. @throws std::runtime_error naming the file, the line and
/// what is wrong (another format, a cell outside the grid, a non-finite time).
[[nodiscard]] RayReach ReadRayReachFile(const std::string& path);

}  // namespace kestrel
