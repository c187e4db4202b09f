#pragma once
/// @file
/// The mapper node (kestrel-mapper): fuses depth images and planar scans into the 3D occupancy
/// map, ray by ray, at the pose interpolated at each scan's stamp (mapping/pose_history.h).
/// Several vehicles feed one map (config.vehicle_prefixes, docs/design.md §7.10): each vehicle's
/// scans are paired with its own poses, and all go through the one queue below.
///
/// Order and determinism: handlers only queue; ProcessPending() applies queued scans in
/// (stamp, vehicle, sensor) order, each once every stream has passed its stamp (or order_wait_s)
/// and its pose is known, so the same messages give the same map bit for bit whatever the delays
/// between the sensors' publishers (docs/design.md §3.6). A scan newer
/// than the latest pose waits, until a pose after it arrives or the newest input stamp passes it by
/// pose_history.max_wait_s (message time, so that a replayed log pairs exactly as live); scans
/// older than the history, across a pose gap, malformed, or already applied (the same publisher
/// epoch and a sequence number not above the last one applied from it: docs/design.md §3.4) are
/// counted by reason and skipped; a restarted publisher (a new epoch) is applied at once. Outputs:
/// full snapshots in chunks (MAP3D) at a low rate, deltas of the changed cells in between
/// (MAP3D_DELTA: the cells the map tracked as changed since the last delta or snapshot,
/// OccupancyMap::ForEachChangedCell), MAP_STATUS and a heartbeat. Map messages are sized and
/// paced for small receive buffers (docs/design.md §7.6): no chunk or delta is larger than
/// map_message_max_bytes, a snapshot's chunks go out at snapshot_bytes_per_s, and a delta goes
/// out as soon as it fills that limit (after the scan that filled it; one that a single scan took
/// past three times the limit becomes a snapshot). Publishing never changes the map.
///
/// Overload policy (documented in config/mapper.yaml): when the oldest queued scan is more than
/// max_backlog_s behind the newest input, the next scans apply only every k-th ray (k doubles
/// while behind, halves once caught up); when the queue exceeds max_queue scans the oldest is
/// dropped. Both show in MAP_STATUS (ray_decimation, skip reasons, applied_every_message).
///
/// Decisions (docs/design.md §3.6): how far behind the node falls depends on the host's load,
/// and what it receives on the network, so every decision on a queued scan is recorded, in the
/// order taken: applied (with its ray stride and the vehicle's pose used) or skipped for good
/// (with the reason). They go out on decisions_channel (map_decisions_t) and into decisions_log,
/// which also holds every applied scan as received (the logger may miss one the node had).
/// A node told to FollowDecisions() takes none of its own: it applies exactly the recorded ones,
/// and so holds the map of the mapper that recorded them, bit for bit, whatever its load was.
/// A checkpoint carries the history of decisions it holds (DecisionHistory), so a resumed
/// mapper's decisions continue it.

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <unordered_set>
#include <variant>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/heartbeat.h"
#include "common/lcm_decode.h"
#include "common/log.h"
#include "kestrel/depth_image_t.hpp"
#include "kestrel/map3d_chunk_t.hpp"
#include "kestrel/map_decision_t.hpp"
#include "kestrel/planar_scan_t.hpp"
#include "kestrel/pose_t.hpp"
#include "mapping/map_file.h"
#include "mapping/mapper_config.h"
#include "mapping/occupancy_map.h"
#include "mapping/scan_integrator.h"

