#pragma once
/// @file
/// kestrel-hokuyo's node: owns the serial port, feeds the HokuyoDriver state machine, publishes
/// kestrel planar_scan_t on SCAN_HOKUYO and the heartbeat on HEARTBEAT_HOKUYO. Reopens the port
/// with exponential back-off after a hang-up (EIO/POLLHUP), a missing device, or when the
/// driver asks (no reply, no scan, stream error). Every problem is counted in a DropCounter
/// and reported in the heartbeat. Single-threaded: Poll() waits on the port, and the caller
/// (Run, or a test) handles LCM in between.

#include <cstdint>
#include <memory>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/heartbeat.h"
#include "common/log.h"
#include "common/node_loop.h"
#include "drivers/hokuyo/hokuyo_config.h"
#include "drivers/hokuyo/hokuyo_driver.h"
#include "drivers/serial/serial_port.h"

namespace kestrel {

class HokuyoNode {
 public:
  /// @throws ConfigError if config.Validate() does. Does not open the port yet.
  HokuyoNode(lcm::LCM& lcm, const HokuyoConfig& config, Clock& clock);
  HokuyoNode(const HokuyoNode&) = delete;
  HokuyoNode& operator=(const HokuyoNode&) = delete;

  /// One step: opens the port when due, waits at most timeout_ms for bytes, feeds the driver,
  /// writes its commands, publishes its scans, and closes the port when it must be reopened.
  void Poll(int timeout_ms);
  /// Refreshes the heartbeat's values and publishes it.
  void PublishHeartbeat();
  /// Runs until SIGINT/SIGTERM: Poll (10 ms), LCM and the heartbeat timer; sends QT on the way
  /// out (laser off) and runs the loop's shutdown hooks (a last heartbeat, STATE_STOPPING).
  int Run(NodeLoop& loop);

  [[nodiscard]] const HokuyoDriver& driver() const { return driver_; }
  [[nodiscard]] bool port_open() const { return port_ != nullptr; }
  [[nodiscard]] int64_t scans_published() const { return scans_published_; }
  /// Successful opens of the port (the first included).
  [[nodiscard]] int64_t opens() const { return opens_; }
  [[nodiscard]] const DropCounter& drops() const { return drops_; }
  /// The publisher epoch stamped on every scan (common/identity.h).
  [[nodiscard]] int64_t epoch() const { return epoch_; }

 private:
  void TryOpen(int64_t now_utime);
  void Close(const std::string& reason, int64_t now_utime);
  void WriteOutput();
  void PublishScans();
  void CollectEvents();

  lcm::LCM& lcm_;
  HokuyoConfig config_;
  Clock& clock_;
  HokuyoDriver driver_;
  Heartbeat heartbeat_;
  DropCounter drops_;
  std::unique_ptr<SerialPort> port_;
  int64_t next_open_utime_{0};
  double backoff_s_;
  int64_t opens_{0};
  int64_t scans_published_{0};
  int64_t epoch_;
  int64_t seq_{0};
  int64_t rate_window_start_utime_{0};
  int64_t rate_window_scans_{0};
  double scan_rate_hz_{0.0};
  std::string last_error_;
};

}  // namespace kestrel
