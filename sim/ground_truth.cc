#include "sim/ground_truth.h"

#include <algorithm>
#include <cmath>
#include <queue>
#include <thread>

#include "common/check.h"

namespace kestrel {
namespace {

// Overlaps thinner than this do not count, so faces that lie on cell boundaries up to rounding
// (2.25 - 0.05 against 22 * 0.1) do not spill into the neighbouring cell, m.
constexpr double kOverlapTolerance_m = 1e-9;

// Interiors of an oriented box and an axis-aligned cell intersect (separating-axis theorem over
// the 3 + 3 face normals and the 9 edge cross products; an axis separates when the projected
// intervals at most touch). Near-zero cross products (parallel edges) are skipped: the face
// axes already decide those cases.
bool BoxOverlapsCell(const WorldBox& box, const Eigen::AlignedBox3d& cell) {
  const Eigen::Matrix3d R = box.q_WO.toRotationMatrix();  // columns: box axes in W
  const Eigen::Vector3d cell_half = 0.5 * cell.sizes();
  const Eigen::Vector3d d = box.center_m - cell.center();
  auto separated = [&](const Eigen::Vector3d& axis) {
    const double r_box = (R.transpose() * axis).cwiseAbs().dot(box.half_extents_m);
    const double r_cell = axis.cwiseAbs().dot(cell_half);
    return std::abs(d.dot(axis)) >= r_box + r_cell - kOverlapTolerance_m * axis.norm();
  };
  for (int a = 0; a < 3; ++a) {
    if (separated(Eigen::Vector3d::Unit(a))) return false;
    if (separated(R.col(a))) return false;
  }
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) {
      const Eigen::Vector3d axis = Eigen::Vector3d::Unit(a).cross(R.col(b));
      if (axis.squaredNorm() < 1e-12) continue;
      if (separated(axis)) return false;
    }
  }
  return true;
}

bool CylinderOverlapsCell(const WorldCylinder& c, const Eigen::AlignedBox3d& cell) {
  if (!(c.z_max_m > cell.min().z() + kOverlapTolerance_m &&
        c.z_min_m < cell.max().z() - kOverlapTolerance_m)) {
    return false;
  }
  const double qx = std::clamp(c.center_xy_m.x(), cell.min().x(), cell.max().x());
  const double qy = std::clamp(c.center_xy_m.y(), cell.min().y(), cell.max().y());
  const double dx = qx - c.center_xy_m.x();
  const double dy = qy - c.center_xy_m.y();
  const double r = c.radius_m - kOverlapTolerance_m;
  return dx * dx + dy * dy < r * r;
}

bool HalfSpaceOverlapsCell(const WorldPlane& p, const Eigen::AlignedBox3d& cell) {
  // Lowest value of n.x over the cell (at its corner against the normal).
  const double lowest = p.normal.dot(cell.center()) - p.normal.cwiseAbs().dot(0.5 * cell.sizes());
  return lowest < p.offset_m - kOverlapTolerance_m;
}

// A triangle (a surface) meets the closed cell, up to kOverlapTolerance_m (touching counts: a
// triangle lying in a cell face marks the cells on both sides). Separating-axis test over the
// cell's 3 face normals, the triangle's normal and the 9 edge cross products (Akenine-Moller).
bool TriangleOverlapsCell(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                          const Eigen::Vector3d& c, const Eigen::AlignedBox3d& cell) {
  const Eigen::Vector3d center = cell.center();
  const Eigen::Vector3d half = 0.5 * cell.sizes();
  const Eigen::Vector3d v[3] = {a - center, b - center, c - center};
  auto separated = [&](const Eigen::Vector3d& axis) {
    const double p0 = v[0].dot(axis), p1 = v[1].dot(axis), p2 = v[2].dot(axis);
    const double r = half.dot(axis.cwiseAbs());
    const double tol = kOverlapTolerance_m * axis.norm();
    return std::min({p0, p1, p2}) > r + tol || std::max({p0, p1, p2}) < -r - tol;
  };
  for (int k = 0; k < 3; ++k) {
    if (separated(Eigen::Vector3d::Unit(k))) return false;
  }
  const Eigen::Vector3d e[3] = {v[1] - v[0], v[2] - v[1], v[0] - v[2]};
  const Eigen::Vector3d normal = e[0].cross(e[1]);
  if (normal.squaredNorm() > 0.0 && separated(normal)) return false;
  for (int k = 0; k < 3; ++k) {
    for (int m = 0; m < 3; ++m) {
      const Eigen::Vector3d axis = Eigen::Vector3d::Unit(k).cross(e[m]);
      if (axis.squaredNorm() < 1e-24) continue;
      if (separated(axis)) return false;
    }
  }
  return true;
}

