#include "sim/world.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "common/check.h"

namespace kestrel {
namespace {

Eigen::Quaterniond QuaternionFromRpy(const Eigen::Vector3d& rpy_rad) {
  // R = Rz(yaw) Ry(pitch) Rx(roll): extrinsic roll, then pitch, then yaw about W axes.
  return (Eigen::AngleAxisd(rpy_rad.z(), Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(rpy_rad.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rpy_rad.x(), Eigen::Vector3d::UnitX()))
      .normalized();
}

WorldBox ParseBox(const ConfigNode& n) {
  WorldBox box;
  n.Read("name", &box.name);
  const bool has_min_max = n.Has("min_m") || n.Has("max_m");
  const bool has_center_size = n.Has("center_m") || n.Has("size_m");
  if (has_min_max && has_center_size) {
    n.Fail("min_m", "give either min_m/max_m or center_m/size_m, not both");
  }
  if (has_min_max) {
    Eigen::Vector3d lo, hi;
    n.ReadRequired("min_m", &lo);
    n.ReadRequired("max_m", &hi);
    for (int a = 0; a < 3; ++a) {
      if (!(hi[a] > lo[a])) n.Fail("max_m", "must exceed min_m on every axis");
    }
    box.center_m = 0.5 * (lo + hi);
    box.half_extents_m = 0.5 * (hi - lo);
  } else {
    Eigen::Vector3d size;
    n.ReadRequired("center_m", &box.center_m);
    n.ReadRequired("size_m", &size, Range::Positive());
    box.half_extents_m = 0.5 * size;
  }
  if (n.Has("yaw_rad") && n.Has("rpy_rad")) n.Fail("yaw_rad", "give yaw_rad or rpy_rad, not both");
  if (n.Has("yaw_rad")) {
    double yaw = 0.0;
    n.Read("yaw_rad", &yaw, Range::Closed(-2.0 * M_PI, 2.0 * M_PI));
    box.q_WO = QuaternionFromYaw(yaw);
  } else if (n.Has("rpy_rad")) {
    Eigen::Vector3d rpy;
    n.Read("rpy_rad", &rpy, Range::Closed(-2.0 * M_PI, 2.0 * M_PI));
    box.q_WO = QuaternionFromRpy(rpy);
  }
  return box;
}

WorldCylinder ParseCylinder(const ConfigNode& n) {
  WorldCylinder c;
  n.Read("name", &c.name);
  std::vector<double> center;
  n.ReadRequired("center_m", &center, Range::Any(), 2);
  c.center_xy_m = Eigen::Vector2d(center[0], center[1]);
  n.ReadRequired("radius_m", &c.radius_m, Range::Positive());
  n.ReadRequired("z_min_m", &c.z_min_m);
  n.ReadRequired("z_max_m", &c.z_max_m);
  if (!(c.z_max_m > c.z_min_m)) n.Fail("z_max_m", "must exceed z_min_m");
  return c;
}

WorldMesh ParseMesh(const ConfigNode& n, const ObjReader& read_obj) {
  std::string file;
  n.ReadRequired("file", &file);
  std::string dir;
  const size_t slash = n.file().find_last_of('/');
  if (!file.empty() && file[0] != '/' && slash != std::string::npos) {
    dir = n.file().substr(0, slash + 1);
  }
  WorldMesh mesh;
  try {
    mesh = read_obj(dir + file);
  } catch (const ConfigError& e) {
    n.Fail("file", e.what());
  }
  n.Read("name", &mesh.name);
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  double yaw = 0.0;
  double scale = 1.0;
  n.Read("position_m", &position);
  n.Read("yaw_rad", &yaw, Range::Closed(-2.0 * M_PI, 2.0 * M_PI));
  n.Read("scale", &scale, Range::Positive());
  const Eigen::Quaterniond q = QuaternionFromYaw(yaw);
  for (Eigen::Vector3d& v : mesh.vertices_W) v = q * (scale * v) + position;
  return mesh;
}

WorldPlane ParsePlane(const ConfigNode& n) {
  WorldPlane p;
  n.Read("name", &p.name);
  n.ReadRequired("normal", &p.normal);
  if (!(p.normal.norm() > 1e-9)) n.Fail("normal", "must be a non-zero vector");
  p.normal.normalize();
  n.ReadRequired("offset_m", &p.offset_m);
  return p;
}

}  // namespace

namespace {

// Distance from p to triangle abc (closest point by region tests, Ericson 2004, 5.1.5).
double DistanceToTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                          const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return ap.norm();
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return bp.norm();
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return (p - (a + d1 / (d1 - d3) * ab)).norm();
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return cp.norm();
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return (p - (a + d2 / (d2 - d6) * ac)).norm();
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    return (p - (b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b))).norm();
  }
  const double denom = 1.0 / (va + vb + vc);
  return (p - (a + ab * (vb * denom) + ac * (vc * denom))).norm();
}

