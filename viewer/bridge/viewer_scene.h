#pragma once
/// @file
/// Everything the live viewer page shows, kept by the bridge (kestrel-viewer) from Kestrel's
/// messages, and its encoding into the page's WebSocket frames. Pure: no LCM, no sockets.
///
/// Wire protocol (one WebSocket message per frame; the page is viewer/web/viewer.js):
///
/// "vehicle" is the index of the vehicle in hello's list: each vehicle's pose, path, plan and
/// exploration are kept and sent apart (its prefix before each channel name).
///
/// Binary frames, little-endian, the first byte is the kind:
///  - kind 1, voxels (48-byte header, then num_entries x 8 bytes):
///      u8 kind=1 | u8 flags (bit 0: reset = drop every voxel first, i.e. a full snapshot)
///      | u16 0 | u32 num_entries | f64 origin_m[3] (lower corner of cell (0,0,0), W)
///      | f64 resolution_m | i64 map_seq;
///      entry: i16 x, i16 y, i16 z (cell index), u8 q, u8 0. q = round(P * 255) of an occupied
///      cell (P > occupied threshold), q = 0: the cell is no longer occupied.
///  - kind 2, a 2D grid map (56-byte header, the name padded to 8 bytes, then f32 values):
///      u8 kind=2 | u8 0 | u16 name_length | u32 width | u32 height | u32 0
///      | f64 origin_m[2] | f64 height_m | f64 resolution_m | i64 utime; name (the channel,
///      e.g. "MAP2D_COLLISION", "V2_MAP2D_COLLISION"); width * height f32, row-major, x fastest
///      (grid_map_t.values).
/// Text frames are JSON objects with a "type":
///  - "hello": protocol version, occupied threshold, channel names, vehicles: [prefix, ...]
///      (docs/design.md §7.10; [""] for one vehicle without a prefix);
///  - "pose": {vehicle, utime, p: [x, y, z] m, q: [w, x, y, z], valid} (the vehicle's latest
///      POSE_VICON);
///  - "path": {vehicle, reset, points: [[x, y, z], ...]}: its flown path, appended (reset:
///      replace);
///  - "plan": {vehicle, seq, points}: its latest TRAJECTORY, sampled;
///  - "exploration": {vehicle, seq, state, mode, reason, chosen, goal, best_gain, candidates:
///      [[x, y, z, yaw, gain_nats, objective], ...]} from its EXPLORATION_STATUS;
///  - "entropy": {reset, points: [[utime_s, H_nats], ...]} from MAP_STATUS, appended;
///  - "status": map_seq, current, occupied count, mapper rates and the bridge's counters.
///
/// A client that connects gets SnapshotFrames() (hello, all voxels with reset, the latest of
/// everything, whole histories); afterwards every TakeUpdateFrames() result, which holds only
/// what changed since the previous call, coalesced (many map deltas give one voxel frame).

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "kestrel/exploration_status_t.hpp"
#include "kestrel/grid_map_t.hpp"
#include "kestrel/map3d_chunk_t.hpp"
#include "kestrel/map3d_delta_t.hpp"
#include "kestrel/map_status_t.hpp"
#include "kestrel/pose_t.hpp"
#include "kestrel/trajectory_t.hpp"
#include "viewer/bridge/voxel_stream.h"

namespace kestrel {

/// The protocol version sent in "hello" (bump when a frame layout changes).
/// 2: the per-vehicle frames name their vehicle, hello lists the vehicles.
inline constexpr int kViewerProtocolVersion = 2;

/// One WebSocket message: binary or text (JSON).
struct ViewerFrame {
  bool binary{false};
  std::string bytes;
};

/// What the scene keeps; defaults suit the paper's runs.
struct ViewerSceneConfig {
  double occupied_threshold{0.5};    ///< cells with P(m) above this are shown, in [0, 1)
  double path_min_step_m{0.02};      ///< flown path: a point when the vehicle moved this far, m
  int max_path_points{20000};        ///< flown path points kept (halved when exceeded)
  int max_entropy_points{20000};     ///< entropy history points kept (halved when exceeded)
  double plan_sample_period_s{0.1};  ///< TRAJECTORY sampled every this long, s
  int max_plan_points{2000};         ///< samples of one plan at most (period grows to fit)
  int max_candidates{512};           ///< candidates forwarded per plan (best objective first)
  /// Channel names for "hello" (display only).
  std::map<std::string, std::string> channels;
  /// The vehicles' channel prefixes (docs/design.md §7.10), at least one; index k is vehicle k.
  std::vector<std::string> vehicles{""};
};

/// Encodes a voxel frame (kind 1) as documented in the file comment.
[[nodiscard]] std::string EncodeVoxelFrame(bool reset, int64_t map_seq,
                                           const Eigen::Vector3d& origin_m, double resolution_m,
                                           const std::vector<VoxelEntry>& entries);
/// Encodes a grid frame (kind 2) under `name`. Precondition: values.size() == width * height.
[[nodiscard]] std::string EncodeGridFrame(const std::string& name, const grid_map_t& grid);
/// `text` as a JSON string literal (quotes, backslashes and control characters escaped).
[[nodiscard]] std::string JsonString(const std::string& text);

class ViewerScene {
 public:
  /// @throws std::invalid_argument on a threshold outside [0, 1), non-positive sizes or no
  ///   vehicle.
  explicit ViewerScene(const ViewerSceneConfig& config);