bool SphereIsClear(const World& world, const Eigen::Vector3d& p, double radius) {
  return !NearestObstacleWithin(world, p, radius).has_value();
}

}  // namespace

GridSpec GridSpec::FromLimits(const Eigen::Vector3d& min_m, const Eigen::Vector3d& max_m,
                              double resolution_m) {
  KESTREL_THROW_UNLESS(std::isfinite(resolution_m) && resolution_m > 0.0,
                       "grid resolution " << resolution_m << " m must be positive");
  GridSpec g;
  g.min_m = min_m;
  g.resolution_m = resolution_m;
  for (int a = 0; a < 3; ++a) {
    KESTREL_THROW_UNLESS(std::isfinite(min_m[a]) && std::isfinite(max_m[a]) && max_m[a] > min_m[a],
                         "grid limits axis " << a << " [" << min_m[a] << ", " << max_m[a]
                                             << "] must be finite and ordered");
    g.dims[a] =
        std::max(1, static_cast<int>(std::ceil((max_m[a] - min_m[a]) / resolution_m - 1e-9)));
  }
  return g;
}

Eigen::Vector3i GridSpec::CellOf(size_t index) const {
  const size_t nx = static_cast<size_t>(dims.x());
  const size_t ny = static_cast<size_t>(dims.y());
  return Eigen::Vector3i(static_cast<int>(index % nx), static_cast<int>((index / nx) % ny),
                         static_cast<int>(index / (nx * ny)));
}

Eigen::AlignedBox3d GridSpec::BoxOf(const Eigen::Vector3i& c) const {
  const Eigen::Vector3d lo = min_m + c.cast<double>() * resolution_m;
  const Eigen::Vector3d hi = min_m + (c.array() + 1).cast<double>().matrix() * resolution_m;
  return Eigen::AlignedBox3d(lo, hi);
}

std::vector<uint8_t> VoxelizeWorld(const World& world, const GridSpec& grid) {
  std::vector<uint8_t> occupied(grid.size(), 0);
  // Cells whose box may touch `bounds` (clamped to the grid); visit(cell_index, cell_box).
  auto for_cells_in = [&](const Eigen::AlignedBox3d& bounds, auto&& visit) {
    Eigen::Vector3i lo, hi;
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::max(
          0,
          static_cast<int>(std::floor((bounds.min()[a] - grid.min_m[a]) / grid.resolution_m)) - 1);
      hi[a] = std::min(
          grid.dims[a] - 1,
          static_cast<int>(std::floor((bounds.max()[a] - grid.min_m[a]) / grid.resolution_m)) + 1);
      if (lo[a] > hi[a]) return;
    }
    for (int k = lo.z(); k <= hi.z(); ++k) {
      for (int j = lo.y(); j <= hi.y(); ++j) {
        for (int i = lo.x(); i <= hi.x(); ++i) {
          const Eigen::Vector3i c(i, j, k);
          visit(grid.IndexOf(c), grid.BoxOf(c));
        }
      }
    }
  };
  for (const WorldBox& b : world.boxes) {
    for_cells_in(BoundsOf(b), [&](size_t index, const Eigen::AlignedBox3d& cell) {
      if (!occupied[index] && BoxOverlapsCell(b, cell)) occupied[index] = 1;
    });
  }
  for (const WorldCylinder& c : world.cylinders) {
    for_cells_in(BoundsOf(c), [&](size_t index, const Eigen::AlignedBox3d& cell) {
      if (!occupied[index] && CylinderOverlapsCell(c, cell)) occupied[index] = 1;
    });
  }
  for (const WorldMesh& m : world.meshes) {
    for (const Eigen::Vector3i& t : m.triangles) {
      const Eigen::Vector3d& a = m.vertices_W[static_cast<size_t>(t[0])];
      const Eigen::Vector3d& b = m.vertices_W[static_cast<size_t>(t[1])];
      const Eigen::Vector3d& c = m.vertices_W[static_cast<size_t>(t[2])];
      Eigen::AlignedBox3d bounds(a);
      bounds.extend(b);
      bounds.extend(c);
      for_cells_in(bounds, [&](size_t index, const Eigen::AlignedBox3d& cell) {
        if (!occupied[index] && TriangleOverlapsCell(a, b, c, cell)) occupied[index] = 1;
      });
    }
  }
  for (const WorldPlane& p : world.planes) {
    for (size_t index = 0; index < grid.size(); ++index) {
      if (!occupied[index] && HalfSpaceOverlapsCell(p, grid.BoxOf(grid.CellOf(index)))) {
        occupied[index] = 1;
      }
    }
  }
  return occupied;
}

