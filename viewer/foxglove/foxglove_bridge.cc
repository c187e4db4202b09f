#include "viewer/foxglove/foxglove_bridge.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <tuple>

#include "common/config_publisher.h"
#include "common/lcm_decode.h"
#include "common/trajectory_message.h"
#include "kestrel/exploration_status_t.hpp"
#include "kestrel/grid_map_t.hpp"
#include "kestrel/map3d_chunk_t.hpp"
#include "kestrel/map3d_delta_t.hpp"
#include "kestrel/params_t.hpp"
#include "kestrel/trajectory_t.hpp"
#include "viewer/bridge/viewer_scene.h"

namespace kestrel::foxglove {
namespace {

// The JSON Schemas, after Foxglove's schema definitions of the same names (only the fields this
// bridge fills; Foxglove's panels read the message by the schema's name).
const char* const kTimeSchema =
    R"({"type":"object","properties":{"sec":{"type":"integer","minimum":0},)"
    R"("nsec":{"type":"integer","minimum":0,"maximum":999999999}}})";
const char* const kVector3Schema =
    R"({"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},)"
    R"("z":{"type":"number"}}})";
const char* const kQuaternionSchema =
    R"({"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},)"
    R"("z":{"type":"number"},"w":{"type":"number"}}})";
const char* const kColorSchema =
    R"({"type":"object","properties":{"r":{"type":"number"},"g":{"type":"number"},)"
    R"("b":{"type":"number"},"a":{"type":"number"}}})";

std::string PoseSchema() {
  return std::string(R"({"type":"object","properties":{"position":)") + kVector3Schema +
         R"(,"orientation":)" + kQuaternionSchema + "}}";
}

std::string FrameTransformSchema() {
  return std::string(R"({"title":"foxglove.FrameTransform","type":"object","properties":{)") +
         R"("timestamp":)" + kTimeSchema +
         R"(,"parent_frame_id":{"type":"string"},"child_frame_id":{"type":"string"},)" +
         R"("translation":)" + kVector3Schema + R"(,"rotation":)" + kQuaternionSchema + "}}";
}

std::string GridSchema() {
  return std::string(R"({"title":"foxglove.Grid","type":"object","properties":{)") +
         R"("timestamp":)" + kTimeSchema + R"(,"frame_id":{"type":"string"},"pose":)" +
         PoseSchema() + R"(,"column_count":{"type":"integer","minimum":0},)" +
         R"("cell_size":{"type":"object","properties":{"x":{"type":"number"},)" +
         R"("y":{"type":"number"}}},"row_stride":{"type":"integer","minimum":0},)" +
         R"("cell_stride":{"type":"integer","minimum":0},"fields":{"type":"array","items":)" +
         R"({"type":"object","properties":{"name":{"type":"string"},)" +
         R"("offset":{"type":"integer","minimum":0},"type":{"type":"integer"}}}},)" +
         R"("data":{"type":"string","contentEncoding":"base64"}}})";
}

std::string SceneUpdateSchema() {
  const std::string pose = PoseSchema();
  const std::string array_of = R"({"type":"array","items":)";
  const std::string arrow = R"({"type":"object","properties":{"pose":)" + pose +
                            R"(,"shaft_length":{"type":"number"},"shaft_diameter":)" +
                            R"({"type":"number"},"head_length":{"type":"number"},)" +
                            R"("head_diameter":{"type":"number"},"color":)" + kColorSchema + "}}";
  const std::string cube = R"({"type":"object","properties":{"pose":)" + pose + R"(,"size":)" +
                           kVector3Schema + R"(,"color":)" + kColorSchema + "}}";
  const std::string line =
      R"({"type":"object","properties":{"type":{"type":"integer"},"pose":)" + pose +
      R"(,"thickness":{"type":"number"},"scale_invariant":{"type":"boolean"},"points":)" +
      array_of + kVector3Schema + R"(},"color":)" + kColorSchema + R"(,"colors":)" + array_of +
      kColorSchema + R"(},"indices":)" + array_of + R"({"type":"integer"}}}})";
  const std::string entity =
      R"({"type":"object","properties":{"timestamp":)" + std::string(kTimeSchema) +
      R"(,"frame_id":{"type":"string"},"id":{"type":"string"},"lifetime":)" + kTimeSchema +
      R"(,"frame_locked":{"type":"boolean"},"metadata":)" + array_of +
      R"({"type":"object","properties":{"key":{"type":"string"},"value":{"type":"string"}}}},)" +
      R"("arrows":)" + array_of + arrow + R"(},"cubes":)" + array_of + cube + R"(},"lines":)" +
      array_of + line + "}}}";
  const std::string deletion = R"({"type":"object","properties":{"timestamp":)" +
                               std::string(kTimeSchema) +
                               R"(,"type":{"type":"integer"},"id":{"type":"string"}}})";
  return R"({"title":"foxglove.SceneUpdate","type":"object","properties":{"deletions":)" +
         array_of + deletion + R"(},"entities":)" + array_of + entity + "}}}";
}

