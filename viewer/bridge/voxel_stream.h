#pragma once
/// @file
/// The viewer's copy of the mapper's occupied cells, rebuilt from MAP3D snapshot chunks and
/// MAP3D_DELTA messages (lcmtypes/kestrel_map3d_*.lcm), and the changes a viewer must be sent.
///
/// Only cells with P(m) > occupied_threshold are kept, each with its probability quantized to a
/// byte (QuantizeProbability). A snapshot is staged until all of its chunks arrived, then replaces
/// the copy; a delta applies when its prev_seq equals the copy's map_seq, and a delta that does
/// not follow (a lost message) marks the copy stale until the next full snapshot (the same rules
/// as mapping/map_replica.h, over a sparse set instead of a dense lattice, so a growing map works).
///
/// Change tracking: every cell whose quantized value changes is remembered with the value it had
/// at the last TakeChanges(); TakeChanges() then returns only the cells whose value differs, with
/// their current value (0 = no longer occupied). Applying the returned changes, in order, to the
/// result of an earlier Occupied() (or of the previous changes) gives the current Occupied().
/// Many map updates between two calls coalesce into one set of changes, bounded by the map size.

#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "kestrel/map3d_chunk_t.hpp"
#include "kestrel/map3d_delta_t.hpp"
#include "lcmtypes/message_codecs.h"

namespace kestrel {

/// One occupied cell as sent to the page: cell index (i16 per axis) and quantized probability.
struct VoxelEntry {
  int16_t x{0};
  int16_t y{0};
  int16_t z{0};
  uint8_t q{0};  ///< round(P * 255) (>= 1) when occupied; 0 means "not occupied (any more)"
  bool operator==(const VoxelEntry& o) const {
    return x == o.x && y == o.y && z == o.z && q == o.q;
  }
};

/// The cells changed since the previous TakeChanges().
struct VoxelChanges {
  /// True when the receiver must drop every voxel first (the lattice changed): `entries` then
  /// holds the whole occupied set.
  bool reset{false};
  std::vector<VoxelEntry> entries;  ///< sorted by (z, y, x)
};

/// The byte sent for probability p: 0 if p <= threshold (not occupied), else round(p * 255)
/// clamped to [1, 255]. Precondition: threshold in [0, 1).
[[nodiscard]] uint8_t QuantizeProbability(double p, double occupied_threshold);

class VoxelStream {
 public:
  /// @throws std::invalid_argument unless occupied_threshold is in [0, 1).
  explicit VoxelStream(double occupied_threshold);

  /// Applies one snapshot chunk. Returns false with *error when it is malformed (sizes,
  /// encoding, zlib) or out of sequence (the partial snapshot is then dropped).
  bool Apply(const map3d_chunk_t& chunk, std::string* error);
  /// Applies a delta. Returns false with *error when there is no snapshot yet, the lattice
  /// differs, or it does not follow the copy (the copy is then stale until the next snapshot).
  /// A delta following the snapshot being staged (the mapper paces a snapshot's chunks and keeps
  /// sending deltas: docs/design.md §3.3) is kept and applied once that snapshot is whole.
  bool Apply(const map3d_delta_t& delta, std::string* error);

  /// The changes since the previous call (or since construction); see the file comment.
  [[nodiscard]] VoxelChanges TakeChanges();
  /// Every occupied cell now, sorted by (z, y, x).
  [[nodiscard]] std::vector<VoxelEntry> Occupied() const;

  [[nodiscard]] size_t occupied_count() const { return occupied_.size(); }
  [[nodiscard]] double occupied_threshold() const { return threshold_; }
  /// True once a snapshot arrived (the lattice below is then known).
  [[nodiscard]] bool has_snapshot() const { return has_snapshot_; }
  /// True once a snapshot arrived and no delta has been missed since.
  [[nodiscard]] bool current() const { return has_snapshot_ && !stale_; }
  /// Map updates reflected (map3d_delta_t.seq / map3d_chunk_t.map_seq), -1 before a snapshot.
  [[nodiscard]] int64_t map_seq() const { return seq_; }
  /// The publisher epoch of the mapper the copy comes from (docs/design.md §3.4), 0 before a
  /// snapshot.
  [[nodiscard]] int64_t map_epoch() const { return epoch_; }
  /// Time of the newest map data reflected (us).
  [[nodiscard]] int64_t utime() const { return utime_; }
  /// Lower corner of cell (0, 0, 0) in W (m), and the cell edge (m).
  [[nodiscard]] const Eigen::Vector3d& origin_m() const { return origin_m_; }
  [[nodiscard]] double resolution_m() const { return resolution_m_; }
  /// Occupied cells ignored because an index does not fit in 16 bits (never for the paper's
  /// lattices).
  [[nodiscard]] int64_t cells_out_of_range() const { return cells_out_of_range_; }

 private:
  using Key = uint64_t;
  using CellSet = std::unordered_map<Key, uint8_t>;
  [[nodiscard]] static bool MakeKey(int x, int y, int z, Key* key);
  [[nodiscard]] static VoxelEntry EntryOf(Key key, uint8_t q);
  [[nodiscard]] bool SameLattice(const double origin[3], double resolution) const;
  /// Sets cell `key` to q (0 removes it), remembering its value at the last TakeChanges().
  void Set(Key key, uint8_t q);
  /// Applies the deltas kept for the snapshot just completed.
  bool ApplyStagedDeltas(std::string* error);

  double threshold_;
  CellSet occupied_;
  CellSet changed_;  // cell -> quantized value at the last TakeChanges()
  bool reset_pending_{false};
  Eigen::Vector3d origin_m_{Eigen::Vector3d::Zero()};
  double resolution_m_{0.0};
  int64_t seq_{-1};
  int64_t epoch_{0};
  int64_t utime_{0};
  bool has_snapshot_{false};
  bool stale_{false};
  int64_t cells_out_of_range_{0};
  // Snapshot being assembled.
  CellSet staging_;
  int64_t staging_id_{-1};
  int64_t staging_epoch_{0};
  int staging_next_chunk_{0};
  SnapshotDeltaBuffer staged_deltas_;  // deltas following the staged snapshot
};

}  // namespace kestrel
