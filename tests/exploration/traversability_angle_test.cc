// Doors at any angle to the map's axes (exploration/traversability.h, step 3b; docs/exploration.md,
// "Traversability"): occupancy rasterised from geometry the way the mapper marks cells (any
// overlap makes a cell occupied), a door of the vehicle's diameter + 2 x 0.12 m passable at every
// angle and offset, a gap of the diameter + 2 x 0.01 m never, and a rotated two-room layout
// reachable end to end.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "exploration/dijkstra.h"
#include "exploration/planner.h"
#include "exploration/traversability.h"
#include "tests/exploration/test_input.h"

namespace kestrel {
namespace {

constexpr double kAlpha = 0.075;
constexpr double kRadius = 0.44;
constexpr double kPi = 3.14159265358979323846;
constexpr float kFree = 1e-4f;
constexpr float kOccupied = 0.9999f;

// A rectangle: centre, half extents along its own axes, and the angle of its first axis.
struct Rect {
  Eigen::Vector2d centre;
  Eigen::Vector2d half;
  double angle_rad;
  [[nodiscard]] std::array<Eigen::Vector2d, 4> Corners() const {
    const Eigen::Vector2d u(std::cos(angle_rad), std::sin(angle_rad));
    const Eigen::Vector2d v(-u.y(), u.x());
    return {centre + half.x() * u + half.y() * v, centre - half.x() * u + half.y() * v,
            centre - half.x() * u - half.y() * v, centre + half.x() * u - half.y() * v};
  }
  // Distance from p to the rectangle (0 inside).
  [[nodiscard]] double Distance(const Eigen::Vector2d& p) const {
    const Eigen::Vector2d u(std::cos(angle_rad), std::sin(angle_rad));
    const Eigen::Vector2d v(-u.y(), u.x());
    const Eigen::Vector2d d = p - centre;
    const double a = std::max(std::abs(d.dot(u)) - half.x(), 0.0);
    const double b = std::max(std::abs(d.dot(v)) - half.y(), 0.0);
    return std::hypot(a, b);
  }
};

// Whether the axis-aligned square [lo, lo + alpha]^2 and r overlap with positive area (separating
// axes: the square's two and the rectangle's two).
bool Overlaps(const Eigen::Vector2d& lo, const Rect& r) {
  const std::array<Eigen::Vector2d, 4> sq = {lo, lo + Eigen::Vector2d(kAlpha, 0),
                                             lo + Eigen::Vector2d(kAlpha, kAlpha),
                                             lo + Eigen::Vector2d(0, kAlpha)};
  const std::array<Eigen::Vector2d, 4> rc = r.Corners();
  const Eigen::Vector2d u(std::cos(r.angle_rad), std::sin(r.angle_rad));
  for (const Eigen::Vector2d& axis :
       {Eigen::Vector2d(1, 0), Eigen::Vector2d(0, 1), u, Eigen::Vector2d(-u.y(), u.x())}) {
    double a0 = 1e300, a1 = -1e300, b0 = 1e300, b1 = -1e300;
    for (const Eigen::Vector2d& p : sq) {
      a0 = std::min(a0, p.dot(axis));
      a1 = std::max(a1, p.dot(axis));
    }
    for (const Eigen::Vector2d& p : rc) {
      b0 = std::min(b0, p.dot(axis));
      b1 = std::max(b1, p.dot(axis));
    }
    if (std::min(a1, b1) - std::max(a0, b0) <= 1e-12) return false;
  }
  return true;
}

// A known-free 3D map of n x n x 24 cells from (0, 0, 0) whose columns are occupied wherever
// they overlap one of `walls` (the mapper's rule: any overlap).
struct GeometryMap {
  int n;
  std::vector<float> p;
  GeometryMap(int cells, const std::vector<Rect>& walls)
      : n(cells), p(static_cast<size_t>(cells) * cells * 24, kFree) {
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        const Eigen::Vector2d lo(i * kAlpha, j * kAlpha);
        const bool hit =
            std::any_of(walls.begin(), walls.end(), [&](const Rect& r) { return Overlaps(lo, r); });
        if (!hit) continue;
        for (int k = 0; k < 24; ++k) {
          p[static_cast<size_t>(i) + static_cast<size_t>(n) * (j + static_cast<size_t>(n) * k)] =
              kOccupied;
        }
      }
    }
  }
  [[nodiscard]] OccupancyGridView View() const {
    OccupancyGridView v;
    v.dims = Eigen::Vector3i(n, n, 24);
    v.origin_m = Eigen::Vector3d::Zero();
    v.resolution_m = kAlpha;
    v.probability = p.data();
    return v;
  }
};

