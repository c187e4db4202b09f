#pragma once
/// @file
/// The VectorNav VN-100 serial protocol, pure (docs/protocols.md §7): no port, no clock inside.
///
/// Binary output (docs/protocols.md §7.2): 0xFA, a byte of output groups, one little-endian
/// 16-bit field word per group present, the fields' values little endian in bit order, and a
/// CRC-16-CCITT (polynomial 0x1021, initial value 0) of everything after the sync byte, sent
/// most significant byte first, so that the CRC of everything after the sync byte including the
/// CRC is 0. Kestrel asks for the common group (1) with TimeStartup (ns since power-on, u64),
/// AngularRate (rad/s, 3 float32) and Accel (m/s^2, 3 float32).
///
/// ASCII commands (docs/protocols.md §7.3): "$VN<command>,<fields>*<checksum>\r\n", the
/// checksum the XOR of the bytes between '$' and '*' as two upper-case hex digits. The device
/// echoes a register write with its own checksum, and answers an error with "$VNERR,<code>".
///
/// Frames (docs/protocols.md §7.4): the VN-100 body frame is x forward, y right, z down, and its
/// Accel is specific force (at rest, level, it reads about (0, 0, -9.8)); Kestrel's body is
/// x forward, y left, z up: y and z change sign both ways.

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace kestrel {

/// CRC-16-CCITT as the VN-100 computes it: polynomial 0x1021, initial value 0, no reflection.
[[nodiscard]] uint16_t Vn100Crc16(const uint8_t* data, size_t size);
/// The ASCII checksum: XOR of every byte.
[[nodiscard]] uint8_t Vn100Checksum(std::string_view body);

/// Common-group field bits.
enum Vn100CommonField : uint16_t {
  kVn100TimeStartup = 1u << 0,
  kVn100AngularRate = 1u << 5,
  kVn100Accel = 1u << 8,
};
/// The common-group fields Kestrel streams.
constexpr uint16_t kVn100KestrelFields = kVn100TimeStartup | kVn100AngularRate | kVn100Accel;

/// Payload bytes of a common-group field set; std::nullopt if it holds a bit the VN-100 does not
/// define (15).
[[nodiscard]] std::optional<size_t> Vn100CommonPayloadSize(uint16_t fields);

/// One inertial sample in the device's own frame and units.
struct Vn100Sample {
  uint64_t time_startup_ns{0};                ///< device clock, ns since power-on
  std::array<float, 3> angular_rate_radps{};  ///< device frame (x fwd, y right, z down)
  std::array<float, 3> accel_mps2{};          ///< specific force, device frame
};

/// The binary frame of `sample` (common group, kVn100KestrelFields), CRC included.
[[nodiscard]] std::vector<uint8_t> EncodeVn100Frame(const Vn100Sample& sample);

/// A command line with its checksum: "$VN" + body + "*XX\r\n" (body e.g. "WRG,75,1,2,01,0121").
[[nodiscard]] std::string Vn100Command(std::string_view body);
/// The register-write body of binary output 1: "WRG,75,<async_mode>,<rate_divisor>,01,<fields>".
[[nodiscard]] std::string Vn100BinaryOutputBody(int async_mode, int rate_divisor,
                                                uint16_t fields = kVn100KestrelFields);

/// Converts between the device frame and Kestrel's body frame (y and z negated; its own inverse).
[[nodiscard]] std::array<double, 3> Vn100ToBody(const std::array<float, 3>& v);

/// What the parser found in the byte stream.
struct Vn100Message {
  enum class Kind { kSample, kAscii } kind{Kind::kSample};
  Vn100Sample sample;  ///< kSample
  std::string ascii;   ///< kAscii: the line without "$", checksum and "\r\n" (e.g. "VNWRG,75,...")
};

/// Finds binary frames and ASCII lines in a byte stream that may hold garbage, counting every
/// byte or frame dropped by reason: "bad_crc", "unknown_group" (a group other than common),
/// "unknown_field", "bad_checksum" (an ASCII line), "garbage" (bytes before a sync).
/// A valid frame after garbage is never lost. Not thread-safe.
class Vn100Parser {
 public:
  /// Appends bytes and returns the messages completed, in order.
  std::vector<Vn100Message> Feed(std::string_view bytes);
  /// Drops by reason since construction.
  [[nodiscard]] const std::map<std::string, int64_t>& drops() const { return drops_; }
  /// Frames decoded since construction.
  [[nodiscard]] int64_t frames() const { return frames_; }
  /// Forgets any partial message (a reopened port).
  void Reset() { buffer_.clear(); }

 private:
  void Drop(const std::string& reason, size_t bytes);
  std::string buffer_;
  std::map<std::string, int64_t> drops_;
  int64_t frames_{0};
};

}  // namespace kestrel
