#include "sim/ground_truth.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace kestrel {
namespace {

World EmptyWorld(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  World w;
  w.name = "scene";
  w.map_min_m = lo;
  w.map_max_m = hi;
  w.exploration_height_m = 0.5 * (lo.z() + hi.z());
  return w;
}

// Fraction of a cell's stratified sample points (n^3) that lie inside some obstacle.
int SamplesInside(const World& w, const Eigen::AlignedBox3d& cell, int n) {
  int inside = 0;
  for (int a = 0; a < n; ++a) {
    for (int b = 0; b < n; ++b) {
      for (int c = 0; c < n; ++c) {
        const Eigen::Vector3d f((a + 0.5) / n, (b + 0.5) / n, (c + 0.5) / n);
        const Eigen::Vector3d p = cell.min() + f.cwiseProduct(cell.sizes());
        inside += IsInsideObstacle(w, p) ? 1 : 0;
      }
    }
  }
  return inside;
}

// Euclidean distance from p to the nearest box or cylinder (0 inside): a test-only oracle.
double DistanceToObstacles(const World& w, const Eigen::Vector3d& p) {
  double best = 1e300;
  for (const WorldBox& b : w.boxes) {
    const Eigen::Vector3d p_O = b.q_WO.conjugate() * (p - b.center_m);
    best = std::min(best, (p_O.cwiseAbs() - b.half_extents_m).cwiseMax(0.0).norm());
  }
  for (const WorldCylinder& c : w.cylinders) {
    const double radial = std::max(0.0, (p.head<2>() - c.center_xy_m).norm() - c.radius_m);
    const double vertical = std::max({0.0, c.z_min_m - p.z(), p.z() - c.z_max_m});
    best = std::min(best, std::hypot(radial, vertical));
  }
  return best;
}

// The cell count per axis rounds up, and exact multiples do not gain a cell.
TEST(GridSpec, CountsCellsLikeTheMap) {
  const GridSpec paper = GridSpec::FromLimits({-4, -6, -0.15}, {4, 6, 1.5}, 0.075);
  EXPECT_EQ(paper.dims, Eigen::Vector3i(107, 160, 22));
  const GridSpec g = GridSpec::FromLimits({0, 0, 0}, {1, 1, 1}, 0.25);
  EXPECT_EQ(g.dims, Eigen::Vector3i(4, 4, 4));
  for (size_t i = 0; i < paper.size(); i += 997) EXPECT_EQ(paper.IndexOf(paper.CellOf(i)), i);
  EXPECT_THROW(GridSpec::FromLimits({0, 0, 0}, {1, 1, 1}, 0.0), std::invalid_argument);
  EXPECT_THROW(GridSpec::FromLimits({0, 0, 0}, {1, -1, 1}, 0.1), std::invalid_argument);
}

// An axis-aligned box occupies exactly the cells its interior overlaps: faces on cell boundaries
// do not spill into the next cell, faces inside a cell take the whole cell.
TEST(VoxelizeWorld, AxisAlignedBoxOccupiesExactlyTheOverlappedCells) {
  World w = EmptyWorld({0, 0, 0}, {2, 2, 1});
  w.boxes.push_back(WorldBox{"on_faces",
                             {0.5, 0.25, 0.125},
                             {0.25, 0.25, 0.125},
                             Eigen::Quaterniond::Identity()});  // [0.25,0.75]x[0,0.5]x[0,0.25]
  w.boxes.push_back(WorldBox{"inside",
                             {1.5, 1.5, 0.5},
                             {0.2, 0.2, 0.2},
                             Eigen::Quaterniond::Identity()});  // [1.3,1.7]^2 x [0.3,0.7]
  const GridSpec g = GridSpec::FromLimits(w.map_min_m, w.map_max_m, 0.125);
  const std::vector<uint8_t> occ = VoxelizeWorld(w, g);
  size_t count = 0;
  for (size_t i = 0; i < g.size(); ++i) {
    const Eigen::Vector3i c = g.CellOf(i);
    const bool in_a = c.x() >= 2 && c.x() < 6 && c.y() >= 0 && c.y() < 4 && c.z() >= 0 && c.z() < 2;
    // 1.3 / 0.125 = 10.4 -> cells 10..13 in x and y; 0.3 / 0.125 = 2.4 -> cells 2..5 in z.
    const bool in_b =
        c.x() >= 10 && c.x() <= 13 && c.y() >= 10 && c.y() <= 13 && c.z() >= 2 && c.z() <= 5;
    EXPECT_EQ(occ[i] != 0, in_a || in_b) << c.transpose();
    count += occ[i];
  }
  EXPECT_EQ(count, 4u * 4 * 2 + 4 * 4 * 4);
}

// A floor half-space at z = 0 on the paper's z grid fills exactly the two layers below 0.
TEST(VoxelizeWorld, FloorFillsTheLayersBelowIt) {
  World w = EmptyWorld({-1, -1, -0.15}, {1, 1, 1.5});
  w.planes.push_back(WorldPlane{"floor", Eigen::Vector3d::UnitZ(), 0.0});
  const GridSpec g = GridSpec::FromLimits(w.map_min_m, w.map_max_m, 0.075);
  const std::vector<uint8_t> occ = VoxelizeWorld(w, g);
  for (size_t i = 0; i < g.size(); ++i) EXPECT_EQ(occ[i] != 0, g.CellOf(i).z() < 2) << i;
}

// Rotated boxes and cylinders against a sampling oracle: a cell with any sample inside an
// obstacle is occupied; an occupied cell with no sample inside overlaps only a sliver (an
// obstacle comes within the cell's half diagonal of its centre), and slivers are few.
TEST(VoxelizeWorld, RotatedBoxesAndCylindersMatchSampling) {
  std::mt19937_64 gen(17);
  std::uniform_real_distribution<double> U(0.0, 1.0);  // test-only randomness
  World w = EmptyWorld({-2, -2, -1}, {2, 2, 1});
  for (int i = 0; i < 6; ++i) {
    const Eigen::Quaterniond q =
        Eigen::Quaterniond(U(gen) - 0.5, U(gen) - 0.5, U(gen) - 0.5, U(gen) - 0.5).normalized();
    w.boxes.push_back(WorldBox{"b",
                               {3 * U(gen) - 1.5, 3 * U(gen) - 1.5, U(gen) - 0.5},
                               {0.1 + 0.4 * U(gen), 0.1 + 0.4 * U(gen), 0.1 + 0.4 * U(gen)},
                               q});
    w.cylinders.push_back(WorldCylinder{"c",
                                        {3 * U(gen) - 1.5, 3 * U(gen) - 1.5},
                                        0.1 + 0.3 * U(gen),
                                        -0.8 * U(gen),
                                        0.8 * U(gen)});
  }
  const GridSpec g = GridSpec::FromLimits(w.map_min_m, w.map_max_m, 0.1);
  const std::vector<uint8_t> occ = VoxelizeWorld(w, g);
  size_t occupied = 0, slivers = 0, missed = 0;
  for (size_t i = 0; i < g.size(); ++i) {
    const Eigen::AlignedBox3d cell = g.BoxOf(g.CellOf(i));
    const int inside = SamplesInside(w, cell, 6);
    if (inside > 0 && !occ[i]) ++missed;
    if (occ[i]) {
      ++occupied;
      if (inside == 0) {
        ++slivers;
        // A sliver: some obstacle must come within the cell's half diagonal of its centre.
        EXPECT_LT(DistanceToObstacles(w, cell.center()), 0.5 * cell.sizes().norm())
            << g.CellOf(i).transpose();
      }
    }
  }
  EXPECT_EQ(missed, 0u);
  EXPECT_GT(occupied, 500u);
  EXPECT_LT(slivers, occupied / 10);
}

// Mesh triangles against sampling: every cell holding a point of a triangle (a 60 x 60
// barycentric grid of points per triangle) is occupied, and every occupied cell lies within its
// half diagonal (plus the sampling step) of a triangle point.
TEST(VoxelizeWorld, MeshTrianglesMarkTheCellsTheyCross) {
  std::mt19937_64 gen(23);
  std::uniform_real_distribution<double> U(-1.0, 1.0);  // test-only randomness
  World w = EmptyWorld({-2, -2, -1}, {2, 2, 1});
  WorldMesh mesh;
  for (int i = 0; i < 10; ++i) {
    const Eigen::Vector3d c(1.5 * U(gen), 1.5 * U(gen), 0.5 * U(gen));
    for (int k = 0; k < 3; ++k)
      mesh.vertices_W.push_back(c + 0.5 * Eigen::Vector3d(U(gen), U(gen), U(gen)));
    mesh.triangles.emplace_back(3 * i, 3 * i + 1, 3 * i + 2);
  }
  w.meshes.push_back(mesh);
  const GridSpec g = GridSpec::FromLimits(w.map_min_m, w.map_max_m, 0.1);
  const std::vector<uint8_t> occ = VoxelizeWorld(w, g);
  std::vector<Eigen::Vector3d> points;
  constexpr int kSteps = 60;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    const Eigen::Vector3d& a = mesh.vertices_W[static_cast<size_t>(t[0])];
    const Eigen::Vector3d& b = mesh.vertices_W[static_cast<size_t>(t[1])];
    const Eigen::Vector3d& c = mesh.vertices_W[static_cast<size_t>(t[2])];
    for (int i = 0; i <= kSteps; ++i) {
      for (int j = 0; i + j <= kSteps; ++j) {
        points.push_back(a + (b - a) * (i + 0.31) / (kSteps + 1) +
                         (c - a) * (j + 0.29) / (kSteps + 1));
      }
    }
  }
  size_t occupied = 0;
  for (const Eigen::Vector3d& p : points) {
    const Eigen::Vector3i c = ((p - g.min_m) / g.resolution_m).array().floor().cast<int>();
    if ((c.array() < 0).any() || (c.array() >= g.dims.array()).any()) continue;
    EXPECT_EQ(occ[g.IndexOf(c)], 1) << p.transpose();
  }
  const double step = 0.5 * std::sqrt(3.0) * 1.0 / kSteps;  // generous: edges up to ~1.7 m
  for (size_t i = 0; i < g.size(); ++i) {
    if (!occ[i]) continue;
    ++occupied;
    const Eigen::AlignedBox3d cell = g.BoxOf(g.CellOf(i));
    double nearest = 1e300;
    for (const Eigen::Vector3d& p : points) nearest = std::min(nearest, (p - cell.center()).norm());
    EXPECT_LT(nearest, 0.5 * cell.sizes().norm() + step) << g.CellOf(i).transpose();
  }
  EXPECT_GT(occupied, 200u);
}

