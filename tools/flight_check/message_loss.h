#pragma once
/// @file
/// Counts the messages a subscriber did not receive, from what it did receive
/// (docs/design.md §3.3, §3.4): on every stream that numbers its messages one by one (`seq` per
/// publisher epoch), the gaps between consecutive sequence numbers; on the map channels, the
/// snapshot chunks that never arrived (per snapshot id, `num_chunks` minus the chunks seen; a
/// snapshot id skipped altogether) and the deltas whose `prev_seq` names no map update this
/// subscriber saw (a delta or snapshot in between was lost). Messages are recognised by their LCM
/// fingerprint, not by channel name. Nothing is judged before the first message of a publisher
/// epoch (a subscriber started late) nor after the last (the end of listening): a snapshot is
/// judged when a chunk of a later snapshot of its mapper arrives (a mapper sends one snapshot's
/// chunks after the other, deltas in between), so one still incomplete when listening stops is not
/// counted.

#include <cstdint>
#include <map>
#include <set>
#include <string>

namespace kestrel {

class MessageLoss {
 public:
  /// One received LCM message (its encoded bytes, fingerprint first).
  void Add(const std::string& channel, const void* data, int size);

  struct Stream {
    int64_t received{0};
    int64_t lost{0};  ///< sequence numbers skipped
  };
  /// Per channel with a one-by-one `seq` (not the map channels, not MAP2D_*, whose seq is the
  /// explorer's plan number).
  [[nodiscard]] const std::map<std::string, Stream>& streams() const { return streams_; }

  struct Map {
    int64_t chunks_received{0};
    int64_t chunks_lost{0};           ///< chunks of snapshots seen in part
    int64_t snapshots_complete{0};    ///< every chunk arrived
    int64_t snapshots_incomplete{0};  ///< some chunk lost
    int64_t snapshots_missed{0};      ///< snapshot ids never seen at all (between seen ones)
    int64_t deltas_received{0};
    int64_t delta_gaps{0};           ///< deltas following a map update this subscriber never saw
    int64_t largest_chunk_bytes{0};  ///< largest encoded map3d_chunk_t received
    int64_t largest_delta_bytes{0};  ///< largest encoded map3d_delta_t received
  };
  /// Map channels (map3d_chunk_t, map3d_delta_t), all mappers together. Call Finish() first.
  [[nodiscard]] const Map& map() const { return map_; }
  /// Closes the accounting: judges the snapshots still open.
  void Finish();
  /// Map messages lost: chunks lost + snapshots missed + delta gaps (a missed snapshot counts one,
  /// a gap counts one, though either may hide more).
  [[nodiscard]] int64_t map_lost() const {
    return map_.chunks_lost + map_.snapshots_missed + map_.delta_gaps;
  }
  [[nodiscard]] int64_t streams_lost() const;

 private:
  struct Snapshot {
    int32_t num_chunks{0};
    std::set<int32_t> chunks;
  };
  struct MapperState {
    std::map<int64_t, Snapshot> snapshots;  // by snapshot id, only those not yet judged
    int64_t last_snapshot_id{-1};
    std::set<int64_t> seen_map_seqs;  // map updates a snapshot or delta brought here
  };
  void AddChunk(const void* data, int size);
  void AddDelta(const void* data, int size);
  // Judges the snapshots of `m` older than `before_id`.
  void Judge(MapperState* m, int64_t before_id);

  std::map<std::string, Stream> streams_;
  std::map<std::pair<std::string, int64_t>, int64_t> last_seq_;  // (channel, epoch) -> seq
  std::map<int64_t, MapperState> mappers_;                       // by epoch
  Map map_;
};

}  // namespace kestrel
