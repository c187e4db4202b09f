#include "drivers/vicon/vicon_packet.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>
#include <stdexcept>

namespace kestrel {
namespace {

// Little-endian reads from a byte buffer, independent of the host's byte order.
uint16_t ReadU16(const uint8_t* p) {
  return static_cast<uint16_t>(p[0] | (static_cast<uint16_t>(p[1]) << 8));
}

uint32_t ReadU32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | (static_cast<uint32_t>(p[1]) << 8) |
         (static_cast<uint32_t>(p[2]) << 16) | (static_cast<uint32_t>(p[3]) << 24);
}

double ReadF64(const uint8_t* p) {
  uint64_t bits = 0;
  for (int i = 7; i >= 0; --i) bits = (bits << 8) | p[i];
  double value;
  std::memcpy(&value, &bits, sizeof(value));
  return value;
}

void WriteU16(uint16_t v, std::vector<uint8_t>* out) {
  out->push_back(static_cast<uint8_t>(v & 0xff));
  out->push_back(static_cast<uint8_t>(v >> 8));
}

void WriteU32(uint32_t v, std::vector<uint8_t>* out) {
  for (int i = 0; i < 4; ++i) out->push_back(static_cast<uint8_t>((v >> (8 * i)) & 0xff));
}

void WriteF64(double value, std::vector<uint8_t>* out) {
  uint64_t bits;
  std::memcpy(&bits, &value, sizeof(bits));
  for (int i = 0; i < 8; ++i) out->push_back(static_cast<uint8_t>((bits >> (8 * i)) & 0xff));
}

ViconPacketError Fail(ViconPacketError error, std::string* reason, const std::string& text) {
  if (reason != nullptr) *reason = std::string(ViconPacketErrorName(error)) + ": " + text;
  return error;
}

}  // namespace

const char* ViconPacketErrorName(ViconPacketError error) {
  switch (error) {
    case ViconPacketError::kNone:
      return "none";
    case ViconPacketError::kTooShort:
      return "too_short";
    case ViconPacketError::kTooLong:
      return "too_long";
    case ViconPacketError::kTooManyItems:
      return "too_many_items";
    case ViconPacketError::kUnknownItemId:
      return "unknown_item_id";
    case ViconPacketError::kBadItemSize:
      return "bad_item_size";
    case ViconPacketError::kTrailingBytes:
      return "trailing_bytes";
    case ViconPacketError::kBadName:
      return "bad_name";
    case ViconPacketError::kDuplicateName:
      return "duplicate_name";
    case ViconPacketError::kNonFinite:
      return "non_finite";
  }
  return "unknown";
}

ViconPacketError ParseViconDatagram(const uint8_t* data, size_t size,
                                    const ViconParseOptions& options, ViconFrame* frame,
                                    std::string* reason) {
  frame->objects.clear();
  if (size > kViconMaxDatagramBytes) {
    std::ostringstream s;
    s << size << " bytes, at most " << kViconMaxDatagramBytes;
    return Fail(ViconPacketError::kTooLong, reason, s.str());
  }
  if (size < kViconHeaderBytes || data == nullptr) {
    std::ostringstream s;
    s << size << " bytes, the header needs " << kViconHeaderBytes;
    return Fail(ViconPacketError::kTooShort, reason, s.str());
  }
  frame->frame_number = ReadU32(data);
  const size_t count = data[4];
  if (count > kViconMaxItems) {
    std::ostringstream s;
    s << "item count " << count << ", at most " << kViconMaxItems;
    return Fail(ViconPacketError::kTooManyItems, reason, s.str());
  }
  const size_t needed = kViconHeaderBytes + count * kViconItemBytes;
  if (size < needed) {
    std::ostringstream s;
    s << size << " bytes, " << count << " items need " << needed;
    return Fail(ViconPacketError::kTooShort, reason, s.str());
  }
  for (size_t i = needed; i < size; ++i) {
    if (data[i] != 0 || !options.allow_zero_padding) {
      std::ostringstream s;
      s << (size - needed) << " bytes after " << count << " items"
        << (data[i] != 0 ? ", non-zero at offset " + std::to_string(i) : ", padding forbidden");
      return Fail(ViconPacketError::kTrailingBytes, reason, s.str());
    }
  }
  frame->objects.reserve(count);
  for (size_t k = 0; k < count; ++k) {
    const size_t offset = kViconHeaderBytes + k * kViconItemBytes;
    const uint8_t* item = data + offset;
    if (item[0] != kViconObjectItemId) {
      std::ostringstream s;
      s << "item " << k << " at offset " << offset << " has id " << int{item[0]}
        << ", expected 0 (object)";
      return Fail(ViconPacketError::kUnknownItemId, reason, s.str());
    }
    const uint16_t item_size = ReadU16(item + 1);
    if (item_size != kViconObjectDataBytes) {
      std::ostringstream s;
      s << "item " << k << " at offset " << offset << " has size " << item_size << ", expected "
        << kViconObjectDataBytes;
      return Fail(ViconPacketError::kBadItemSize, reason, s.str());
    }
    const uint8_t* name_bytes = item + kViconItemHeaderBytes;
    size_t name_length = 0;
    while (name_length < kViconNameBytes && name_bytes[name_length] != 0) ++name_length;
    if (name_length == kViconNameBytes || name_length == 0) {
      std::ostringstream s;
      s << "item " << k << ": name "
        << (name_length == 0 ? "is empty" : "has no NUL within 24 bytes (over-long)");
      return Fail(ViconPacketError::kBadName, reason, s.str());
    }
    for (size_t i = 0; i < name_length; ++i) {
      if (name_bytes[i] < 0x20 || name_bytes[i] == 0x7f) {
        std::ostringstream s;
        s << "item " << k << ": name holds control byte " << int{name_bytes[i]} << " at " << i;
        return Fail(ViconPacketError::kBadName, reason, s.str());
      }
    }
    ViconObject object;
    object.name.assign(reinterpret_cast<const char*>(name_bytes), name_length);
    for (const ViconObject& other : frame->objects) {
      if (other.name == object.name) {
        return Fail(ViconPacketError::kDuplicateName, reason,
                    "item " + std::to_string(k) + ": object '" + object.name + "' twice");
      }
    }
    const uint8_t* values = name_bytes + kViconNameBytes;
    for (int j = 0; j < 3; ++j) {
      const size_t value_offset = 8 * static_cast<size_t>(j);
      object.translation_mm[j] = ReadF64(values + value_offset);
      object.rotation_rad[j] = ReadF64(values + 24 + value_offset);
    }
    if (!object.translation_mm.allFinite() || !object.rotation_rad.allFinite()) {
      return Fail(ViconPacketError::kNonFinite, reason,
                  "item " + std::to_string(k) + " ('" + object.name +
                      "'): NaN or infinity in translation or rotation");
    }
    frame->objects.push_back(std::move(object));
  }
  if (reason != nullptr) reason->clear();
  return ViconPacketError::kNone;
}