// Oracle for the observable set from one position: a cell is observable when some ray of the
// sweep crosses its box (slab test) before the ray's first hit (+1 um) or its range.
std::vector<uint8_t> BruteForceObservable(const World& w, const WorldRayCaster& caster,
                                          const GridSpec& g, const Eigen::Vector3d& o,
                                          const ObservabilityConfig& cfg) {
  std::vector<uint8_t> seen(g.size(), 0);
  const int n_az = static_cast<int>(std::round(2 * M_PI / cfg.azimuth_step_rad));
  const int n_el =
      static_cast<int>(std::floor(
          (cfg.elevation_max_rad - cfg.elevation_min_rad) / cfg.elevation_step_rad + 1e-9)) +
      1;
  for (int e = 0; e < n_el; ++e) {
    const double el = cfg.elevation_min_rad + e * cfg.elevation_step_rad;
    for (int a = 0; a < n_az; ++a) {
      const double az = 2 * M_PI * a / n_az;
      const Eigen::Vector3d u(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az),
                              std::sin(el));
      const double hit = caster.CastRay(o, u, cfg.max_range_m);
      const double t_end = std::isfinite(hit) ? hit + 1e-6 : cfg.max_range_m;
      for (size_t i = 0; i < g.size(); ++i) {
        const Eigen::AlignedBox3d box = g.BoxOf(g.CellOf(i));
        double t0 = 0.0, t1 = t_end;
        for (int k = 0; k < 3; ++k) {
          if (u[k] == 0.0) {
            if (o[k] < box.min()[k] || o[k] > box.max()[k]) t0 = 1e300;
            continue;
          }
          double ta = (box.min()[k] - o[k]) / u[k], tb = (box.max()[k] - o[k]) / u[k];
          if (ta > tb) std::swap(ta, tb);
          t0 = std::max(t0, ta);
          t1 = std::min(t1, tb);
        }
        if (t0 < t1) seen[i] = 1;
      }
    }
  }
  (void)w;
  return seen;
}

