#pragma once
/// @file
/// The Vicon Tracker "UDP Object Stream" datagram (docs/protocols.md §3.1): a pure
/// parser (untrusted bytes in, objects or a rejection reason out) and an encoder for the emitter.
///
/// Layout, little endian, packed, no alignment:
/// @code
///   offset 0   u32      frame number
///   offset 4   u8       item count N
///   offset 5 + 75 k, per item k in [0, N):
///     +0   u8       item id (0 = object)
///     +1   u16      item data size (72: the bytes that follow, name + 6 doubles)
///     +3   char[24] object name, NUL-terminated (so at most 23 characters)
///     +27  f64 x 3  translation x, y, z, millimetres, in the Vicon world frame
///     +51  f64 x 3  rotation rx, ry, rz, radians, Euler "XYZ" (see QuaternionFromViconEulerXyz)
/// @endcode
/// At most 1024 bytes per datagram, hence at most 13 items. Tracker writes each datagram into a
/// fixed-size buffer (its "buffer size" setting), and public readers receive 256/512-byte reads,
/// so bytes after the last item are accepted when they are all zero (padding) and rejected
/// otherwise (unverified against a Tracker capture; a config switch in the bridge can forbid it).
///
/// Euler convention: Vicon's EulerXYZ is the intrinsic x-y'-z'' sequence, R = Rx(rx) Ry(ry) Rz(rz)
/// (equivalently extrinsic z, then y, then x). This matches Vicon's Tracker help page "Access Vicon
/// Tracker data from Simulink" as quoted by public UDP-stream readers ("XYZ, intrinsic, or ZYX,
/// extrinsic"), and the DataStream SDK's matrix-to-EulerXYZ (ry = asin(R02)). Unverified against a
/// live Tracker here; the bridge can select the other order in configuration.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace kestrel {

/// Largest datagram Tracker sends, bytes.
inline constexpr size_t kViconMaxDatagramBytes = 1024;
/// Frame number (4) + item count (1), bytes.
inline constexpr size_t kViconHeaderBytes = 5;
/// Item header: id (1) + data size (2), bytes.
inline constexpr size_t kViconItemHeaderBytes = 3;
/// The item data size field of an object item: name (24) + 6 doubles (48), bytes.
inline constexpr uint16_t kViconObjectDataBytes = 72;
/// One whole object item, bytes.
inline constexpr size_t kViconItemBytes = kViconItemHeaderBytes + kViconObjectDataBytes;  // 75
/// Name field width, bytes, NUL included.
inline constexpr size_t kViconNameBytes = 24;
/// Item id of an object.
inline constexpr uint8_t kViconObjectItemId = 0;
/// Items that fit in one datagram: (1024 - 5) / 75.
inline constexpr size_t kViconMaxItems =
    (kViconMaxDatagramBytes - kViconHeaderBytes) / kViconItemBytes;  // 13

/// One object as carried on the wire (Vicon units: mm, rad).
struct ViconObject {
  std::string name;                                         ///< object name, 1..23 bytes
  Eigen::Vector3d translation_mm{Eigen::Vector3d::Zero()};  ///< position, mm, Vicon world
  Eigen::Vector3d rotation_rad{Eigen::Vector3d::Zero()};    ///< Euler XYZ (rx, ry, rz), rad
};

/// One datagram: a frame number and its objects (names unique within the frame).
struct ViconFrame {
  uint32_t frame_number{0};          ///< Tracker's frame counter (wraps at 2^32)
  std::vector<ViconObject> objects;  ///< in datagram order, at most kViconMaxItems
};

/// Why a datagram was rejected. Stable names (ViconPacketErrorName) are used as drop kinds.
enum class ViconPacketError {
  kNone = 0,       ///< well formed
  kTooShort,       ///< fewer than 5 bytes, or fewer than the item count needs
  kTooLong,        ///< more than 1024 bytes
  kTooManyItems,   ///< item count above 13
  kUnknownItemId,  ///< item id other than 0
  kBadItemSize,    ///< item data size other than 72
  kTrailingBytes,  ///< non-zero bytes after the last item (or zero padding when forbidden)
  kBadName,        ///< empty, no NUL within 24 bytes, or a control character
  kDuplicateName,  ///< the same object twice in one frame
  kNonFinite,      ///< NaN or infinity in a translation or rotation
};

/// "too_short", "too_long", ... for logs and drop counters.
[[nodiscard]] const char* ViconPacketErrorName(ViconPacketError error);

/// Parser options.
struct ViconParseOptions {
  /// Accept all-zero bytes after the last item (Tracker's fixed-size buffer). Non-zero trailing
  /// bytes are always rejected.
  bool allow_zero_padding{true};
};

/// Parses one datagram. Never reads outside [data, data + size), never throws, allocates at most
/// kViconMaxItems objects. On failure returns the error, sets *reason to a sentence naming the
/// offset and value, and leaves *frame unspecified (but valid). `data` may be null when size is 0.
[[nodiscard]] ViconPacketError ParseViconDatagram(const uint8_t* data, size_t size,
                                                  const ViconParseOptions& options,
                                                  ViconFrame* frame, std::string* reason);

/// Encodes a frame exactly as documented above (no padding).
/// @throws std::invalid_argument if there are more than 13 objects, a name is empty, longer than
/// 23 bytes or holds a NUL, or a value is not finite.
[[nodiscard]] std::vector<uint8_t> EncodeViconDatagram(const ViconFrame& frame);

/// Which Euler order to read the rotation in.
enum class ViconEulerOrder {
  kIntrinsicXyz,  ///< R = Rx(rx) Ry(ry) Rz(rz): Vicon's documented EulerXYZ (default)
  kExtrinsicXyz,  ///< R = Rz(rz) Ry(ry) Rx(rx): the other reading, selectable in config
};

/// Unit quaternion (Hamilton, active) for Euler angles (rx, ry, rz) in rad, for the given order.
/// kIntrinsicXyz: q = q_x(rx) * q_y(ry) * q_z(rz), i.e. R = Rx(rx) Ry(ry) Rz(rz). Precondition:
/// finite angles.
[[nodiscard]] Eigen::Quaterniond QuaternionFromViconEuler(
    const Eigen::Vector3d& rotation_rad, ViconEulerOrder order = ViconEulerOrder::kIntrinsicXyz);

/// Inverse of QuaternionFromViconEuler for kIntrinsicXyz: (rx, ry, rz) with ry in [-pi/2, pi/2],
/// rx, rz in (-pi, pi]; ry = asin(R02), rx = atan2(-R12, R22), rz = atan2(-R01, R00). At gimbal
/// lock (|R02| = 1) rz = 0 and rx carries the whole rotation about x.
[[nodiscard]] Eigen::Vector3d ViconEulerXyzFromQuaternion(const Eigen::Quaterniond& q);

}  // namespace kestrel
