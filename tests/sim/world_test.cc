#include "sim/world.h"

#include <cmath>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

namespace kestrel {
namespace {

const std::string kWorldsDir = std::string(KESTREL_SOURCE_DIR) + "/config/worlds/";

constexpr const char* kMinimal = R"(
name: tiny
map_limits: {min_m: [-1, -2, -0.5], max_m: [3, 4, 2]}
start: {position_m: [0.5, 0.5, 0], yaw_rad: 0.5}
exploration_height_m: 1.0
obstacles:
  - {type: plane, name: floor, normal: [0, 0, 2], offset_m: 0}
  - {type: box, name: a, min_m: [1, 1, 0], max_m: [2, 3, 1]}
  - {type: box, name: b, center_m: [0, 3, 0.5], size_m: [0.4, 0.2, 1.0], yaw_rad: 0.25}
  - {type: cylinder, name: c, center_m: [2.5, -1], radius_m: 0.3, z_min_m: 0, z_max_m: 0.7}
)";

// Expects ParseWorld on `text` to throw a ConfigError whose message contains every fragment.
void ExpectRejected(const std::string& text, const std::vector<std::string>& fragments) {
  try {
    (void)ParseWorld(ConfigNode::FromString(text, "bad_world.yaml"));
    FAIL() << "accepted:\n" << text;
  } catch (const ConfigError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("bad_world.yaml"), std::string::npos) << what;
    for (const std::string& f : fragments) EXPECT_NE(what.find(f), std::string::npos) << what;
  }
}

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

// Every field of a small world lands where the format says.
TEST(World, ParsesEveryPrimitiveKind) {
  const World w = ParseWorld(ConfigNode::FromString(kMinimal, "tiny.yaml"));
  EXPECT_EQ(w.name, "tiny");
  EXPECT_EQ(w.map_min_m, Eigen::Vector3d(-1, -2, -0.5));
  EXPECT_EQ(w.map_max_m, Eigen::Vector3d(3, 4, 2));
  EXPECT_NEAR(YawOf(w.start_X_WB.q), 0.5, 1e-12);
  EXPECT_EQ(w.exploration_height_m, 1.0);
  ASSERT_EQ(w.boxes.size(), 2u);
  ASSERT_EQ(w.cylinders.size(), 1u);
  ASSERT_EQ(w.planes.size(), 1u);
  EXPECT_EQ(w.boxes[0].center_m, Eigen::Vector3d(1.5, 2, 0.5));
  EXPECT_EQ(w.boxes[0].half_extents_m, Eigen::Vector3d(0.5, 1, 0.5));
  EXPECT_NEAR(YawOf(w.boxes[1].q_WO), 0.25, 1e-12);
  EXPECT_EQ(w.boxes[1].half_extents_m, Eigen::Vector3d(0.2, 0.1, 0.5));
  EXPECT_EQ(w.cylinders[0].radius_m, 0.3);
  EXPECT_EQ(w.planes[0].normal, Eigen::Vector3d::UnitZ());  // normalised
  EXPECT_EQ(w.size(), 4u);
}

// Points inside a primitive are inside; boundaries and free space are not.
TEST(World, InsideTestMatchesGeometry) {
  const World w = ParseWorld(ConfigNode::FromString(kMinimal, "tiny.yaml"));
  EXPECT_TRUE(IsInsideObstacle(w, {1.5, 2.0, 0.5}));
  EXPECT_FALSE(IsInsideObstacle(w, {2.0, 2.0, 0.5}));  // on the face
  EXPECT_TRUE(IsInsideObstacle(w, {2.5, -1.0 + 0.29, 0.3}));
  EXPECT_FALSE(IsInsideObstacle(w, {2.5, -1.0 + 0.31, 0.3}));
  EXPECT_TRUE(IsInsideObstacle(w, {0.0, 0.0, -0.01}));  // below the floor
  // Rotated box b: its local x axis points along yaw 0.25.
  const Eigen::Vector3d ax(std::cos(0.25), std::sin(0.25), 0.0);
  EXPECT_TRUE(IsInsideObstacle(w, Eigen::Vector3d(0, 3, 0.5) + 0.19 * ax));
  EXPECT_FALSE(IsInsideObstacle(w, Eigen::Vector3d(0, 3, 0.5) + 0.21 * ax));
}

