#pragma once
/// @file
/// A pseudo-terminal for a device emulator: the emulator keeps the master side, a driver opens
/// the slave's path (or a stable symlink to it) as it would the device. Raw mode, so the slave
/// never echoes what the driver writes. Unplug closes both sides (the driver sees a hang-up).

#include <string>

namespace kestrel {

class PseudoTerminal {
 public:
  /// Opens a pty (raw, master non-blocking) and links `link_path` to its slave ("" = no link).
  /// @throws std::runtime_error naming the call and errno.
  explicit PseudoTerminal(std::string link_path = "");
  ~PseudoTerminal();
  PseudoTerminal(const PseudoTerminal&) = delete;
  PseudoTerminal& operator=(const PseudoTerminal&) = delete;

  /// Closes both sides and removes the link (a driver reading it sees a hang-up).
  void Unplug();
  /// Opens a new pty and points the link at it (after Unplug). @throws std::runtime_error.
  void Plug();
  [[nodiscard]] bool plugged() const { return master_fd_ >= 0; }
  /// The master side's descriptor (-1 when unplugged).
  [[nodiscard]] int master_fd() const { return master_fd_; }
  /// The slave's path (/dev/pts/N).
  [[nodiscard]] const std::string& slave_path() const { return slave_path_; }
  /// The path a driver should open: the link if any, else the slave's path.
  [[nodiscard]] const std::string& device_path() const {
    return link_path_.empty() ? slave_path_ : link_path_;
  }

 private:
  std::string link_path_;
  std::string slave_path_;
  int master_fd_{-1};
  int slave_fd_{-1};
};

}  // namespace kestrel