// From a single position (lattice step larger than the map), the swept set equals the oracle's,
// walls stop the rays, and the cells behind a wall are not observable.
TEST(ObservableCells, SinglePoseMatchesSlabOracle) {
  World w = EmptyWorld({-1.5, -1.5, -0.15}, {1.5, 1.5, 1.2});
  w.start_X_WB.p = Eigen::Vector3d(0.0123, -0.0271, 0.0);
  w.exploration_height_m = 0.5137;
  w.planes.push_back(WorldPlane{"floor", Eigen::Vector3d::UnitZ(), 0.0});
  w.boxes.push_back(
      WorldBox{"wall", {0.9, 0.0, 0.75}, {0.05, 0.6, 0.75}, Eigen::Quaterniond::Identity()});
  const WorldRayCaster caster(w);
  const GridSpec g = GridSpec::FromLimits(w.map_min_m, w.map_max_m, 0.1);
  ObservabilityConfig cfg;
  cfg.pose_spacing_m = 10.0;
  cfg.vehicle_radius_m = 0.3;
  cfg.azimuth_step_rad = 3.0 * M_PI / 180;
  cfg.elevation_step_rad = 5.0 * M_PI / 180;
  cfg.max_range_m = 1.3;
  const ObservableCells obs = ComputeObservableCells(w, caster, g, cfg);
  ASSERT_EQ(obs.sensor_origins.size(), 1u);
  const Eigen::Vector3d o = obs.sensor_origins[0];
  EXPECT_EQ(o, Eigen::Vector3d(0.0123, -0.0271, 0.5137));
  const std::vector<uint8_t> oracle = BruteForceObservable(w, caster, g, o, cfg);
  size_t count = 0;
  for (size_t i = 0; i < g.size(); ++i) {
    EXPECT_EQ(obs.observable[i], oracle[i]) << g.CellOf(i).transpose();
    count += obs.observable[i];
  }
  EXPECT_GT(count, 100u);
  // Cells just behind the wall (x in [1.0, 1.1), |y| < 0.3, z near the sensor) are hidden.
  for (double y = -0.25; y <= 0.25; y += 0.1) {
    EXPECT_EQ(obs.observable[g.IndexOf(Eigen::Vector3i(25, static_cast<int>((y + 1.5) / 0.1), 6))],
              0);
  }
  // The wall's own face cells are observed (first hits).
  EXPECT_EQ(obs.observable[g.IndexOf(Eigen::Vector3i(23, 15, 5))], 1);
}