// Bad files are refused with the file, the key path and the reason.
TEST(World, RefusesBadFilesNamingKeyAndReason) {
  ExpectRejected(Replace(kMinimal, "min_m: [1, 1, 0], max_m: [2, 3, 1]",
                         "min_m: [1, 1, 0], max_m: [2, 0.5, 1]"),
                 {"obstacles[1].max_m", "must exceed min_m", "line 8"});
  ExpectRejected(Replace(kMinimal, "radius_m: 0.3", "radius_m: -0.3"),
                 {"obstacles[3].radius_m", "-0.3"});
  ExpectRejected(Replace(kMinimal, "type: cylinder", "type: sphere"),
                 {"obstacles[3].type", "sphere"});
  ExpectRejected(Replace(kMinimal, "yaw_rad: 0.25", "yaw_rad: 0.25, colour: red"),
                 {"obstacles[2].colour"});
  ExpectRejected(Replace(kMinimal, "position_m: [0.5, 0.5, 0]", "position_m: [9, 0.5, 0]"),
                 {"start.position_m", "inside map_limits"});
  ExpectRejected(Replace(kMinimal, "exploration_height_m: 1.0", "exploration_height_m: 2.5"),
                 {"exploration_height_m", "2.5"});
  ExpectRejected(Replace(kMinimal, "normal: [0, 0, 2]", "normal: [0, 0, 0]"),
                 {"obstacles[0].normal", "non-zero"});
  ExpectRejected(Replace(kMinimal, "size_m: [0.4, 0.2, 1.0]", "size_m: [0.4, 0.2]"),
                 {"obstacles[2].size_m"});
  ExpectRejected(Replace(kMinimal, "map_limits: {min_m: [-1, -2, -0.5], max_m: [3, 4, 2]}", ""),
                 {"map_limits"});
  EXPECT_THROW((void)LoadWorld("/nonexistent/world.yaml"), ConfigError);
}

// A start inside an obstacle at the exploration height is refused naming it (the vehicle's own
// clearance is the simulator's check, SimConfig); StartClearanceProblem and NearestObstacleWithin
// name the nearest obstacle within a clearance.
TEST(World, RefusesAStartInsideAnObstacle) {
  try {
    (void)ParseWorld(
        ConfigNode::FromString(Replace(Replace(kMinimal, "max_m: [2, 3, 1]", "max_m: [2, 3, 1.5]"),
                                       "position_m: [0.5, 0.5, 0]", "position_m: [1.5, 2, 0]"),
                               "bad_world.yaml"));
    FAIL() << "accepted a start inside box a";
  } catch (const std::exception& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("box 'a'"), std::string::npos) << what;
    EXPECT_NE(what.find("the start (1.5, 2)"), std::string::npos) << what;
  }
  const World w = ParseWorld(ConfigNode::FromString(kMinimal, "tiny.yaml"));
  // From (0.5, 0.5, 1): box a's edge at (1, 1, 1) is sqrt(0.5) away, the floor 1 m.
  EXPECT_FALSE(StartClearanceProblem(w, Eigen::Vector3d::Zero(), 0.44));
  const std::optional<NearObstacle> near =
      NearestObstacleWithin(w, Eigen::Vector3d(0.5, 0.5, 1.0), 1.5);
  ASSERT_TRUE(near);
  EXPECT_EQ(near->what, "box 'a'");
  EXPECT_NEAR(near->distance_m, std::sqrt(0.5), 1e-12);
  const std::optional<std::string> problem =
      StartClearanceProblem(w, Eigen::Vector3d(0.3, 0.3, 0.0), 0.44);
  ASSERT_TRUE(problem);
  EXPECT_NE(problem->find("box 'a'"), std::string::npos) << *problem;
  EXPECT_NE(problem->find("clearance of 0.44 m"), std::string::npos) << *problem;
}

// The shipped worlds load, carry the paper's limits, and leave 0.5 m free around the start from
// just above the floor to above the exploration height (sampled every 2 cm).
TEST(World, ShippedWorldsLoadWithClearStart) {
  struct Expected {
    std::string file;
    Eigen::Vector3d min, max;
  };
  const std::vector<Expected> worlds = {
      {"paper_sim.yaml", {-4, -6, -0.15}, {4, 6, 1.5}},
      {"lasr.yaml", {0.5, -8.3, -0.15}, {10.3, 3.5, 1.5}},
      {"office.yaml", {0, 0, -0.15}, {20, 14, 2.0}},
  };
  for (const Expected& e : worlds) {
    SCOPED_TRACE(e.file);
    const World w = LoadWorld(kWorldsDir + e.file);
    EXPECT_TRUE(w.map_min_m.isApprox(e.min)) << w.map_min_m.transpose();
    EXPECT_TRUE(w.map_max_m.isApprox(e.max)) << w.map_max_m.transpose();
    EXPECT_GE(w.size(), 10u);
    const Eigen::Vector3d s = w.start_X_WB.p;
    int inside = 0;
    for (double z = 0.02; z <= w.exploration_height_m + 0.3; z += 0.02) {
      for (double dx = -0.5; dx <= 0.5001; dx += 0.02) {
        for (double dy = -0.5; dy <= 0.5001; dy += 0.02) {
          if (dx * dx + dy * dy > 0.25 + 1e-9) continue;
          inside += IsInsideObstacle(w, Eigen::Vector3d(s.x() + dx, s.y() + dy, z)) ? 1 : 0;
        }
      }
    }
    EXPECT_EQ(inside, 0);
    EXPECT_FALSE(IsInsideObstacle(w, s + Eigen::Vector3d(0, 0, 0.01)));
  }
}

