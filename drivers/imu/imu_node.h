#pragma once
/// @file
/// kestrel-imu's node: a VN-100 on a serial port (docs/protocols.md §7) to imu_t on IMU.
/// Opens the port, turns the ASCII output off (register 06), asks for binary output 1 (register
/// 75: the common group's TimeStartup, AngularRate, Accel every rate_divisor samples of the 800 Hz
/// base), checking each echo (reply_timeout_s, command_retries), then decodes frames and publishes
/// each sample in Kestrel's body frame. Stamps: the device's TimeStartup mapped to host time by
/// the smallest (arrival - device time) over the last clock_window_s (MinimumLatencyClock), so the
/// stamps keep the device's regular spacing, not the USB arrival jitter; a device clock that goes
/// back (a power cycle) restarts the mapping. A hang-up, a missing device, no frame for
/// frame_timeout_s or a refused configuration closes the port; it is reopened with back-off.
/// Every frame or byte dropped is counted by reason (heartbeat dropped.<reason>).
/// Single-threaded: Poll() waits on the port; the caller handles LCM in between.

#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <utility>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/heartbeat.h"
#include "common/log.h"
#include "common/realtime.h"
#include "common/reopen_backoff.h"
#include "drivers/imu/vn100.h"
#include "drivers/serial/serial_port.h"

namespace kestrel {

class ConfigNode;

/// config/drivers/imu.yaml (LoadImuConfig).
struct ImuConfig {
  std::string port{"/dev/ttyUSB0"};  ///< serial device (prefer /dev/serial/by-id/...)
  int baud{921600};                  ///< termios rate the device is set to
  int async_mode{1};                 ///< binary output on serial port 1 (1), 2 (2) or both (3)
  int rate_divisor{2};               ///< output rate = 800 Hz / rate_divisor
  std::string channel{"IMU"};        ///< out: imu_t
  std::string sensor_name{"imu"};    ///< imu_t.sensor_name
  std::string heartbeat_channel{"HEARTBEAT_IMU"};
  double reply_timeout_s{0.2};       ///< wait for a command's echo, s
  int command_retries{2};            ///< retries before the port is reopened
  double frame_timeout_s{0.2};       ///< no frame this long while streaming: reopen, s
  double reopen_backoff_min_s{0.1};  ///< first delay before reopening, s (doubles per failure)
  double reopen_backoff_max_s{2.0};  ///< longest delay between reopen attempts, s
  double clock_window_s{2.0};        ///< the minimum-latency window of the clock mapping, s
  double heartbeat_period_s{1.0};    ///< s
  RealtimeConfig realtime;           ///< the process's real-time settings

  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// @throws ConfigError naming the key.
[[nodiscard]] ImuConfig LoadImuConfig(const ConfigNode& root);

/// Device time to host time: host = device + min over the window of (arrival - device). Pure.
class MinimumLatencyClock {
 public:
  explicit MinimumLatencyClock(int64_t window_us) : window_us_(window_us) {}
  /// One sample of device time device_us that arrived at host time arrival_utime; returns its
  /// host stamp, always later than the previous one's (by 1 us where the minimum has just fallen
  /// by more than the sample spacing). A device time earlier than the last one restarts the
  /// mapping (counted).
  int64_t Stamp(int64_t device_us, int64_t arrival_utime);
  void Reset() {
    samples_.clear();
    last_stamp_utime_ = 0;
  }
  [[nodiscard]] int64_t restarts() const { return restarts_; }
  /// The offset in use, us (host - device; 0 before any sample).
  [[nodiscard]] int64_t offset_us() const { return samples_.empty() ? 0 : samples_.front().second; }

 private:
  int64_t window_us_;
  std::deque<std::pair<int64_t, int64_t>> samples_;  // (device_us, arrival - device), minima
  int64_t last_device_us_{-1};
  int64_t last_stamp_utime_{0};
  int64_t restarts_{0};
};

class ImuNode {
 public:
  /// @throws std::invalid_argument if config.Validate() does. Does not open the port yet.
  ImuNode(lcm::LCM& lcm, const ImuConfig& config, const Clock& clock);
  ImuNode(const ImuNode&) = delete;
  ImuNode& operator=(const ImuNode&) = delete;

  /// One step: opens the port when due, configures it, waits at most timeout_ms for bytes,
  /// publishes the samples decoded, and closes the port when it must be reopened.
  void Poll(int timeout_ms);
  /// Refreshes the heartbeat's values and publishes it.
  void PublishHeartbeat();

  [[nodiscard]] bool streaming() const { return state_ == State::kStreaming; }
  [[nodiscard]] int64_t published() const { return published_; }
  [[nodiscard]] int64_t opens() const { return opens_; }
  [[nodiscard]] const DropCounter& drops() const { return drops_; }
  [[nodiscard]] const MinimumLatencyClock& clock_mapping() const { return mapping_; }
  /// Time from a sample's device-time stamp to its publication, us.
  [[nodiscard]] const LoopTiming& sample_to_publish() const { return sample_to_publish_; }

 private:
  enum class State { kClosed, kAsciiOff, kBinaryOutput, kStreaming };
  void Close(const std::string& why);
  void SendCommand();
  void Handle(const Vn100Message& m, int64_t arrival_utime);
  void CountParserDrops();

  lcm::LCM& lcm_;
  ImuConfig config_;
  const Clock& clock_;
  Heartbeat heartbeat_;
  DropCounter drops_;
  std::unique_ptr<SerialPort> port_;
  Vn100Parser parser_;
  std::map<std::string, int64_t> parser_drops_seen_;
  MinimumLatencyClock mapping_;
  State state_{State::kClosed};
  std::string expected_echo_;
  int64_t command_deadline_utime_{0};
  int retries_left_{0};
  int64_t last_frame_utime_{0};
  ReopenBackoff reopen_;
  int64_t epoch_;
  int64_t seq_{0};
  int64_t published_{0};
  int64_t opens_{0};
  std::string last_error_;
  LoopTiming sample_to_publish_;
};

}  // namespace kestrel
