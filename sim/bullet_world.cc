#include "sim/bullet_world.h"

#include <limits>
#include <string>
#include <vector>

#include <btBulletCollisionCommon.h>

#include "common/check.h"

namespace kestrel {
namespace {

btVector3 ToBt(const Eigen::Vector3d& v) { return btVector3(v.x(), v.y(), v.z()); }

btTransform ToBt(const Eigen::Vector3d& p, const Eigen::Quaterniond& q) {
  return btTransform(btQuaternion(q.x(), q.y(), q.z(), q.w()), ToBt(p));
}

// Counts distinct world objects with a contact point at distance <= 0.
struct ContactCounter : public btCollisionWorld::ContactResultCallback {
  const btCollisionObject* vehicle{nullptr};
  bool include_planes{true};
  std::vector<const btCollisionObject*> touched;

  btScalar addSingleResult(btManifoldPoint& point, const btCollisionObjectWrapper* a, int, int,
                           const btCollisionObjectWrapper* b, int, int) override {
    if (point.getDistance() > 0.0) return 0.0;
    const btCollisionObject* other =
        a->getCollisionObject() == vehicle ? b->getCollisionObject() : a->getCollisionObject();
    if (!include_planes && other->getCollisionShape()->getShapeType() == STATIC_PLANE_PROXYTYPE) {
      return 0.0;
    }
    for (const btCollisionObject* t : touched) {
      if (t == other) return 0.0;
    }
    touched.push_back(other);
    return 0.0;
  }
};

// The closest hit and, on triangle meshes, the index of the triangle hit.
struct ClosestWithTriangle : public btCollisionWorld::ClosestRayResultCallback {
  using btCollisionWorld::ClosestRayResultCallback::ClosestRayResultCallback;
  int triangle{0};
  btScalar addSingleResult(btCollisionWorld::LocalRayResult& result,
                           bool normal_in_world) override {
    triangle = result.m_localShapeInfo != nullptr ? result.m_localShapeInfo->m_triangleIndex : 0;
    return ClosestRayResultCallback::addSingleResult(result, normal_in_world);
  }
};

}  // namespace

struct BulletWorld::Impl {
  btDefaultCollisionConfiguration configuration;
  btCollisionDispatcher dispatcher{&configuration};
  btDbvtBroadphase broadphase;
  btCollisionWorld world{&dispatcher, &broadphase, &configuration};
  std::vector<std::unique_ptr<btTriangleMesh>> meshes;  // before shapes: outlives them
  std::vector<std::unique_ptr<btCollisionShape>> shapes;
  std::vector<std::unique_ptr<btCollisionObject>> objects;
  std::vector<std::string> names;  // parallel to objects (user index)
  std::unique_ptr<btCylinderShapeZ> vehicle_shape;
  std::unique_ptr<btCollisionObject> vehicle;

  Impl() = default;
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;
  ~Impl() {
    for (auto& object : objects) world.removeCollisionObject(object.get());
  }

