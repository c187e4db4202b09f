#include "drivers/motors/esc_emulator.h"

#include <algorithm>

#include "common/clock.h"

namespace kestrel {

EscEmulator::EscEmulator(BlCtrlVersion version, std::vector<int> addresses, const EscMap& map,
                         double esc_timeout_s)
    : version_(version),
      addresses_(std::move(addresses)),
      map_(map),
      timeout_us_(SecondsToUtime(esc_timeout_s)),
      set_points_(addresses_.size(), 0),
      last_write_utime_(addresses_.size(), -1),
      written_(addresses_.size(), false) {}

bool EscEmulator::Handle(I2cMessage& message, int64_t now_utime) {
  const auto it = std::find(addresses_.begin(), addresses_.end(), message.address);
  if (it == addresses_.end()) return false;
  const auto i = static_cast<size_t>(it - addresses_.begin());
  if (message.read) {
    // Current grows with the square root of thrust in a real rotor too; this is a plausible
    // figure for the heartbeat, not a motor model: 1 A per N of thrust.
    BlCtrlStatus status;
    status.current_A = BlCtrlSetPointToThrust(map_, version_, set_points_[i]);
    status.max_pwm = 255;
    status.temperature_C = 30;
    const std::vector<uint8_t> bytes = EncodeBlCtrlStatus(status);
    for (size_t k = 0; k < message.data.size(); ++k) message.data[k] = k < 3 ? bytes[k] : 0;
    ++reads_;
    return true;
  }
  const auto set_point = DecodeBlCtrlSetPoint(version_, message.data);
  if (!set_point.has_value()) {
    ++malformed_writes_;
    return false;
  }
  set_points_[i] = *set_point;
  last_write_utime_[i] = now_utime;
  written_[i] = true;
  return true;
}

bool EscEmulator::ApplyTimeout(int64_t now_utime) {
  bool stopped = false;
  for (size_t i = 0; i < set_points_.size(); ++i) {
    if (set_points_[i] != 0 && now_utime - last_write_utime_[i] > timeout_us_) {
      set_points_[i] = 0;
      stopped = true;
    }
  }
  return stopped;
}

std::vector<double> EscEmulator::thrust_N() const {
  std::vector<double> out;
  for (const int s : set_points_) out.push_back(BlCtrlSetPointToThrust(map_, version_, s));
  return out;
}

bool EscEmulator::TakeCompleteRefresh() {
  if (std::find(written_.begin(), written_.end(), false) != written_.end()) return false;
  std::fill(written_.begin(), written_.end(), false);
  return true;
}

}  // namespace kestrel