namespace kestrel {

/// The name under which a checkpoint's stream table holds its history of decisions: per mapper
/// life, in order, (its epoch, how many of its decisions the map holds). Never an LCM channel.
inline constexpr const char* kDecisionHistoryStream = "#decisions";

class MapperNode {
 public:
  /// Subscribes to the sensors and poses; resumes from config.checkpoint_path if it holds a
  /// valid map of this run (docs/design.md §3.5): a corrupt file is moved aside as
  /// <path>.corrupt, another run's checkpoint (unless config.resume is "any") as
  /// <path>.run-<its run id>, and the map then starts empty.
  /// @throws std::invalid_argument if config.Validate() throws; std::runtime_error if another
  /// run's checkpoint cannot be moved aside (it is never overwritten).
  MapperNode(lcm::LCM& lcm, const MapperConfig& config, const Clock& clock);
  MapperNode(const MapperNode&) = delete;
  MapperNode& operator=(const MapperNode&) = delete;

  /// Applies every queued scan whose pose is known (at most max_scans; <= 0: all). Returns the
  /// number of scans applied or skipped.
  int ProcessPending(int max_scans = 0);
  /// At the end of the input (exit, the end of a replayed log): applies every queued scan whose
  /// pose is known without waiting for the other streams to pass it. Returns the number applied
  /// or skipped.
  int ApplyRemaining();
  /// Publishes whatever is due at the clock's time: status/heartbeat, delta, snapshot, and saves
  /// the checkpoint when due.
  void PublishDue();
  /// Takes a full snapshot now and sends its first chunk (map_channel); the others follow at
  /// config.snapshot_bytes_per_s from PublishDue (all at once when it is 0). A snapshot still
  /// being sent is first sent out whole. docs/design.md §3.3, §7.6.
  void PublishSnapshot();
  /// Publishes the cells changed since the last delta or snapshot (a snapshot instead when they
  /// are more than three times config.map_message_max_bytes and none is being sent).
  void PublishDelta();
  /// True while a snapshot's chunks are still being sent.
  [[nodiscard]] bool snapshot_in_flight() const { return !outgoing_chunks_.empty(); }
  void PublishStatus();
  /// Saves the checkpoint (if configured), after publishing the decisions it holds. Returns
  /// false (logged) on failure.
  bool SaveCheckpoint();
  /// Publishes the decisions taken since the last call (and appends them to decisions_log). Also
  /// called by PublishDue (every 0.1 s of the node's clock, or 64 decisions) and SaveCheckpoint;
  /// call it at exit.
  void PublishDecisions();

  /// Takes no decision of its own from now on: applies `decisions` (a recorded history, in
  /// order), each once its scan has arrived: an applied one with its ray stride and pose, a
  /// skipped one counted under its reason. Scans no decision names are not applied (counted as
  /// "not_applied_live"). Poses are not used. docs/design.md §3.6.
  void FollowDecisions(std::vector<map_decision_t> decisions);
  /// The decisions not followed yet (at the end of the input: their scans never came).
  [[nodiscard]] const std::deque<map_decision_t>& decisions_to_follow() const { return to_follow_; }
  /// Decisions this node took (or followed) since it started.
  [[nodiscard]] int64_t decisions_taken() const { return decision_count_; }
  /// The mapper lives whose decisions the map held at start (a resumed checkpoint): epoch and
  /// how many of its decisions, in order (empty: an empty map).
  [[nodiscard]] const std::vector<EpochSequence>& resumed_lives() const { return lives_; }

  /// Hands one recorded message (a log's event, in log order) to the node as if received, then
  /// applies what it can: a log fed this way gives the map of a mapper that received it live and
  /// kept up (docs/design.md §3.6, §7.3).
  void HandleRecorded(const std::string& channel, const void* data, size_t size);

  /// Catching up from the run's log (docs/design.md §3.6). BeginCatchUp() holds the live input
  /// aside, raw; the log is then fed through FeedCatchUp() from its start, in order (messages in
  /// the checkpoint are skipped as already applied); once catch_up_overlaps() (the log has
  /// reached a held live message) and the log's end is read, EndCatchUp() handles the held
  /// messages the log did not also hold, and live input flows again.
  void BeginCatchUp();
  void FeedCatchUp(const std::string& channel, const void* data, size_t size);
  [[nodiscard]] bool catch_up_overlaps() const { return catch_up_overlap_; }
  struct CatchUpResult {
    int64_t fed{0};       ///< log events fed
    int64_t held{0};      ///< live messages held meanwhile
    int64_t repeated{0};  ///< held messages the log also held (not handled twice)
    bool overlapped{false};
  };
  CatchUpResult EndCatchUp();