void ObservabilityConfig::Validate() const {
  KESTREL_THROW_UNLESS(pose_spacing_m > 0.0 && std::isfinite(pose_spacing_m),
                       "pose_spacing_m = " << pose_spacing_m << "; accepted: (0, inf)");
  KESTREL_THROW_UNLESS(vehicle_radius_m >= 0.0 && std::isfinite(vehicle_radius_m),
                       "vehicle_radius_m = " << vehicle_radius_m << "; accepted: [0, inf)");
  KESTREL_THROW_UNLESS(azimuth_step_rad > 0.0 && azimuth_step_rad <= 2.0 * M_PI,
                       "azimuth_step_rad = " << azimuth_step_rad << "; accepted: (0, 2 pi]");
  KESTREL_THROW_UNLESS(elevation_step_rad > 0.0 && elevation_step_rad <= M_PI,
                       "elevation_step_rad = " << elevation_step_rad << "; accepted: (0, pi]");
  KESTREL_THROW_UNLESS(elevation_min_rad >= -M_PI / 2 && elevation_max_rad <= M_PI / 2 &&
                           elevation_min_rad <= elevation_max_rad,
                       "elevation range [" << elevation_min_rad << ", " << elevation_max_rad
                                           << "] rad; accepted: ordered within [-pi/2, pi/2]");
  KESTREL_THROW_UNLESS(max_range_m > 0.0 && std::isfinite(max_range_m),
                       "max_range_m = " << max_range_m << "; accepted: (0, inf)");
  KESTREL_THROW_UNLESS(num_threads >= 1, "num_threads = " << num_threads << "; accepted: >= 1");
  KESTREL_THROW_UNLESS(return_range_m >= 0.0 && std::isfinite(return_range_m),
                       "return_range_m = " << return_range_m << "; accepted: [0, inf)");
  KESTREL_THROW_UNLESS(
      empty_ray_max_elevation_rad >= 0.0,
      "empty_ray_max_elevation_rad = " << empty_ray_max_elevation_rad << "; accepted: [0, inf]");
}

ObservabilityConfig SensorSweep(double max_range_m, double vertical_fov_rad,
                                bool camera_no_return_informs, double camera_depth_range_m,
                                double horizontal_fov_rad) {
  ObservabilityConfig oc;
  oc.max_range_m = max_range_m;
  oc.return_range_m = std::max(max_range_m, camera_depth_range_m) *
                      std::sqrt(1.0 + std::pow(std::tan(0.5 * horizontal_fov_rad), 2) +
                                std::pow(std::tan(0.5 * vertical_fov_rad), 2));
  oc.elevation_min_rad = -0.5 * vertical_fov_rad;
  oc.elevation_max_rad = 0.5 * vertical_fov_rad;
  if (!camera_no_return_informs) oc.empty_ray_max_elevation_rad = 0.0;
  return oc;
}

