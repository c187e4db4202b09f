#include "viewer/bridge/viewer_scene.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numeric>

#include "common/check.h"
#include "common/trajectory_message.h"
#include "exploration/explorer_state.h"

namespace kestrel {
namespace {

// Little-endian writers, whatever the host's byte order.
void PutU8(std::string* out, uint8_t v) { out->push_back(static_cast<char>(v)); }
void PutU16(std::string* out, uint16_t v) {
  for (int i = 0; i < 2; ++i) PutU8(out, static_cast<uint8_t>(v >> (8 * i)));
}
void PutU32(std::string* out, uint32_t v) {
  for (int i = 0; i < 4; ++i) PutU8(out, static_cast<uint8_t>(v >> (8 * i)));
}
void PutU64(std::string* out, uint64_t v) {
  for (int i = 0; i < 8; ++i) PutU8(out, static_cast<uint8_t>(v >> (8 * i)));
}
void PutF64(std::string* out, double v) {
  uint64_t bits;
  std::memcpy(&bits, &v, sizeof bits);
  PutU64(out, bits);
}
void PutF32(std::string* out, float v) {
  uint32_t bits;
  std::memcpy(&bits, &v, sizeof bits);
  PutU32(out, bits);
}

// A JSON number (non-finite values become null, which JSON has no number for).
void AppendNumber(std::string* out, double v, const char* format = "%.6g") {
  if (!std::isfinite(v)) {
    *out += "null";
    return;
  }
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, format, v);
  *out += buffer;
}
void AppendPoint(std::string* out, const Eigen::Vector3d& p) {
  *out += '[';
  for (int a = 0; a < 3; ++a) {
    if (a > 0) *out += ',';
    AppendNumber(out, p[a], "%.4f");
  }
  *out += ']';
}
void AppendPoints(std::string* out, const std::vector<Eigen::Vector3d>& points, size_t from) {
  *out += '[';
  for (size_t i = from; i < points.size(); ++i) {
    if (i > from) *out += ',';
    AppendPoint(out, points[i]);
  }
  *out += ']';
}
// Keeps every other element (the first and the last stay), so histories stay bounded.
template <class T>
void Halve(std::vector<T>* v) {
  if (v->size() < 3) return;
  std::vector<T> kept;
  kept.reserve(v->size() / 2 + 2);
  for (size_t i = 0; i + 1 < v->size(); i += 2) kept.push_back((*v)[i]);
  kept.push_back(v->back());
  v->swap(kept);
}

}  // namespace

std::string EncodeVoxelFrame(bool reset, int64_t map_seq, const Eigen::Vector3d& origin_m,
                             double resolution_m, const std::vector<VoxelEntry>& entries) {
  std::string out;
  out.reserve(48 + entries.size() * 8);
  PutU8(&out, 1);
  PutU8(&out, reset ? 1 : 0);
  PutU16(&out, 0);
  PutU32(&out, static_cast<uint32_t>(entries.size()));
  for (int a = 0; a < 3; ++a) PutF64(&out, origin_m[a]);
  PutF64(&out, resolution_m);
  PutU64(&out, static_cast<uint64_t>(map_seq));
  for (const VoxelEntry& e : entries) {
    PutU16(&out, static_cast<uint16_t>(e.x));
    PutU16(&out, static_cast<uint16_t>(e.y));
    PutU16(&out, static_cast<uint16_t>(e.z));
    PutU8(&out, e.q);
    PutU8(&out, 0);
  }
  return out;
}

std::string EncodeGridFrame(const std::string& name, const grid_map_t& grid) {
  KESTREL_DEMAND(grid.width >= 0 && grid.height >= 0 &&
                 grid.values.size() == static_cast<size_t>(grid.width) * grid.height);
  const size_t name_length = std::min<size_t>(name.size(), 0xffff);
  std::string out;
  out.reserve(64 + name_length + grid.values.size() * 4);
  PutU8(&out, 2);
  PutU8(&out, 0);
  PutU16(&out, static_cast<uint16_t>(name_length));
  PutU32(&out, static_cast<uint32_t>(grid.width));
  PutU32(&out, static_cast<uint32_t>(grid.height));
  PutU32(&out, 0);
  PutF64(&out, grid.origin_m[0]);
  PutF64(&out, grid.origin_m[1]);
  PutF64(&out, grid.height_m);
  PutF64(&out, grid.resolution_m);
  PutU64(&out, static_cast<uint64_t>(grid.utime));
  out.append(name, 0, name_length);
  while (out.size() % 8 != 0) PutU8(&out, 0);
  for (const float v : grid.values) PutF32(&out, v);
  return out;
}