  /// A scan as the map received it: the sensor's pose (the vehicle's pose at the scan's stamp
  /// minus the sensor's stamp_offset_s, times its calibrated mount) and its readings, exactly as
  /// applied (after any ray decimation: every ray_stride-th pixel or beam, intrinsics and angle
  /// step scaled).
  struct AppliedScan {
    int64_t utime{0};       ///< the scan's stamp, us
    int64_t pose_utime{0};  ///< where its pose was interpolated: utime - stamp_offset_s, us
    size_t sensor{0};       ///< index into config.sensors
    size_t vehicle{0};      ///< index into config.vehicle_prefixes
    Pose3 X_WS;
    const SensorModel* model{nullptr};
    // A depth image: width x height counts, row-major, and its intrinsics.
    const uint16_t* depth_counts{nullptr};
    int width{0}, height{0};
    double depth_scale_m{0.0};
    DepthIntrinsics intrinsics;
    // A planar scan.
    const float* ranges_m{nullptr};
    int num_ranges{0};
    double angle_min_rad{0.0}, angle_step_rad{0.0};
    /// The scan's rays as the integrator casts them (mapping/scan_integrator.h).
    [[nodiscard]] std::vector<SensorRay> Rays() const;
  };
  /// Called after each scan is applied to the map (benchmarks and calibration feed the same
  /// scans to other consumers: tools/fidelity). Empty: none.
  void SetScanObserver(std::function<void(const AppliedScan&)> observer) {
    scan_observer_ = std::move(observer);
  }
  /// Called with every pose the node keeps for pairing (vehicle index, stamp in us, X_WB), in
  /// arrival order (the sensor calibration interpolates in the same poses: tools/fidelity).
  void SetPoseObserver(std::function<void(size_t, int64_t, const Pose3&)> observer) {
    pose_observer_ = std::move(observer);
  }

  [[nodiscard]] double entropy_nats() const;
  /// FNV-1a hash of the map cells (bit-exact comparisons).
  [[nodiscard]] uint64_t map_hash() const;
  [[nodiscard]] int64_t map_seq() const { return map_seq_; }
  [[nodiscard]] int64_t scans_applied() const { return scans_applied_; }
  /// Depth frames whose every pixel read 0 (a covered lens; docs/algorithms.md §3.4).
  [[nodiscard]] int64_t all_zero_frames() const { return all_zero_frames_; }
  [[nodiscard]] const DropCounter& skipped() const { return skipped_; }
  [[nodiscard]] size_t queue_depth() const { return queue_.size(); }
  /// True while no input has been skipped for a reason other than "already in the checkpoint",
  /// and no ray was decimated.
  [[nodiscard]] bool applied_every_message() const;
  /// Per input channel, the last applied sequence number of every publisher epoch.
  [[nodiscard]] const StreamSequences& sequences() const { return sequences_; }
  /// The run this mapper maps (config.run_id, or the fresh id made at start).
  [[nodiscard]] const std::string& run_id() const { return run_id_; }
  /// True if the map was resumed from the checkpoint.
  [[nodiscard]] bool resumed() const { return resumed_; }
  /// This mapper's publisher epoch, stamped on its messages (common/identity.h).
  [[nodiscard]] int64_t epoch() const { return epoch_; }
  /// Input channels on which a new publisher epoch appeared after another had been applied.
  [[nodiscard]] int64_t publisher_restarts() const { return publisher_restarts_; }
  /// P of a cell no scan has touched (the prior: P_init for the exact model).
  [[nodiscard]] double PriorProbability() const;
  /// Probability of a cell.
  [[nodiscard]] double ProbabilityAt(const CellIndex& cell) const;
  /// Saves the map to `path` (Kestrel map file, with the stream positions but no run id: a saved
  /// map is not a checkpoint) / exports OctoMap .bt/.ot / PLY.
  void SaveMapFile(const std::string& path) const;
  void ExportOctoMapFile(const std::string& path) const;
  size_t ExportPlyFile(const std::string& path) const;
  /// The grid geometry (origin, resolution, bounds).
  [[nodiscard]] const GridGeometry& geometry() const;

