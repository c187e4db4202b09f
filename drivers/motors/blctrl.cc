#include "drivers/motors/blctrl.h"

#include <algorithm>
#include <cmath>

#include "common/check.h"

namespace kestrel {

std::optional<BlCtrlVersion> ParseBlCtrlVersion(const std::string& name) {
  if (name == "blctrl_v1") return BlCtrlVersion::kV1;
  if (name == "blctrl_v2") return BlCtrlVersion::kV2;
  return std::nullopt;
}

int BlCtrlFullScale(BlCtrlVersion version) { return version == BlCtrlVersion::kV1 ? 255 : 2047; }

std::vector<uint8_t> EncodeBlCtrlSetPoint(BlCtrlVersion version, int set_point) {
  KESTREL_THROW_UNLESS(
      set_point >= 0 && set_point <= BlCtrlFullScale(version),
      "BL-Ctrl set point " << set_point << " is not in 0.." << BlCtrlFullScale(version));
  if (version == BlCtrlVersion::kV1) return {static_cast<uint8_t>(set_point)};
  return {static_cast<uint8_t>(set_point >> 3), static_cast<uint8_t>(set_point & 0x07)};
}

std::optional<int> DecodeBlCtrlSetPoint(BlCtrlVersion version, const std::vector<uint8_t>& bytes) {
  if (version == BlCtrlVersion::kV1) {
    if (bytes.size() != 1) return std::nullopt;
    return bytes[0];
  }
  if (bytes.size() != 2 || bytes[1] > 0x07) return std::nullopt;
  return (bytes[0] << 3) | bytes[1];
}

std::optional<BlCtrlStatus> DecodeBlCtrlStatus(const std::vector<uint8_t>& bytes) {
  if (bytes.size() != 3) return std::nullopt;
  BlCtrlStatus status;
  status.current_A = 0.1 * bytes[0];
  status.max_pwm = bytes[1];
  status.temperature_C = bytes[2];
  return status;
}

std::vector<uint8_t> EncodeBlCtrlStatus(const BlCtrlStatus& status) {
  const auto byte = [](double v) {
    return static_cast<uint8_t>(std::clamp(std::lround(std::isfinite(v) ? v : 0.0), 0L, 255L));
  };
  return {byte(status.current_A * 10.0), byte(status.max_pwm), byte(status.temperature_C)};
}

int ThrustToBlCtrlSetPoint(const EscMap& map, BlCtrlVersion version, double thrust_N, bool armed) {
  if (!armed || !std::isfinite(thrust_N)) return 0;
  const int full = BlCtrlFullScale(version);
  const double u = std::sqrt(std::max(0.0, thrust_N) / map.full_command_thrust_N);
  const auto set_point = static_cast<int>(std::lround(std::clamp(u, 0.0, 1.0) * full));
  const auto idle = static_cast<int>(std::ceil(map.idle_command * full));
  return std::max(set_point, idle);
}

double BlCtrlSetPointToThrust(const EscMap& map, BlCtrlVersion version, int set_point) {
  const double u = static_cast<double>(set_point) / BlCtrlFullScale(version);
  return map.full_command_thrust_N * u * u;
}

}  // namespace kestrel
