#pragma once
/// @file
/// Ground truth for map quality (docs/algorithms.md §12.1): the world voxelised on a map grid,
/// and the set of cells a sensor can observe from collision-free poses at the exploration height.
///
/// Grid convention (docs/algorithms.md §1.1): cell (i, j, k) spans
/// [min + i*alpha, min + (i+1)*alpha) per axis; the count per axis is ceil((max - min)/alpha)
/// (computed as ceil((max - min)/alpha - 1e-9), so an exact multiple does not gain a cell from
/// rounding). Flat index = i + nx * (j + ny * k).

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "sim/world.h"
#include "sim/world_ray_caster.h"

namespace kestrel {

/// A regular grid of cubic cells aligned to its lower limit.
struct GridSpec {
  Eigen::Vector3d min_m{Eigen::Vector3d::Zero()};  ///< lower limit (corner of cell 0), W, m
  double resolution_m{0.075};                      ///< cell edge alpha, m
  Eigen::Vector3i dims{Eigen::Vector3i::Ones()};   ///< cells per axis

  /// The grid over [min_m, max_m] with edge resolution_m (dims as in the file comment).
  /// @throws std::invalid_argument unless resolution_m > 0 and max_m > min_m on every axis.
  static GridSpec FromLimits(const Eigen::Vector3d& min_m, const Eigen::Vector3d& max_m,
                             double resolution_m);