 private:
  struct Pending {
    int64_t utime;
    int64_t seq;
    int64_t epoch;
    size_t sensor;   // index into config_.sensors
    size_t vehicle;  // index into config_.vehicle_prefixes (and poses_)
    std::string channel;
    std::shared_ptr<const depth_image_t> depth;  // metadata; its pixels decoded in `counts`
    std::shared_ptr<const std::vector<uint16_t>> counts;
    std::shared_ptr<const planar_scan_t> scan;
    /// The message as received, kept only to be written to decisions_log when applied.
    std::shared_ptr<const std::vector<uint8_t>> raw;
  };
  using MapPtr =
      std::variant<std::unique_ptr<DenseOccupancyMap>, std::unique_ptr<GrowingOccupancyMap>>;

  void OnPose(size_t vehicle, const pose_t& msg);
  void OnDepth(size_t sensor, size_t vehicle, const std::string& channel, const depth_image_t& msg);
  void OnScan(size_t sensor, size_t vehicle, const std::string& channel, const planar_scan_t& msg);
  void Enqueue(Pending p);
  bool AlreadyApplied(const std::string& channel, int64_t epoch, int64_t seq);
  // The same message is waiting in the queue (a message both logged and received live).
  bool AlreadyQueued(const std::string& channel, int64_t epoch, int64_t seq);
  // Counts the messages of (channel, epoch) that never arrived: a seq above the last one seen
  // plus one (lost between the publisher and this node: the network, a full queue).
  void NoteArrival(const std::string& channel, int64_t epoch, int64_t seq);
  // Records (channel, epoch, seq) as applied or skipped for good; logs a new epoch once.
  void Record(const Pending& p);
  void Skip(const Pending& p, const std::string& reason, const std::string& detail);
  void Apply(const Pending& p, const Pose3& X_WB, int64_t pose_utime);
  // Records a decision (Apply, Skip) for PublishDecisions.
  void Decide(const Pending& p, int8_t action, const std::string& reason, const Pose3& X_WB);
  // Follows the recorded decisions as far as their scans have come (FollowDecisions).
  int FollowPending();
  // The encoded message, for decisions_log (nullptr when there is none).
  template <class Message>
  [[nodiscard]] std::shared_ptr<const std::vector<uint8_t>> RawForLog(const Message& msg) const;
  // Appends one event to decisions_log (flushed if asked); closes it on a write failure.
  void WriteDecisionsLog(const std::string& channel, const std::vector<uint8_t>& bytes,
                         int64_t utime, bool flush);
  void CreateEmptyMap();
  void LoadCheckpoint();
  // Moves a corrupt checkpoint to <path>.corrupt and starts an empty map.
  void RefuseCheckpoint(const std::string& why);
  // The integrator into map_ (after map_ was made or loaded).
  void CreateIntegrator();
  /// Calls f(block_origin_cell, probabilities[512]) for every block holding any observed cell.
  template <class F>
  void ForEachBlock(F&& f) const;
  // Sends the next paced chunk if it is due at `now` (one per call).
  void SendDueChunk(int64_t now);
  // Changed cells a delta may hold (map_message_max_bytes).
  [[nodiscard]] size_t MaxDeltaCells() const;
  [[nodiscard]] size_t ChangedCellCount() const;