// Kestrel's own schema: params_t as JSON (Foxglove's Raw Messages panel shows it).
std::string ParamsSchema() {
  return R"({"title":"kestrel.Params","type":"object","properties":{)"
         R"("timestamp":{"type":"object","properties":{"sec":{"type":"integer"},)"
         R"("nsec":{"type":"integer"}}},"process":{"type":"string"},"host":{"type":"string"},)"
         R"("pid":{"type":"integer"},"epoch":{"type":"integer"},"run_id":{"type":"string"},)"
         R"("config_file":{"type":"string"},"args":{"type":"array","items":{"type":"string"}},)"
         R"("params":{"type":"array","items":{"type":"object","properties":{)"
         R"("key":{"type":"string"},"value":{"type":"string"},"file":{"type":"string"},)"
         R"("source":{"type":"string","enum":["default","file","override"]}}}}}})";
}

std::string Number(double v) {
  if (!std::isfinite(v)) return "0";
  char text[32];
  std::snprintf(text, sizeof(text), "%.9g", v);
  return text;
}

std::string Time(uint64_t time_ns) {
  return R"({"sec":)" + std::to_string(time_ns / 1000000000ULL) + R"(,"nsec":)" +
         std::to_string(time_ns % 1000000000ULL) + "}";
}

uint64_t NanosecondsOf(int64_t utime) {
  return utime > 0 ? static_cast<uint64_t>(utime) * 1000ULL : 0;
}

std::string Vector3(double x, double y, double z) {
  return R"({"x":)" + Number(x) + R"(,"y":)" + Number(y) + R"(,"z":)" + Number(z) + "}";
}

std::string Quaternion(double x, double y, double z, double w) {
  return R"({"x":)" + Number(x) + R"(,"y":)" + Number(y) + R"(,"z":)" + Number(z) + R"(,"w":)" +
         Number(w) + "}";
}

std::string Color(double r, double g, double b, double a) {
  return R"({"r":)" + Number(r) + R"(,"g":)" + Number(g) + R"(,"b":)" + Number(b) + R"(,"a":)" +
         Number(a) + "}";
}

std::string Pose(double x, double y, double z, double yaw_rad) {
  return R"({"position":)" + Vector3(x, y, z) + R"(,"orientation":)" +
         Quaternion(0.0, 0.0, std::sin(0.5 * yaw_rad), std::cos(0.5 * yaw_rad)) + "}";
}

/// One SceneEntity with the given primitive arrays (JSON arrays of primitives).
std::string Entity(const std::string& frame, const std::string& id, uint64_t time_ns,
                   const std::string& arrows, const std::string& cubes, const std::string& lines) {
  return R"({"timestamp":)" + Time(time_ns) + R"(,"frame_id":)" + JsonString(frame) + R"(,"id":)" +
         JsonString(id) +
         R"(,"lifetime":{"sec":0,"nsec":0},"frame_locked":false,"metadata":[],"arrows":)" + arrows +
         R"(,"cubes":)" + cubes + R"(,"spheres":[],"cylinders":[],"lines":)" + lines +
         R"(,"triangles":[],"texts":[],"models":[]})";
}

/// Occupancy probability to a colour: yellow at the threshold to red at 1.
std::string ProbabilityColor(double p) {
  const double t = std::clamp((p - 0.5) / 0.5, 0.0, 1.0);
  return Color(1.0, 0.9 * (1.0 - t), 0.1, 1.0);
}

}  // namespace