std::string JsonString(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (u < 0x20) {
      char buffer[8];
      std::snprintf(buffer, sizeof buffer, "\\u%04x", u);
      out += buffer;
    } else {
      out += c;
    }
  }
  out += '"';
  return out;
}

ViewerScene::ViewerScene(const ViewerSceneConfig& config)
    : config_(config), voxels_(config.occupied_threshold) {
  KESTREL_THROW_UNLESS(config.path_min_step_m >= 0 && config.max_path_points >= 2 &&
                           config.max_entropy_points >= 2 && config.plan_sample_period_s > 0 &&
                           config.max_plan_points >= 2 && config.max_candidates >= 0,
                       "viewer scene sizes: path step " << config.path_min_step_m << ", points "
                                                        << config.max_path_points);
  KESTREL_THROW_UNLESS(!config.vehicles.empty(), "viewer scene: no vehicle");
  vehicles_.resize(config.vehicles.size());
}

bool ViewerScene::OnMapChunk(const map3d_chunk_t& msg, std::string* error) {
  return voxels_.Apply(msg, error);
}

bool ViewerScene::OnMapDelta(const map3d_delta_t& msg, std::string* error) {
  return voxels_.Apply(msg, error);
}

void ViewerScene::OnMapStatus(const map_status_t& msg) {
  map_status_ = msg;
  if (!entropy_.empty() && msg.utime <= entropy_.back().first) return;
  entropy_.emplace_back(msg.utime, msg.map_entropy_nats);
  if (entropy_.size() > static_cast<size_t>(config_.max_entropy_points)) {
    Halve(&entropy_);
    entropy_reset_ = true;
  }
}

bool ViewerScene::OnGridMap(const std::string& channel, const grid_map_t& msg, std::string* error) {
  if (msg.width < 0 || msg.height < 0 ||
      msg.values.size() != static_cast<size_t>(msg.width) * static_cast<size_t>(msg.height) ||
      !(msg.resolution_m > 0)) {
    *error = "grid " + channel + ": " + std::to_string(msg.values.size()) + " values for " +
             std::to_string(msg.width) + " x " + std::to_string(msg.height) + " cells";
    return false;
  }
  grids_[channel] = msg;
  grid_dirty_[channel] = true;
  return true;
}

void ViewerScene::OnPose(size_t vehicle, const pose_t& msg) {
  Vehicle& v = vehicles_.at(vehicle);
  v.pose = msg;
  v.pose_dirty = true;
  if (!msg.valid) return;
  const Eigen::Vector3d p(msg.position_m[0], msg.position_m[1], msg.position_m[2]);
  if (!p.allFinite()) return;
  if (!v.path.empty() && (p - v.path.back()).norm() < config_.path_min_step_m) return;
  v.path.push_back(p);
  if (v.path.size() > static_cast<size_t>(config_.max_path_points)) {
    Halve(&v.path);
    v.path_reset = true;
  }
}

bool ViewerScene::OnTrajectory(size_t vehicle, const trajectory_t& msg, std::string* error) {
  Vehicle& v = vehicles_.at(vehicle);
  const std::optional<PiecewisePolynomialTrajectory> trajectory = FromMessage(msg, error);
  if (!trajectory) return false;
  const double dt_s = std::max(config_.plan_sample_period_s,
                               trajectory->duration_s() / (config_.max_plan_points - 1));
  v.plan.clear();
  for (const TrajectorySample& s : trajectory->Sample(dt_s)) v.plan.push_back(s.flat.position_m);
  v.plan_seq = msg.seq;
  v.plan_dirty = true;
  return true;
}

void ViewerScene::OnExploration(size_t vehicle, const exploration_status_t& msg) {
  Vehicle& v = vehicles_.at(vehicle);
  v.exploration = msg;
  v.exploration_dirty = true;
}

void ViewerScene::SetBridgeCounter(const std::string& name, int64_t value) {
  counters_[name] = value;
}

std::string ViewerScene::HelloJson() const {
  std::string out = "{\"type\":\"hello\",\"version\":" + std::to_string(kViewerProtocolVersion);
  out += ",\"threshold\":";
  AppendNumber(&out, config_.occupied_threshold);
  out += ",\"channels\":{";
  bool first = true;
  for (const auto& [key, channel] : config_.channels) {
    if (!first) out += ',';
    first = false;
    out += JsonString(key) + ":" + JsonString(channel);
  }
  out += "},\"vehicles\":[";
  for (size_t k = 0; k < config_.vehicles.size(); ++k) {
    if (k > 0) out += ',';
    out += JsonString(config_.vehicles[k]);
  }
  out += "]}";
  return out;
}

