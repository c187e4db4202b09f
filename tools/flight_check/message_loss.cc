#include "tools/flight_check/message_loss.h"

#include <algorithm>
#include <cstring>
#include <string>

#include "common/lcm_decode.h"
#include "kestrel/command_t.hpp"
#include "kestrel/controller_status_t.hpp"
#include "kestrel/depth_image_t.hpp"
#include "kestrel/exploration_status_t.hpp"
#include "kestrel/heartbeat_t.hpp"
#include "kestrel/imu_t.hpp"
#include "kestrel/map3d_chunk_t.hpp"
#include "kestrel/map3d_delta_t.hpp"
#include "kestrel/map_decisions_t.hpp"
#include "kestrel/map_status_t.hpp"
#include "kestrel/motor_command_t.hpp"
#include "kestrel/planar_scan_t.hpp"
#include "kestrel/pose_t.hpp"
#include "kestrel/procman_order_t.hpp"
#include "kestrel/procman_status_t.hpp"
#include "kestrel/sim_truth_t.hpp"
#include "kestrel/trajectory_t.hpp"

namespace kestrel {

namespace {

int64_t BigEndian64(const uint8_t* p) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v = (v << 8) | p[i];
  return static_cast<int64_t>(v);
}

// The types whose second and third fields are a per-publisher seq counted one by one and the
// publisher's epoch (after the fingerprint and utime). grid_map_t is not one: its seq is the
// explorer's plan number, and the 2D maps go out only every map2d_period_s.
bool NumberedOneByOne(int64_t hash) {
  static const int64_t kHashes[] = {command_t::getHash(),        controller_status_t::getHash(),
                                    depth_image_t::getHash(),    exploration_status_t::getHash(),
                                    heartbeat_t::getHash(),      imu_t::getHash(),
                                    map_status_t::getHash(),     map_decisions_t::getHash(),
                                    motor_command_t::getHash(),  planar_scan_t::getHash(),
                                    pose_t::getHash(),           procman_order_t::getHash(),
                                    procman_status_t::getHash(), sim_truth_t::getHash(),
                                    trajectory_t::getHash()};
  for (const int64_t h : kHashes) {
    if (h == hash) return true;
  }
  return false;
}

}  // namespace

void MessageLoss::Add(const std::string& channel, const void* data, int size) {
  if (size < 8) return;
  const auto* bytes = static_cast<const uint8_t*>(data);
  const int64_t hash = BigEndian64(bytes);
  if (hash == map3d_chunk_t::getHash()) return AddChunk(data, size);
  if (hash == map3d_delta_t::getHash()) return AddDelta(data, size);
  if (!NumberedOneByOne(hash) || size < 32) return;
  const int64_t seq = BigEndian64(bytes + 16);
  const int64_t epoch = BigEndian64(bytes + 24);
  Stream& s = streams_[channel];
  ++s.received;
  const auto key = std::make_pair(channel, epoch);
  const auto it = last_seq_.find(key);
  if (it != last_seq_.end()) {
    if (seq > it->second + 1) s.lost += seq - it->second - 1;
    if (seq > it->second) it->second = seq;
  } else {
    last_seq_.emplace(key, seq);
  }
}

void MessageLoss::AddChunk(const void* data, int size) {
  map3d_chunk_t chunk;
  std::string error;
  if (!GuardedDecode(data, static_cast<size_t>(size), &chunk, &error)) return;
  ++map_.chunks_received;
  map_.largest_chunk_bytes = std::max<int64_t>(map_.largest_chunk_bytes, size);
  MapperState& m = mappers_[chunk.epoch];
  if (chunk.snapshot_id > m.last_snapshot_id) {
    if (m.last_snapshot_id >= 0)
      map_.snapshots_missed += chunk.snapshot_id - m.last_snapshot_id - 1;
    m.last_snapshot_id = chunk.snapshot_id;
  }
  // A mapper sends one snapshot after the other: a chunk of this one closes the older ones.
  Judge(&m, chunk.snapshot_id);
  Snapshot& s = m.snapshots[chunk.snapshot_id];
  s.num_chunks = chunk.num_chunks;
  s.chunks.insert(chunk.chunk_index);
  m.seen_map_seqs.insert(chunk.map_seq);
}

void MessageLoss::AddDelta(const void* data, int size) {
  map3d_delta_t delta;
  std::string error;
  if (!GuardedDecode(data, static_cast<size_t>(size), &delta, &error)) return;
  ++map_.deltas_received;
  map_.largest_delta_bytes = std::max<int64_t>(map_.largest_delta_bytes, size);
  MapperState& m = mappers_[delta.epoch];
  // Deltas go on while a snapshot's chunks are paced (docs/design.md §3.3): they close nothing.
  if (!m.seen_map_seqs.empty() && m.seen_map_seqs.count(delta.prev_seq) == 0) ++map_.delta_gaps;
  m.seen_map_seqs.insert(delta.seq);
}

void MessageLoss::Judge(MapperState* m, int64_t before_id) {
  for (auto it = m->snapshots.begin(); it != m->snapshots.end();) {
    if (it->first >= before_id) break;
    const int64_t missing = static_cast<int64_t>(it->second.num_chunks) -
                            static_cast<int64_t>(it->second.chunks.size());
    if (missing > 0) {
      map_.chunks_lost += missing;
      ++map_.snapshots_incomplete;
    } else {
      ++map_.snapshots_complete;
    }
    it = m->snapshots.erase(it);
  }
}

void MessageLoss::Finish() {
  // Snapshots still open may still have been going out: only complete ones count.
  for (auto& [epoch, m] : mappers_) {
    for (auto it = m.snapshots.begin(); it != m.snapshots.end();) {
      if (static_cast<int64_t>(it->second.chunks.size()) == it->second.num_chunks) {
        ++map_.snapshots_complete;
        it = m.snapshots.erase(it);
      } else {
        ++it;
      }
    }
  }
}

int64_t MessageLoss::streams_lost() const {
  int64_t n = 0;
  for (const auto& [channel, s] : streams_) n += s.lost;
  return n;
}

}  // namespace kestrel
