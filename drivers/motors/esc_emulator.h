#pragma once
/// @file
/// BL-Ctrl ESCs emulated byte for byte (docs/protocols.md §6.5), the devices' side of an
/// I2cSocketServer: set-point writes at the configured addresses are decoded as the ESCs decode
/// them, a read returns the status bytes, any other address is a NACK. Each ESC stops its motor
/// when its set points stop for esc_timeout_s, as the real ones do. The rotor thrusts follow the
/// vehicle's ESC map, so a simulator fed with them flies on what the ESCs received.

#include <cstdint>
#include <vector>

#include "common/vehicle_config.h"
#include "drivers/motors/blctrl.h"
#include "drivers/motors/i2c_bus.h"

namespace kestrel {

class EscEmulator {
 public:
  /// `addresses`: rotor 1..n's 7-bit addresses.
  EscEmulator(BlCtrlVersion version, std::vector<int> addresses, const EscMap& map,
              double esc_timeout_s);
  /// One message of a transfer at host time now_utime (I2cSocketServer::Device); false: NACK
  /// (no ESC at that address, or a write of the wrong length, which the ESC ignores).
  bool Handle(I2cMessage& message, int64_t now_utime);
  /// Applies the ESCs' own time-out at now_utime; true if a motor stopped because of it.
  bool ApplyTimeout(int64_t now_utime);
  /// The set points in force, rotor 1..n.
  [[nodiscard]] const std::vector<int>& set_points() const { return set_points_; }
  /// The rotor thrusts they give, N.
  [[nodiscard]] std::vector<double> thrust_N() const;
  /// True once every ESC has had a set point since the last call (a whole refresh arrived).
  bool TakeCompleteRefresh();
  /// Writes refused (a wrong length or lower bits beyond three), and reads answered.
  [[nodiscard]] int64_t malformed_writes() const { return malformed_writes_; }
  [[nodiscard]] int64_t reads() const { return reads_; }

 private:
  BlCtrlVersion version_;
  std::vector<int> addresses_;
  EscMap map_;
  int64_t timeout_us_;
  std::vector<int> set_points_;
  std::vector<int64_t> last_write_utime_;
  std::vector<bool> written_;
  int64_t malformed_writes_{0};
  int64_t reads_{0};
};

}  // namespace kestrel
