#pragma once
/// @file
/// A subscriber's copy of the mapper's 3D map, rebuilt from MAP3D snapshot chunks and
/// MAP3D_DELTA messages over a fixed dense lattice (the explorer, viewers, the replay check).
///
/// A snapshot is staged until all of its chunks have arrived, then replaces the copy (cells in
/// no block hold p_init). The mapper paces a snapshot's chunks and keeps sending deltas meanwhile
/// (docs/design.md §3.3): a delta of the staged snapshot's mapper that follows it (its prev_seq is
/// the snapshot's map_seq, or the seq of the delta kept before it) is kept and applied once the
/// snapshot is whole; it is also applied to the copy at once if it follows the copy. A delta
/// applies when it comes from the same mapper (publisher epoch, docs/design.md §3.4) as the copy
/// and its prev_seq equals the copy's sequence; a delta that does not follow (a lost message) or
/// comes from another epoch (a restarted mapper, which counts from 0 again) marks the copy stale
/// until the next full snapshot. Cells outside the lattice are ignored (a growing map may extend
/// past it).

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "kestrel/map3d_chunk_t.hpp"
#include "kestrel/map3d_delta_t.hpp"
#include "lcmtypes/message_codecs.h"

namespace kestrel {

class MapReplica {
 public:
  /// A replica over cells [0, dims) from origin_m with edge resolution_m, all at p_init.
  /// @throws std::invalid_argument on non-positive dims or resolution.
  MapReplica(const Eigen::Vector3d& origin_m, double resolution_m, const Eigen::Vector3i& dims,
             double p_init);

  /// Applies a snapshot chunk. Returns false with *error if it does not fit this lattice
  /// (origin or resolution differ) or is malformed (sizes, encoding, zlib).
  bool Apply(const map3d_chunk_t& chunk, std::string* error);
  /// Applies a delta. Returns false with *error if it does not follow the copy (the copy is then
  /// stale until the next snapshot) or does not fit the lattice.
  bool Apply(const map3d_delta_t& delta, std::string* error);

  /// True once a full snapshot arrived and no delta has been missed since.
  [[nodiscard]] bool current() const { return has_snapshot_ && !stale_; }
  /// Map updates reflected (map3d_delta_t.seq / map3d_chunk_t.map_seq), -1 before any snapshot.
  [[nodiscard]] int64_t seq() const { return seq_; }
  /// The epoch of the mapper the copy comes from (0 before any snapshot).
  [[nodiscard]] int64_t epoch() const { return epoch_; }
  /// Time of the newest data in the copy (us).
  [[nodiscard]] int64_t utime() const { return utime_; }
  [[nodiscard]] const Eigen::Vector3i& dims() const { return dims_; }
  [[nodiscard]] const Eigen::Vector3d& origin_m() const { return origin_m_; }
  [[nodiscard]] double resolution_m() const { return resolution_m_; }
  /// Probabilities, x fastest then y then z (dims.prod() values).
  [[nodiscard]] const std::vector<float>& probabilities() const { return probabilities_; }
  [[nodiscard]] float At(int x, int y, int z) const;

 private:
  [[nodiscard]] bool SameLattice(const double origin[3], double resolution,
                                 std::string* error) const;
  [[nodiscard]] bool Inside(int x, int y, int z) const {
    return x >= 0 && y >= 0 && z >= 0 && x < dims_.x() && y < dims_.y() && z < dims_.z();
  }
  [[nodiscard]] size_t Index(int x, int y, int z) const {
    return static_cast<size_t>(x) +
           static_cast<size_t>(dims_.x()) *
               (static_cast<size_t>(y) + static_cast<size_t>(dims_.y()) * static_cast<size_t>(z));
  }

  Eigen::Vector3d origin_m_;
  double resolution_m_;
  Eigen::Vector3i dims_;
  float p_init_;
  std::vector<float> probabilities_;
  int64_t seq_{-1};
  int64_t epoch_{0};
  int64_t utime_{0};
  bool has_snapshot_{false};
  bool stale_{false};
  // Snapshot being assembled.
  std::vector<float> staging_;
  int64_t staging_id_{-1};
  int64_t staging_epoch_{0};
  int staging_next_chunk_{0};
  SnapshotDeltaBuffer staged_deltas_;  // deltas following the staged snapshot
};

}  // namespace kestrel