std::string ViewerScene::PoseJson(size_t vehicle) const {
  const pose_t& m = *vehicles_[vehicle].pose;
  std::string out = "{\"type\":\"pose\",\"vehicle\":" + std::to_string(vehicle) +
                    ",\"utime\":" + std::to_string(m.utime) + ",\"p\":";
  AppendPoint(&out, Eigen::Vector3d(m.position_m[0], m.position_m[1], m.position_m[2]));
  out += ",\"q\":[";
  for (int i = 0; i < 4; ++i) {
    if (i > 0) out += ',';
    AppendNumber(&out, m.orientation_wxyz[i]);
  }
  out += "],\"valid\":";
  out += m.valid ? "true" : "false";
  out += '}';
  return out;
}

std::string ViewerScene::PathJson(size_t vehicle, bool reset, size_t from) const {
  std::string out = "{\"type\":\"path\",\"vehicle\":" + std::to_string(vehicle) + ",\"reset\":";
  out += reset ? "true" : "false";
  out += ",\"points\":";
  AppendPoints(&out, vehicles_[vehicle].path, reset ? 0 : from);
  out += '}';
  return out;
}

std::string ViewerScene::PlanJson(size_t vehicle) const {
  const Vehicle& v = vehicles_[vehicle];
  std::string out = "{\"type\":\"plan\",\"vehicle\":" + std::to_string(vehicle) +
                    ",\"seq\":" + std::to_string(v.plan_seq) + ",\"points\":";
  AppendPoints(&out, v.plan, 0);
  out += '}';
  return out;
}

std::string ViewerScene::ExplorationJson(size_t vehicle) const {
  const exploration_status_t& m = *vehicles_[vehicle].exploration;
  std::string out = "{\"type\":\"exploration\",\"vehicle\":" + std::to_string(vehicle) +
                    ",\"utime\":" + std::to_string(m.utime) + ",\"seq\":" + std::to_string(m.seq) +
                    ",\"state\":" + std::to_string(static_cast<int>(m.state)) +
                    ",\"state_name\":" + JsonString(ExplorerStateName(m.state)) +
                    ",\"mode\":" + JsonString(m.mode) + ",\"reason\":" + JsonString(m.reason) +
                    ",\"entropy\":";
  AppendNumber(&out, m.map_entropy_nats);
  out += ",\"best_gain\":";
  AppendNumber(&out, m.best_unweighted_gain_nats);
  // The chosen candidate is kept first in the list sent, then the best objectives.
  std::vector<int> order(m.candidates.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    if ((a == m.chosen_index) != (b == m.chosen_index)) return a == m.chosen_index;
    return m.candidates[static_cast<size_t>(a)].objective >
           m.candidates[static_cast<size_t>(b)].objective;
  });
  if (order.size() > static_cast<size_t>(config_.max_candidates)) {
    order.resize(static_cast<size_t>(config_.max_candidates));
  }
  const bool has_chosen = m.chosen_index >= 0 && !order.empty() && order[0] == m.chosen_index;
  out += ",\"chosen\":";
  out += has_chosen ? "0" : "-1";
  out += ",\"goal\":";
  AppendPoint(&out,
              Eigen::Vector3d(m.goal_position_m[0], m.goal_position_m[1], m.goal_position_m[2]));
  out += ",\"goal_yaw\":";
  AppendNumber(&out, m.goal_yaw_rad);
  out += ",\"candidates\":[";
  for (size_t k = 0; k < order.size(); ++k) {
    const candidate_t& c = m.candidates[static_cast<size_t>(order[k])];
    if (k > 0) out += ',';
    out += '[';
    for (int a = 0; a < 3; ++a) {
      AppendNumber(&out, c.position_m[a], "%.4f");
      out += ',';
    }
    AppendNumber(&out, c.yaw_rad, "%.4f");
    out += ',';
    AppendNumber(&out, c.gain_nats);
    out += ',';
    AppendNumber(&out, c.objective);
    out += ']';
  }
  out += "]}";
  return out;
}