const std::string& SchemaOf(const std::string& schema_name) {
  static const std::map<std::string, std::string> schemas = {
      {"foxglove.SceneUpdate", SceneUpdateSchema()},
      {"foxglove.Grid", GridSchema()},
      {"foxglove.FrameTransform", FrameTransformSchema()},
      {"kestrel.Params", ParamsSchema()}};
  static const std::string none;
  const auto it = schemas.find(schema_name);
  return it == schemas.end() ? none : it->second;
}

std::string Base64(const void* data, size_t size) {
  static const char* const kAlphabet =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const auto* bytes = static_cast<const uint8_t*>(data);
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  for (size_t i = 0; i < size; i += 3) {
    const uint32_t b0 = bytes[i];
    const uint32_t b1 = i + 1 < size ? bytes[i + 1] : 0;
    const uint32_t b2 = i + 2 < size ? bytes[i + 2] : 0;
    const uint32_t triple = (b0 << 16) | (b1 << 8) | b2;
    out += kAlphabet[(triple >> 18) & 63];
    out += kAlphabet[(triple >> 12) & 63];
    out += i + 1 < size ? kAlphabet[(triple >> 6) & 63] : '=';
    out += i + 2 < size ? kAlphabet[triple & 63] : '=';
  }
  return out;
}

Bridge::Bridge(BridgeConfig config)
    : config_(std::move(config)), voxels_(config_.occupied_threshold) {
  if (config_.block_cells < 1) throw std::invalid_argument("block_cells must be at least 1");
  if (!(config_.trajectory_sample_period_s > 0) || config_.max_trajectory_points < 2) {
    throw std::invalid_argument("trajectory sampling: a positive period and at least 2 points");
  }
}