  lcm::LCM& lcm_;
  MapperConfig config_;
  std::function<void(const AppliedScan&)> scan_observer_;
  std::function<void(size_t, int64_t, const Pose3&)> pose_observer_;
  const Clock& clock_;
  int64_t epoch_;       // this publisher's epoch
  std::string run_id_;  // config_.run_id or a fresh one
  bool resumed_{false};
  int64_t publisher_restarts_{0};
  std::vector<SensorModel> models_;
  std::vector<Pose3> mounts_;              // by sensor: CalibratedMount()
  std::vector<int64_t> stamp_offsets_us_;  // by sensor: stamp_offset_s
  MapPtr map_;
  std::unique_ptr<ScanIntegrator> integrator_;  // into map_
  std::vector<PoseHistory> poses_;              // by vehicle
  std::vector<int64_t> vehicle_latest_utime_;   // newest input stamp of each vehicle
  std::deque<Pending> queue_;
  std::map<std::pair<std::string, int64_t>, int64_t> last_seen_seq_;  // NoteArrival
  StreamSequences sequences_;
  DropCounter skipped_;
  DropCounter bad_poses_;
  Heartbeat heartbeat_;
  GuardedSubscriptions subscriptions_;

  int64_t map_seq_{0};
  int64_t delta_seq_{0};
  int64_t snapshot_id_{0};
  int64_t last_delta_map_seq_{0};
  int64_t status_seq_{0};
  int64_t scans_applied_{0};
  int64_t all_zero_frames_{0};
  std::map<std::string, int64_t> all_zero_streak_;  // per channel: frames of 0s in a row
  int64_t latest_input_utime_{0};
  // The newest stamp queued of each (vehicle, sensor) stream (order_wait_s).
  std::map<std::pair<size_t, size_t>, int64_t> stream_latest_utime_;
  // Catching up from the log (BeginCatchUp).
  struct Held {
    std::string channel;
    std::vector<uint8_t> data;
    uint64_t hash;
  };
  bool catching_up_{false};
  bool catch_up_overlap_{false};
  std::vector<Held> held_;
  std::unordered_set<uint64_t> held_hashes_;
  std::unordered_set<uint64_t> fed_since_overlap_;
  int64_t catch_up_fed_{0};
  // Whether every stream seen has passed `utime`, or the newest input is order_wait_s past it.
  [[nodiscard]] bool StreamsPassed(int64_t utime) const;
  bool input_ended_{false};  // ApplyRemaining: no stream waits
  int64_t newest_applied_utime_{0};
  int ray_stride_{1};
  bool decimated_ever_{false};
  // Decisions (docs/design.md §3.6).
  std::vector<EpochSequence> lives_;       // the resumed checkpoint's history of decisions
  std::vector<map_decision_t> decisions_;  // taken, not yet published
  int64_t decision_count_{0};              // taken by this life
  int64_t decisions_seq_{0};
  int64_t last_decisions_utime_{-1};
  std::unique_ptr<lcm::LogFile> decisions_log_;
  bool following_{false};
  std::deque<map_decision_t> to_follow_;
  using ScanKey = std::tuple<std::string, int64_t, int64_t>;  // channel, epoch, seq
  std::map<ScanKey, int> followed_keys_;  // applied decisions still to follow, by scan
  std::map<ScanKey, Pending> arrived_;    // their scans, once arrived
  uint64_t rays_total_{0};
  uint64_t cells_total_{0};
  uint64_t rays_at_last_status_{0};
  uint64_t cells_at_last_status_{0};
  int64_t last_status_utime_{-1};  // for the rates in MAP_STATUS
  int64_t status_due_utime_{-1};
  int64_t last_delta_utime_{-1};
  int64_t last_snapshot_utime_{-1};
  int64_t last_checkpoint_utime_{-1};
  std::deque<map3d_chunk_t> outgoing_chunks_;  // the snapshot being sent, encoded when taken
  int64_t next_chunk_utime_{-1};               // when the next one may go (pacing)
};

}  // namespace kestrel