std::vector<uint8_t> EncodeViconDatagram(const ViconFrame& frame) {
  if (frame.objects.size() > kViconMaxItems) {
    throw std::invalid_argument("EncodeViconDatagram: " + std::to_string(frame.objects.size()) +
                                " objects, at most " + std::to_string(kViconMaxItems));
  }
  std::vector<uint8_t> out;
  out.reserve(kViconHeaderBytes + frame.objects.size() * kViconItemBytes);
  WriteU32(frame.frame_number, &out);
  out.push_back(static_cast<uint8_t>(frame.objects.size()));
  for (const ViconObject& object : frame.objects) {
    if (object.name.empty() || object.name.size() >= kViconNameBytes ||
        object.name.find('\0') != std::string::npos) {
      throw std::invalid_argument("EncodeViconDatagram: object name '" + object.name +
                                  "' must have 1..23 bytes and no NUL");
    }
    if (!object.translation_mm.allFinite() || !object.rotation_rad.allFinite()) {
      throw std::invalid_argument("EncodeViconDatagram: object '" + object.name +
                                  "' has a non-finite value");
    }
    out.push_back(kViconObjectItemId);
    WriteU16(kViconObjectDataBytes, &out);
    for (size_t i = 0; i < kViconNameBytes; ++i) {
      out.push_back(i < object.name.size() ? static_cast<uint8_t>(object.name[i]) : 0);
    }
    for (int j = 0; j < 3; ++j) WriteF64(object.translation_mm[j], &out);
    for (int j = 0; j < 3; ++j) WriteF64(object.rotation_rad[j], &out);
  }
  return out;
}

Eigen::Quaterniond QuaternionFromViconEuler(const Eigen::Vector3d& rotation_rad,
                                            ViconEulerOrder order) {
  const Eigen::Quaterniond qx(Eigen::AngleAxisd(rotation_rad.x(), Eigen::Vector3d::UnitX()));
  const Eigen::Quaterniond qy(Eigen::AngleAxisd(rotation_rad.y(), Eigen::Vector3d::UnitY()));
  const Eigen::Quaterniond qz(Eigen::AngleAxisd(rotation_rad.z(), Eigen::Vector3d::UnitZ()));
  Eigen::Quaterniond q = order == ViconEulerOrder::kIntrinsicXyz ? qx * qy * qz : qz * qy * qx;
  q.normalize();
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();  // one representative: w >= 0
  return q;
}

Eigen::Vector3d ViconEulerXyzFromQuaternion(const Eigen::Quaterniond& q) {
  const Eigen::Matrix3d R = q.normalized().toRotationMatrix();
  // R = Rx Ry Rz: R02 = sin(ry), R12 = -sin(rx) cos(ry), R22 = cos(rx) cos(ry),
  // R01 = -cos(ry) sin(rz), R00 = cos(ry) cos(rz).
  const double s = std::clamp(R(0, 2), -1.0, 1.0);
  const double ry = std::asin(s);
  if (std::abs(s) < 1.0 - 1e-12) {
    return {std::atan2(-R(1, 2), R(2, 2)), ry, std::atan2(-R(0, 1), R(0, 0))};
  }
  // Gimbal lock: only rx +- rz is defined; R21 = sin(rx +- rz), R11 = cos(rx +- rz).
  return {std::atan2(R(2, 1), R(1, 1)), ry, 0.0};
}

}  // namespace kestrel
