#include "mapping/map_replica.h"

#include <cmath>

#include "common/check.h"
#include "lcmtypes/message_codecs.h"

namespace kestrel {

MapReplica::MapReplica(const Eigen::Vector3d& origin_m, double resolution_m,
                       const Eigen::Vector3i& dims, double p_init)
    : origin_m_(origin_m),
      resolution_m_(resolution_m),
      dims_(dims),
      p_init_(static_cast<float>(p_init)) {
  KESTREL_THROW_UNLESS(
      dims.minCoeff() > 0 && resolution_m > 0 && origin_m.allFinite(),
      "replica lattice: dims " << dims.transpose() << ", resolution " << resolution_m);
  probabilities_.assign(static_cast<size_t>(dims.prod()), p_init_);
}

float MapReplica::At(int x, int y, int z) const {
  return Inside(x, y, z) ? probabilities_[Index(x, y, z)] : p_init_;
}

bool MapReplica::SameLattice(const double origin[3], double resolution, std::string* error) const {
  const double tol = 1e-9;
  bool same = std::abs(resolution - resolution_m_) < tol;
  for (int a = 0; a < 3; ++a) same = same && std::abs(origin[a] - origin_m_[a]) < tol;
  if (!same) {
    *error = "map lattice (origin, resolution " + std::to_string(resolution) +
             ") differs from the replica's (" + std::to_string(resolution_m_) + ")";
  }
  return same;
}

bool MapReplica::Apply(const map3d_chunk_t& chunk, std::string* error) {
  if (!SameLattice(chunk.origin_m, chunk.resolution_m, error)) return false;
  if (chunk.num_chunks <= 0 || chunk.chunk_index < 0 || chunk.chunk_index >= chunk.num_chunks ||
      chunk.block_edge != 8) {
    *error = "chunk " + std::to_string(chunk.chunk_index) + "/" + std::to_string(chunk.num_chunks) +
             " with block edge " + std::to_string(chunk.block_edge) + " is malformed";
    return false;
  }
  if (chunk.chunk_index == 0) {
    staging_.assign(probabilities_.size(), static_cast<float>(chunk.p_init));
    staging_id_ = chunk.snapshot_id;
    staging_epoch_ = chunk.epoch;
    staging_next_chunk_ = 0;
    staged_deltas_.Begin(chunk.epoch, chunk.map_seq);
  }
  if (chunk.snapshot_id != staging_id_ || chunk.epoch != staging_epoch_ ||
      chunk.chunk_index != staging_next_chunk_) {
    staging_id_ = -1;  // a chunk was lost: wait for the next snapshot
    *error = "snapshot " + std::to_string(chunk.snapshot_id) + " chunk " +
             std::to_string(chunk.chunk_index) + " out of sequence";
    return false;
  }
  std::vector<float> values;
  const std::string why = DecodeMapChunkCells(chunk, &values);
  if (!why.empty()) {
    staging_id_ = -1;
    *error = "chunk " + std::to_string(chunk.chunk_index) + ": " + why;
    return false;
  }
  for (int b = 0; b < chunk.num_blocks; ++b) {
    const auto& bi = chunk.block_index[static_cast<size_t>(b)];
    for (int i = 0; i < 512; ++i) {
      const int x = bi[0] * 8 + (i & 7), y = bi[1] * 8 + ((i >> 3) & 7), z = bi[2] * 8 + (i >> 6);
      if (Inside(x, y, z)) staging_[Index(x, y, z)] = values[static_cast<size_t>(b) * 512 + i];
    }
  }
  ++staging_next_chunk_;
  if (staging_next_chunk_ == chunk.num_chunks) {
    probabilities_.swap(staging_);
    seq_ = chunk.map_seq;
    epoch_ = chunk.epoch;
    utime_ = chunk.utime;
    has_snapshot_ = true;
    stale_ = false;
    staging_id_ = -1;
    // The deltas sent while the snapshot's chunks were paced follow it (docs/design.md §3.3).
    for (const map3d_delta_t& delta : staged_deltas_.Take()) {
      if (!Apply(delta, error)) return false;
    }
  }
  return true;
}

bool MapReplica::Apply(const map3d_delta_t& delta, std::string* error) {
  MapDeltaCells changed;
  if (const std::string why = DecodeMapDelta(delta, &changed); !why.empty()) {
    *error = "delta: " + why;
    return false;
  }
  if (!SameLattice(delta.origin_m, delta.resolution_m, error)) return false;
  // A delta sent while the staged snapshot's chunks are still arriving: kept for it.
  const bool kept = staging_id_ >= 0 && staged_deltas_.Keep(delta);
  if (!has_snapshot_) {
    if (kept) return true;
    *error = "delta before any snapshot";
    return false;
  }
  if (delta.epoch != epoch_) {  // a restarted mapper: its seq says nothing about this copy
    if (kept) return true;
    stale_ = true;
    *error = "delta of mapper epoch " + std::to_string(delta.epoch) + " on a copy of epoch " +
             std::to_string(epoch_) + ": stale until that mapper's next snapshot";
    return false;
  }
  if (delta.seq <= seq_) return true;  // already reflected by a newer snapshot
  if (delta.prev_seq != seq_) {
    if (kept) return true;  // it follows the snapshot on its way, not this copy
    stale_ = true;
    *error = "delta " + std::to_string(delta.prev_seq) + " -> " + std::to_string(delta.seq) +
             " does not follow " + std::to_string(seq_) + ": stale until the next snapshot";
    return false;
  }
  for (size_t i = 0; i < changed.cells.size(); ++i) {
    const auto& c = changed.cells[i];
    if (Inside(c[0], c[1], c[2]))
      probabilities_[Index(c[0], c[1], c[2])] = changed.probabilities[i];
  }
  seq_ = delta.seq;
  utime_ = delta.utime;
  return true;
}

}  // namespace kestrel