bool Bridge::OnLcm(const std::string& channel, const void* data, size_t size,
                   std::vector<Message>* out, std::string* error) {
  if (channel == config_.map_channel) {
    map3d_chunk_t chunk;
    return GuardedDecode(data, size, &chunk, error) && voxels_.Apply(chunk, error);
  }
  if (channel == config_.delta_channel) {
    map3d_delta_t delta;
    return GuardedDecode(data, size, &delta, error) && voxels_.Apply(delta, error);
  }
  if (channel == config_.pose_channel) {
    pose_t pose;
    if (!GuardedDecode(data, size, &pose, error)) return false;
    if (!pose.valid) return true;  // motion capture lost the body: nothing to draw
    const double* p = pose.position_m;
    const double* q = pose.orientation_wxyz;
    if (!std::isfinite(p[0] + p[1] + p[2] + q[0] + q[1] + q[2] + q[3])) {
      *error = "pose with a non-finite value";
      return false;
    }
    Message m{"/tf", "foxglove.FrameTransform", NanosecondsOf(pose.utime), ""};
    m.json = R"({"timestamp":)" + Time(m.time_ns) + R"(,"parent_frame_id":)" +
             JsonString(config_.world_frame) + R"(,"child_frame_id":)" +
             JsonString(config_.vehicle_frame) + R"(,"translation":)" + Vector3(p[0], p[1], p[2]) +
             R"(,"rotation":)" + Quaternion(q[1], q[2], q[3], q[0]) + "}";
    out->push_back(std::move(m));
    return true;
  }
  if (channel.rfind(config_.map2d_prefix, 0) == 0) {
    grid_map_t grid;
    if (!GuardedDecode(data, size, &grid, error)) return false;
    if (grid.width <= 0 || grid.height <= 0 ||
        static_cast<int64_t>(grid.values.size()) != int64_t{grid.width} * grid.height) {
      *error = "grid size does not match its values";
      return false;
    }
    std::string name = channel.substr(config_.map2d_prefix.size());
    std::transform(name.begin(), name.end(), name.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    Message m{"/map2d/" + name, "foxglove.Grid", NanosecondsOf(grid.utime), ""};
    // float32 little-endian, as the message holds them on this (little-endian) host.
    m.json = R"({"timestamp":)" + Time(m.time_ns) + R"(,"frame_id":)" +
             JsonString(config_.world_frame) + R"(,"pose":{"position":)" +
             Vector3(grid.origin_m[0], grid.origin_m[1], grid.height_m) +
             R"(,"orientation":{"x":0,"y":0,"z":0,"w":1}},"column_count":)" +
             std::to_string(grid.width) + R"(,"cell_size":{"x":)" + Number(grid.resolution_m) +
             R"(,"y":)" + Number(grid.resolution_m) + R"(},"row_stride":)" +
             std::to_string(4 * grid.width) +
             R"(,"cell_stride":4,"fields":[{"name":"value","offset":0,"type":7}],"data":")" +
             Base64(grid.values.data(), grid.values.size() * sizeof(float)) + "\"}";
    out->push_back(std::move(m));
    return true;
  }
  if (!config_.params_prefix.empty() && channel.rfind(config_.params_prefix, 0) == 0) {
    params_t params;
    if (!GuardedDecode(data, size, &params, error)) return false;
    std::string name = channel.substr(config_.params_prefix.size());
    std::transform(name.begin(), name.end(), name.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    Message m{"/params/" + name, "kestrel.Params", NanosecondsOf(params.utime), ""};
    std::string args;
    for (const std::string& a : params.args) args += (args.empty() ? "" : ",") + JsonString(a);
    std::string values;
    for (const param_t& p : params.params) {
      values += (values.empty() ? "" : ",") + std::string(R"({"key":)") + JsonString(p.key) +
                R"(,"value":)" + JsonString(p.value) + R"(,"file":)" + JsonString(p.file) +
                R"(,"source":")" + ParamSourceName(p.source) + "\"}";
    }
    m.json = R"({"timestamp":)" + Time(m.time_ns) + R"(,"process":)" + JsonString(params.process) +
             R"(,"host":)" + JsonString(params.host) + R"(,"pid":)" + std::to_string(params.pid) +
             R"(,"epoch":)" + std::to_string(params.epoch) + R"(,"run_id":)" +
             JsonString(params.run_id) + R"(,"config_file":)" + JsonString(params.config_file) +
             R"(,"args":[)" + args + R"(],"params":[)" + values + "]}";
    out->push_back(std::move(m));
    return true;
  }
  if (channel == config_.trajectory_channel) {
    trajectory_t msg;
    if (!GuardedDecode(data, size, &msg, error)) return false;
    const std::optional<PiecewisePolynomialTrajectory> trajectory = FromMessage(msg, error);
    if (!trajectory) return false;
    const double period_s =
        std::max(config_.trajectory_sample_period_s,
                 trajectory->duration_s() / (config_.max_trajectory_points - 1));
    std::string points;
    for (const TrajectorySample& s : trajectory->Sample(period_s)) {
      const Eigen::Vector3d& p = s.flat.position_m;
      points += (points.empty() ? "" : ",") + Vector3(p.x(), p.y(), p.z());
    }
    Message m{"/trajectory", "foxglove.SceneUpdate", NanosecondsOf(msg.utime), ""};
    const std::string line = R"([{"type":0,"pose":)" + Pose(0, 0, 0, 0) +
                             R"(,"thickness":0.03,"scale_invariant":false,"points":[)" + points +
                             R"(],"color":)" + Color(0.1, 0.6, 1.0, 1.0) +
                             R"(,"colors":[],"indices":[]}])";
    m.json = R"({"deletions":[],"entities":[)" +
             Entity(config_.world_frame, "trajectory", m.time_ns, "[]", "[]", line) + "]}";
    out->push_back(std::move(m));
    return true;
  }
  if (channel == config_.exploration_channel) {
    exploration_status_t msg;
    if (!GuardedDecode(data, size, &msg, error)) return false;
    double max_gain = 0.0;
    for (const candidate_t& c : msg.candidates) max_gain = std::max(max_gain, c.gain_nats);
    std::string arrows;
    for (size_t i = 0; i < msg.candidates.size(); ++i) {
      const candidate_t& c = msg.candidates[i];
      const bool chosen = static_cast<int32_t>(i) == msg.chosen_index;
      const double share = max_gain > 0 ? std::clamp(c.gain_nats / max_gain, 0.0, 1.0) : 0.0;
      arrows += (arrows.empty() ? "" : ",") + std::string(R"({"pose":)") +
                Pose(c.position_m[0], c.position_m[1], c.position_m[2], c.yaw_rad) +
                R"(,"shaft_length":0.25,"shaft_diameter":0.03,"head_length":0.1,)" +
                R"("head_diameter":0.08,"color":)" +
                (chosen ? Color(1.0, 0.55, 0.0, 1.0) : Color(0.2, 0.3 + 0.7 * share, 1.0, 0.8)) +
                "}";
    }
    Message m{"/candidates", "foxglove.SceneUpdate", NanosecondsOf(msg.utime), ""};
    m.json = R"({"deletions":[],"entities":[)" +
             Entity(config_.world_frame, "candidates", m.time_ns, "[" + arrows + "]", "[]", "[]") +
             "]}";
    out->push_back(std::move(m));
    return true;
  }
  return true;
}

