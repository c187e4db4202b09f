#pragma once
/// @file
/// A serial port on POSIX termios for USB CDC-ACM sensors (docs/protocols.md §1.1): raw 8N1,
/// CLOCAL|CREAD, no echo, non-canonical, no flow control; an exclusive lock (flock and TIOCEXCL)
/// so two drivers never share a device; poll()-based time-outs; a hang-up (POLLHUP, EIO, ENXIO,
/// unplug) reported as IoStatus::kDisconnected so the caller can reopen.

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>

namespace kestrel {

/// Outcome of one read or write.
enum class IoStatus {
  kOk,            ///< some bytes moved (or, for a write, all of them)
  kTimeout,       ///< nothing within the time-out
  kDisconnected,  ///< the device went away (hang-up, EIO, ENXIO, ENODEV): reopen
  kError,         ///< any other failure (errno in IoResult::error_number)
};

/// "ok", "timeout", "disconnected", "error".
[[nodiscard]] const char* ToString(IoStatus status);

struct IoResult {
  IoStatus status{IoStatus::kOk};
  size_t bytes{0};      ///< bytes read or written
  int error_number{0};  ///< errno for kDisconnected/kError (0 for a POLLHUP)
};

/// A bidirectional byte stream with time-outs (a serial port; tests may use a pty directly).
class ByteStream {
 public:
  virtual ~ByteStream() = default;
  /// Writes all of `bytes` within timeout_ms (kTimeout if only part went).
  virtual IoResult Write(std::string_view bytes, int timeout_ms) = 0;
  /// Appends up to max_bytes to *out, waiting at most timeout_ms for the first byte
  /// (0: only what is already there).
  virtual IoResult Read(std::string* out, size_t max_bytes, int timeout_ms) = 0;
  /// Discards unread input and unsent output.
  virtual void Flush() = 0;
  /// A file descriptor that poll() can wait on for input (-1 if none).
  [[nodiscard]] virtual int fd() const = 0;
};

/// Opening or configuring the port failed. what() names the path and the system error.
class SerialError : public std::runtime_error {
 public:
  SerialError(const std::string& message, int error_number)
      : std::runtime_error(message), error_number_(error_number) {}
  [[nodiscard]] int error_number() const { return error_number_; }

 private:
  int error_number_;
};

/// Serial port settings.
struct SerialOptions {
  int baud{115200};          ///< one of the standard termios rates (CDC-ACM ignores it)
  bool exclusive{true};      ///< flock(LOCK_EX|LOCK_NB) and TIOCEXCL
  bool flush_on_open{true};  ///< tcflush(TCIOFLUSH) after configuring
};

/// An open serial port (RAII: closed in the destructor).
class SerialPort final : public ByteStream {
 public:
  /// Opens `path` (O_RDWR|O_NOCTTY|O_NONBLOCK), locks it, sets raw 8N1 and flushes.
  /// @throws SerialError if the device is missing, busy (locked by another process), not a
  /// terminal, or the baud rate is not supported.
  explicit SerialPort(const std::string& path, const SerialOptions& options = {});
  ~SerialPort() override;
  SerialPort(const SerialPort&) = delete;
  SerialPort& operator=(const SerialPort&) = delete;

  IoResult Write(std::string_view bytes, int timeout_ms) override;
  IoResult Read(std::string* out, size_t max_bytes, int timeout_ms) override;
  void Flush() override;
  [[nodiscard]] int fd() const override { return fd_; }
  [[nodiscard]] const std::string& path() const { return path_; }

 private:
  std::string path_;
  int fd_{-1};
};

}  // namespace kestrel