// The inside of a sealed hollow box is never observable; cells the sweep reaches that are
// occupied are surface cells (each touches an observable free cell).
TEST(ObservableCells, SealedInteriorIsNeverObservable) {
  World w = EmptyWorld({0, 0, -0.2}, {4, 4, 1.6});
  w.start_X_WB.p = Eigen::Vector3d(0.8, 0.8, 0.0);
  w.exploration_height_m = 0.7;
  w.planes.push_back(WorldPlane{"floor", Eigen::Vector3d::UnitZ(), 0.0});
  // A closed crate [2.2, 3.4] x [2.2, 3.4] x [0, 1.2] with 0.1 m walls and lid.
  const Eigen::Quaterniond I = Eigen::Quaterniond::Identity();
  w.boxes.push_back(WorldBox{"w", {2.25, 2.8, 0.6}, {0.05, 0.6, 0.6}, I});
  w.boxes.push_back(WorldBox{"e", {3.35, 2.8, 0.6}, {0.05, 0.6, 0.6}, I});
  w.boxes.push_back(WorldBox{"s", {2.8, 2.25, 0.6}, {0.5, 0.05, 0.6}, I});
  w.boxes.push_back(WorldBox{"n", {2.8, 3.35, 0.6}, {0.5, 0.05, 0.6}, I});
  w.boxes.push_back(WorldBox{"lid", {2.8, 2.8, 1.15}, {0.5, 0.5, 0.05}, I});
  const WorldRayCaster caster(w);
  const GridSpec g = GridSpec::FromLimits(w.map_min_m, w.map_max_m, 0.1);
  ObservabilityConfig cfg;
  cfg.pose_spacing_m = 0.3;
  cfg.vehicle_radius_m = 0.3;
  cfg.azimuth_step_rad = 2.0 * M_PI / 180;
  cfg.elevation_step_rad = 3.0 * M_PI / 180;
  const ObservableCells obs = ComputeObservableCells(w, caster, g, cfg);
  EXPECT_GT(obs.sensor_origins.size(), 50u);
  const std::vector<uint8_t> occ = VoxelizeWorld(w, g);
  size_t observable = 0;
  for (size_t i = 0; i < g.size(); ++i) {
    const Eigen::Vector3i c = g.CellOf(i);
    observable += obs.observable[i];
    const bool interior =
        c.x() >= 24 && c.x() < 33 && c.y() >= 24 && c.y() < 33 && c.z() >= 2 && c.z() < 13;
    if (interior) {
      EXPECT_EQ(obs.observable[i], 0) << c.transpose();
    }
    if (obs.observable[i] && occ[i]) {
      bool touches_free_observable = false;
      for (int dz = -1; dz <= 1; ++dz) {
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) {
            const Eigen::Vector3i n = c + Eigen::Vector3i(dx, dy, dz);
            if ((n.array() < 0).any() || (n.array() >= g.dims.array()).any()) continue;
            const size_t j = g.IndexOf(n);
            touches_free_observable |= obs.observable[j] && !occ[j];
          }
        }
      }
      EXPECT_TRUE(touches_free_observable) << c.transpose();
    }
  }
  EXPECT_GT(observable, g.size() / 4);
  // Same answer with one thread.
  cfg.num_threads = 1;
  EXPECT_EQ(ComputeObservableCells(w, caster, g, cfg).observable, obs.observable);
}

}  // namespace
}  // namespace kestrel
