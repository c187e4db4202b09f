#pragma once
/// @file
/// Fast exact ray casting against a World's primitives: slab test for boxes (rotated ones in
/// their own frame), quadratic for vertical cylinders (side) plus the two caps, Moller-Trumbore
/// for mesh triangles (two-sided) and a plane test for half-spaces.
/// Finite primitives sit in an acceleration structure so that the cost grows with the primitives
/// near the ray, not with their number: a bounding-volume hierarchy (binary, surface-area-heuristic
/// splits, nearest child first, pruned by the best hit so far; the default) or a uniform 3D grid
/// over their bounding boxes walked by Amanatides & Woo (1987). Half-spaces are tested on every
/// ray.
///
/// The caster is immutable after construction and therefore safe to share between threads;
/// CastRays splits a batch over std::threads in contiguous chunks (results do not depend on the
/// thread count). Validated against Bullet's btCollisionWorld::rayTest (sim/bullet_world.h) in
/// tests/sim/world_ray_caster_test.cc.

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "sim/world.h"

namespace kestrel {

/// Exact ray caster over a World's primitives.
class WorldRayCaster {
 public:
  /// Primitive ids: boxes 0..nb-1, then cylinders, then mesh triangles (mesh by mesh, in file
  /// order), then planes. kNoHit for none.
  static constexpr int kNoHit = -1;

  /// Acceleration structure over the finite primitives.
  enum class Accelerator { kBvh, kGrid };

  /// Builds the BVH and, for kGrid, the grid (cubic bins of edge `bin_m` > 0; the count per axis
  /// is capped at 256, which enlarges the bins for huge worlds); `accelerator` picks the one
  /// CastRay walks. @throws std::invalid_argument on bad `bin_m`.
  explicit WorldRayCaster(const World& world, double bin_m = 0.5,
                          Accelerator accelerator = Accelerator::kBvh);

  /// Distance (m) along the unit direction u_W from o_W to the first primitive surface in
  /// [0, max_range_m]; +infinity when there is none. A ray starting inside (or on the surface
  /// of) a solid returns 0. `primitive` (if not nullptr) receives the id hit or kNoHit.
  /// Precondition: |u_W| = 1 (KESTREL_ASSERT), max_range_m >= 0.
  /// `hint` (optional) is a primitive likely to be hit, e.g. the previous pixel's: it is tested
  /// first so the search prunes more; the distance returned does not depend on it.
  [[nodiscard]] double CastRay(const Eigen::Vector3d& o_W, const Eigen::Vector3d& u_W,
                               double max_range_m, int* primitive = nullptr,
                               int hint = kNoHit) const;

  /// The same answer by testing every primitive (no acceleration): the oracle for both.
  [[nodiscard]] double CastRayBruteForce(const Eigen::Vector3d& o_W, const Eigen::Vector3d& u_W,
                                         double max_range_m, int* primitive = nullptr) const;

  /// Casts rays from one origin along unit directions u_W[i]; out_m[i] as CastRay. Uses up to
  /// `num_threads` std::threads (1 = this thread only) over contiguous chunks; the results are
  /// identical for any thread count (each ray's hit primitive hints the next ray's search).
  /// Resizes *out_m.
  void CastRays(const Eigen::Vector3d& o_W, const std::vector<Eigen::Vector3d>& u_W,
                double max_range_m, std::vector<double>* out_m, int num_threads = 1) const;

  /// Number of primitives (boxes + cylinders + planes).
  [[nodiscard]] int num_primitives() const { return num_primitives_; }
  /// Grid bins per axis (zero unless built with Accelerator::kGrid).
  [[nodiscard]] const Eigen::Vector3i& grid_dims() const { return dims_; }

 private:
  struct Box {
    Eigen::Matrix3d R_OW;    // rows: box axes in W
    Eigen::Vector3d center;  // W
    Eigen::Vector3d half;    // half extents
    Eigen::Vector3d lo, hi;  // W corners (axis-aligned boxes)
    bool axis_aligned;
  };
  // A ray with its per-axis reciprocals (computed once per ray).
  struct Ray {
    Eigen::Vector3d o, u, inv;
  };
  struct Cylinder {
    double cx, cy, r2, z_min, z_max;
  };
  struct Triangle {
    Eigen::Vector3d v0, e1, e2;  // vertex 0 and the edges to vertices 1 and 2, W
  };
  struct Plane {
    Eigen::Vector3d normal;
    double offset;
  };

  // Entry distance of the ray into primitive `id` if it is < best (updates best and hit).
  void TestPrimitive(int id, const Ray& ray, double* best, int* hit) const;
  void TestPlanes(const Eigen::Vector3d& o, const Eigen::Vector3d& u, double* best, int* hit) const;
  void WalkGrid(const Ray& ray, double max_range_m, double* best, int* hit) const;
  void WalkBvh(const Ray& ray, double max_range_m, double* best, int* hit) const;
  int BuildBvh(std::vector<int>* ids, int begin, int end,
               const std::vector<Eigen::AlignedBox3d>& bounds);

  struct BvhNode {
    double lo[3], hi[3];  // bounds
    int first;            // leaf: first index into bvh_items_; inner: left child
    int count;            // leaf: number of items (> 0); inner: 0
    int right;            // inner: right child
  };
  Accelerator accelerator_{Accelerator::kBvh};
  std::vector<BvhNode> bvh_;
  std::vector<int32_t> bvh_items_;

  std::vector<Box> boxes_;
  std::vector<Cylinder> cylinders_;
  std::vector<Triangle> triangles_;
  std::vector<Plane> planes_;
  int num_finite_{0};
  int num_primitives_{0};
  // Grid: bins over [grid_min_, grid_min_ + dims_ * bin_), CSR lists of finite primitive ids.
  Eigen::Vector3d grid_min_{Eigen::Vector3d::Zero()};
  Eigen::Vector3d grid_max_{Eigen::Vector3d::Zero()};
  double bin_m_{0.5};
  double inv_bin_{2.0};
  Eigen::Vector3i dims_{Eigen::Vector3i::Zero()};
  std::vector<uint32_t> bin_begin_;  // size bins + 1
  std::vector<int32_t> bin_items_;
};

}  // namespace kestrel
