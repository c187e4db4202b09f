// The Foxglove translation (viewer/foxglove/foxglove_bridge.h) on a recorded mission (the report
// fixture's log): every message is checked against the LCM message it came from, decoded here;
// the map's SceneUpdates, applied in order as Foxglove applies them (deletions, then entities
// replacing those of the same id), leave exactly the occupied cells of an independent copy of the
// map, and so does the whole-map snapshot.
#include <cmath>
#include <cstring>
#include <map>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>
#include <nlohmann/json.hpp>

#include "common/lcm_decode.h"
#include "common/trajectory_message.h"
#include "kestrel/exploration_status_t.hpp"
#include "kestrel/grid_map_t.hpp"
#include "kestrel/map3d_chunk_t.hpp"
#include "kestrel/map3d_delta_t.hpp"
#include "kestrel/params_t.hpp"
#include "kestrel/pose_t.hpp"
#include "kestrel/trajectory_t.hpp"
#include "viewer/bridge/voxel_stream.h"
#include "viewer/foxglove/foxglove_bridge.h"

namespace kestrel::foxglove {
namespace {

using nlohmann::json;
const std::string kLog = std::string(KESTREL_REPORT_FIXTURE_DIR) + "/combined.lcmlog";

std::string DecodeBase64(const std::string& text) {
  std::string out;
  int bits = 0;
  uint32_t acc = 0;
  for (const char c : text) {
    int v = -1;
    if (c >= 'A' && c <= 'Z') v = c - 'A';
    if (c >= 'a' && c <= 'z') v = c - 'a' + 26;
    if (c >= '0' && c <= '9') v = c - '0' + 52;
    if (c == '+') v = 62;
    if (c == '/') v = 63;
    if (v < 0) continue;  // '=' padding
    acc = (acc << 6) | static_cast<uint32_t>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += static_cast<char>((acc >> bits) & 0xff);
    }
  }
  return out;
}

TEST(FoxgloveBase64, MatchesRfc4648) {
  EXPECT_EQ(Base64("", 0), "");
  EXPECT_EQ(Base64("f", 1), "Zg==");
  EXPECT_EQ(Base64("fo", 2), "Zm8=");
  EXPECT_EQ(Base64("foo", 3), "Zm9v");
  EXPECT_EQ(Base64("foobar", 6), "Zm9vYmFy");
  const std::string bytes = "\x00\xff\x10kestrel\x80";
  EXPECT_EQ(DecodeBase64(Base64(bytes.data(), bytes.size())), bytes);
}

/// A scene as Foxglove keeps it from SceneUpdates: entities by id.
struct Scene {
  std::map<std::string, json> entities;
  void Apply(const json& update) {
    for (const json& d : update["deletions"]) {
      if (d["type"] == 1) entities.clear();
      if (d["type"] == 0) entities.erase(d["id"].get<std::string>());
    }
    for (const json& e : update["entities"]) entities[e["id"].get<std::string>()] = e;
  }
  // Cube centres (rounded to 0.1 mm) and their red-green colour.
  [[nodiscard]] std::set<std::tuple<long, long, long>> Cubes() const {
    std::set<std::tuple<long, long, long>> out;
    for (const auto& [id, e] : entities) {
      for (const json& c : e["cubes"]) {
        const json& p = c["pose"]["position"];
        out.insert({std::lround(p["x"].get<double>() * 1e4),
                    std::lround(p["y"].get<double>() * 1e4),
                    std::lround(p["z"].get<double>() * 1e4)});
      }
    }
    return out;
  }
};

TEST(FoxgloveBridge, EveryTopicIsTheLoggedMessage) {
  Bridge bridge(BridgeConfig{});
  VoxelStream truth(0.5);  // an independent copy of the map
  Scene scene;
  lcm::LogFile log(kLog, "r");
  ASSERT_TRUE(log.good()) << kLog;
  int poses = 0, grids = 0, plans = 0, trajectories = 0, map_updates = 0, configurations = 0;
  int64_t next_map_utime = 0;
  std::vector<Message> out;
  while (const lcm::LogEvent* e = log.readNextEvent()) {
    const std::string channel = e->channel;
    const size_t size = static_cast<size_t>(e->datalen);
    out.clear();
    std::string error;
    ASSERT_TRUE(bridge.OnLcm(channel, e->data, size, &out, &error)) << channel << ": " << error;
    if (channel == "MAP3D") {
      map3d_chunk_t chunk;
      ASSERT_TRUE(GuardedDecode(e->data, size, &chunk, &error));
      ASSERT_TRUE(truth.Apply(chunk, &error)) << error;
    } else if (channel == "MAP3D_DELTA") {
      map3d_delta_t delta;
      ASSERT_TRUE(GuardedDecode(e->data, size, &delta, &error));
      (void)truth.Apply(delta, &error);
    } else if (channel == "POSE_VICON") {
      pose_t pose;
      ASSERT_TRUE(GuardedDecode(e->data, size, &pose, &error));
      ASSERT_EQ(out.size(), pose.valid ? 1u : 0u);
      if (!pose.valid) continue;
      const json tf = json::parse(out[0].json);
      EXPECT_EQ(out[0].topic, "/tf");
      EXPECT_EQ(out[0].time_ns, static_cast<uint64_t>(pose.utime) * 1000);
      EXPECT_EQ(tf["timestamp"]["sec"].get<int64_t>() * 1000000000 +
                    tf["timestamp"]["nsec"].get<int64_t>(),
                pose.utime * 1000);
      EXPECT_EQ(tf["parent_frame_id"], "world");
      EXPECT_EQ(tf["child_frame_id"], "vehicle");
      EXPECT_NEAR(tf["translation"]["x"].get<double>(), pose.position_m[0], 1e-8);
      EXPECT_NEAR(tf["translation"]["z"].get<double>(), pose.position_m[2], 1e-8);
      EXPECT_NEAR(tf["rotation"]["w"].get<double>(), pose.orientation_wxyz[0], 1e-8);
      EXPECT_NEAR(tf["rotation"]["z"].get<double>(), pose.orientation_wxyz[3], 1e-8);
      ++poses;
    } else if (channel.rfind("MAP2D_", 0) == 0) {
      grid_map_t grid;
      ASSERT_TRUE(GuardedDecode(e->data, size, &grid, &error));
      ASSERT_EQ(out.size(), 1u);
      const json g = json::parse(out[0].json);
      EXPECT_EQ(out[0].schema_name, "foxglove.Grid");
      EXPECT_EQ(g["column_count"], grid.width);
      EXPECT_EQ(g["row_stride"], 4 * grid.width);
      EXPECT_EQ(g["fields"][0]["type"], 7);  // FLOAT32
      EXPECT_NEAR(g["pose"]["position"]["x"].get<double>(), grid.origin_m[0], 1e-8);
      EXPECT_NEAR(g["pose"]["position"]["z"].get<double>(), grid.height_m, 1e-8);
      const std::string data = DecodeBase64(g["data"].get<std::string>());
      ASSERT_EQ(data.size(), grid.values.size() * 4);
      std::vector<float> values(grid.values.size());
      std::memcpy(values.data(), data.data(), data.size());
      EXPECT_EQ(values, grid.values);
      ++grids;
    } else if (channel == "EXPLORATION_STATUS") {
      exploration_status_t plan;
      ASSERT_TRUE(GuardedDecode(e->data, size, &plan, &error));
      ASSERT_EQ(out.size(), 1u);
      const json arrows = json::parse(out[0].json)["entities"][0]["arrows"];
      ASSERT_EQ(arrows.size(), plan.candidates.size());
      for (size_t i = 0; i < arrows.size(); ++i) {
        EXPECT_NEAR(arrows[i]["pose"]["position"]["y"].get<double>(),
                    plan.candidates[i].position_m[1], 1e-8);
        const double yaw = 2.0 * std::atan2(arrows[i]["pose"]["orientation"]["z"].get<double>(),
                                            arrows[i]["pose"]["orientation"]["w"].get<double>());
        EXPECT_NEAR(std::remainder(yaw - plan.candidates[i].yaw_rad, 2 * M_PI), 0.0, 1e-6);
      }
      ++plans;
    } else if (channel.rfind("PARAMS_", 0) == 0) {
      params_t params;
      ASSERT_TRUE(GuardedDecode(e->data, size, &params, &error));
      ASSERT_EQ(out.size(), 1u);
      std::string name = channel.substr(7);
      for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      EXPECT_EQ(out[0].topic, "/params/" + name);
      EXPECT_EQ(out[0].schema_name, "kestrel.Params");
      const json p = json::parse(out[0].json);
      EXPECT_EQ(p["process"], params.process);
      EXPECT_EQ(p["config_file"], params.config_file);
      EXPECT_EQ(p["args"].get<std::vector<std::string>>(), params.args);
      ASSERT_EQ(p["params"].size(), params.params.size());
      for (size_t i = 0; i < params.params.size(); ++i) {
        EXPECT_EQ(p["params"][i]["key"], params.params[i].key);
        EXPECT_EQ(p["params"][i]["value"], params.params[i].value);
        EXPECT_EQ(p["params"][i]["file"], params.params[i].file);
        EXPECT_EQ(p["params"][i]["source"],
                  params.params[i].source == param_t::SOURCE_DEFAULT ? "default"
                  : params.params[i].source == param_t::SOURCE_FILE  ? "file"
                                                                     : "override");
      }
      ++configurations;
    } else if (channel == "TRAJECTORY") {
      trajectory_t msg;
      ASSERT_TRUE(GuardedDecode(e->data, size, &msg, &error));
      const auto trajectory = FromMessage(msg, &error);
      ASSERT_TRUE(trajectory.has_value()) << error;
      ASSERT_EQ(out.size(), 1u);
      const json points = json::parse(out[0].json)["entities"][0]["lines"][0]["points"];
      ASSERT_GE(points.size(), 2u);
      const auto start = trajectory->Evaluate(trajectory->start_time_s()).position_m;
      const auto end = trajectory->Evaluate(trajectory->end_time_s()).position_m;
      EXPECT_NEAR(points.front()["x"].get<double>(), start.x(), 1e-6);
      EXPECT_NEAR(points.back()["y"].get<double>(), end.y(), 1e-6);
      ++trajectories;
    }
    if (e->timestamp >= next_map_utime) {  // the live node's 1 Hz map updates
      next_map_utime = e->timestamp + 1000000;
      if (const auto update = bridge.TakeMapUpdate()) {
        scene.Apply(json::parse(update->json));
        ++map_updates;
      }
    }
  }
  if (const auto update = bridge.TakeMapUpdate()) scene.Apply(json::parse(update->json));
  EXPECT_GT(poses, 100);
  EXPECT_GT(grids, 2);
  EXPECT_GT(plans, 2);
  EXPECT_GT(trajectories, 2);
  EXPECT_GT(map_updates, 10);
  EXPECT_EQ(configurations, 4);  // the mission's simulator, controller, mapper and explorer

  // The scene's cubes are the copy's occupied cells, at their centres.
  std::set<std::tuple<long, long, long>> expected;
  const double r = truth.resolution_m();
  for (const VoxelEntry& c : truth.Occupied()) {
    expected.insert({std::lround((truth.origin_m().x() + (c.x + 0.5) * r) * 1e4),
                     std::lround((truth.origin_m().y() + (c.y + 0.5) * r) * 1e4),
                     std::lround((truth.origin_m().z() + (c.z + 0.5) * r) * 1e4)});
  }
  ASSERT_GT(expected.size(), 1000u);
  EXPECT_EQ(scene.Cubes(), expected);
  Scene fresh;
  const auto snapshot = bridge.MapSnapshot();
  ASSERT_TRUE(snapshot.has_value());
  fresh.Apply(json::parse(snapshot->json));
  EXPECT_EQ(fresh.Cubes(), expected);
  EXPECT_EQ(bridge.occupied_count(), expected.size());
  // Every message's schema is a JSON Schema of that name.
  for (const char* name :
       {"foxglove.SceneUpdate", "foxglove.Grid", "foxglove.FrameTransform", "kestrel.Params"}) {
    EXPECT_EQ(json::parse(SchemaOf(name))["title"], name);
  }
}

TEST(FoxgloveBridge, RefusesMalformedMessagesAndIgnoresOtherChannels) {
  Bridge bridge(BridgeConfig{});
  std::vector<Message> out;
  std::string error;
  const char garbage[] = "not an lcm message";
  EXPECT_FALSE(bridge.OnLcm("POSE_VICON", garbage, sizeof garbage, &out, &error));
  EXPECT_FALSE(error.empty());
  EXPECT_TRUE(bridge.OnLcm("IMU", garbage, sizeof garbage, &out, &error));
  EXPECT_TRUE(out.empty());
  pose_t pose{};
  pose.valid = true;
  pose.position_m[0] = std::nan("");
  pose.orientation_wxyz[0] = 1.0;
  std::vector<uint8_t> bytes(static_cast<size_t>(pose.getEncodedSize()));
  pose.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  EXPECT_FALSE(bridge.OnLcm("POSE_VICON", bytes.data(), bytes.size(), &out, &error));
  EXPECT_NE(error.find("non-finite"), std::string::npos);
  EXPECT_FALSE(bridge.MapSnapshot().has_value());
  EXPECT_FALSE(bridge.TakeMapUpdate().has_value());
}

}  // namespace
}  // namespace kestrel::foxglove