// The shipped configuration's traversability (config/exploration/explorer.yaml, volumetric).
TraversabilityConfig Config() {
  TraversabilityConfig c;
  c.height_m = 1.0;
  c.band_below_m = 0.25;
  c.band_above_m = 0.15;
  c.vehicle_radius_m = kRadius;
  return c;  // margin_m and passage_margin_m: the defaults
}

using test::Reachable;  // over the traversable cells and the passages

// A straight wall 0.12 m thick through `centre` at `angle_deg` to the x axis, with a gap of
// `width_m` centred on `centre`; both parts reach beyond the map.
std::vector<Rect> WallWithGap(const Eigen::Vector2d& centre, double angle_deg, double width_m) {
  const double a = angle_deg * kPi / 180.0;
  const Eigen::Vector2d u(std::cos(a), std::sin(a));
  const double half_length = 5.0;
  return {Rect{centre + (0.5 * width_m + half_length) * u, {half_length, 0.06}, a},
          Rect{centre - (0.5 * width_m + half_length) * u, {half_length, 0.06}, a}};
}

// Door sweep: angles 0-45 deg in 5 deg steps, offsets of the door's centre in fractions of a cell.
template <typename F>
void SweepDoor(double width_m, F&& check) {
  for (int deg = 0; deg <= 45; deg += 5) {
    for (const double fx : {0.0, 0.25, 0.5, 0.71}) {
      for (const double fy : {0.0, 0.37, 0.5, 0.9}) {
        const Eigen::Vector2d centre((32 + fx) * kAlpha, (32 + fy) * kAlpha);
        const std::vector<Rect> walls = WallWithGap(centre, deg, width_m);
        const GeometryMap m(64, walls);
        const Traversability t = ComputeTraversability(m.View(), Config());
        const double a = deg * kPi / 180.0;
        const Eigen::Vector2d normal(-std::sin(a), std::cos(a));
        check(deg, fx, fy, walls, t, centre + 1.2 * normal, centre - 1.2 * normal);
      }
    }
  }
}

// A door of the vehicle's diameter + 2 x 0.12 m (1.12 m between its jambs): passable at every
// angle and offset, and every passage point it opens keeps at least radius + passage margin from
// the true jambs (the blocked cells hold them).
TEST(TraversabilityAnyAngle, DoorOfDiameterPlus24cmPassableAtEveryAngle) {
  const double width = 2.0 * kRadius + 2.0 * 0.12;
  int passages = 0;
  SweepDoor(width,
            [&](int deg, double fx, double fy, const std::vector<Rect>& walls,
                const Traversability& t, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
              EXPECT_TRUE(Reachable(t, a, b)) << deg << " deg, offset " << fx << ", " << fy;
              for (const auto& [cell, point] : t.passage_points) {
                double d = 1e300;
                for (const Rect& r : walls) d = std::min(d, r.Distance(point));
                EXPECT_GE(d, Config().passage_clearance_m() - 1e-9) << deg << " deg, cell " << cell;
                EXPECT_LE(t.clearance.values[static_cast<size_t>(cell)], d + 1e-9) << deg << " deg";
              }
              passages += static_cast<int>(t.passage_points.size());
            });
  EXPECT_GT(passages, 0);  // the passages opened some
}

// A gap of the vehicle's diameter + 2 x 0.01 m (0.90 m): never passable, at any angle or offset.
TEST(TraversabilityAnyAngle, GapOfDiameterPlus2cmNeverPassable) {
  const double width = 2.0 * kRadius + 2.0 * 0.01;
  SweepDoor(width,
            [&](int deg, double fx, double fy, const std::vector<Rect>&, const Traversability& t,
                const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
              EXPECT_FALSE(Reachable(t, a, b)) << deg << " deg, offset " << fx << ", " << fy;
            });
}

