#include "drivers/imu/vn100.h"

#include <cstdio>
#include <cstring>

namespace kestrel {

namespace {
constexpr uint8_t kSync = 0xFA;
constexpr size_t kMaxAsciiLine = 256;

// Payload bytes of each common-group field, bit 0..14 (docs/protocols.md §7.2).
constexpr std::array<size_t, 15> kCommonFieldBytes = {
    8,   // 0 TimeStartup (u64 ns)
    8,   // 1 TimeGps (u64 ns)
    8,   // 2 TimeSyncIn (u64 ns)
    12,  // 3 YawPitchRoll (3 float)
    16,  // 4 Quaternion (4 float)
    12,  // 5 AngularRate (3 float)
    24,  // 6 Position (3 double)
    12,  // 7 Velocity (3 float)
    12,  // 8 Accel (3 float)
    24,  // 9 Imu (UncompAccel, UncompGyro: 6 float)
    20,  // 10 MagPres (Mag 3 float, Temp, Pres)
    28,  // 11 DeltaTheta (dt, dTheta 3, dVel 3: 7 float)
    2,   // 12 InsStatus (u16)
    4,   // 13 SyncInCnt (u32)
    8,   // 14 TimeGpsPps (u64 ns)
};

template <typename T>
void Put(std::vector<uint8_t>* out, T value) {
  uint8_t bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));  // little endian host (x86-64, aarch64)
  out->insert(out->end(), bytes, bytes + sizeof(T));
}

template <typename T>
T Get(const uint8_t* at) {
  T value;
  std::memcpy(&value, at, sizeof(T));
  return value;
}
}  // namespace

uint16_t Vn100Crc16(const uint8_t* data, size_t size) {
  uint16_t crc = 0;
  for (size_t i = 0; i < size; ++i) {
    crc ^= static_cast<uint16_t>(data[i]) << 8;
    for (int bit = 0; bit < 8; ++bit) {
      crc = (crc & 0x8000) != 0 ? static_cast<uint16_t>((crc << 1) ^ 0x1021)
                                : static_cast<uint16_t>(crc << 1);
    }
  }
  return crc;
}

uint8_t Vn100Checksum(std::string_view body) {
  uint8_t x = 0;
  for (const char c : body) x ^= static_cast<uint8_t>(c);
  return x;
}

std::optional<size_t> Vn100CommonPayloadSize(uint16_t fields) {
  if ((fields & 0x8000) != 0) return std::nullopt;
  size_t size = 0;
  for (size_t bit = 0; bit < kCommonFieldBytes.size(); ++bit) {
    if ((fields & (1u << bit)) != 0) size += kCommonFieldBytes[bit];
  }
  return size;
}

std::vector<uint8_t> EncodeVn100Frame(const Vn100Sample& sample) {
  std::vector<uint8_t> out = {kSync, 0x01};
  Put<uint16_t>(&out, kVn100KestrelFields);
  Put<uint64_t>(&out, sample.time_startup_ns);
  for (const float v : sample.angular_rate_radps) Put<float>(&out, v);
  for (const float v : sample.accel_mps2) Put<float>(&out, v);
  const uint16_t crc = Vn100Crc16(out.data() + 1, out.size() - 1);
  out.push_back(static_cast<uint8_t>(crc >> 8));
  out.push_back(static_cast<uint8_t>(crc & 0xFF));
  return out;
}

std::string Vn100Command(std::string_view body) {
  const std::string line = "VN" + std::string(body);
  char checksum[3];
  std::snprintf(checksum, sizeof(checksum), "%02X", Vn100Checksum(line));
  return "$" + line + "*" + checksum + "\r\n";
}

std::string Vn100BinaryOutputBody(int async_mode, int rate_divisor, uint16_t fields) {
  char body[64];
  std::snprintf(body, sizeof(body), "WRG,75,%d,%d,01,%04X", async_mode, rate_divisor, fields);
  return body;
}

std::array<double, 3> Vn100ToBody(const std::array<float, 3>& v) {
  return {static_cast<double>(v[0]), -static_cast<double>(v[1]), -static_cast<double>(v[2])};
}

void Vn100Parser::Drop(const std::string& reason, size_t bytes) {
  ++drops_[reason];
  buffer_.erase(0, bytes);
}

std::vector<Vn100Message> Vn100Parser::Feed(std::string_view bytes) {
  buffer_.append(bytes);
  std::vector<Vn100Message> out;
  while (!buffer_.empty()) {
    const auto* b = reinterpret_cast<const uint8_t*>(buffer_.data());
    if (b[0] == kSync) {
      if (buffer_.size() < 4) break;
      if (b[1] != 0x01) {  // only the common group is asked for
        Drop("unknown_group", 1);
        continue;
      }
      const uint16_t fields = Get<uint16_t>(b + 2);
      const auto payload = Vn100CommonPayloadSize(fields);
      if (!payload.has_value()) {
        Drop("unknown_field", 1);
        continue;
      }
      const size_t size = 4 + *payload + 2;
      if (buffer_.size() < size) break;
      if (Vn100Crc16(b + 1, size - 1) != 0) {
        Drop("bad_crc", 1);  // resynchronise from the next byte
        continue;
      }
      if ((fields & kVn100KestrelFields) != kVn100KestrelFields) {
        Drop("missing_field", size);  // a frame without the fields Kestrel needs
        continue;
      }
      // Fields in bit order; Kestrel's three, wherever others sit between them.
      Vn100Message m;
      size_t at = 4;
      for (size_t bit = 0; bit < kCommonFieldBytes.size(); ++bit) {
        if ((fields & (1u << bit)) == 0) continue;
        if (bit == 0) m.sample.time_startup_ns = Get<uint64_t>(b + at);
        for (int k = 0; k < 3; ++k) {
          if (bit == 5) m.sample.angular_rate_radps[k] = Get<float>(b + at + 4 * k);
          if (bit == 8) m.sample.accel_mps2[k] = Get<float>(b + at + 4 * k);
        }
        at += kCommonFieldBytes[bit];
      }
      ++frames_;
      out.push_back(m);
      buffer_.erase(0, size);
      continue;
    }
    if (b[0] == '$') {
      // A line ends within kMaxAsciiLine bytes, or the '$' was not a line's start: the same
      // decision however the bytes were split across reads.
      size_t end = buffer_.find("\r\n");
      if (end != std::string::npos && end + 2 > kMaxAsciiLine) end = std::string::npos;
      if (end == std::string::npos) {
        if (buffer_.size() < kMaxAsciiLine) break;
        Drop("garbage", 1);
        continue;
      }
      const std::string line = buffer_.substr(1, end - 1);
      const size_t star = line.rfind('*');
      unsigned checksum = 0;
      if (star == std::string::npos || line.size() != star + 3 ||
          (line.compare(star + 1, 2, "XX") != 0 &&
           (std::sscanf(line.c_str() + star + 1, "%2X", &checksum) != 1 ||
            checksum != Vn100Checksum(std::string_view(line).substr(0, star))))) {
        Drop("bad_checksum", end + 2);
        continue;
      }
      Vn100Message m;
      m.kind = Vn100Message::Kind::kAscii;
      m.ascii = line.substr(0, star);
      out.push_back(m);
      buffer_.erase(0, end + 2);
      continue;
    }
    // Garbage: skip to the next byte that could start a message, counted once per run.
    size_t next = 1;
    while (next < buffer_.size() && b[next] != kSync && b[next] != '$') ++next;
    Drop("garbage", next);
  }
  return out;
}

}  // namespace kestrel
