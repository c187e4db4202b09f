#pragma once
/// @file
/// The world's primitives in a Bullet btCollisionWorld (double-precision Bullet): the reference
/// for the fast ray caster (sim/world_ray_caster.h) and the contact detector for the vehicle.
/// Debian's Bullet is built without thread safety: a BulletWorld must be used from one thread at
/// a time (no concurrent RayTest calls).
///
/// Representation (static collision objects): planes are btStaticPlaneShape; cylinders
/// btCylinderShapeZ with zero collision margin (the exact cylinder, though Bullet's convex ray cast
/// only converges to about 2e-4 m on it and, like on boxes, sometimes reports hits on rays that
/// pass beside the shape: measured in tests/sim/world_ray_caster_test.cc); boxes are by default
/// 12-triangle btBvhTriangleMeshShapes, whose ray test is an exact plane intersection, or
/// btBoxShapes (convex: the same convergence and false hits as the cylinders); each mesh is one
/// btBvhTriangleMeshShape.

#include <memory>
#include <string>

#include <Eigen/Core>

#include "common/se3.h"
#include "sim/world.h"

namespace kestrel {

/// One static Bullet collision world built from a World.
class BulletWorld {
 public:
  /// How boxes are given to Bullet.
  enum class BoxShape { kTriangleMesh, kConvexBox };

  /// Builds the collision world. The vehicle is a vertical cylinder of `vehicle_radius_m` and
  /// `vehicle_height_m` centred on the body origin, used by CountVehicleContacts.
  explicit BulletWorld(const World& world, double vehicle_radius_m = 0.4,
                       double vehicle_height_m = 0.2, BoxShape box_shape = BoxShape::kTriangleMesh);
  /// Removes the objects from the Bullet world before freeing them.
  ~BulletWorld();
  BulletWorld(const BulletWorld&) = delete;
  BulletWorld& operator=(const BulletWorld&) = delete;

  /// Distance (m) along the unit direction u_W from o_W to the first surface within
  /// [0, max_range_m] by btCollisionWorld::rayTest (closest hit); +infinity when nothing is hit.
  /// `primitive` (if not nullptr) receives the id of the object hit, numbered as in WorldRayCaster
  /// (boxes, then cylinders, then planes), or -1. Not thread-safe.
  [[nodiscard]] double RayTest(const Eigen::Vector3d& o_W, const Eigen::Vector3d& u_W,
                               double max_range_m, int* primitive = nullptr) const;

  /// Number of world primitives in contact with (touching or penetrating, distance <= 0) the
  /// vehicle shape at pose X_WB; `include_planes` false leaves the half-spaces (the floor) out.
  /// The name of one contacted primitive goes to `first_name` when it is not nullptr.
  /// Not thread-safe.
  [[nodiscard]] int CountVehicleContacts(const Pose3& X_WB, bool include_planes,
                                         std::string* first_name = nullptr) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kestrel