std::string WriteTemp(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path) << text;
  return path;
}

// OBJ: vertices, polygons split into fans, negative and v/t/n indices, other lines ignored.
TEST(ObjFile, ReadsVerticesAndFaces) {
  const std::string path = WriteTemp("sim_quad.obj",
                                     "# comment\n"
                                     "mtllib x.mtl\no thing\n"
                                     "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                                     "vn 0 0 1\nvt 0 0\n"
                                     "f 1/1/1 2/1/1 3/1/1 4/1/1\n"
                                     "f -4 -3 -1\n");
  const WorldMesh m = ReadObjFile(path);
  ASSERT_EQ(m.vertices_W.size(), 4u);
  ASSERT_EQ(m.triangles.size(), 3u);
  EXPECT_EQ(m.triangles[0], Eigen::Vector3i(0, 1, 2));
  EXPECT_EQ(m.triangles[1], Eigen::Vector3i(0, 2, 3));
  EXPECT_EQ(m.triangles[2], Eigen::Vector3i(0, 1, 3));
  EXPECT_EQ(m.vertices_W[2], Eigen::Vector3d(1, 1, 0));
}

// Bad OBJ files are refused with the file, the line and the reason; through a world file the
// error also names the world file and the key.
TEST(ObjFile, RefusesBadFilesNamingTheLine) {
  auto expect_error = [](const std::string& text, const std::vector<std::string>& fragments) {
    const std::string path = WriteTemp("sim_bad.obj", text);
    try {
      (void)ReadObjFile(path);
      FAIL() << "accepted " << text;
    } catch (const ConfigError& e) {
      for (const std::string& f : fragments) {
        EXPECT_NE(std::string(e.what()).find(f), std::string::npos) << e.what();
      }
    }
  };
  expect_error("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", {"sim_bad.obj", "line 4", "outside 1..3"});
  expect_error("v 0 0 0\nv 1 zero 0\n", {"line 2", "three finite numbers"});
  expect_error("v 0 0 0\nv 1 0 0\nf 1 2\n", {"line 3", "at least 3"});
  expect_error("v 0 0 0\n", {"no faces"});
  expect_error("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 x 3\n", {"line 4", "bad vertex index"});
  EXPECT_THROW((void)ReadObjFile("/nonexistent.obj"), ConfigError);
  const std::string world_text = Replace(
      kMinimal, "  - {type: plane,", "  - {type: mesh, file: /nonexistent.obj}\n  - {type: plane,");
  ExpectRejected(world_text, {"obstacles[0].file", "nonexistent.obj"});
}

// A mesh obstacle is read relative to the world file, scaled, turned and placed.
TEST(ObjFile, WorldPlacesMeshes) {
  (void)WriteTemp("sim_tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  const std::string world_path =
      WriteTemp("sim_mesh_world.yaml",
                Replace(kMinimal, "  - {type: plane,",
                        "  - {type: mesh, name: tri, file: sim_tri.obj, position_m: [1, 2, 0.5],\n"
                        "     yaw_rad: 1.5707963267948966, scale: 2}\n  - {type: plane,"));
  const World w = LoadWorld(world_path);
  ASSERT_EQ(w.meshes.size(), 1u);
  EXPECT_EQ(w.meshes[0].name, "tri");
  EXPECT_TRUE(w.meshes[0].vertices_W[1].isApprox(Eigen::Vector3d(1, 4, 0.5), 1e-12));
  EXPECT_TRUE(w.meshes[0].vertices_W[2].isApprox(Eigen::Vector3d(-1, 2, 0.5), 1e-12));
  EXPECT_EQ(w.size(), 5u);
  const World office = LoadWorld(kWorldsDir + "office.yaml");
  ASSERT_EQ(office.meshes.size(), 1u);
  EXPECT_EQ(office.meshes[0].triangles.size(), 6u);
}

}  // namespace
}  // namespace kestrel
