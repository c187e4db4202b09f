#pragma once
/// @file
/// Kestrel's channels as Foxglove messages (docs/design.md §7.3): the translation shared by the
/// live Foxglove WebSocket endpoint of kestrel-viewer (foxglove_server.h) and the LCM-log to MCAP
/// exporter (kestrel-mcap-export). Pure: bytes in, JSON out; no sockets, no files.
///
/// Every topic is JSON-encoded ("json") with a JSON Schema ("jsonschema") named after the
/// Foxglove schema it follows, so Foxglove's 3D and map panels draw it without a plugin (the
/// configuration has a schema of Kestrel's own, shown by Foxglove's Raw Messages panel).
///
/// Topics (schema: what, from which channel):
///  - `/map` (foxglove.SceneUpdate): one entity per block of 16^3 cells, a cube per cell with P
///    above the occupied threshold, coloured by P; from MAP3D and MAP3D_DELTA, coalesced
///    (TakeMapUpdate);
///  - `/tf` (foxglove.FrameTransform): `world` -> `vehicle`, from valid POSE_VICON poses;
///  - `/map2d/<name>` (foxglove.Grid): one FLOAT32 field `value`, from MAP2D_<NAME>;
///  - `/trajectory` (foxglove.SceneUpdate): the planned trajectory as a line strip, from
///    TRAJECTORY;
///  - `/candidates` (foxglove.SceneUpdate): an arrow per candidate pose, the chosen one orange,
///    from EXPLORATION_STATUS;
///  - `/params/<process>` (kestrel.Params, Kestrel's own schema): a process's configuration
///    (every key, value, file and source; its command line), from PARAMS_<PROCESS>
///    (docs/design.md §6).
///
/// Frames: `world` is Kestrel's W (z up), `vehicle` its body frame B.

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "kestrel/pose_t.hpp"
#include "viewer/bridge/voxel_stream.h"

namespace kestrel::foxglove {

/// A Foxglove message: its topic, its schema (name and JSON Schema text) and the JSON payload.
struct Message {
  std::string topic;
  std::string schema_name;  ///< e.g. "foxglove.SceneUpdate"
  uint64_t time_ns{0};      ///< the message's own time (Kestrel's utime x 1000)
  std::string json;
};

/// The JSON Schema of a Foxglove schema this bridge uses ("foxglove.SceneUpdate",
/// "foxglove.Grid", "foxglove.FrameTransform"); "" for any other name.
[[nodiscard]] const std::string& SchemaOf(const std::string& schema_name);

/// RFC 4648 base64 (with padding) of `size` bytes.
[[nodiscard]] std::string Base64(const void* data, size_t size);

struct BridgeConfig {
  double occupied_threshold{0.5};  ///< cells with P above it are drawn, in [0, 1)
  int block_cells{16};             ///< cells per block edge: one SceneUpdate entity per block
  double trajectory_sample_period_s{0.1};
  int max_trajectory_points{2000};
  std::string world_frame{"world"};
  std::string vehicle_frame{"vehicle"};
  std::string map_channel{"MAP3D"};
  std::string delta_channel{"MAP3D_DELTA"};
  std::string pose_channel{"POSE_VICON"};
  std::string trajectory_channel{"TRAJECTORY"};
  std::string exploration_channel{"EXPLORATION_STATUS"};
  std::string map2d_prefix{"MAP2D_"};
  std::string params_prefix{"PARAMS_"};
};

class Bridge {
 public:
  /// @throws std::invalid_argument on a threshold outside [0, 1) or a block size below 1.
  explicit Bridge(BridgeConfig config);

  /// One LCM message. Appends at once the messages it gives (pose, grid, trajectory,
  /// candidates) to *out; map data waits for TakeMapUpdate. Channels it does not translate are
  /// ignored (true). Returns false with *error when the message is malformed or refused.
  bool OnLcm(const std::string& channel, const void* data, size_t size, std::vector<Message>* out,
             std::string* error);

  /// The blocks whose cells changed since the last call, as one SceneUpdate (all blocks, after
  /// a deletion of everything, when the lattice changed), stamped with the map's time; nothing
  /// when no cell changed. With `render` false the changes are taken into the blocks but no JSON
  /// is made (nothing is returned): what the live endpoint does while nobody subscribes to /map.
  [[nodiscard]] std::optional<Message> TakeMapUpdate(bool render = true);
  /// The whole map as one SceneUpdate (for a client that subscribes late); nothing before the
  /// first snapshot.
  [[nodiscard]] std::optional<Message> MapSnapshot() const;

  [[nodiscard]] size_t occupied_count() const { return voxels_.occupied_count(); }
  [[nodiscard]] size_t block_count() const { return blocks_.size(); }

 private:
  using BlockKey = int64_t;
  [[nodiscard]] BlockKey BlockOf(const VoxelEntry& e) const;
  [[nodiscard]] std::string BlockEntity(BlockKey key, uint64_t time_ns) const;
  [[nodiscard]] std::string MapUpdate(const std::vector<BlockKey>& blocks, bool delete_all,
                                      uint64_t time_ns) const;

  BridgeConfig config_;
  VoxelStream voxels_;
  /// Occupied cells per block: cell index (x, y, z) -> q (P x 255).
  std::map<BlockKey, std::map<std::tuple<int16_t, int16_t, int16_t>, uint8_t>> blocks_;
};

}  // namespace kestrel::foxglove
