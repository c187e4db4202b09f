#include "viewer/bridge/voxel_stream.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/check.h"
#include "lcmtypes/message_codecs.h"

namespace kestrel {

uint8_t QuantizeProbability(double p, double occupied_threshold) {
  if (!(p > occupied_threshold)) return 0;
  const double q = std::round(std::min(1.0, p) * 255.0);
  return static_cast<uint8_t>(std::clamp(q, 1.0, 255.0));
}

VoxelStream::VoxelStream(double occupied_threshold) : threshold_(occupied_threshold) {
  KESTREL_THROW_UNLESS(occupied_threshold >= 0.0 && occupied_threshold < 1.0,
                       "occupied_threshold " << occupied_threshold << " is outside [0, 1)");
}

bool VoxelStream::MakeKey(int x, int y, int z, Key* key) {
  const auto fits = [](int v) {
    return v >= std::numeric_limits<int16_t>::min() && v <= std::numeric_limits<int16_t>::max();
  };
  if (!fits(x) || !fits(y) || !fits(z)) return false;
  *key = static_cast<Key>(static_cast<uint16_t>(x)) |
         (static_cast<Key>(static_cast<uint16_t>(y)) << 16) |
         (static_cast<Key>(static_cast<uint16_t>(z)) << 32);
  return true;
}

VoxelEntry VoxelStream::EntryOf(Key key, uint8_t q) {
  VoxelEntry e;
  e.x = static_cast<int16_t>(static_cast<uint16_t>(key & 0xffff));
  e.y = static_cast<int16_t>(static_cast<uint16_t>((key >> 16) & 0xffff));
  e.z = static_cast<int16_t>(static_cast<uint16_t>((key >> 32) & 0xffff));
  e.q = q;
  return e;
}

bool VoxelStream::SameLattice(const double origin[3], double resolution) const {
  const double tol = 1e-9;
  bool same = std::abs(resolution - resolution_m_) < tol;
  for (int a = 0; a < 3; ++a) same = same && std::abs(origin[a] - origin_m_[a]) < tol;
  return same;
}

void VoxelStream::Set(Key key, uint8_t q) {
  const auto it = occupied_.find(key);
  const uint8_t prior = it == occupied_.end() ? 0 : it->second;
  if (prior == q) return;
  changed_.emplace(key, prior);  // keeps the value of the last TakeChanges() if already there
  if (q == 0) {
    occupied_.erase(it);
  } else {
    occupied_[key] = q;
  }
}

bool VoxelStream::Apply(const map3d_chunk_t& chunk, std::string* error) {
  const int edge = chunk.block_edge;
  if (chunk.num_chunks <= 0 || chunk.chunk_index < 0 || chunk.chunk_index >= chunk.num_chunks ||
      edge <= 0 || edge > 64 || chunk.num_blocks < 0 ||
      chunk.block_index.size() != static_cast<size_t>(chunk.num_blocks) ||
      !(chunk.resolution_m > 0.0) || !std::isfinite(chunk.resolution_m) ||
      !std::isfinite(chunk.origin_m[0]) || !std::isfinite(chunk.origin_m[1]) ||
      !std::isfinite(chunk.origin_m[2])) {
    staging_id_ = -1;
    *error = "chunk " + std::to_string(chunk.chunk_index) + "/" + std::to_string(chunk.num_chunks) +
             " with block edge " + std::to_string(edge) + " is malformed";
    return false;
  }
  if (chunk.chunk_index == 0) {
    staging_.clear();
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
  const size_t block_cells = static_cast<size_t>(edge) * edge * edge;
  std::vector<float> values;
  if (const std::string why = DecodeMapChunkCells(chunk, &values); !why.empty()) {
    staging_id_ = -1;
    *error = "chunk " + std::to_string(chunk.chunk_index) + ": " + why;
    return false;
  }
  // dims bound the map when all are positive (a dense map); a growing map sends zeros.
  const bool bounded = chunk.dims[0] > 0 && chunk.dims[1] > 0 && chunk.dims[2] > 0;
  for (int b = 0; b < chunk.num_blocks; ++b) {
    const auto& bi = chunk.block_index[static_cast<size_t>(b)];
    for (size_t i = 0; i < block_cells; ++i) {
      const uint8_t q =
          QuantizeProbability(values[static_cast<size_t>(b) * block_cells + i], threshold_);
      if (q == 0) continue;
      const int ii = static_cast<int>(i);
      const int x = bi[0] * edge + ii % edge, y = bi[1] * edge + (ii / edge) % edge,
                z = bi[2] * edge + ii / (edge * edge);
      if (bounded && (x < 0 || y < 0 || z < 0 || x >= chunk.dims[0] || y >= chunk.dims[1] ||
                      z >= chunk.dims[2])) {
        continue;
      }
      Key key;
      if (MakeKey(x, y, z, &key)) {
        staging_[key] = q;
      } else {
        ++cells_out_of_range_;
      }
    }
  }
  ++staging_next_chunk_;
  if (staging_next_chunk_ < chunk.num_chunks) return true;

  staging_id_ = -1;
  if (current() && chunk.epoch == epoch_ && chunk.map_seq < seq_ &&
      SameLattice(chunk.origin_m, chunk.resolution_m)) {
    staging_.clear();
    return ApplyStagedDeltas(error);  // deltas already took the copy past this snapshot
  }
  if (!has_snapshot_ || !SameLattice(chunk.origin_m, chunk.resolution_m)) {
    // A new lattice: the receivers start over from the whole set.
    occupied_.swap(staging_);
    changed_.clear();
    reset_pending_ = true;
    for (int a = 0; a < 3; ++a) origin_m_[a] = chunk.origin_m[a];
    resolution_m_ = chunk.resolution_m;
  } else {
    std::vector<Key> gone;
    for (const auto& [key, q] : occupied_) {
      if (staging_.count(key) == 0) gone.push_back(key);
    }
    for (const Key key : gone) Set(key, 0);
    for (const auto& [key, q] : staging_) Set(key, q);
  }
  staging_.clear();
  seq_ = chunk.map_seq;
  epoch_ = chunk.epoch;
  utime_ = chunk.utime;
  has_snapshot_ = true;
  stale_ = false;
  return ApplyStagedDeltas(error);
}

bool VoxelStream::ApplyStagedDeltas(std::string* error) {
  for (const map3d_delta_t& delta : staged_deltas_.Take()) {
    if (!Apply(delta, error)) return false;
  }
  return true;
}

bool VoxelStream::Apply(const map3d_delta_t& delta, std::string* error) {
  MapDeltaCells changed;
  if (const std::string why = DecodeMapDelta(delta, &changed); !why.empty()) {
    *error = "delta: " + why;
    return false;
  }
  // A delta sent while the staged snapshot's chunks are still arriving: kept for it.
  const bool kept = staging_id_ >= 0 && staged_deltas_.Keep(delta);
  if (!has_snapshot_) {
    if (kept) return true;
    *error = "delta before any snapshot";
    return false;
  }
  if (!SameLattice(delta.origin_m, delta.resolution_m)) {
    if (kept) return true;  // the staged snapshot brings its lattice
    *error = "delta lattice differs from the snapshot's";
    return false;
  }
  if (delta.epoch != epoch_) {  // a restarted mapper (docs/design.md §3.4): wait for its snapshot
    if (kept) return true;
    stale_ = true;
    *error = "delta of mapper epoch " + std::to_string(delta.epoch) + " on a copy of epoch " +
             std::to_string(epoch_) + ": stale until that mapper's next snapshot";
    return false;
  }
  if (delta.seq <= seq_) return true;  // already reflected by a newer snapshot
  if (stale_ || delta.prev_seq != seq_) {
    if (kept) return true;  // it follows the snapshot on its way, not this copy
    stale_ = true;
    *error = "delta " + std::to_string(delta.prev_seq) + " -> " + std::to_string(delta.seq) +
             " does not follow " + std::to_string(seq_) + ": stale until the next snapshot";
    return false;
  }
  for (size_t i = 0; i < changed.cells.size(); ++i) {
    const auto& c = changed.cells[i];
    Key key;
    const uint8_t q = QuantizeProbability(changed.probabilities[i], threshold_);
    if (MakeKey(c[0], c[1], c[2], &key)) {
      Set(key, q);
    } else if (q != 0) {
      ++cells_out_of_range_;
    }
  }
  seq_ = delta.seq;
  utime_ = delta.utime;
  return true;
}

namespace {
bool ByZyx(const VoxelEntry& a, const VoxelEntry& b) {
  if (a.z != b.z) return a.z < b.z;
  if (a.y != b.y) return a.y < b.y;
  return a.x < b.x;
}
}  // namespace

VoxelChanges VoxelStream::TakeChanges() {
  VoxelChanges out;
  if (reset_pending_) {
    out.reset = true;
    out.entries = Occupied();
  } else {
    for (const auto& [key, prior] : changed_) {
      const auto it = occupied_.find(key);
      const uint8_t now = it == occupied_.end() ? 0 : it->second;
      if (now != prior) out.entries.push_back(EntryOf(key, now));
    }
    std::sort(out.entries.begin(), out.entries.end(), ByZyx);
  }
  changed_.clear();
  reset_pending_ = false;
  return out;
}

std::vector<VoxelEntry> VoxelStream::Occupied() const {
  std::vector<VoxelEntry> out;
  out.reserve(occupied_.size());
  for (const auto& [key, q] : occupied_) out.push_back(EntryOf(key, q));
  std::sort(out.begin(), out.end(), ByZyx);
  return out;
}

}  // namespace kestrel