// Euclidean distance from p to the solid (0 inside).
double DistanceToBox(const WorldBox& b, const Eigen::Vector3d& p) {
  const Eigen::Vector3d p_O = b.q_WO.conjugate() * (p - b.center_m);
  return (p_O.cwiseAbs() - b.half_extents_m).cwiseMax(0.0).norm();
}

double DistanceToCylinder(const WorldCylinder& c, const Eigen::Vector3d& p) {
  const double radial = std::max(0.0, (p.head<2>() - c.center_xy_m).norm() - c.radius_m);
  const double vertical = std::max({0.0, c.z_min_m - p.z(), p.z() - c.z_max_m});
  return std::hypot(radial, vertical);
}

}  // namespace

std::optional<NearObstacle> NearestObstacleWithin(const World& world, const Eigen::Vector3d& p,
                                                  double radius_m) {
  std::optional<NearObstacle> best;
  const auto offer = [&](const std::string& what, double d) {
    if (d <= radius_m && (!best || d < best->distance_m)) best = NearObstacle{what, d};
  };
  for (const WorldBox& b : world.boxes) offer("box '" + b.name + "'", DistanceToBox(b, p));
  for (const WorldCylinder& c : world.cylinders) {
    offer("cylinder '" + c.name + "'", DistanceToCylinder(c, p));
  }
  for (const WorldPlane& pl : world.planes) {
    offer("plane '" + pl.name + "'", std::max(0.0, pl.normal.dot(p) - pl.offset_m));
  }
  for (const WorldMesh& m : world.meshes) {
    for (const Eigen::Vector3i& t : m.triangles) {
      offer("mesh '" + m.name + "'", DistanceToTriangle(p, m.vertices_W[static_cast<size_t>(t[0])],
                                                        m.vertices_W[static_cast<size_t>(t[1])],
                                                        m.vertices_W[static_cast<size_t>(t[2])]));
    }
  }
  return best;
}

std::optional<std::string> StartClearanceProblem(const World& world,
                                                 const Eigen::Vector3d& start_offset_m,
                                                 double clearance_m) {
  const Eigen::Vector3d p(world.start_X_WB.p.x() + start_offset_m.x(),
                          world.start_X_WB.p.y() + start_offset_m.y(), world.exploration_height_m);
  const std::optional<NearObstacle> near = NearestObstacleWithin(world, p, clearance_m);
  if (!near) return std::nullopt;
  std::ostringstream m;
  m << "world '" << world.name << "': the start (" << p.x() << ", " << p.y()
    << ") at the exploration height " << p.z() << " m lies " << near->distance_m << " m from "
    << near->what;
  if (clearance_m > 0.0) {
    m << ", inside the vehicle's clearance of " << clearance_m << " m (half its diameter)";
  } else {
    m << " (inside it)";
  }
  m << ": the vehicle cannot take off and climb there; move the start or the obstacle";
  return m.str();
}

