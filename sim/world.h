#pragma once
/// @file
/// Simulated worlds: solid primitives (boxes, possibly rotated; vertical cylinders; half-spaces
/// bounded by planes) with the map limits, the start pose and the exploration height of a run.
/// World frame W: x east, y north, z up (docs/design.md §4). A world file is
/// YAML read through common/config.h; every error names the file, the key path (and the YAML line
/// where one is known) and the reason.
///
/// File format (all lengths in metres, angles in radians):
/// @code
///   name: paper_sim
///   map_limits: {min_m: [-4, -6, -0.15], max_m: [4, 6, 1.5]}
///   start: {position_m: [0, 0, 0], yaw_rad: 0}   # vehicle body origin on the floor
///   exploration_height_m: 0.75
///   obstacles:
///     - {type: plane, name: floor, normal: [0, 0, 1], offset_m: 0}       # solid where n.x < d
///     - {type: box, name: wall, min_m: [-4, 5.9, 0], max_m: [4, 6, 1.5]} # axis-aligned
///     - {type: box, name: desk, center_m: [1, 2, 0.375], size_m: [1.2, 0.6, 0.75],
///        yaw_rad: 0.3}                                                    # or rpy_rad: [r, p, y]
///     - {type: cylinder, name: bin, center_m: [2, 3], radius_m: 0.2, z_min_m: 0, z_max_m: 0.6}
/// @endcode
///     - {type: mesh, name: statue, file: meshes/pyramid.obj, position_m: [1, 1, 0],
///        yaw_rad: 0.5, scale: 1.0}                                        # OBJ, see ReadObjFile
/// A mesh file path is relative to the world file's folder. Meshes are surfaces, not solids:
/// rays stop on their triangles and voxelisation marks the cells the triangles cross, but their
/// inside is neither occupied nor "inside" for IsInsideObstacle.

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "common/config.h"
#include "common/se3.h"

namespace kestrel {

/// A solid box: centre, half extents along its own axes, orientation R_WO (identity = aligned).
struct WorldBox {
  std::string name;                                                ///< for messages and tests
  Eigen::Vector3d center_m{Eigen::Vector3d::Zero()};               ///< centre in W, m
  Eigen::Vector3d half_extents_m{Eigen::Vector3d::Constant(0.5)};  ///< half sizes, m, > 0
  Eigen::Quaterniond q_WO{Eigen::Quaterniond::Identity()};         ///< box axes in W
};

/// A solid vertical (axis along W z) circular cylinder.
struct WorldCylinder {
  std::string name;                                      ///< for messages and tests
  Eigen::Vector2d center_xy_m{Eigen::Vector2d::Zero()};  ///< axis position (x, y) in W, m
  double radius_m{0.1};                                  ///< radius, m, > 0
  double z_min_m{0.0};                                   ///< bottom, m
  double z_max_m{1.0};                                   ///< top, m, > z_min_m
};

/// A solid half-space {x : normal . x < offset_m}; its boundary is the plane normal . x = offset_m.
/// The floor is {normal (0,0,1), offset 0}: solid below z = 0.
struct WorldPlane {
  std::string name;                                  ///< for messages and tests
  Eigen::Vector3d normal{Eigen::Vector3d::UnitZ()};  ///< unit outward normal (towards free space)
  double offset_m{0.0};                              ///< plane offset along the normal, m
};

/// A triangle mesh (a surface) in W: vertices already placed (scale, yaw, position applied).
struct WorldMesh {
  std::string name;                         ///< for messages and tests
  std::string file;                         ///< OBJ file it came from ("" if built in code)
  std::vector<Eigen::Vector3d> vertices_W;  ///< vertex positions in W, m
  std::vector<Eigen::Vector3i> triangles;   ///< vertex indices (0-based) of each triangle
};

/// A whole world: obstacles plus the run's map limits, start pose and exploration height.
struct World {
  std::string name;    ///< world name (file stem if absent)
  std::string source;  ///< file it was loaded from ("" if built in code)
  Eigen::Vector3d map_min_m{Eigen::Vector3d::Zero()};  ///< lower map limit in W, m
  Eigen::Vector3d map_max_m{Eigen::Vector3d::Ones()};  ///< upper map limit in W, m
  Pose3 start_X_WB;                                    ///< vehicle start pose (on the floor), X_WB
  double exploration_height_m{0.75};                   ///< flight plane height z in W, m
  std::vector<WorldBox> boxes;                         ///< solid boxes
  std::vector<WorldCylinder> cylinders;                ///< solid vertical cylinders
  std::vector<WorldPlane> planes;                      ///< solid half-spaces
  std::vector<WorldMesh> meshes;                       ///< triangle surfaces

  /// Total number of triangles of all meshes.
  [[nodiscard]] size_t num_triangles() const {
    size_t n = 0;
    for (const WorldMesh& m : meshes) n += m.triangles.size();
    return n;
  }
  /// Total number of primitives (each mesh triangle counts as one).
  [[nodiscard]] size_t size() const {
    return boxes.size() + cylinders.size() + planes.size() + num_triangles();
  }