  /// Map input (VoxelStream::Apply). Returns false with *error when refused.
  bool OnMapChunk(const map3d_chunk_t& msg, std::string* error);
  bool OnMapDelta(const map3d_delta_t& msg, std::string* error);
  /// MAP_STATUS: appends (utime, entropy) when time advances.
  void OnMapStatus(const map_status_t& msg);
  /// A MAP2D_* grid under its channel name. Returns false with *error on inconsistent sizes.
  bool OnGridMap(const std::string& channel, const grid_map_t& msg, std::string* error);
  /// A vehicle's POSE_VICON: its latest pose; valid poses extend its flown path. `vehicle` is
  /// an index into config.vehicles (precondition); the overloads without it are vehicle 0.
  void OnPose(size_t vehicle, const pose_t& msg);
  void OnPose(const pose_t& msg) { OnPose(0, msg); }
  /// A vehicle's TRAJECTORY: sampled for display. Returns false with *error on an inconsistent
  /// message.
  bool OnTrajectory(size_t vehicle, const trajectory_t& msg, std::string* error);
  bool OnTrajectory(const trajectory_t& msg, std::string* error) {
    return OnTrajectory(0, msg, error);
  }
  /// A vehicle's EXPLORATION_STATUS: state, goal and candidates.
  void OnExploration(size_t vehicle, const exploration_status_t& msg);
  void OnExploration(const exploration_status_t& msg) { OnExploration(0, msg); }
  /// Counters of the bridge itself (malformed messages, refused maps, clients ...) for "status".
  void SetBridgeCounter(const std::string& name, int64_t value);

  /// Everything now, for a client that just connected (or has to catch up).
  [[nodiscard]] std::vector<ViewerFrame> SnapshotFrames() const;
  /// What changed since the previous call (nothing: empty).
  [[nodiscard]] std::vector<ViewerFrame> TakeUpdateFrames();

  [[nodiscard]] const VoxelStream& voxels() const { return voxels_; }
  [[nodiscard]] size_t vehicle_count() const { return vehicles_.size(); }
  /// Flown path points kept of a vehicle (default: vehicle 0).
  [[nodiscard]] size_t path_points(size_t vehicle = 0) const {
    return vehicles_.at(vehicle).path.size();
  }
  [[nodiscard]] size_t entropy_points() const { return entropy_.size(); }

 private:
  /// What is kept of one vehicle, and what of it changed since the last update.
  struct Vehicle {
    std::optional<pose_t> pose;
    bool pose_dirty{false};
    std::vector<Eigen::Vector3d> path;
    size_t path_sent{0};
    bool path_reset{false};
    int64_t plan_seq{-1};
    std::vector<Eigen::Vector3d> plan;
    bool plan_dirty{false};
    std::optional<exploration_status_t> exploration;
    bool exploration_dirty{false};
  };

  [[nodiscard]] std::string HelloJson() const;
  [[nodiscard]] std::string PoseJson(size_t vehicle) const;
  [[nodiscard]] std::string PathJson(size_t vehicle, bool reset, size_t from) const;
  [[nodiscard]] std::string PlanJson(size_t vehicle) const;
  [[nodiscard]] std::string ExplorationJson(size_t vehicle) const;
  [[nodiscard]] std::string EntropyJson(bool reset, size_t from) const;
  [[nodiscard]] std::string StatusJson() const;
  [[nodiscard]] std::string VoxelSnapshotFrame() const;

  ViewerSceneConfig config_;
  VoxelStream voxels_;
  // Latest grids by channel, and the channels changed since the last update.
  std::map<std::string, grid_map_t> grids_;
  std::map<std::string, bool> grid_dirty_;
  std::vector<Vehicle> vehicles_;                    // one per config_.vehicles entry, same order
  std::vector<std::pair<int64_t, double>> entropy_;  // (utime, H nats)
  size_t entropy_sent_{0};
  bool entropy_reset_{false};
  std::optional<map_status_t> map_status_;
  std::map<std::string, int64_t> counters_;
  std::string last_status_;  // the last "status" sent by TakeUpdateFrames
};

}  // namespace kestrel