Bridge::BlockKey Bridge::BlockOf(const VoxelEntry& e) const {
  const auto b = [this](int16_t v) {
    return static_cast<int64_t>(std::floor(static_cast<double>(v) / config_.block_cells)) + 4096;
  };
  return (b(e.z) << 26) | (b(e.y) << 13) | b(e.x);
}

std::string Bridge::BlockEntity(BlockKey key, uint64_t time_ns) const {
  std::string cubes;
  const auto it = blocks_.find(key);
  const double r = voxels_.resolution_m();
  const Eigen::Vector3d& o = voxels_.origin_m();
  if (it != blocks_.end()) {
    for (const auto& [cell, q] : it->second) {
      const auto [x, y, z] = cell;
      cubes += (cubes.empty() ? "" : ",") + std::string(R"({"pose":)") +
               Pose(o.x() + (x + 0.5) * r, o.y() + (y + 0.5) * r, o.z() + (z + 0.5) * r, 0.0) +
               R"(,"size":)" + Vector3(r, r, r) + R"(,"color":)" +
               ProbabilityColor(static_cast<double>(q) / 255.0) + "}";
    }
  }
  return Entity(config_.world_frame, "block " + std::to_string(key), time_ns, "[]",
                "[" + cubes + "]", "[]");
}

std::string Bridge::MapUpdate(const std::vector<BlockKey>& blocks, bool delete_all,
                              uint64_t time_ns) const {
  std::string entities;
  std::string deletions;
  for (const BlockKey key : blocks) {
    if (blocks_.count(key) == 0) {  // emptied: delete the entity
      deletions += (deletions.empty() ? "" : ",") + std::string(R"({"timestamp":)") +
                   Time(time_ns) + R"(,"type":0,"id":)" +
                   JsonString("block " + std::to_string(key)) + "}";
    } else {
      entities += (entities.empty() ? "" : ",") + BlockEntity(key, time_ns);
    }
  }
  if (delete_all) deletions = R"({"timestamp":)" + Time(time_ns) + R"(,"type":1,"id":""})";
  return R"({"deletions":[)" + deletions + R"(],"entities":[)" + entities + "]}";
}

std::optional<Message> Bridge::TakeMapUpdate(bool render) {
  if (!voxels_.has_snapshot()) return std::nullopt;
  const VoxelChanges changes = voxels_.TakeChanges();
  if (!changes.reset && changes.entries.empty()) return std::nullopt;
  std::vector<BlockKey> dirty;
  if (changes.reset) {
    for (const auto& [key, cells] : blocks_) dirty.push_back(key);
    blocks_.clear();
  }
  for (const VoxelEntry& e : changes.entries) {
    const BlockKey key = BlockOf(e);
    dirty.push_back(key);
    if (e.q == 0) {
      const auto it = blocks_.find(key);
      if (it == blocks_.end()) continue;
      it->second.erase({e.x, e.y, e.z});
      if (it->second.empty()) blocks_.erase(it);
    } else {
      blocks_[key][{e.x, e.y, e.z}] = e.q;
    }
  }
  if (!render) return std::nullopt;
  std::sort(dirty.begin(), dirty.end());
  dirty.erase(std::unique(dirty.begin(), dirty.end()), dirty.end());
  if (changes.reset) {  // every block after a deletion of everything
    dirty.clear();
    for (const auto& [key, cells] : blocks_) dirty.push_back(key);
  }
  const uint64_t time_ns = NanosecondsOf(voxels_.utime());
  return Message{"/map", "foxglove.SceneUpdate", time_ns, MapUpdate(dirty, changes.reset, time_ns)};
}

std::optional<Message> Bridge::MapSnapshot() const {
  if (!voxels_.has_snapshot()) return std::nullopt;
  std::vector<BlockKey> all;
  for (const auto& [key, cells] : blocks_) all.push_back(key);
  const uint64_t time_ns = NanosecondsOf(voxels_.utime());
  return Message{"/map", "foxglove.SceneUpdate", time_ns, MapUpdate(all, true, time_ns)};
}

}  // namespace kestrel::foxglove