  // `first_id`: the WorldRayCaster id of the object (of its first triangle for meshes, whose hits
  // add the triangle index: user index 2 is 1 for meshes).
  void Add(std::unique_ptr<btCollisionShape> shape, const btTransform& X, const std::string& name,
           int first_id, bool is_mesh = false) {
    auto object = std::make_unique<btCollisionObject>();
    object->setCollisionShape(shape.get());
    object->setWorldTransform(X);
    object->setUserIndex(first_id);
    object->setUserIndex2(is_mesh ? 1 : 0);
    object->setUserIndex3(static_cast<int>(names.size()));
    world.addCollisionObject(object.get());
    names.push_back(name);
    shapes.push_back(std::move(shape));
    objects.push_back(std::move(object));
  }
};

BulletWorld::BulletWorld(const World& world, double vehicle_radius_m, double vehicle_height_m,
                         BoxShape box_shape)
    : impl_(std::make_unique<Impl>()) {
  KESTREL_THROW_UNLESS(vehicle_radius_m > 0.0 && vehicle_height_m > 0.0,
                       "vehicle radius " << vehicle_radius_m << " m and height " << vehicle_height_m
                                         << " m must be positive");
  int next_id = 0;
  for (const WorldBox& b : world.boxes) {
    if (box_shape == BoxShape::kConvexBox) {
      auto shape = std::make_unique<btBoxShape>(ToBt(b.half_extents_m));
      impl_->Add(std::move(shape), ToBt(b.center_m, b.q_WO), b.name, next_id++);
      continue;
    }
    // Two triangles per face, in the box frame.
    auto mesh = std::make_unique<btTriangleMesh>();
    const Eigen::Vector3d& h = b.half_extents_m;
    auto corner = [&](int i) {
      return btVector3((i & 1) ? h.x() : -h.x(), (i & 2) ? h.y() : -h.y(),
                       (i & 4) ? h.z() : -h.z());
    };
    static constexpr int kFaces[6][4] = {{0, 2, 6, 4}, {1, 5, 7, 3}, {0, 4, 5, 1},
                                         {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 6, 7, 5}};
    for (const auto& f : kFaces) {
      mesh->addTriangle(corner(f[0]), corner(f[1]), corner(f[2]));
      mesh->addTriangle(corner(f[0]), corner(f[2]), corner(f[3]));
    }
    auto shape = std::make_unique<btBvhTriangleMeshShape>(mesh.get(), true);
    impl_->meshes.push_back(std::move(mesh));
    impl_->Add(std::move(shape), ToBt(b.center_m, b.q_WO), b.name, next_id++);
  }
  for (const WorldCylinder& c : world.cylinders) {
    const double half_height = 0.5 * (c.z_max_m - c.z_min_m);
    auto shape = std::make_unique<btCylinderShapeZ>(btVector3(c.radius_m, c.radius_m, half_height));
    shape->setMargin(0.0);
    const Eigen::Vector3d center(c.center_xy_m.x(), c.center_xy_m.y(), c.z_min_m + half_height);
    impl_->Add(std::move(shape), ToBt(center, Eigen::Quaterniond::Identity()), c.name, next_id++);
  }
  btTransform identity;
  identity.setIdentity();
  for (const WorldMesh& m : world.meshes) {
    auto mesh = std::make_unique<btTriangleMesh>();
    for (const Eigen::Vector3i& t : m.triangles) {
      mesh->addTriangle(ToBt(m.vertices_W[static_cast<size_t>(t[0])]),
                        ToBt(m.vertices_W[static_cast<size_t>(t[1])]),
                        ToBt(m.vertices_W[static_cast<size_t>(t[2])]));
    }
    auto shape = std::make_unique<btBvhTriangleMeshShape>(mesh.get(), true);
    impl_->meshes.push_back(std::move(mesh));
    impl_->Add(std::move(shape), identity, m.name, next_id, true);
    next_id += static_cast<int>(m.triangles.size());
  }
  for (const WorldPlane& p : world.planes) {
    auto shape = std::make_unique<btStaticPlaneShape>(ToBt(p.normal), p.offset_m);
    impl_->Add(std::move(shape), identity, p.name, next_id++);
  }
  impl_->vehicle_shape = std::make_unique<btCylinderShapeZ>(
      btVector3(vehicle_radius_m, vehicle_radius_m, 0.5 * vehicle_height_m));
  impl_->vehicle = std::make_unique<btCollisionObject>();
  impl_->vehicle->setCollisionShape(impl_->vehicle_shape.get());
  impl_->world.updateAabbs();
}

BulletWorld::~BulletWorld() = default;

double BulletWorld::RayTest(const Eigen::Vector3d& o_W, const Eigen::Vector3d& u_W,
                            double max_range_m, int* primitive) const {
  const btVector3 from = ToBt(o_W);
  const btVector3 to = ToBt(o_W + max_range_m * u_W);
  ClosestWithTriangle callback(from, to);
  impl_->world.rayTest(from, to, callback);
  if (primitive != nullptr) {
    *primitive = -1;
    if (callback.hasHit()) {
      const btCollisionObject* o = callback.m_collisionObject;
      *primitive = o->getUserIndex() + (o->getUserIndex2() == 1 ? callback.triangle : 0);
    }
  }
  if (!callback.hasHit()) return std::numeric_limits<double>::infinity();
  return callback.m_closestHitFraction * max_range_m;
}

int BulletWorld::CountVehicleContacts(const Pose3& X_WB, bool include_planes,
                                      std::string* first_name) const {
  impl_->vehicle->setWorldTransform(ToBt(X_WB.p, X_WB.q));
  ContactCounter counter;
  counter.vehicle = impl_->vehicle.get();
  counter.include_planes = include_planes;
  impl_->world.contactTest(impl_->vehicle.get(), counter);
  if (first_name != nullptr && !counter.touched.empty()) {
    *first_name = impl_->names[static_cast<size_t>(counter.touched.front()->getUserIndex3())];
  }
  return static_cast<int>(counter.touched.size());
}

}  // namespace kestrel
