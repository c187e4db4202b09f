#pragma once
/// @file
/// A VN-100 on a pseudo-terminal, byte for byte (docs/protocols.md §7.5), single-threaded: the
/// caller polls it for commands and hands it samples at the device's base rate (800 Hz).
/// At power-on it streams ASCII "$VNYMR" lines (every 20th sample, as the factory 40 Hz) and no
/// binary output; it answers register writes 06 (asynchronous ASCII type) and 75 (binary output
/// 1) with their echo, a read of register 01 with its model, and anything else with $VNERR.
/// Binary output 1 then streams one frame every rate-divisor samples.

#include <cstdint>
#include <string>
#include <vector>

#include "drivers/imu/vn100.h"
#include "drivers/serial/pseudo_terminal.h"

namespace kestrel {

class Vn100Emulator {
 public:
  /// Opens the pty (and the link, if link_path is set). @throws std::runtime_error.
  explicit Vn100Emulator(const std::string& link_path = "");

  /// Reads and answers what the driver wrote (never blocks).
  void Poll();
  /// One sample at the base rate: written out per the output configuration (never blocks; a
  /// frame the pty cannot take is counted as dropped, as a device's full output buffer).
  void Sample(const Vn100Sample& sample);
  /// Unplug and plug the device: a hang-up, then a power-on state (no binary output).
  void Unplug();
  void Plug();

  [[nodiscard]] const std::string& device_path() const { return pty_.device_path(); }
  [[nodiscard]] int64_t frames_sent() const { return frames_sent_; }
  [[nodiscard]] int64_t frames_dropped() const { return frames_dropped_; }
  [[nodiscard]] const std::vector<std::string>& commands() const { return commands_; }
  [[nodiscard]] int rate_divisor() const { return rate_divisor_; }
  [[nodiscard]] bool binary_output() const { return async_mode_ != 0; }
  /// Writes raw bytes to the driver (tests: garbage on the line).
  void Inject(const std::string& bytes);

 private:
  void Answer(const std::string& line);
  void Send(const std::string& bytes);
  void PowerOn();

  PseudoTerminal pty_;
  std::string input_;
  std::vector<std::string> commands_;
  int ascii_type_{14};  // VNYMR
  int async_mode_{0};
  int rate_divisor_{1};
  uint16_t fields_{0};
  int64_t samples_{0};
  int64_t frames_sent_{0};
  int64_t frames_dropped_{0};
};

}  // namespace kestrel