  /// Checks the geometry: limits ordered, half extents and radii positive and finite, unit-able
  /// normals, start inside the limits, exploration height inside the z limits.
  /// @throws std::invalid_argument naming the primitive and the bad value.
  void Validate() const;
};

/// An obstacle near a point: what it is ("box 'desk'", "cylinder 'bin'", "plane 'floor'",
/// "mesh 'statue'") and its distance, m (0 inside it).
struct NearObstacle {
  std::string what;
  double distance_m{0.0};
};

/// The obstacle nearest to p among those within radius_m of it (the sphere the observable set
/// requires clear, sim/ground_truth.h ComputeObservableCells), or nullopt when that sphere is
/// clear.
[[nodiscard]] std::optional<NearObstacle> NearestObstacleWithin(const World& world,
                                                                const Eigen::Vector3d& p,
                                                                double radius_m);

/// A start the vehicle cannot use: the world's start moved by start_offset_m (x, y), at the
/// exploration height, with an obstacle within clearance_m (0: inside one). The message names the
/// world, the start, the obstacle, its distance and the clearance; nullopt when the start is
/// clear. Without this check such a world flies nowhere and scores "nan of 0 observable cells".
[[nodiscard]] std::optional<std::string> StartClearanceProblem(
    const World& world, const Eigen::Vector3d& start_offset_m, double clearance_m);

/// Reads a world from a parsed YAML document (format in the file comment). Unknown keys are errors.
/// @throws ConfigError naming the file, key path, YAML line and reason.
[[nodiscard]] World ParseWorld(const ConfigNode& root);

/// Reads the OBJ file at a path (ReadObjFile; tests and the fuzzer give their own).
using ObjReader = std::function<WorldMesh(const std::string& path)>;
/// ParseWorld with the mesh files read by `read_obj` (the path is relative to the folder of
/// root.file(), as in the file comment). @throws ConfigError as ParseWorld.
[[nodiscard]] World ParseWorld(const ConfigNode& root, const ObjReader& read_obj);

/// Loads and validates a world file. @throws ConfigError (file, key, line, reason).
[[nodiscard]] World LoadWorld(const std::string& path);
/// LoadWorld of a file that the configuration `including` names: the file is loaded through
/// including.Include(path), so that its values are part of the process's effective configuration.
[[nodiscard]] World LoadWorld(const std::string& path, const ConfigNode& including);

/// A controller's geofence (control/safety.h), W, m.
struct Geofence {
  Eigen::Vector3d min_m{Eigen::Vector3d::Zero()};  ///< lower corner
  Eigen::Vector3d max_m{Eigen::Vector3d::Zero()};  ///< upper corner
};

/// The geofence beside and below a world's map limits, m.
inline constexpr double kGeofenceMarginM = 0.2;
/// The geofence above a world's map limits, m: room over the map's top before a landing.
inline constexpr double kGeofenceHeadroomM = 1.0;

/// The geofence of a flight in `world`: the map limits widened by kGeofenceMarginM below and on
/// every side and by kGeofenceHeadroomM above. The one derivation (docs/design.md §7.2) that
/// kestrel-mission, the process sheets (scripts/world-env, through kestrel-world-env) and the
/// system tests use.
[[nodiscard]] Geofence WorldGeofence(const World& world);

/// True when the point lies strictly inside some primitive (boundaries count as free).
[[nodiscard]] bool IsInsideObstacle(const World& world, const Eigen::Vector3d& p_W);
/// How deep the point lies inside the solids, m: the largest over the primitives of its distance
/// to that primitive's surface when it is inside (0 outside every primitive). Meshes are surfaces
/// and have no inside. A point inside the union of two touching primitives (a wall built of two
/// boxes) may lie deeper than either says: this is a lower bound there.
[[nodiscard]] double DepthInsideObstacle(const World& world, const Eigen::Vector3d& p_W);

/// Reads a Wavefront OBJ file: "v x y z" vertices and "f i j k ..." faces (1-based indices,
/// negative ones counting back from the last vertex, "i/t/n" forms accepted, polygons split
/// into a triangle fan); every other line (comments, normals, texture coordinates, groups,
/// materials) is ignored. Vertices are in the file's units, taken as metres.
/// @throws ConfigError naming the file, the line and the reason (bad number, index out of range,
/// a face with fewer than 3 vertices, no faces at all).
[[nodiscard]] WorldMesh ReadObjFile(const std::string& path);
/// The pure core of ReadObjFile: parses OBJ text, `path` standing in for the file in errors and
/// in WorldMesh::file. @throws ConfigError as ReadObjFile.
[[nodiscard]] WorldMesh ParseObj(const std::string& text, const std::string& path);

/// Axis-aligned bounding box in W of a box primitive.
[[nodiscard]] Eigen::AlignedBox3d BoundsOf(const WorldBox& box);
/// Axis-aligned bounding box in W of a cylinder primitive.
[[nodiscard]] Eigen::AlignedBox3d BoundsOf(const WorldCylinder& cylinder);

}  // namespace kestrel
