#pragma once
/// @file
/// The pure core of kestrel-vicon: datagrams (with their host receive time) in, pose_t messages
/// out. No socket, no clock, no LCM: the node feeds it and publishes what it returns.
///
/// Behaviour (docs/protocols.md §3.3, docs/design.md §2.4):
/// - Each configured object seen in an accepted frame gives one pose_t: position in m (mm / 1000),
///   orientation from the Euler angles (vicon_packet.h), utime = receive time - latency_s,
///   valid = true, has_velocity = false (filtering is the controller estimator's job).
/// - Frame numbers (u32, compared modulo 2^32): a repeat of the last frame is ignored; a forward
///   step of d > 1 counts d - 1 dropped frames (d - 1 > max_frame_gap: a stream restart instead);
///   a step back of at most reorder_window_frames is a late datagram and is ignored; a larger step
///   back is a Tracker restart and is accepted.
/// - An object not seen for longer than timeout_s becomes invalid: a pose_t with valid = false,
///   zero position and identity orientation is published at once and then every
///   invalid_repeat_period_s, never its last pose. Objects never seen are invalid from the start.
/// - Malformed datagrams are rejected with the parser's reason and counted by kind.

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "drivers/vicon/vicon_config.h"
#include "drivers/vicon/vicon_packet.h"
#include "kestrel/pose_t.hpp"

namespace kestrel {

/// Counters since start (all monotonic).
struct ViconBridgeStats {
  int64_t datagrams{0};  ///< datagrams handed to the bridge
  int64_t malformed{0};  ///< rejected by the parser (by kind in malformed_by_kind)
  std::map<std::string, int64_t> malformed_by_kind;  ///< ViconPacketErrorName -> count
  int64_t frames_accepted{0};                        ///< frames whose objects were used
  int64_t frames_dropped{0};                         ///< frame numbers skipped by the stream (gaps)
  int64_t frames_repeated{0};                        ///< repeats of the last frame number, ignored
  int64_t frames_late{0};           ///< older frames within the reorder window, ignored
  int64_t stream_restarts{0};       ///< frame counter discontinuities accepted as restarts
  int64_t occluded{0};              ///< configured objects sent with an all-zero pose
  int64_t unconfigured_objects{0};  ///< object items whose name is not configured
  int64_t poses_published{0};       ///< valid pose_t returned
  int64_t invalid_published{0};     ///< invalid pose_t returned
  int64_t timeouts{0};              ///< valid -> invalid transitions
};

/// One message for the node to publish.
struct ViconPoseOutput {
  std::string channel;  ///< the object's configured channel
  pose_t pose;          ///< the message, stamped and sequenced
};

class ViconBridge {
 public:
  /// @throws std::invalid_argument if config.Validate() throws.
  explicit ViconBridge(const ViconConfig& config);

  /// Handles one datagram received at `receive_utime` (host clock, us). Appends the poses to
  /// publish to *out. Returns kNone when the datagram was well formed (even if it was then ignored
  /// as a repeat or late frame), else the parser's error with *reason set.
  ViconPacketError HandleDatagram(const uint8_t* data, size_t size, int64_t receive_utime,
                                  std::vector<ViconPoseOutput>* out, std::string* reason);

  /// Applies the time-out at `now_utime` (us): appends invalid pose_t for objects that just timed
  /// out, and repeats them for objects still invalid when invalid_repeat_period_s has passed.
  void CheckTimeouts(int64_t now_utime, std::vector<ViconPoseOutput>* out);

  /// Counters since construction.
  [[nodiscard]] const ViconBridgeStats& stats() const { return stats_; }
  /// Number of configured objects.
  [[nodiscard]] size_t num_objects() const { return objects_.size(); }
  /// Whether configured object i (config order) is currently valid.
  [[nodiscard]] bool object_valid(size_t i) const { return objects_.at(i).valid; }
  /// Number of configured objects currently valid.
  [[nodiscard]] int num_valid() const;

 private:
  struct ObjectState {
    ViconObjectConfig config;
    bool valid{false};
    int64_t last_seen_utime{-1};
    int64_t last_invalid_utime{-1};
    int64_t seq{0};
  };
  /// Classifies the frame number; returns true when the frame is to be used.
  bool AcceptFrameNumber(uint32_t frame_number);
  pose_t MakePose(ObjectState* state, int64_t utime) const;

  ViconConfig config_;
  ViconParseOptions parse_options_;
  ViconEulerOrder euler_order_;
  int64_t latency_us_;
  int64_t timeout_us_;
  int64_t invalid_repeat_us_;
  std::vector<ObjectState> objects_;
  std::map<std::string, size_t> index_by_name_;
  bool have_frame_{false};
  uint32_t last_frame_{0};
  ViconFrame frame_;  // reused per datagram
  ViconBridgeStats stats_;
};

}  // namespace kestrel