// Two 3 x 3 m rooms joined by a 1.12 m door in their shared wall, the whole layout rotated 20-35
// deg: the far room is reachable from the near one.
TEST(TraversabilityAnyAngle, RotatedTwoRoomsReachTheFarRoom) {
  const double door = 2.0 * kRadius + 2.0 * 0.12;
  const double t = 0.06;  // half a wall's thickness
  for (const double deg : {20.0, 27.0, 35.0}) {
    for (const double f : {0.0, 0.4}) {
      const double a = deg * kPi / 180.0;
      const Eigen::Vector2d centre((50 + f) * kAlpha, (50 + 0.7 * f) * kAlpha);
      const Eigen::Matrix2d rot = Eigen::Rotation2Dd(a).toRotationMatrix();
      // In the layout's own frame: rooms [-3, 0] x [-1.5, 1.5] and [0, 3] x [-1.5, 1.5].
      const auto wall = [&](double x0, double y0, double x1, double y1) {
        const Eigen::Vector2d c = centre + rot * Eigen::Vector2d(0.5 * (x0 + x1), 0.5 * (y0 + y1));
        return Rect{c, {0.5 * (x1 - x0), 0.5 * (y1 - y0)}, a};
      };
      const double gap0 = -0.5 * door;
      const double gap1 = 0.5 * door;
      const std::vector<Rect> walls = {
          wall(-3 - t, 1.5 - t, 3 + t, 1.5 + t),    // north
          wall(-3 - t, -1.5 - t, 3 + t, -1.5 + t),  // south
          wall(-3 - t, -1.5, -3 + t, 1.5),          // west
          wall(3 - t, -1.5, 3 + t, 1.5),            // east
          wall(-t, gap1, t, 1.5),                   // the shared wall, north of the door
          wall(-t, -1.5, t, gap0),                  // south of it
      };
      const GeometryMap m(100, walls);
      const Traversability tr = ComputeTraversability(m.View(), Config());
      const Eigen::Vector2d near_room = centre + rot * Eigen::Vector2d(-1.5, 0.0);
      const Eigen::Vector2d far_room = centre + rot * Eigen::Vector2d(1.5, 0.0);
      EXPECT_TRUE(Reachable(tr, near_room, far_room)) << deg << " deg, offset " << f;
    }
  }
}

// The whole volumetric planner through a 1.12 m door at an angle: a 6 x 6 m room (the map's
// 80 x 80 x 22 cells from (-3, -3, -0.15) m, walls 3 cells thick, the floor below z = 0) cut
// by a 0.12 m wall through the door, rasterised with the mapper's rule; the vehicle plans from one
// side to the other, diagonally across the door, and its trajectory keeps the vehicle's radius
// from the true wall at every 10 ms sample (collision-free), crossing where the map holds the
// door at its narrowest.
TEST(TraversabilityAnyAngle, PlannedTrajectoryThroughARotatedDoorIsCollisionFree) {
  const double door = 2.0 * kRadius + 2.0 * 0.12;
  const Eigen::Vector3i dims(80, 80, 22);
  const Eigen::Vector3d origin(-3.0, -3.0, -0.15);
  for (const int deg : {10, 27, 45}) {
    for (const double f : {0.0, 0.5}) {
      const Eigen::Vector2d centre(f * kAlpha, 0.3 * f * kAlpha);
      const std::vector<Rect> walls = WallWithGap(centre, deg, door);
      std::vector<float> values(static_cast<size_t>(dims.prod()), kFree);
      for (int j = 0; j < dims.y(); ++j) {
        for (int i = 0; i < dims.x(); ++i) {
          const Eigen::Vector2d lo(origin.x() + i * kAlpha, origin.y() + j * kAlpha);
          const bool outer = i < 3 || j < 3 || i >= dims.x() - 3 || j >= dims.y() - 3;
          const bool hit = outer || std::any_of(walls.begin(), walls.end(),
                                                [&](const Rect& r) { return Overlaps(lo, r); });
          for (int k = 0; k < dims.z(); ++k) {
            const bool floor = origin.z() + (k + 0.5) * kAlpha < 0.0;
            values[static_cast<size_t>(i + dims.x() * (j + dims.y() * k))] =
                hit || floor ? kOccupied : kFree;
          }
        }
      }
      const double a = deg * kPi / 180.0;
      const Eigen::Vector2d u(std::cos(a), std::sin(a));
      const Eigen::Vector2d n(-u.y(), u.x());
      const Eigen::Vector2d from = centre - 1.3 * n - 0.5 * u;
      const Eigen::Vector2d to = centre + 1.3 * n + 0.5 * u;
      PlannerConfig config;
      config.mode = ExplorationMode::kVolumetric;
      const PlanResult r = PlanToPoint(
          config, test::InputOn(test::GridView(dims, origin, kAlpha, values), from.x(), from.y()),
          to, 0.0);
      ASSERT_EQ(r.status, PlanStatus::kGoal) << deg << " deg, offset " << f << ": " << r.reason;
      ASSERT_TRUE(r.trajectory.trajectory.has_value());
      double least = 1e300;
      for (const TrajectorySample& smp : r.trajectory.trajectory->Sample(0.01)) {
        const Eigen::Vector2d p = smp.flat.position_m.head<2>();
        for (const Rect& w : walls) least = std::min(least, w.Distance(p));
      }
      EXPECT_GE(least, kRadius) << deg << " deg, offset " << f;
      EXPECT_LT(least, 0.5 * door + 0.05) << deg << " deg: it went through the door";
    }
  }
}

}  // namespace
}  // namespace kestrel