void World::Validate() const {
  for (int a = 0; a < 3; ++a) {
    KESTREL_THROW_UNLESS(
        std::isfinite(map_min_m[a]) && std::isfinite(map_max_m[a]) && map_max_m[a] > map_min_m[a],
        "world '" << name << "': map limits axis " << a << " [" << map_min_m[a] << ", "
                  << map_max_m[a] << "] must be finite and ordered");
  }
  for (const WorldBox& b : boxes) {
    KESTREL_THROW_UNLESS(
        b.half_extents_m.allFinite() && b.half_extents_m.minCoeff() > 0.0 && b.center_m.allFinite(),
        "world '" << name << "': box '" << b.name << "' has a bad size or centre");
  }
  for (const WorldCylinder& c : cylinders) {
    KESTREL_THROW_UNLESS(std::isfinite(c.radius_m) && c.radius_m > 0.0 && c.z_max_m > c.z_min_m &&
                             c.center_xy_m.allFinite(),
                         "world '" << name << "': cylinder '" << c.name << "' is degenerate");
  }
  for (const WorldPlane& p : planes) {
    KESTREL_THROW_UNLESS(std::abs(p.normal.norm() - 1.0) < 1e-9 && std::isfinite(p.offset_m),
                         "world '" << name << "': plane '" << p.name << "' needs a unit normal");
  }
  for (const WorldMesh& m : meshes) {
    for (const Eigen::Vector3d& v : m.vertices_W) {
      KESTREL_THROW_UNLESS(
          v.allFinite(), "world '" << name << "': mesh '" << m.name << "' has a non-finite vertex");
    }
    const int n = static_cast<int>(m.vertices_W.size());
    for (const Eigen::Vector3i& t : m.triangles) {
      KESTREL_THROW_UNLESS(t.minCoeff() >= 0 && t.maxCoeff() < n,
                           "world '" << name << "': mesh '" << m.name << "' triangle "
                                     << t.transpose() << " indexes outside 0.." << n - 1);
    }
  }
  const Eigen::Vector3d& s = start_X_WB.p;
  KESTREL_THROW_UNLESS(
      (s.array() >= map_min_m.array()).all() && (s.array() <= map_max_m.array()).all(),
      "world '" << name << "': start position " << s.transpose() << " lies outside the map limits");
  KESTREL_THROW_UNLESS(exploration_height_m > map_min_m.z() && exploration_height_m < map_max_m.z(),
                       "world '" << name << "': exploration height " << exploration_height_m
                                 << " m outside the z limits");
  // The vehicle's clearance is the simulator's (SimConfig::Validate); here, not inside a solid.
  const std::optional<std::string> start_problem =
      StartClearanceProblem(*this, Eigen::Vector3d::Zero(), 0.0);
  if (start_problem) throw std::invalid_argument(*start_problem);
}

World ParseWorld(const ConfigNode& root) { return ParseWorld(root, ReadObjFile); }

World ParseWorld(const ConfigNode& root, const ObjReader& read_obj) {
  World world;
  world.source = root.file();
  root.Read("name", &world.name);
  const ConfigNode limits = root.Child("map_limits");
  limits.ReadRequired("min_m", &world.map_min_m);
  limits.ReadRequired("max_m", &world.map_max_m);
  for (int a = 0; a < 3; ++a) {
    if (!(world.map_max_m[a] > world.map_min_m[a])) {
      limits.Fail("max_m", "must exceed min_m on every axis");
    }
  }
  const ConfigNode start = root.Child("start");
  start.ReadRequired("position_m", &world.start_X_WB.p);
  double yaw = 0.0;
  start.Read("yaw_rad", &yaw, Range::Closed(-2.0 * M_PI, 2.0 * M_PI));
  world.start_X_WB.q = QuaternionFromYaw(yaw);
  for (int a = 0; a < 3; ++a) {
    if (world.start_X_WB.p[a] < world.map_min_m[a] || world.start_X_WB.p[a] > world.map_max_m[a]) {
      start.Fail("position_m", "must lie inside map_limits");
    }
  }
  root.ReadRequired("exploration_height_m", &world.exploration_height_m,
                    Range::Open(world.map_min_m.z(), world.map_max_m.z()));
  for (const ConfigNode& item : root.Elements("obstacles")) {
    std::string type;
    item.ReadRequired("type", &type, std::vector<std::string>{"box", "cylinder", "plane", "mesh"});
    if (type == "box") {
      world.boxes.push_back(ParseBox(item));
    } else if (type == "mesh") {
      world.meshes.push_back(ParseMesh(item, read_obj));
    } else if (type == "cylinder") {
      world.cylinders.push_back(ParseCylinder(item));
    } else {
      world.planes.push_back(ParsePlane(item));
    }
  }
  root.CheckNoUnknownKeys();
  world.Validate();
  return world;
}

namespace {
World NamedAfterFile(World world, const std::string& path) {
  if (world.name.empty()) {
    const size_t slash = path.find_last_of('/');
    std::string stem = path.substr(slash == std::string::npos ? 0 : slash + 1);
    const size_t dot = stem.find_last_of('.');
    world.name = stem.substr(0, dot);
  }
  return world;
}
}  // namespace

World LoadWorld(const std::string& path) {
  return NamedAfterFile(ParseWorld(ConfigNode::LoadFile(path)), path);
}

World LoadWorld(const std::string& path, const ConfigNode& including) {
  return NamedAfterFile(ParseWorld(including.Include(path)), path);
}

Geofence WorldGeofence(const World& world) {
  Geofence fence;
  fence.min_m = world.map_min_m - Eigen::Vector3d::Constant(kGeofenceMarginM);
  fence.max_m =
      world.map_max_m + Eigen::Vector3d(kGeofenceMarginM, kGeofenceMarginM, kGeofenceHeadroomM);
  return fence;
}