std::string ViewerScene::EntropyJson(bool reset, size_t from) const {
  std::string out = "{\"type\":\"entropy\",\"reset\":";
  out += reset ? "true" : "false";
  out += ",\"points\":[";
  for (size_t i = reset ? 0 : from; i < entropy_.size(); ++i) {
    if (i > (reset ? 0 : from)) out += ',';
    out += '[';
    AppendNumber(&out, static_cast<double>(entropy_[i].first) * 1e-6, "%.3f");
    out += ',';
    AppendNumber(&out, entropy_[i].second, "%.8g");
    out += ']';
  }
  out += "]}";
  return out;
}

std::string ViewerScene::StatusJson() const {
  std::string out = "{\"type\":\"status\",\"map_seq\":" + std::to_string(voxels_.map_seq()) +
                    ",\"map_utime\":" + std::to_string(voxels_.utime()) + ",\"current\":";
  out += voxels_.current() ? "true" : "false";
  out += ",\"occupied\":" + std::to_string(voxels_.occupied_count());
  if (map_status_) {
    out += ",\"entropy\":";
    AppendNumber(&out, map_status_->map_entropy_nats, "%.8g");
    out += ",\"rays_per_s\":";
    AppendNumber(&out, map_status_->rays_per_s);
    out += ",\"applied_every_message\":";
    out += map_status_->applied_every_message ? "true" : "false";
  }
  out += ",\"bridge\":{";
  bool first = true;
  for (const auto& [name, value] : counters_) {
    if (!first) out += ',';
    first = false;
    out += JsonString(name) + ":" + std::to_string(value);
  }
  out += "}}";
  return out;
}

std::string ViewerScene::VoxelSnapshotFrame() const {
  return EncodeVoxelFrame(true, voxels_.map_seq(), voxels_.origin_m(), voxels_.resolution_m(),
                          voxels_.Occupied());
}

std::vector<ViewerFrame> ViewerScene::SnapshotFrames() const {
  std::vector<ViewerFrame> frames;
  frames.push_back({false, HelloJson()});
  if (voxels_.has_snapshot()) frames.push_back({true, VoxelSnapshotFrame()});
  for (const auto& [channel, grid] : grids_)
    frames.push_back({true, EncodeGridFrame(channel, grid)});
  for (size_t k = 0; k < vehicles_.size(); ++k) {
    const Vehicle& v = vehicles_[k];
    if (v.pose) frames.push_back({false, PoseJson(k)});
    frames.push_back({false, PathJson(k, true, 0)});
    if (v.plan_seq >= 0) frames.push_back({false, PlanJson(k)});
    if (v.exploration) frames.push_back({false, ExplorationJson(k)});
  }
  frames.push_back({false, EntropyJson(true, 0)});
  frames.push_back({false, StatusJson()});
  return frames;
}

std::vector<ViewerFrame> ViewerScene::TakeUpdateFrames() {
  std::vector<ViewerFrame> frames;
  const VoxelChanges changes = voxels_.TakeChanges();
  if (changes.reset || !changes.entries.empty()) {
    frames.push_back({true, EncodeVoxelFrame(changes.reset, voxels_.map_seq(), voxels_.origin_m(),
                                             voxels_.resolution_m(), changes.entries)});
  }
  for (auto& [channel, dirty] : grid_dirty_) {
    if (dirty) frames.push_back({true, EncodeGridFrame(channel, grids_.at(channel))});
    dirty = false;
  }
  for (size_t k = 0; k < vehicles_.size(); ++k) {
    Vehicle& v = vehicles_[k];
    if (v.pose_dirty && v.pose) frames.push_back({false, PoseJson(k)});
    v.pose_dirty = false;
    if (v.path_reset || v.path_sent < v.path.size()) {
      frames.push_back({false, PathJson(k, v.path_reset, v.path_sent)});
    }
    v.path_reset = false;
    v.path_sent = v.path.size();
    if (v.plan_dirty) frames.push_back({false, PlanJson(k)});
    v.plan_dirty = false;
    if (v.exploration_dirty && v.exploration) frames.push_back({false, ExplorationJson(k)});
    v.exploration_dirty = false;
  }
  if (entropy_reset_ || entropy_sent_ < entropy_.size()) {
    frames.push_back({false, EntropyJson(entropy_reset_, entropy_sent_)});
  }
  entropy_reset_ = false;
  entropy_sent_ = entropy_.size();
  std::string status = StatusJson();
  if (status != last_status_) {
    frames.push_back({false, status});
    last_status_ = std::move(status);
  }
  return frames;
}

}  // namespace kestrel