ObservableCells ComputeObservableCells(const World& world, const WorldRayCaster& caster,
                                       const GridSpec& grid, const ObservabilityConfig& config) {
  config.Validate();
  // Lattice of positions at the exploration height, aligned to the start position.
  const double h = world.exploration_height_m;
  const double step = config.pose_spacing_m;
  const Eigen::Vector2d s = world.start_X_WB.p.head<2>();
  const int i_lo = static_cast<int>(std::ceil((world.map_min_m.x() - s.x()) / step));
  const int i_hi = static_cast<int>(std::floor((world.map_max_m.x() - s.x()) / step));
  const int j_lo = static_cast<int>(std::ceil((world.map_min_m.y() - s.y()) / step));
  const int j_hi = static_cast<int>(std::floor((world.map_max_m.y() - s.y()) / step));
  const int ni = i_hi - i_lo + 1;
  const int nj = j_hi - j_lo + 1;
  KESTREL_DEMAND(ni > 0 && nj > 0);
  auto position = [&](int i, int j) {
    return Eigen::Vector3d(s.x() + (i_lo + i) * step, s.y() + (j_lo + j) * step, h);
  };
  std::vector<uint8_t> clear(static_cast<size_t>(ni) * nj, 0);
  for (int j = 0; j < nj; ++j) {
    for (int i = 0; i < ni; ++i) {
      clear[static_cast<size_t>(j) * ni + i] =
          SphereIsClear(world, position(i, j), config.vehicle_radius_m) ? 1 : 0;
    }
  }
  std::vector<uint8_t> keep = clear;
  if (config.require_reachable) {
    std::fill(keep.begin(), keep.end(), 0);
    const int si = -i_lo;
    const int sj = -j_lo;
    if (si >= 0 && si < ni && sj >= 0 && sj < nj && clear[static_cast<size_t>(sj) * ni + si]) {
      std::queue<std::pair<int, int>> frontier;
      frontier.push({si, sj});
      keep[static_cast<size_t>(sj) * ni + si] = 1;
      while (!frontier.empty()) {
        const auto [i, j] = frontier.front();
        frontier.pop();
        const int di[4] = {1, -1, 0, 0};
        const int dj[4] = {0, 0, 1, -1};
        for (int n = 0; n < 4; ++n) {
          const int a = i + di[n];
          const int b = j + dj[n];
          if (a < 0 || a >= ni || b < 0 || b >= nj) continue;
          const size_t idx = static_cast<size_t>(b) * ni + a;
          if (clear[idx] && !keep[idx]) {
            keep[idx] = 1;
            frontier.push({a, b});
          }
        }
      }
    }
  }
  ObservableCells result;
  for (int j = 0; j < nj; ++j) {
    for (int i = 0; i < ni; ++i) {
      if (keep[static_cast<size_t>(j) * ni + i]) result.sensor_origins.push_back(position(i, j));
    }
  }
  // Ray directions: every azimuth and elevation step.
  std::vector<Eigen::Vector3d> dirs;
  std::vector<uint8_t> empty_observes;  // per direction: a ray without a hit observes its cells
  const double return_range = std::max(config.max_range_m, config.return_range_m);
  const int n_az = std::max(1, static_cast<int>(std::round(2.0 * M_PI / config.azimuth_step_rad)));
  const int n_el =
      static_cast<int>(std::floor((config.elevation_max_rad - config.elevation_min_rad) /
                                      config.elevation_step_rad +
                                  1e-9)) +
      1;
  for (int e = 0; e < n_el; ++e) {
    const double el = config.elevation_min_rad + e * config.elevation_step_rad;
    for (int a = 0; a < n_az; ++a) {
      const double az = 2.0 * M_PI * a / n_az;
      dirs.emplace_back(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
      empty_observes.push_back(std::abs(el) <= config.empty_ray_max_elevation_rad + 1e-12 ? 1 : 0);
    }
  }
  // Poses split over threads, each with its own set, merged by OR (order-independent).
  const size_t num_poses = result.sensor_origins.size();
  const size_t threads =
      std::max<size_t>(1, std::min<size_t>(static_cast<size_t>(config.num_threads), num_poses));
  std::vector<std::vector<uint8_t>> partial(threads, std::vector<uint8_t>(grid.size(), 0));
  auto work = [&](size_t t) {
    std::vector<uint8_t>& seen = partial[t];
    for (size_t p = t; p < num_poses; p += threads) {
      const Eigen::Vector3d& o = result.sensor_origins[p];
      int primitive = WorldRayCaster::kNoHit;  // hints the next ray's search
      for (size_t d = 0; d < dirs.size(); ++d) {
        const Eigen::Vector3d& u = dirs[d];
        const double hit = caster.CastRay(o, u, return_range, &primitive, primitive);
        if (!std::isfinite(hit) && empty_observes[d] == 0) continue;
        // A hit includes the cell just behind the surface point (the obstacle's cell): 1 um on.
        const double t_end =
            std::min(std::isfinite(hit) ? hit + 1e-6 : config.max_range_m, config.max_range_m);
        WalkCells(grid, o, u, t_end, [&](size_t index, double) { seen[index] = 1; });
      }
    }
  };
  std::vector<std::thread> pool;
  for (size_t t = 1; t < threads; ++t) pool.emplace_back(work, t);
  work(0);
  for (std::thread& th : pool) th.join();
  result.observable.assign(grid.size(), 0);
  for (const auto& seen : partial) {
    for (size_t i = 0; i < grid.size(); ++i) result.observable[i] |= seen[i];
  }
  return result;
}

}  // namespace kestrel
