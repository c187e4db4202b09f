#pragma once
/// @file
/// The Hokuyo driver as a state machine over a byte stream: no I/O and no clock of its own, so
/// the node feeds it bytes and times and writes what it asks, and tests can drive it directly.
///
/// Start-up, as the mature drivers (urg_node, hokuyo_node) do it (docs/protocols.md §1.4):
///  1. "SCIP2.0": probe; switches a URG-04LX out of SCIP 1.1 ("0"), "0E" if already in 2.0;
///  2. "TM2": leave a time-adjust mode a previous session left on ("03": was not on);
///  3. "QT": stop a stream left running (its scans are skipped until the QT echo arrives);
///  4. "PP": model, DMIN/DMAX, ARES, AMIN/AMAX, AFRT, SCAN (checked against `profile`);
///  5. "VV": vendor, product, firmware, serial;
///  6. "TM0", N x "TM1", "TM2": the clock offset (HokuyoClockModel);
///  7. "MD" (or "ME" with intensities) with unlimited scans; then each "99" reply is a scan.
/// Replies are matched to the pending command by their echo; anything else is skipped.
/// A command without reply is retried, then the driver asks for the port to be reopened, as it
/// does when no scan arrives for scan_timeout_s or the stream reports an error status.

#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "drivers/hokuyo/hokuyo_clock.h"
#include "drivers/hokuyo/hokuyo_config.h"
#include "drivers/hokuyo/hokuyo_model.h"
#include "drivers/hokuyo/scip_codec.h"

namespace kestrel {

/// One scan converted to the planar_scan_t conventions.
struct HokuyoScan {
  int64_t utime{0};                 ///< host time of the first step, us
  uint32_t sensor_timestamp_ms{0};  ///< the raw 24-bit stamp
  int64_t sensor_time_ms{0};        ///< the stamp unwrapped
  int64_t receive_utime{0};         ///< host time the reply was read, us
  float angle_min_rad{0.0f};        ///< angle of the first step, (s - AFRT) * 2 pi / ARES
  float angle_step_rad{0.0f};       ///< 2 pi / ARES
  float time_step_s{0.0f};          ///< (60 / SCAN) / ARES
  float range_min_m{0.0f};          ///< DMIN
  float range_max_m{0.0f};          ///< DMAX
  std::vector<float> ranges_m;      ///< > 0 return, 0 no return, NaN invalid
  std::vector<float> intensities;   ///< ME only
};

/// A counted problem, for the node's DropCounter (kind, reason).
struct HokuyoDriverEvent {
  std::string kind;
  std::string reason;
};

class HokuyoDriver {
 public:
  enum class State {
    kIdle,                        ///< not started (port closed)
    kProbing,                     ///< SCIP2.0 sent
    kLeavingTimeAdjust,           ///< TM2 sent
    kStoppingStream,              ///< QT sent
    kReadingParameters,           ///< PP sent
    kReadingVersion,              ///< VV sent
    kEnteringTimeAdjust,          ///< TM0 sent
    kSyncingClock,                ///< TM1 sent
    kLeavingTimeAdjustAfterSync,  ///< TM2 sent
    kStartingStream,              ///< MD/ME sent
    kStreaming,                   ///< scans arriving
  };

  /// @throws ConfigError if config.Validate() does.
  explicit HokuyoDriver(const HokuyoConfig& config);

  /// The port was (re)opened at now_utime: restarts the start-up sequence.
  void Start(int64_t now_utime);
  /// The port was closed (the driver waits for Start()).
  void Stop();
  /// Bytes read at now_utime.
  void OnBytes(std::string_view bytes, int64_t now_utime);
  /// The output last taken was written, starting at write_start_utime (the TM1 send time: the
  /// sensor cannot have read its clock for the reply before that).
  void OnWritten(int64_t write_start_utime);
  /// Checks time-outs.
  void OnTick(int64_t now_utime);

  /// Bytes to write now (taken: a second call returns "").
  [[nodiscard]] std::string TakeOutput();
  /// Scans decoded since the last call.
  [[nodiscard]] std::vector<HokuyoScan> TakeScans();
  /// Problems counted since the last call.
  [[nodiscard]] std::vector<HokuyoDriverEvent> TakeEvents();

  /// True once the driver wants the port closed and reopened (cleared by Start()).
  [[nodiscard]] bool needs_reopen() const { return needs_reopen_; }
  [[nodiscard]] const std::string& reopen_reason() const { return reopen_reason_; }
  [[nodiscard]] State state() const { return state_; }
  /// The next time OnTick has something to check, us (INT64_MAX if none).
  [[nodiscard]] int64_t next_deadline_utime() const;
  /// PP values of the connected sensor (valid from kReadingVersion on).
  [[nodiscard]] const HokuyoModel& model() const { return model_; }
  /// VV values of the connected sensor.
  [[nodiscard]] const std::map<std::string, std::string>& version() const { return version_; }
  [[nodiscard]] const HokuyoClockModel& clock() const { return clock_; }
  /// The streaming command sent (e.g. "MD0044072501000").
  [[nodiscard]] const std::string& stream_command() const { return stream_command_; }
  [[nodiscard]] int64_t scans_decoded() const { return scans_decoded_; }
  [[nodiscard]] int64_t skipped_replies() const { return skipped_replies_; }

 private:
  void Send(const std::string& command, int64_t now_utime);
  void Resend(int64_t now_utime);
  void RequestReopen(const std::string& reason);
  void Count(const std::string& kind, const std::string& reason);
  void HandleReply(const scip::Reply& reply, int64_t now_utime);
  void HandlePendingReply(const scip::Reply& reply, int64_t now_utime);
  void HandleScan(const scip::Reply& reply, int64_t now_utime);
  bool ReadParameters(const scip::Reply& reply);
  [[nodiscard]] bool MatchesPending(const scip::Reply& reply) const;

  HokuyoConfig config_;
  State state_{State::kIdle};
  scip::ReplyParser parser_;
  SensorClockUnwrapper unwrapper_;
  HokuyoClockModel clock_;
  HokuyoModel model_;
  std::map<std::string, std::string> version_;
  std::string output_;
  std::vector<HokuyoScan> scans_;
  std::vector<HokuyoDriverEvent> events_;

  std::string pending_;  // command text awaiting its reply ("" if none)
  int64_t pending_send_utime_{0};
  int64_t deadline_utime_{0};
  int attempts_{0};
  int sync_samples_{0};
  int64_t next_sync_utime_{-1};  // kSyncingClock: when to send the next TM1 (-1: none due)
  int first_step_{0};
  int last_step_{0};
  std::string stream_command_;
  int64_t last_scan_utime_{0};
  bool needs_reopen_{false};
  std::string reopen_reason_;
  int64_t scans_decoded_{0};
  int64_t skipped_replies_{0};
};

/// "probing", "streaming", ...
[[nodiscard]] const char* ToString(HokuyoDriver::State state);

}  // namespace kestrel
