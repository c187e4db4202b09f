#include "sim/world_ray_caster.h"

#include <cmath>
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "sim/bullet_world.h"

namespace kestrel {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Uniform double in [lo, hi) from 53 random bits (explicit, so the test is the same everywhere).
double Uniform(std::mt19937_64* g, double lo, double hi) {
  return lo + (hi - lo) * static_cast<double>((*g)() >> 11) * 0x1.0p-53;
}

Eigen::Vector3d RandomUnit(std::mt19937_64* g) {
  while (true) {
    const Eigen::Vector3d v(Uniform(g, -1, 1), Uniform(g, -1, 1), Uniform(g, -1, 1));
    const double n = v.norm();
    if (n > 0.1 && n <= 1.0) return v / n;
  }
}

// A random world of `n` boxes (half of them rotated about all axes), `n/2` cylinders and a floor.
World RandomWorld(std::mt19937_64* g, int n) {
  World w;
  w.name = "random";
  w.map_min_m = Eigen::Vector3d(-6, -6, -1);
  w.map_max_m = Eigen::Vector3d(6, 6, 3);
  w.exploration_height_m = 1.0;
  for (int i = 0; i < n; ++i) {
    WorldBox b;
    b.name = "box" + std::to_string(i);
    b.center_m = Eigen::Vector3d(Uniform(g, -5, 5), Uniform(g, -5, 5), Uniform(g, 0, 2));
    b.half_extents_m =
        Eigen::Vector3d(Uniform(g, 0.05, 0.6), Uniform(g, 0.05, 0.6), Uniform(g, 0.05, 0.6));
    if (i % 2 == 1) {
      b.q_WO = Eigen::Quaterniond(Uniform(g, -1, 1), Uniform(g, -1, 1), Uniform(g, -1, 1),
                                  Uniform(g, -1, 1))
                   .normalized();
    }
    w.boxes.push_back(b);
  }
  for (int i = 0; i < n / 2; ++i) {
    WorldCylinder c;
    c.name = "cyl" + std::to_string(i);
    c.center_xy_m = Eigen::Vector2d(Uniform(g, -5, 5), Uniform(g, -5, 5));
    c.radius_m = Uniform(g, 0.05, 0.5);
    c.z_min_m = Uniform(g, -0.5, 1.0);
    c.z_max_m = c.z_min_m + Uniform(g, 0.1, 2.0);
    w.cylinders.push_back(c);
  }
  w.planes.push_back(WorldPlane{"floor", Eigen::Vector3d::UnitZ(), 0.0});
  // A mesh of n/2 random triangles (surfaces).
  WorldMesh mesh;
  mesh.name = "triangles";
  for (int i = 0; i < n / 2; ++i) {
    const Eigen::Vector3d c(Uniform(g, -5, 5), Uniform(g, -5, 5), Uniform(g, 0, 2));
    for (int k = 0; k < 3; ++k) {
      mesh.vertices_W.push_back(
          c + Eigen::Vector3d(Uniform(g, -0.6, 0.6), Uniform(g, -0.6, 0.6), Uniform(g, -0.6, 0.6)));
    }
    mesh.triangles.emplace_back(3 * i, 3 * i + 1, 3 * i + 2);
  }
  w.meshes.push_back(mesh);
  return w;
}

Eigen::Vector3d RandomFreePoint(const World& w, std::mt19937_64* g) {
  while (true) {
    const Eigen::Vector3d p(Uniform(g, -6, 6), Uniform(g, -6, 6), Uniform(g, 0.01, 2.5));
    if (!IsInsideObstacle(w, p)) return p;
  }
}

// Independent triangle oracle: where the ray o + s u crosses the plane of each triangle, and
// whether that point lies in the triangle (barycentric coordinates by areas, 1e-9 slack). Returns
// the first such s >= 0, or +inf.
double FirstTriangleCrossing(const World& w, const Eigen::Vector3d& o, const Eigen::Vector3d& u) {
  double first = kInf;
  for (const WorldMesh& m : w.meshes) {
    for (const Eigen::Vector3i& t : m.triangles) {
      const Eigen::Vector3d& a = m.vertices_W[static_cast<size_t>(t[0])];
      const Eigen::Vector3d& b = m.vertices_W[static_cast<size_t>(t[1])];
      const Eigen::Vector3d& c = m.vertices_W[static_cast<size_t>(t[2])];
      const Eigen::Vector3d n = (b - a).cross(c - a);
      const double rate = n.dot(u);
      if (rate == 0.0) continue;
      const double s = n.dot(a - o) / rate;
      if (s < 0.0 || s >= first) continue;
      const Eigen::Vector3d p = o + s * u;
      const double area = n.norm();
      const double wa = (b - p).cross(c - p).dot(n) / (area * area);
      const double wb = (c - p).cross(a - p).dot(n) / (area * area);
      const double wc = (a - p).cross(b - p).dot(n) / (area * area);
      if (wa >= -1e-9 && wb >= -1e-9 && wc >= -1e-9) first = s;
    }
  }
  return first;
}

World OneOfEach() {
  World w;
  w.map_min_m = Eigen::Vector3d(-10, -10, -1);
  w.map_max_m = Eigen::Vector3d(10, 10, 5);
  w.boxes.push_back(WorldBox{"aligned", {3, 0, 1}, {0.5, 1, 1}, Eigen::Quaterniond::Identity()});
  w.boxes.push_back(WorldBox{"turned", {0, 4, 1}, {1, 0.25, 1}, QuaternionFromYaw(M_PI / 4)});
  w.cylinders.push_back(WorldCylinder{"cyl", {-3, 0}, 0.5, 0.0, 2.0});
  w.planes.push_back(WorldPlane{"floor", Eigen::Vector3d::UnitZ(), 0.0});
  WorldMesh m;
  m.name = "triangle";
  m.vertices_W = {{0, -4, 0.5}, {0, -4, 2.5}, {1, -5, 0.5}};  // in the plane x + y = -4
  m.triangles = {Eigen::Vector3i(0, 1, 2)};
  w.meshes.push_back(m);
  return w;
}

// Closed-form distances for each primitive kind.
TEST(WorldRayCaster, HitsPrimitivesAtAnalyticDistances) {
  const World w = OneOfEach();
  const WorldRayCaster caster(w);
  const Eigen::Vector3d o(0, 0, 1);
  int id = -2;
  EXPECT_DOUBLE_EQ(caster.CastRay(o, Eigen::Vector3d::UnitX(), 10.0, &id), 2.5);
  EXPECT_EQ(id, 0);
  EXPECT_DOUBLE_EQ(caster.CastRay(o, -Eigen::Vector3d::UnitX(), 10.0, &id), 2.5);
  EXPECT_EQ(id, 2);
  // The turned box's near face is 0.25 m from its centre along its local y (yaw 45 deg), so the
  // ray along +y meets it at 4 - 0.25 * sqrt(2).
  EXPECT_NEAR(caster.CastRay(o, Eigen::Vector3d::UnitY(), 10.0, &id), 4.0 - 0.25 * std::sqrt(2.0),
              1e-12);
  EXPECT_EQ(id, 1);
  EXPECT_DOUBLE_EQ(caster.CastRay(o, -Eigen::Vector3d::UnitZ(), 10.0, &id), 1.0);
  EXPECT_EQ(id, 4);  // the floor, after 2 boxes, 1 cylinder and 1 triangle
  // The triangle: from (0.2, 0, 1) along -y it meets x + y = -4 at y = -4.2.
  EXPECT_NEAR(caster.CastRay({0.2, 0, 1}, -Eigen::Vector3d::UnitY(), 10.0, &id), 4.2, 1e-12);
  EXPECT_EQ(id, 3);
  EXPECT_EQ(caster.CastRay({-0.2, 0, 1}, -Eigen::Vector3d::UnitY(), 10.0, &id), kInf);  // beside it
  EXPECT_EQ(caster.CastRay(o, Eigen::Vector3d::UnitZ(), 10.0, &id), kInf);
  EXPECT_EQ(id, WorldRayCaster::kNoHit);
  // Out of range and inside.
  EXPECT_EQ(caster.CastRay(o, Eigen::Vector3d::UnitX(), 2.4), kInf);
  EXPECT_EQ(caster.CastRay({3, 0, 1}, Eigen::Vector3d::UnitY(), 10.0, &id), 0.0);
  EXPECT_EQ(id, 0);
  // Cylinder cap from above, and a slanted ray onto the side: from (-3, -2, 1) towards +y the
  // side is met at y = -0.5.
  EXPECT_DOUBLE_EQ(caster.CastRay({-3.2, 0, 3}, -Eigen::Vector3d::UnitZ(), 10.0, &id), 1.0);
  EXPECT_EQ(id, 2);
  EXPECT_DOUBLE_EQ(caster.CastRay({-3, -2, 1}, Eigen::Vector3d::UnitY(), 10.0), 1.5);
  const Eigen::Vector3d slant = Eigen::Vector3d(0, 1, 1).normalized();
  EXPECT_NEAR(caster.CastRay({-3, -2, 0.2}, slant, 10.0), 1.5 * std::sqrt(2.0), 1e-12);
}

// The BVH and the grid walk return exactly what testing every primitive returns, whatever hint.
TEST(WorldRayCaster, AcceleratorsEqualBruteForce) {
  std::mt19937_64 g(7);
  const World w = RandomWorld(&g, 200);
  for (double bin : {0.0, 0.2, 0.5, 1.7}) {
    const WorldRayCaster caster(
        w, bin > 0.0 ? bin : 0.5,
        bin > 0.0 ? WorldRayCaster::Accelerator::kGrid : WorldRayCaster::Accelerator::kBvh);
    for (int i = 0; i < 20000; ++i) {
      const Eigen::Vector3d o = RandomFreePoint(w, &g);
      const Eigen::Vector3d u = RandomUnit(&g);
      const double range = Uniform(&g, 0.5, 12.0);
      const double fast = caster.CastRay(o, u, range);
      const double slow = caster.CastRayBruteForce(o, u, range);
      ASSERT_EQ(fast, slow) << "bin " << bin << " ray " << i;
      // Any hint gives the same distance.
      const int hint = static_cast<int>(g() % static_cast<uint64_t>(caster.num_primitives()));
      ASSERT_EQ(caster.CastRay(o, u, range, nullptr, hint), slow) << "hint " << hint;
    }
  }
}

// Independent check of exactness: just before the hit the ray is in free space, the path up to
// it never enters a solid (sampled every 5 mm) nor crosses a triangle, and just after a
// non-grazing hit it is inside a solid, or the hit is the first triangle crossing.
TEST(WorldRayCaster, HitPointsLieOnSurfaces) {
  std::mt19937_64 g(11);
  const World w = RandomWorld(&g, 60);
  const WorldRayCaster caster(w);
  int checked_inside = 0, hits = 0;
  for (int i = 0; i < 3000; ++i) {
    const Eigen::Vector3d o = RandomFreePoint(w, &g);
    const Eigen::Vector3d u = RandomUnit(&g);
    const double t = caster.CastRay(o, u, 20.0);
    if (t == kInf) continue;
    ++hits;
    ASSERT_FALSE(IsInsideObstacle(w, o + (t - 1e-9) * u)) << i;
    for (double s = 0.0; s < t - 1e-9; s += 0.005) ASSERT_FALSE(IsInsideObstacle(w, o + s * u));
    const double crossing = FirstTriangleCrossing(w, o, u);
    ASSERT_GE(crossing, t - 1e-9) << i;  // no triangle before the hit
    checked_inside +=
        IsInsideObstacle(w, o + (t + 1e-7) * u) || std::abs(crossing - t) < 1e-9 ? 1 : 0;
  }
  EXPECT_GT(hits, 1000);
  EXPECT_GT(checked_inside, hits * 99 / 100);  // all but grazing hits
}

// True when the segment o + s u, s in [0, t), is free of solids (sampled every 1 mm, plus the
// point 1e-9 before t) and crosses no triangle (up to 1e-7 before t), and, for finite t, the ray
// is inside a solid 1e-7 after t or t is where it crosses a triangle (to 1e-7).
bool OracleConfirms(const World& w, const Eigen::Vector3d& o, const Eigen::Vector3d& u, double t,
                    double range) {
  const double end = std::min(t, range);
  for (double s = 0.0; s < end - 1e-9; s += 0.001) {
    if (IsInsideObstacle(w, o + s * u)) return false;
  }
  if (IsInsideObstacle(w, o + (end - 1e-9) * u)) return false;
  const double crossing = FirstTriangleCrossing(w, o, u);
  if (crossing < end - 1e-7) return false;
  if (!std::isfinite(t)) return !(crossing <= range);
  return IsInsideObstacle(w, o + (t + 1e-7) * u) || std::abs(crossing - t) < 1e-7;
}

// Statistics of a comparison with Bullet.
struct BulletComparison {
  int hits = 0, cylinder_hits = 0, triangle_hits = 0, disagreements = 0, bullet_wrong = 0;
  double worst_exact = 0.0, worst_cylinder = 0.0;
  bool fast_always_right = true;
};

// Casts `rays` random rays from free points in [lo, hi] with both casters. Where both hit the
// same primitive (or both miss), records the distance error; elsewhere (or beyond 1e-6 m on
// boxes, triangles and planes, 5e-4 m on cylinders) settles the case with OracleConfirms.
BulletComparison CompareWithBullet(const World& w, int rays, const Eigen::Vector3d& lo,
                                   const Eigen::Vector3d& hi, std::mt19937_64* g) {
  const WorldRayCaster caster(w);
  const BulletWorld bullet(w);
  const int first_cylinder = static_cast<int>(w.boxes.size());
  const int first_triangle = first_cylinder + static_cast<int>(w.cylinders.size());
  const int first_plane = first_triangle + static_cast<int>(w.num_triangles());
  constexpr double kRange = 8.0;
  BulletComparison c;
  for (int i = 0; i < rays; ++i) {
    Eigen::Vector3d o;
    do {
      o = Eigen::Vector3d(Uniform(g, lo.x(), hi.x()), Uniform(g, lo.y(), hi.y()),
                          Uniform(g, lo.z(), hi.z()));
    } while (IsInsideObstacle(w, o));
    const Eigen::Vector3d u = RandomUnit(g);
    int id = WorldRayCaster::kNoHit;
    int bullet_id = -1;
    const double fast = caster.CastRay(o, u, kRange, &id);
    const double reference = bullet.RayTest(o, u, kRange, &bullet_id);
    const bool on_cylinder = id >= first_cylinder && id < first_triangle;
    const double err = id == WorldRayCaster::kNoHit ? 0.0 : std::abs(fast - reference);
    if (id != bullet_id || err > (on_cylinder ? 5e-4 : 1e-6)) {
      ++c.disagreements;
      c.fast_always_right &= OracleConfirms(w, o, u, fast, kRange);
      c.bullet_wrong += OracleConfirms(w, o, u, reference, kRange) ? 0 : 1;
      continue;
    }
    if (id == WorldRayCaster::kNoHit) continue;
    ++c.hits;
    c.triangle_hits += id >= first_triangle && id < first_plane ? 1 : 0;
    if (on_cylinder) {
      ++c.cylinder_hits;
      c.worst_cylinder = std::max(c.worst_cylinder, err);
    } else {
      c.worst_exact = std::max(c.worst_exact, err);
    }
  }
  std::printf(
      "%s, %d rays: %d agreeing hits (%d on cylinders, %d on triangles); worst |fast - bullet| "
      "%.3g m (boxes, triangles, planes), %.3g m (cylinders); %d disagreements (Bullet wrong "
      "in %d)\n",
      w.name.c_str(), rays, c.hits, c.cylinder_hits, c.triangle_hits, c.worst_exact,
      c.worst_cylinder, c.disagreements, c.bullet_wrong);
  return c;
}

// Agreement with Bullet's btCollisionWorld::rayTest on thousands of random rays: both hit the
// same primitive (or both miss) at distances within 1e-6 m on boxes, triangles and planes and
// 5e-4 m on cylinders (Bullet's GJK ray cast stops at about 2e-4 m there), except on a few rays
// (< 0.5 %) where Bullet's tolerances show (hits on cylinders the ray passes beside, triangle
// edge tolerance on box edges). Each of those is settled by sampling the ray against the
// inside test, and the fast caster must be the one that is right, every time.
TEST(WorldRayCaster, AgreesWithBulletRayTest) {
  std::mt19937_64 g(3);
  const World w = RandomWorld(&g, 80);
  constexpr int kRays = 20000;
  const BulletComparison c = CompareWithBullet(w, kRays, {-6, -6, 0.01}, {6, 6, 2.5}, &g);
  EXPECT_GT(c.hits, kRays / 2);
  EXPECT_GT(c.cylinder_hits, 1000);
  EXPECT_GT(c.triangle_hits, 100);
  EXPECT_LT(c.disagreements, kRays / 200);
  EXPECT_TRUE(c.fast_always_right);
  EXPECT_EQ(c.bullet_wrong, c.disagreements);
  EXPECT_LT(c.worst_exact, 1e-6);
  EXPECT_LT(c.worst_cylinder, 5e-4);
}

// The same agreement in the shipped worlds, from free points inside their map limits. Their
// walls abut, so a ray through a shared face may hit either box at the same distance: there a
// disagreement can have both casters right.
TEST(WorldRayCaster, AgreesWithBulletRayTestInShippedWorlds) {
  std::mt19937_64 g(4);
  for (const char* name : {"paper_sim", "lasr", "office"}) {
    const World w = LoadWorld(std::string(KESTREL_SOURCE_DIR) + "/config/worlds/" + name + ".yaml");
    constexpr int kRays = 5000;
    const BulletComparison c = CompareWithBullet(w, kRays, w.map_min_m, w.map_max_m, &g);
    EXPECT_GT(c.hits, kRays / 2) << name;
    EXPECT_LT(c.disagreements, kRays / 200) << name;
    EXPECT_TRUE(c.fast_always_right) << name;  // (abutting boxes: both may be right)
  }
}

// Batches give the same answers whatever the thread count.
TEST(WorldRayCaster, BatchIsIndependentOfThreadCount) {
  std::mt19937_64 g(5);
  const World w = RandomWorld(&g, 100);
  const WorldRayCaster caster(w);
  std::vector<Eigen::Vector3d> dirs(10000);
  for (auto& d : dirs) d = RandomUnit(&g);
  const Eigen::Vector3d o = RandomFreePoint(w, &g);
  std::vector<double> one, many;
  caster.CastRays(o, dirs, 6.0, &one, 1);
  caster.CastRays(o, dirs, 6.0, &many, 3);
  ASSERT_EQ(one.size(), dirs.size());
  EXPECT_EQ(one, many);
  for (size_t i = 0; i < dirs.size(); i += 97) EXPECT_EQ(one[i], caster.CastRay(o, dirs[i], 6.0));
}

TEST(WorldRayCaster, RejectsBadBinSize) {
  const World w = OneOfEach();
  EXPECT_THROW(WorldRayCaster(w, 0.0), std::invalid_argument);
  EXPECT_THROW(WorldRayCaster(w, std::nan("")), std::invalid_argument);
}

}  // namespace
}  // namespace kestrel
