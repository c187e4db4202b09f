#pragma once
/// @file
/// An I2C bus behind a small interface (docs/protocols.md §6.4), so that the ESC protocol's bytes
/// are the same whatever carries them:
///  - LinuxI2cBus: the kernel's i2c-dev (/dev/i2c-N), one ioctl(I2C_RDWR) per transfer;
///  - SocketI2cBus: the same transfers over a Unix-domain SOCK_SEQPACKET socket to a process
///    that answers for the devices (kestrel-esc-emulator in hardware-in-the-loop simulation);
///  - I2cSocketServer: that process's side.
/// OpenI2cBus picks one from a configuration string: "/dev/i2c-1" or "unix:/run/kestrel/esc.sock".

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace kestrel {

/// One message of a transfer: a write of `data`, or a read of data.size() bytes into `data`.
struct I2cMessage {
  uint8_t address{0};  ///< 7-bit device address
  bool read{false};    ///< true: read data.size() bytes; false: write data
  std::vector<uint8_t> data;
};

/// A bus. Not thread-safe.
class I2cBus {
 public:
  virtual ~I2cBus() = default;
  /// Runs `messages` as one transfer (repeated starts between them). On success the reads' data
  /// are filled in; false and *error (what failed: errno text, NACK, time-out) otherwise.
  virtual bool Transfer(std::vector<I2cMessage>* messages, std::string* error) = 0;
  /// What it is, for logs ("/dev/i2c-1", "unix:/tmp/esc.sock").
  [[nodiscard]] virtual std::string name() const = 0;
};

/// The kernel's i2c-dev. Opened at construction.
class LinuxI2cBus final : public I2cBus {
 public:
  /// @throws std::runtime_error naming the device and errno when it cannot be opened.
  explicit LinuxI2cBus(std::string device);
  ~LinuxI2cBus() override;
  LinuxI2cBus(const LinuxI2cBus&) = delete;
  LinuxI2cBus& operator=(const LinuxI2cBus&) = delete;
  bool Transfer(std::vector<I2cMessage>* messages, std::string* error) override;
  [[nodiscard]] std::string name() const override { return device_; }

 private:
  std::string device_;
  int fd_{-1};
};

/// Transfers over a Unix-domain SOCK_SEQPACKET socket, one datagram each way per transfer
/// (docs/protocols.md §6.4). Connected at construction.
class SocketI2cBus final : public I2cBus {
 public:
  /// @throws std::runtime_error naming the path and errno when it cannot connect.
  explicit SocketI2cBus(std::string path, int timeout_ms = 100);
  ~SocketI2cBus() override;
  SocketI2cBus(const SocketI2cBus&) = delete;
  SocketI2cBus& operator=(const SocketI2cBus&) = delete;
  bool Transfer(std::vector<I2cMessage>* messages, std::string* error) override;
  [[nodiscard]] std::string name() const override { return "unix:" + path_; }

 private:
  std::string path_;
  int timeout_ms_;
  int fd_{-1};
};

/// "/dev/..." -> LinuxI2cBus, "unix:PATH" -> SocketI2cBus.
/// @throws std::runtime_error when it cannot be opened, std::invalid_argument for another form.
[[nodiscard]] std::unique_ptr<I2cBus> OpenI2cBus(const std::string& spec);

/// The devices' side of SocketI2cBus: listens on a path, and for every transfer received calls
/// `device` once per message in order (a write: its data; a read: fill data, sized already);
/// `device` returns false for a NACK (no device at that address), which ends the transfer.
class I2cSocketServer {
 public:
  using Device = std::function<bool(I2cMessage& message)>;
  /// Binds and listens (an old socket file at `path` is removed first).
  /// @throws std::runtime_error naming the path and errno.
  I2cSocketServer(std::string path, Device device);
  ~I2cSocketServer();
  I2cSocketServer(const I2cSocketServer&) = delete;
  I2cSocketServer& operator=(const I2cSocketServer&) = delete;
  /// Accepts a client and answers transfers for at most timeout_ms; returns the transfers answered.
  /// A client that hangs up is dropped and the next one accepted (a restarted driver).
  int Poll(int timeout_ms);
  /// Transfers refused as malformed since start.
  [[nodiscard]] int64_t malformed() const { return malformed_; }

 private:
  std::string path_;
  Device device_;
  int listen_fd_{-1};
  int client_fd_{-1};
  int64_t malformed_{0};
};

/// The datagram of a transfer (docs/protocols.md §6.4): "KI2C", the message count, then per
/// message its address, flags (1 = read), length and, for a write, its bytes.
[[nodiscard]] std::vector<uint8_t> EncodeI2cRequest(const std::vector<I2cMessage>& messages);
/// Its inverse; false for a malformed datagram.
[[nodiscard]] bool DecodeI2cRequest(const std::vector<uint8_t>& datagram,
                                    std::vector<I2cMessage>* messages);

}  // namespace kestrel