bool IsInsideObstacle(const World& world, const Eigen::Vector3d& p_W) {
  for (const WorldBox& b : world.boxes) {
    const Eigen::Vector3d p_O = b.q_WO.conjugate() * (p_W - b.center_m);
    if ((p_O.cwiseAbs().array() < b.half_extents_m.array()).all()) return true;
  }
  for (const WorldCylinder& c : world.cylinders) {
    if (p_W.z() > c.z_min_m && p_W.z() < c.z_max_m &&
        (p_W.head<2>() - c.center_xy_m).squaredNorm() < c.radius_m * c.radius_m) {
      return true;
    }
  }
  for (const WorldPlane& p : world.planes) {
    if (p.normal.dot(p_W) < p.offset_m) return true;
  }
  return false;
}

double DepthInsideObstacle(const World& world, const Eigen::Vector3d& p_W) {
  double depth_m = 0.0;
  for (const WorldBox& b : world.boxes) {
    const Eigen::Vector3d p_O = b.q_WO.conjugate() * (p_W - b.center_m);
    depth_m = std::max(depth_m, (b.half_extents_m - p_O.cwiseAbs()).minCoeff());
  }
  for (const WorldCylinder& c : world.cylinders) {
    const double radial = (p_W.head<2>() - c.center_xy_m).norm();
    depth_m = std::max(depth_m,
                       std::min({c.radius_m - radial, p_W.z() - c.z_min_m, c.z_max_m - p_W.z()}));
  }
  for (const WorldPlane& p : world.planes) {
    depth_m = std::max(depth_m, p.offset_m - p.normal.dot(p_W));
  }
  return depth_m;
}

WorldMesh ReadObjFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError(path + ": cannot open the OBJ file");
  std::ostringstream text;
  text << in.rdbuf();
  return ParseObj(text.str(), path);
}

WorldMesh ParseObj(const std::string& text, const std::string& path) {
  std::istringstream in(text);
  WorldMesh mesh;
  mesh.file = path;
  std::string line;
  int line_number = 0;
  auto fail = [&](const std::string& reason) {
    throw ConfigError(path + ": line " + std::to_string(line_number) + ": " + reason);
  };
  while (std::getline(in, line)) {
    ++line_number;
    std::istringstream fields(line);
    std::string tag;
    if (!(fields >> tag) || tag[0] == '#') continue;
    if (tag == "v") {
      Eigen::Vector3d v;
      if (!(fields >> v.x() >> v.y() >> v.z()) || !v.allFinite()) {
        fail("a vertex needs three finite numbers: '" + line + "'");
      }
      mesh.vertices_W.push_back(v);
    } else if (tag == "f") {
      std::vector<int> corners;
      std::string token;
      while (fields >> token) {
        const std::string index_text = token.substr(0, token.find('/'));
        size_t used = 0;
        long index = 0;
        try {
          index = std::stol(index_text, &used);
        } catch (const std::exception&) {
          used = 0;
        }
        if (used == 0 || used != index_text.size()) fail("bad vertex index '" + token + "'");
        const long count = static_cast<long>(mesh.vertices_W.size());
        const long zero_based = index > 0 ? index - 1 : count + index;
        if (index == 0 || zero_based < 0 || zero_based >= count) {
          fail("vertex index " + std::to_string(index) + " outside 1.." + std::to_string(count));
        }
        corners.push_back(static_cast<int>(zero_based));
      }
      if (corners.size() < 3) fail("a face needs at least 3 vertices");
      for (size_t k = 1; k + 1 < corners.size(); ++k) {
        mesh.triangles.emplace_back(corners[0], corners[k], corners[k + 1]);
      }
    }
  }
  if (mesh.triangles.empty()) {
    line_number = 0;
    throw ConfigError(path + ": no faces ('f' lines) in the OBJ file");
  }
  return mesh;
}

Eigen::AlignedBox3d BoundsOf(const WorldBox& box) {
  const Eigen::Matrix3d R = box.q_WO.toRotationMatrix();
  const Eigen::Vector3d reach = R.cwiseAbs() * box.half_extents_m;
  return Eigen::AlignedBox3d(box.center_m - reach, box.center_m + reach);
}

Eigen::AlignedBox3d BoundsOf(const WorldCylinder& c) {
  return Eigen::AlignedBox3d(
      Eigen::Vector3d(c.center_xy_m.x() - c.radius_m, c.center_xy_m.y() - c.radius_m, c.z_min_m),
      Eigen::Vector3d(c.center_xy_m.x() + c.radius_m, c.center_xy_m.y() + c.radius_m, c.z_max_m));
}

}  // namespace kestrel
