// The viewer scene's other frames (pose, paths, plan, candidates, entropy, 2D maps) and the
// server's pure rules (what a page gets, which files are served). JSON frames are parsed with
// yaml-cpp (JSON is YAML), so the checks read the frames as the page does.
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "viewer/bridge/viewer_config.h"
#include "viewer/bridge/viewer_scene.h"
#include "viewer/bridge/viewer_server.h"

namespace kestrel {
namespace {

// The JSON frames of `frames` with type `type`, parsed.
std::vector<YAML::Node> TextFrames(const std::vector<ViewerFrame>& frames,
                                   const std::string& type) {
  std::vector<YAML::Node> out;
  for (const ViewerFrame& f : frames) {
    if (f.binary) continue;
    const YAML::Node node = YAML::Load(f.bytes);
    if (node["type"].as<std::string>() == type) out.push_back(node);
  }
  return out;
}

pose_t PoseAt(double x, double y, double z, int64_t utime) {
  pose_t m{};
  m.utime = utime;
  m.frame_id = "world";
  m.child_frame_id = "kestrel";
  m.valid = true;
  m.position_m[0] = x;
  m.position_m[1] = y;
  m.position_m[2] = z;
  m.orientation_wxyz[0] = 1.0;
  return m;
}

// The flown path is sent once in full to a new page and then only the new points; points closer
// than path_min_step_m to the previous one are not kept; an invalid pose is shown, not flown.
TEST(ViewerScene, TheFlownPathIsSentIncrementally) {
  ViewerSceneConfig config;
  config.path_min_step_m = 0.1;
  ViewerScene scene(config);
  for (int i = 0; i < 10; ++i) scene.OnPose(PoseAt(0.05 * i, 0, 1, i * 10000));
  // x = 0, 0.05, ..., 0.45: kept at 0, 0.1, 0.2, 0.3, 0.4 (steps of two samples).
  EXPECT_EQ(scene.path_points(), 5u);
  const auto first = TextFrames(scene.TakeUpdateFrames(), "path");
  ASSERT_EQ(first.size(), 1u);
  EXPECT_EQ(first[0]["points"].size(), 5u);
  pose_t lost = PoseAt(5, 5, 5, 200000);
  lost.valid = false;
  scene.OnPose(lost);
  scene.OnPose(PoseAt(1.0, 0, 1, 210000));
  const auto update = scene.TakeUpdateFrames();
  const auto path = TextFrames(update, "path");
  ASSERT_EQ(path.size(), 1u);
  EXPECT_FALSE(path[0]["reset"].as<bool>());
  ASSERT_EQ(path[0]["points"].size(), 1u);
  EXPECT_DOUBLE_EQ(path[0]["points"][0][0].as<double>(), 1.0);
  const auto pose = TextFrames(update, "pose");
  ASSERT_EQ(pose.size(), 1u);  // only the latest pose
  EXPECT_DOUBLE_EQ(pose[0]["p"][0].as<double>(), 1.0);
  EXPECT_TRUE(TextFrames(scene.TakeUpdateFrames(), "path").empty());  // nothing new
  const auto snapshot = TextFrames(scene.SnapshotFrames(), "path");
  ASSERT_EQ(snapshot.size(), 1u);
  EXPECT_TRUE(snapshot[0]["reset"].as<bool>());
  EXPECT_EQ(snapshot[0]["points"].size(), 6u);
}

// Histories stay bounded: past max_path_points the path is halved and re-sent with reset.
TEST(ViewerScene, HistoriesAreBounded) {
  ViewerSceneConfig config;
  config.path_min_step_m = 0.0;
  config.max_path_points = 100;
  config.max_entropy_points = 50;
  ViewerScene scene(config);
  for (int i = 0; i < 1000; ++i) {
    scene.OnPose(PoseAt(0.01 * i, 0, 1, i));
    map_status_t status{};
    status.utime = i + 1;
    status.map_entropy_nats = 1000.0 - i;
    scene.OnMapStatus(status);
  }
  EXPECT_LE(scene.path_points(), 100u);
  EXPECT_GE(scene.path_points(), 50u);
  EXPECT_LE(scene.entropy_points(), 50u);
  const auto update = scene.TakeUpdateFrames();
  const auto path = TextFrames(update, "path");
  ASSERT_EQ(path.size(), 1u);
  EXPECT_TRUE(path[0]["reset"].as<bool>());
  // The newest entropy point is always kept.
  const auto entropy = TextFrames(update, "entropy");
  ASSERT_EQ(entropy.size(), 1u);
  const YAML::Node points = entropy[0]["points"];
  EXPECT_DOUBLE_EQ(points[points.size() - 1][1].as<double>(), 1.0);
}

// Candidates: the chosen one first (index 0), then by objective, at most max_candidates; text
// fields are escaped.
TEST(ViewerScene, CandidatesListTheChosenOneFirst) {
  ViewerSceneConfig config;
  config.max_candidates = 3;
  ViewerScene scene(config);
  exploration_status_t m{};
  m.mode = "combined";
  m.reason = "path \"unsafe\"\n";
  m.state = exploration_status_t::STATE_EXPLORING;
  for (int i = 0; i < 6; ++i) {
    candidate_t c{};
    c.position_m[0] = i;
    c.objective = i == 2 ? 0.5 : 10.0 + i;
    m.candidates.push_back(c);
  }
  m.num_candidates = 6;
  m.chosen_index = 2;
  scene.OnExploration(m);
  const auto frames = TextFrames(scene.TakeUpdateFrames(), "exploration");
  ASSERT_EQ(frames.size(), 1u);
  const YAML::Node e = frames[0];
  EXPECT_EQ(e["reason"].as<std::string>(), "path \"unsafe\"\n");
  EXPECT_EQ(e["chosen"].as<int>(), 0);
  ASSERT_EQ(e["candidates"].size(), 3u);
  EXPECT_DOUBLE_EQ(e["candidates"][0][0].as<double>(), 2.0);  // the chosen one
  EXPECT_DOUBLE_EQ(e["candidates"][1][0].as<double>(), 5.0);  // then the best objective
  EXPECT_DOUBLE_EQ(e["candidates"][2][0].as<double>(), 4.0);
}

// A 2D map frame holds the header, the name and the values where the protocol puts them; a map
// whose value count disagrees with its size is refused.
TEST(ViewerScene, GridFramesFollowTheLayout) {
  ViewerScene scene{ViewerSceneConfig{}};
  grid_map_t g{};
  g.name = "collision";
  g.width = 3;
  g.height = 2;
  g.num_values = 6;
  g.values = {0.f, 0.25f, 0.5f, 0.75f, 1.f, 0.125f};
  g.resolution_m = 0.3;
  g.origin_m[0] = -1.5;
  g.origin_m[1] = 2.0;
  g.height_m = 0.8;
  std::string error;
  ASSERT_TRUE(scene.OnGridMap("MAP2D_COLLISION", g, &error)) << error;
  std::vector<ViewerFrame> grids;
  for (const ViewerFrame& f : scene.TakeUpdateFrames()) {
    if (f.binary && f.bytes[0] == 2) grids.push_back(f);
  }
  ASSERT_EQ(grids.size(), 1u);
  const std::string& b = grids[0].bytes;
  const std::string name = "MAP2D_COLLISION";  // 15 bytes, padded to 16
  ASSERT_EQ(b.size(), 56u + 16u + 6u * 4u);
  uint16_t name_length;
  uint32_t width, height;
  double origin_x, resolution;
  float last;
  std::memcpy(&name_length, &b[2], 2);
  std::memcpy(&width, &b[4], 4);
  std::memcpy(&height, &b[8], 4);
  std::memcpy(&origin_x, &b[16], 8);
  std::memcpy(&resolution, &b[40], 8);
  std::memcpy(&last, &b[56 + 16 + 5 * 4], 4);
  EXPECT_EQ(name_length, name.size());
  EXPECT_EQ(b.substr(56, name.size()), name);
  EXPECT_EQ(width, 3u);
  EXPECT_EQ(height, 2u);
  EXPECT_EQ(origin_x, -1.5);
  EXPECT_EQ(resolution, 0.3);
  EXPECT_EQ(last, 0.125f);
  g.values.pop_back();
  EXPECT_FALSE(scene.OnGridMap("MAP2D_COLLISION", g, &error));
  EXPECT_TRUE(scene.TakeUpdateFrames().size() <= 1u);  // no grid frame (at most a status)
}

// A new page's snapshot holds hello first and a status last; JSON strings escape what they must.
TEST(ViewerScene, SnapshotStartsWithHello) {
  ViewerSceneConfig config;
  config.channels = {{"pose", "POSE_VICON"}};
  ViewerScene scene(config);
  const auto frames = scene.SnapshotFrames();
  ASSERT_GE(frames.size(), 2u);
  const YAML::Node hello = YAML::Load(frames.front().bytes);
  EXPECT_EQ(hello["type"].as<std::string>(), "hello");
  EXPECT_EQ(hello["version"].as<int>(), kViewerProtocolVersion);
  EXPECT_EQ(hello["channels"]["pose"].as<std::string>(), "POSE_VICON");
  EXPECT_EQ(YAML::Load(frames.back().bytes)["type"].as<std::string>(), "status");
  EXPECT_EQ(JsonString("a\"b\\c\x01"), "\"a\\\"b\\\\c\\u0001\"");
}

/// A one-segment trajectory from `from` to `to` in `duration_s` at constant velocity, numbered
/// `seq` (the TRAJECTORY layout: coefficient rows per segment, constant term first).
trajectory_t LineTrajectory(const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                            double duration_s, int64_t seq) {
  trajectory_t m{};
  m.utime = 1000;
  m.seq = seq;
  m.epoch = 1;
  m.start_utime = 1000;
  m.num_segments = 1;
  m.num_coeffs = 2;
  m.durations_s = {duration_s};
  const Eigen::Vector3d v = (to - from) / duration_s;
  m.coeffs_x = {{from.x(), v.x()}};
  m.coeffs_y = {{from.y(), v.y()}};
  m.coeffs_z = {{from.z(), v.z()}};
  m.coeffs_yaw = {{0.0, 0.0}};
  return m;
}

// Two vehicles on their own channels: each one's pose, path, plan and exploration are kept and
// sent apart, each frame names its vehicle, and nothing of one shows up as the other's.
TEST(ViewerScene, EachVehicleIsKeptApart) {
  ViewerSceneConfig config;
  config.vehicles = {"V1_", "V2_"};
  config.path_min_step_m = 0.0;
  ViewerScene scene(config);
  ASSERT_EQ(scene.vehicle_count(), 2u);
  for (int i = 0; i < 5; ++i) scene.OnPose(0, PoseAt(1.0 + 0.1 * i, 1.0, 1.0, 1000 + i));
  for (int i = 0; i < 3; ++i) scene.OnPose(1, PoseAt(-2.0, -2.0 - 0.1 * i, 1.5, 1000 + i));
  std::string error;
  ASSERT_TRUE(scene.OnTrajectory(0, LineTrajectory({1, 1, 1}, {3, 1, 1}, 1.0, 11), &error))
      << error;
  ASSERT_TRUE(scene.OnTrajectory(1, LineTrajectory({-2, -2, 1.5}, {-2, -5, 1.5}, 2.0, 22), &error))
      << error;
  exploration_status_t e{};
  e.mode = "volumetric";
  e.state = exploration_status_t::STATE_RETURNING;
  e.seq = 7;
  e.chosen_index = -1;
  e.goal_position_m[0] = -4.0;
  scene.OnExploration(1, e);
  EXPECT_EQ(scene.path_points(0), 5u);
  EXPECT_EQ(scene.path_points(1), 3u);

  for (const auto& frames : {scene.TakeUpdateFrames(), scene.SnapshotFrames()}) {
    const auto hello = TextFrames(frames, "hello");
    if (!hello.empty()) {
      ASSERT_EQ(hello[0]["vehicles"].size(), 2u);
      EXPECT_EQ(hello[0]["vehicles"][0].as<std::string>(), "V1_");
      EXPECT_EQ(hello[0]["vehicles"][1].as<std::string>(), "V2_");
    }
    const auto poses = TextFrames(frames, "pose");
    ASSERT_EQ(poses.size(), 2u);
    for (const YAML::Node& p : poses) {
      const int k = p["vehicle"].as<int>();
      ASSERT_TRUE(k == 0 || k == 1);
      // The latest pose of each: V1_ at x = 1.4, V2_ at y = -2.2.
      EXPECT_NEAR(p["p"][0].as<double>(), k == 0 ? 1.4 : -2.0, 1e-9);
      EXPECT_NEAR(p["p"][1].as<double>(), k == 0 ? 1.0 : -2.2, 1e-9);
    }
    EXPECT_NE(poses[0]["vehicle"].as<int>(), poses[1]["vehicle"].as<int>());
    const auto paths = TextFrames(frames, "path");
    ASSERT_EQ(paths.size(), 2u);
    for (const YAML::Node& p : paths) {
      const int k = p["vehicle"].as<int>();
      ASSERT_EQ(p["points"].size(), k == 0 ? 5u : 3u);
      for (size_t i = 0; i < p["points"].size(); ++i) {
        // Every point of V1_'s path at y = 1, every one of V2_'s at x = -2.
        EXPECT_DOUBLE_EQ(p["points"][i][k == 0 ? 1 : 0].as<double>(), k == 0 ? 1.0 : -2.0);
      }
    }
    const auto plans = TextFrames(frames, "plan");
    ASSERT_EQ(plans.size(), 2u);
    for (const YAML::Node& p : plans) {
      const int k = p["vehicle"].as<int>();
      EXPECT_EQ(p["seq"].as<int>(), k == 0 ? 11 : 22);
      const YAML::Node last = p["points"][p["points"].size() - 1];
      EXPECT_NEAR(last[0].as<double>(), k == 0 ? 3.0 : -2.0, 1e-6);
      EXPECT_NEAR(last[1].as<double>(), k == 0 ? 1.0 : -5.0, 1e-6);
    }
    const auto exploration = TextFrames(frames, "exploration");
    ASSERT_EQ(exploration.size(), 1u);  // V1_ has none yet
    EXPECT_EQ(exploration[0]["vehicle"].as<int>(), 1);
    EXPECT_EQ(exploration[0]["state"].as<int>(), exploration_status_t::STATE_RETURNING);
    // The name from the explorer's table, which the page shows as it comes.
    EXPECT_EQ(exploration[0]["state_name"].as<std::string>(), "returning");
    EXPECT_DOUBLE_EQ(exploration[0]["goal"][0].as<double>(), -4.0);
  }
  // A new pose of V2_ sends V2_'s pose and path only.
  scene.OnPose(1, PoseAt(-2.0, -3.0, 1.5, 2000));
  const auto update = scene.TakeUpdateFrames();
  const auto poses = TextFrames(update, "pose");
  ASSERT_EQ(poses.size(), 1u);
  EXPECT_EQ(poses[0]["vehicle"].as<int>(), 1);
  const auto paths = TextFrames(update, "path");
  ASSERT_EQ(paths.size(), 1u);
  EXPECT_EQ(paths[0]["vehicle"].as<int>(), 1);
  EXPECT_EQ(paths[0]["points"].size(), 1u);
  EXPECT_EQ(scene.path_points(0), 5u);
}

// One vehicle (the default): every per-vehicle frame is vehicle 0, hello lists one vehicle
// without a prefix.
TEST(ViewerScene, OneVehicleIsVehicleZero) {
  ViewerScene scene{ViewerSceneConfig{}};
  scene.OnPose(PoseAt(1, 2, 3, 10));
  const auto frames = scene.SnapshotFrames();
  const auto hello = TextFrames(frames, "hello");
  ASSERT_EQ(hello.size(), 1u);
  ASSERT_EQ(hello[0]["vehicles"].size(), 1u);
  EXPECT_EQ(hello[0]["vehicles"][0].as<std::string>(), "");
  const auto pose = TextFrames(frames, "pose");
  ASSERT_EQ(pose.size(), 1u);
  EXPECT_EQ(pose[0]["vehicle"].as<int>(), 0);
  EXPECT_EQ(TextFrames(frames, "path").size(), 1u);
}

// Pacing: a page too far behind is skipped (and later gets a snapshot), never queued without
// bound.
TEST(ViewerServer, PagesBehindAreSkippedThenResynchronised) {
  EXPECT_EQ(DecideClientAction(false, 0, 1000), ClientAction::kSendUpdate);
  EXPECT_EQ(DecideClientAction(true, 1000, 1000), ClientAction::kSendSnapshot);
  EXPECT_EQ(DecideClientAction(false, 1001, 1000), ClientAction::kSkip);
  EXPECT_EQ(DecideClientAction(true, 5000, 1000), ClientAction::kSkip);
}

// Only plain relative paths under the web root are served.
TEST(ViewerServer, OnlyPlainPathsAreServed) {
  EXPECT_EQ(ResolveWebPath("/w", "/"), "/w/index.html");
  EXPECT_EQ(ResolveWebPath("/w", "/viewer.js?v=2"), "/w/viewer.js");
  EXPECT_EQ(ResolveWebPath("/w", "/../etc/passwd"), "");
  EXPECT_EQ(ResolveWebPath("/w", "/a/..%2f..%2fetc"), "");
  EXPECT_EQ(ResolveWebPath("/w", "//etc/passwd"), "");
  EXPECT_EQ(ResolveWebPath("/w", "viewer.js"), "");
  EXPECT_EQ(ContentTypeOf("/w/viewer.js"), "text/javascript; charset=utf-8");
  EXPECT_EQ(ContentTypeOf("/w/index.html"), "text/html; charset=utf-8");
}

// The configuration accepts loopback addresses only and names the bad key.
TEST(ViewerConfig, OnlyLoopbackIsAccepted) {
  ConfigNode ok = ConfigNode::FromString("port: 0\nscene: {occupied_threshold: 0.7}\n", "v.yaml");
  const ViewerConfig c = LoadViewerConfig(ok);
  EXPECT_EQ(c.scene.occupied_threshold, 0.7);
  EXPECT_EQ(c.scene.channels.at("map"), "MAP3D");
  ConfigNode bad = ConfigNode::FromString("host: 0.0.0.0\n", "v.yaml");
  try {
    (void)LoadViewerConfig(bad);
    ADD_FAILURE() << "0.0.0.0 accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("loopback"), std::string::npos) << e.what();
  }
  ConfigNode threshold = ConfigNode::FromString("scene: {occupied_threshold: 1.0}\n", "v.yaml");
  EXPECT_THROW((void)LoadViewerConfig(threshold), ConfigError);
}

/// The message of the ConfigError LoadViewerConfig throws on `yaml` ("" if it throws none).
std::string RefusalOf(const std::string& yaml) {
  ConfigNode node = ConfigNode::FromString(yaml, "v.yaml");
  try {
    (void)LoadViewerConfig(node);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

// The allowed origins: empty by default; a list is read for the page and for Foxglove, each
// entry checked (a path or "*" refused, naming the key); the shipped file's lists are empty.
TEST(ViewerConfig, AllowedOriginsAreReadAndChecked) {
  ConfigNode none = ConfigNode::FromString("port: 0\n", "v.yaml");
  const ViewerConfig defaults = LoadViewerConfig(none);
  EXPECT_TRUE(defaults.allowed_origins.empty());
  EXPECT_TRUE(defaults.foxglove_allowed_origins.empty());
  ConfigNode app = ConfigNode::FromString(
      "allowed_origins: [http://10.0.0.5:8080]\n"
      "foxglove: {allowed_origins: [https://app.foxglove.dev]}\n",
      "v.yaml");
  const ViewerConfig c = LoadViewerConfig(app);
  EXPECT_EQ(c.allowed_origins, std::vector<std::string>{"http://10.0.0.5:8080"});
  EXPECT_EQ(c.foxglove_allowed_origins, std::vector<std::string>{"https://app.foxglove.dev"});
  EXPECT_NE(RefusalOf("foxglove: {allowed_origins: [https://app.foxglove.dev/]}\n")
                .find("foxglove.allowed_origins: 'https://app.foxglove.dev/'"),
            std::string::npos);
  EXPECT_NE(RefusalOf("allowed_origins: ['*']\n").find("allowed_origins: '*'"), std::string::npos);
  EXPECT_NE(RefusalOf("allowed_origins: https://app.foxglove.dev\n").find("a list of strings"),
            std::string::npos);
}

// The vehicles: one without a prefix by default; a list is read in order and reaches the scene;
// a duplicate, a bad character, an empty list or more than 16 are refused, naming the entry.
TEST(ViewerConfig, VehiclesAreReadAndChecked) {
  ConfigNode none = ConfigNode::FromString("port: 0\n", "v.yaml");
  const ViewerConfig one = LoadViewerConfig(none);
  EXPECT_EQ(one.vehicle_prefixes, std::vector<std::string>{""});
  EXPECT_EQ(one.scene.vehicles, std::vector<std::string>{""});
  ConfigNode two = ConfigNode::FromString("vehicles: [{prefix: V1_}, {prefix: V2_}]\n", "v.yaml");
  const ViewerConfig c = LoadViewerConfig(two);
  EXPECT_EQ(c.vehicle_prefixes, (std::vector<std::string>{"V1_", "V2_"}));
  EXPECT_EQ(c.scene.vehicles, c.vehicle_prefixes);

  std::string what = RefusalOf("vehicles: [{prefix: V1_}, {prefix: V2_}, {prefix: V1_}]\n");
  EXPECT_NE(what.find("v.yaml: vehicles[0] and [2] share the prefix 'V1_'"), std::string::npos)
      << what;
  what = RefusalOf("vehicles: [{prefix: V1_}, {prefix: \"V-2\"}]\n");
  EXPECT_NE(what.find("vehicles[1].prefix = 'V-2': accepted: letters, digits and '_'"),
            std::string::npos)
      << what;
  what = RefusalOf("vehicles: [{prefix: \"V1 \"}]\n");
  EXPECT_NE(what.find("vehicles[0].prefix = 'V1 '"), std::string::npos) << what;
  what = RefusalOf("vehicles: []\n");
  EXPECT_NE(what.find("vehicles: 0 listed; accepted: 1 to 16"), std::string::npos) << what;
  std::string many = "vehicles: [";
  for (int k = 1; k <= 17; ++k)
    many += (k > 1 ? ", " : "") + std::string("{prefix: V") + std::to_string(k) + "_}";
  what = RefusalOf(many + "]\n");
  EXPECT_NE(what.find("vehicles: 17 listed; accepted: 1 to 16"), std::string::npos) << what;
  what = RefusalOf("vehicles: [{name: V1_}]\n");
  EXPECT_NE(what.find("prefix"), std::string::npos) << what;
}

}  // namespace
}  // namespace kestrel
