#pragma once
/// @file
/// kestrel-motors' node (docs/protocols.md §6, docs/design.md §2.6): turns the controller's
/// MOTOR_COMMAND into BL-Ctrl set points on an I2C bus (drivers/motors/i2c_bus.h).
///  - Arming only through the controller: a command with armed false, and anything before the
///    first armed command, writes set point 0 to every ESC.
///  - A command is written at once (latency), and the last one again every refresh period: a
///    BL-Ctrl stops its motor when its set points stop coming.
///  - Watchdog: no valid command for command_timeout_s sends zeros (state reported, logged) until
///    an armed command comes again. Its default equals the simulator's ESC hold (1.5 s) so that a
///    respawned controller takes a flying vehicle over in HOLD (docs/design.md §2.5).
///  - Bad input (malformed, wrong rotor count, a thrust that is not a finite number) is counted
///    by reason and dropped as if it had not come: NaN never reaches an ESC.
///  - A bus error stops the motors: zeros are tried at once, the bus is closed, the heartbeat
///    says FAULT, and the bus is reopened with back-off; the ESCs get zeros until an armed
///    command comes after the reopening. Opening at start is retried the same way.

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/heartbeat.h"
#include "common/lcm_decode.h"
#include "common/log.h"
#include "common/realtime.h"
#include "common/reopen_backoff.h"
#include "common/vehicle_config.h"
#include "drivers/motors/blctrl.h"
#include "drivers/motors/i2c_bus.h"
#include "kestrel/motor_command_t.hpp"

namespace kestrel {

class ConfigNode;

/// config/drivers/motors.yaml (LoadMotorsConfig).
struct MotorsConfig {
  std::string bus{"/dev/i2c-1"};      ///< "/dev/i2c-N" or "unix:PATH" (the ESC emulator)
  std::string protocol{"blctrl_v2"};  ///< blctrl_v1 | blctrl_v2
  std::vector<int> addresses{0x29, 0x2a, 0x2b, 0x2c};  ///< 7-bit ESC address of rotor 1..n
  std::string channel{"MOTOR_COMMAND"};                ///< in: motor_command_t
  std::string heartbeat_channel{"HEARTBEAT_MOTORS"};   ///< out
  double command_timeout_s{1.5};     ///< watchdog: zeros after this long without a command, s
  double refresh_hz{200.0};          ///< set points written again at this rate, Hz
  double status_hz{5.0};             ///< ESC status read at this rate (0: never), Hz
  double reopen_backoff_min_s{0.1};  ///< first delay before reopening the bus, s (doubles)
  double reopen_backoff_max_s{2.0};  ///< longest delay between reopen attempts, s
  double heartbeat_period_s{1.0};    ///< s
  RealtimeConfig realtime;           ///< the process's real-time settings

  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// Reads MotorsConfig (absent keys keep their defaults). @throws ConfigError naming the key.
[[nodiscard]] MotorsConfig LoadMotorsConfig(const ConfigNode& root);

/// Opens a bus from its configuration string (OpenI2cBus); replaced in tests.
using I2cBusOpener = std::function<std::unique_ptr<I2cBus>(const std::string& spec)>;

class MotorsNode {
 public:
  /// Subscribes to the command channel; the bus is opened at the first Refresh.
  /// @throws std::invalid_argument for an invalid config or a rotor count != the addresses'.
  MotorsNode(lcm::LCM& lcm, const MotorsConfig& config, const EscMap& map, const Clock& clock,
             I2cBusOpener open_bus = OpenI2cBus);
  MotorsNode(const MotorsNode&) = delete;
  MotorsNode& operator=(const MotorsNode&) = delete;
  /// Writes zeros on the way out (the motors stop with the driver).
  ~MotorsNode();

  /// The refresh step (every 1 / refresh_hz): opens the bus when due, applies the watchdog,
  /// writes the set points, and reads the ESCs' status when due.
  void Refresh();
  /// Refreshes the heartbeat's values and publishes it.
  void PublishHeartbeat();

  /// The set points last written (0 before any), rotor 1..n.
  [[nodiscard]] const std::vector<int>& set_points() const { return set_points_; }
  [[nodiscard]] bool armed() const { return armed_; }
  [[nodiscard]] bool watchdog_tripped() const { return watchdog_tripped_; }
  [[nodiscard]] bool bus_open() const { return bus_ != nullptr; }
  [[nodiscard]] const DropCounter& drops() const { return drops_; }
  [[nodiscard]] int64_t writes() const { return writes_; }
  [[nodiscard]] int64_t bus_errors() const { return bus_errors_; }
  [[nodiscard]] int64_t watchdog_trips() const { return watchdog_trips_; }
  /// The ESCs' last status (rotor 1..n; zeros before any read).
  [[nodiscard]] const std::vector<BlCtrlStatus>& esc_status() const { return status_; }
  /// Time from a command's stamp to the end of its bus write, us (commands written at once).
  [[nodiscard]] const LoopTiming& command_to_write() const { return command_to_write_; }

 private:
  void OnCommand(const motor_command_t& msg);
  bool Write(const std::vector<int>& set_points);
  void BusFailed(const std::string& error);

  lcm::LCM& lcm_;
  MotorsConfig config_;
  EscMap map_;
  BlCtrlVersion version_;
  const Clock& clock_;
  I2cBusOpener open_bus_;
  std::unique_ptr<I2cBus> bus_;
  Heartbeat heartbeat_;
  DropCounter drops_;
  GuardedSubscriptions subscriptions_;
  std::vector<int> set_points_;
  std::vector<double> thrust_N_;  // the last valid command's thrusts
  std::vector<BlCtrlStatus> status_;
  bool armed_{false};
  bool ever_armed_since_open_{false};
  bool watchdog_tripped_{false};
  bool fault_{false};
  int64_t last_command_utime_{-1};  // host time the last valid command arrived
  ReopenBackoff reopen_;
  int64_t next_status_utime_{0};
  int64_t commands_{0}, writes_{0}, bus_errors_{0}, watchdog_trips_{0}, reopens_{0};
  std::string last_error_;
  LoopTiming command_to_write_;
};

}  // namespace kestrel