  /// Number of cells.
  [[nodiscard]] size_t size() const {
    return static_cast<size_t>(dims.x()) * static_cast<size_t>(dims.y()) *
           static_cast<size_t>(dims.z());
  }
  /// Flat index of cell c (precondition: inside).
  [[nodiscard]] size_t IndexOf(const Eigen::Vector3i& c) const {
    return static_cast<size_t>(c.x()) +
           static_cast<size_t>(dims.x()) *
               (static_cast<size_t>(c.y()) + static_cast<size_t>(dims.y()) * c.z());
  }
  /// Cell of flat index `index`.
  [[nodiscard]] Eigen::Vector3i CellOf(size_t index) const;
  /// The closed box of cell c in W, m.
  [[nodiscard]] Eigen::AlignedBox3d BoxOf(const Eigen::Vector3i& c) const;
  /// Upper limit min_m + dims * resolution_m (may exceed the requested max), m.
  [[nodiscard]] Eigen::Vector3d max_m() const { return min_m + dims.cast<double>() * resolution_m; }
};

/// Occupancy of every cell of `grid`: 1 when some obstacle overlaps the cell's volume (their
/// interiors intersect by more than 1e-9 m: touching a face, up to rounding, is not
/// overlapping), else 0; for mesh triangles (surfaces) a cell is occupied when the triangle
/// meets the closed cell (within 1e-9 m). Exact for every primitive (separating-axis tests for
/// rotated boxes and triangles, closest point for cylinders, corner test for half-spaces).
/// Indexed by GridSpec::IndexOf.
[[nodiscard]] std::vector<uint8_t> VoxelizeWorld(const World& world, const GridSpec& grid);

/// Calls visit(flat_index, t_enter_m) for every cell of `grid` that the segment
/// o + t u, t in [0, t_end_m], passes through, in order of increasing distance (Amanatides & Woo
/// 1987); the walk ends where the segment leaves the grid. Precondition: |u| = 1.
template <typename Visit>
void WalkCells(const GridSpec& grid, const Eigen::Vector3d& o, const Eigen::Vector3d& u,
               double t_end_m, Visit&& visit);

/// How the observable set is swept (docs/algorithms.md §12.1).
struct ObservabilityConfig {
  double pose_spacing_m{0.5};  ///< lattice step of candidate positions in x and y, m, > 0
  /// Radius of the sphere around a candidate position that must be clear of obstacles, m.
  double vehicle_radius_m{0.44};
  bool require_reachable{true};  ///< keep only positions connected to the start on the lattice
  double azimuth_step_rad{M_PI / 180.0};  ///< ray spacing in heading (all headings), rad, > 0
  double elevation_min_rad{-22.5 * M_PI / 180.0};  ///< lowest ray elevation (camera vfov/2), rad
  double elevation_max_rad{22.5 * M_PI / 180.0};   ///< highest ray elevation, rad
  double elevation_step_rad{1.5 * M_PI / 180.0};   ///< elevation spacing, rad, > 0
  double max_range_m{4.0};                         ///< sensor range used by the map, m, > 0
  /// A ray that meets nothing within return_range_m observes its cells only when its elevation is
  /// at most this (rad): +inf, every such ray (a sensor whose "no return" is evidence); 0, only
  /// the horizontal rays of the planar LIDAR, when the depth camera's 0 is no evidence
  /// (docs/algorithms.md §3.4, §12.1). A ray that hits within it always observes.
  double empty_ray_max_elevation_rad{std::numeric_limits<double>::infinity()};
  /// The farthest hit that still returns, m (>= max_range_m; 0: max_range_m). A depth camera's
  /// limit is axial, so its oblique rays return from up to max_range / (axial component); such a
  /// return tells the map its cells up to max_range_m are free (docs/algorithms.md §3.4).
  double return_range_m{0.0};
  int num_threads{2};  ///< threads over poses (result independent of it)

  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// The observable set and the poses it came from.
/// The sweep of the vehicle's sensors as the scorers use it (tools/map_score, kestrel-report):
/// rays to max_range_m within +-vertical_fov_rad/2; a ray returns from up to the depth camera's
/// longest along-ray range (the axial depth it reports to, camera_depth_range_m, at the corner of
/// its field of view: camera_depth_range_m |(tan(hfov/2), tan(vfov/2), 1)|; a depth beyond
/// max_range_m is a no-return, which tells the map its cells up to max_range_m are free); a ray
/// that meets nothing within that observes only in the LIDAR's plane unless the depth camera's
/// "no return" is evidence (docs/algorithms.md §12.1). camera_depth_range_m 0: max_range_m.
[[nodiscard]] ObservabilityConfig SensorSweep(double max_range_m, double vertical_fov_rad,
                                              bool camera_no_return_informs,
                                              double camera_depth_range_m = 8.0,
                                              double horizontal_fov_rad = 58.0 * M_PI / 180.0);

struct ObservableCells {
  std::vector<uint8_t> observable;              ///< 1 per cell some ray reaches (IndexOf)
  std::vector<Eigen::Vector3d> sensor_origins;  ///< sweep positions used, W, m
};

/// Cells that some sensor ray reaches, as the first hit or passing through, from the positions
/// of a lattice (pose_spacing_m, aligned to the start position) at the exploration height inside
/// the map limits whose vehicle sphere is clear (and, if required, connected to the start
/// through clear lattice neighbours), with rays at every azimuth step over all headings and
/// every elevation step in [elevation_min, elevation_max], each to its first hit (the hit cell
/// included) or to max_range_m (rays that hit nothing only up to empty_ray_max_elevation_rad).
/// Sensor origins are the lattice points (extrinsic offsets ignored).
[[nodiscard]] ObservableCells ComputeObservableCells(const World& world,
                                                     const WorldRayCaster& caster,
                                                     const GridSpec& grid,
                                                     const ObservabilityConfig& config);

// ---------------------------------------------------------------------------------------------

template <typename Visit>
void WalkCells(const GridSpec& grid, const Eigen::Vector3d& o, const Eigen::Vector3d& u,
               double t_end_m, Visit&& visit) {
  const Eigen::Vector3d hi = grid.max_m();
  double t0 = 0.0;
  double t1 = t_end_m;
  for (int a = 0; a < 3; ++a) {
    if (u[a] == 0.0) {
      if (o[a] < grid.min_m[a] || o[a] >= hi[a]) return;
      continue;
    }
    double ta = (grid.min_m[a] - o[a]) / u[a];
    double tb = (hi[a] - o[a]) / u[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  if (t0 > t1) return;
  const double inv = 1.0 / grid.resolution_m;
  const Eigen::Vector3d entry = o + t0 * u;
  Eigen::Vector3i cell, step;
  Eigen::Vector3d t_max, t_delta;
  for (int a = 0; a < 3; ++a) {
    cell[a] = std::clamp(static_cast<int>(std::floor((entry[a] - grid.min_m[a]) * inv)), 0,
                         grid.dims[a] - 1);
    if (u[a] > 0.0) {
      step[a] = 1;
      t_max[a] = (grid.min_m[a] + (cell[a] + 1) * grid.resolution_m - o[a]) / u[a];
      t_delta[a] = grid.resolution_m / u[a];
    } else if (u[a] < 0.0) {
      step[a] = -1;
      t_max[a] = (grid.min_m[a] + cell[a] * grid.resolution_m - o[a]) / u[a];
      t_delta[a] = -grid.resolution_m / u[a];
    } else {
      step[a] = 0;
      t_max[a] = std::numeric_limits<double>::infinity();
      t_delta[a] = std::numeric_limits<double>::infinity();
    }
  }
  double t_enter = t0;
  while (true) {
    visit(grid.IndexOf(cell), t_enter);
    int axis = 0;
    if (t_max[1] < t_max[axis]) axis = 1;
    if (t_max[2] < t_max[axis]) axis = 2;
    if (t_max[axis] > t1) return;
    t_enter = t_max[axis];
    cell[axis] += step[axis];
    if (cell[axis] < 0 || cell[axis] >= grid.dims[axis]) return;
    t_max[axis] += t_delta[axis];
  }
}

}  // namespace kestrel
