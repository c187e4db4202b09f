#pragma once
/// @file
/// The MikroKopter BL-Ctrl I2C protocol, pure (docs/protocols.md §6): no bus, no file inside.
/// Each ESC answers at its own 7-bit address, 0x29 for rotor 1 and one more per rotor (0x52, 0x54,
/// ... as 8-bit write addresses). A set point is one write to the ESC's address:
///  - BL-Ctrl 1.x: one byte, 0..255;
///  - BL-Ctrl 2.x: two bytes, the 11-bit set point's upper eight bits (set point >> 3), then its
///    lower three bits (set point & 7).
/// An ESC streams its state back on a read of its address: current (0.1 A), the highest PWM it
/// allows (255 once running) and its temperature (deg C), one byte each.
/// The rotor thrust maps to a set point through the vehicle's ESC map (common/vehicle_config.h):
/// T(u) = T_full u^2 with u = set point / full scale.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/vehicle_config.h"

namespace kestrel {

/// The protocol generation of the ESCs on the bus.
enum class BlCtrlVersion {
  kV1,  ///< BL-Ctrl 1.x: 8-bit set points
  kV2,  ///< BL-Ctrl 2.x: 11-bit set points
};

/// "blctrl_v1" -> kV1, "blctrl_v2" -> kV2; std::nullopt otherwise.
[[nodiscard]] std::optional<BlCtrlVersion> ParseBlCtrlVersion(const std::string& name);

/// The 7-bit address of rotor 1's ESC; rotor i (1-based) is at kBlCtrlFirstAddress + i - 1.
constexpr uint8_t kBlCtrlFirstAddress = 0x29;

/// The largest set point: 255 (V1) or 2047 (V2).
[[nodiscard]] int BlCtrlFullScale(BlCtrlVersion version);

/// The bytes of one set-point write. Precondition: 0 <= set_point <= BlCtrlFullScale(version)
/// (@throws std::invalid_argument otherwise).
[[nodiscard]] std::vector<uint8_t> EncodeBlCtrlSetPoint(BlCtrlVersion version, int set_point);

/// The set point a write carries, or std::nullopt for a write of the wrong length or (V2) lower
/// bits beyond three.
[[nodiscard]] std::optional<int> DecodeBlCtrlSetPoint(BlCtrlVersion version,
                                                      const std::vector<uint8_t>& bytes);

/// What an ESC reports on a read.
struct BlCtrlStatus {
  double current_A{0.0};  ///< motor current, A (0.1 A per count)
  int max_pwm{0};         ///< the PWM ceiling the ESC allows (255 once running)
  int temperature_C{0};   ///< board temperature, deg C
};

/// Bytes read from an ESC (3) to its status; std::nullopt for another length.
[[nodiscard]] std::optional<BlCtrlStatus> DecodeBlCtrlStatus(const std::vector<uint8_t>& bytes);
/// The bytes an ESC sends for `status` (clamped to a byte each; the emulator's side).
[[nodiscard]] std::vector<uint8_t> EncodeBlCtrlStatus(const BlCtrlStatus& status);

/// The set point for a rotor thrust: round(full scale * sqrt(T / T_full)), clamped to
/// [0, full scale]; armed, never below the idle command; not armed, or a thrust that is not a
/// finite number, 0 (NaN never reaches an ESC).
[[nodiscard]] int ThrustToBlCtrlSetPoint(const EscMap& map, BlCtrlVersion version, double thrust_N,
                                         bool armed);
/// The thrust of a set point: T_full (set point / full scale)^2.
[[nodiscard]] double BlCtrlSetPointToThrust(const EscMap& map, BlCtrlVersion version,
                                            int set_point);

}  // namespace kestrel
