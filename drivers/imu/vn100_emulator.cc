#include "drivers/imu/vn100_emulator.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>

namespace kestrel {

namespace {
// VectorNav error codes (docs/protocols.md §7.3).
constexpr int kErrInvalidChecksum = 3;
constexpr int kErrInvalidCommand = 4;
constexpr int kErrInvalidParameter = 7;
constexpr int kErrInvalidRegister = 8;

std::vector<std::string> Split(const std::string& s) {
  std::vector<std::string> out;
  size_t start = 0;
  while (true) {
    const size_t comma = s.find(',', start);
    out.push_back(s.substr(start, comma - start));
    if (comma == std::string::npos) return out;
    start = comma + 1;
  }
}
}  // namespace

Vn100Emulator::Vn100Emulator(const std::string& link_path) : pty_(link_path) { PowerOn(); }

void Vn100Emulator::PowerOn() {
  input_.clear();
  ascii_type_ = 14;
  async_mode_ = 0;
  rate_divisor_ = 1;
  fields_ = 0;
}

void Vn100Emulator::Unplug() { pty_.Unplug(); }

void Vn100Emulator::Plug() {
  pty_.Plug();
  PowerOn();
}

void Vn100Emulator::Send(const std::string& bytes) {
  if (!pty_.plugged()) return;
  const ssize_t n = ::write(pty_.master_fd(), bytes.data(), bytes.size());
  if (n != static_cast<ssize_t>(bytes.size())) ++frames_dropped_;
}

void Vn100Emulator::Inject(const std::string& bytes) { Send(bytes); }

void Vn100Emulator::Poll() {
  if (!pty_.plugged()) return;
  char buffer[512];
  while (true) {
    const ssize_t n = ::read(pty_.master_fd(), buffer, sizeof(buffer));
    if (n <= 0) break;
    input_.append(buffer, static_cast<size_t>(n));
  }
  while (true) {
    const size_t end = input_.find('\n');
    if (end == std::string::npos) {
      if (input_.size() > 512) input_.clear();  // no line ending: an overflow, dropped
      return;
    }
    std::string line = input_.substr(0, end);
    input_.erase(0, end + 1);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const size_t dollar = line.find('$');
    if (dollar == std::string::npos) continue;
    Answer(line.substr(dollar));
  }
}

void Vn100Emulator::Answer(const std::string& line) {
  commands_.push_back(line);
  const auto error = [&](int code) {
    char body[16];
    std::snprintf(body, sizeof(body), "ERR,%02d", code);
    Send(Vn100Command(body));
  };
  const size_t star = line.rfind('*');
  if (line.size() < 3 || line.compare(0, 3, "$VN") != 0 || star == std::string::npos) {
    error(kErrInvalidCommand);
    return;
  }
  const std::string body = line.substr(1, star - 1);  // "VNWRG,75,..."
  const std::string given = line.substr(star + 1);
  char expected[3];
  std::snprintf(expected, sizeof(expected), "%02X", Vn100Checksum(body));
  if (given != "XX" && given != expected) {
    error(kErrInvalidChecksum);
    return;
  }
  const std::vector<std::string> f = Split(body.substr(2));  // "WRG", "75", ...
  const auto number = [](const std::string& s, int base, long* out) {
    char* end = nullptr;
    errno = 0;
    *out = std::strtol(s.c_str(), &end, base);
    return !s.empty() && end != nullptr && *end == '\0' && errno == 0;
  };
  long reg = -1;
  if (f.size() < 2 || !number(f[1], 10, &reg)) {
    error(kErrInvalidCommand);
    return;
  }
  if (f[0] == "RRG" && f.size() == 2) {
    if (reg != 1) {
      error(kErrInvalidRegister);
      return;
    }
    Send(Vn100Command("RRG,01,VN-100T-CR"));
    return;
  }
  if (f[0] != "WRG") {
    error(kErrInvalidCommand);
    return;
  }
  if (reg == 6) {
    long type = 0;
    if (f.size() != 3 || !number(f[2], 10, &type) || type < 0 || type > 255) {
      error(kErrInvalidParameter);
      return;
    }
    ascii_type_ = static_cast<int>(type);
  } else if (reg == 75) {
    long mode = 0, divisor = 0, groups = 0, fields = 0;
    if (f.size() != 6 || !number(f[2], 10, &mode) || !number(f[3], 10, &divisor) ||
        !number(f[4], 16, &groups) || !number(f[5], 16, &fields) || mode < 0 || mode > 3 ||
        divisor < 1 || divisor > 65535 || groups != 0x01 ||
        !Vn100CommonPayloadSize(static_cast<uint16_t>(fields)).has_value()) {
      error(kErrInvalidParameter);
      return;
    }
    async_mode_ = static_cast<int>(mode);
    rate_divisor_ = static_cast<int>(divisor);
    fields_ = static_cast<uint16_t>(fields);
  } else {
    error(kErrInvalidRegister);
    return;
  }
  Send(Vn100Command(body.substr(2)));  // the echo, with the device's checksum
}

void Vn100Emulator::Sample(const Vn100Sample& sample) {
  ++samples_;
  if (ascii_type_ != 0 && samples_ % 20 == 0) {
    char body[128];
    std::snprintf(body, sizeof(body),
                  "YMR,+000.000,+000.000,+000.000,+0.0000,+0.0000,+0.0000,"
                  "%+07.3f,%+07.3f,%+07.3f,%+08.4f,%+08.4f,%+08.4f",
                  sample.accel_mps2[0], sample.accel_mps2[1], sample.accel_mps2[2],
                  sample.angular_rate_radps[0], sample.angular_rate_radps[1],
                  sample.angular_rate_radps[2]);
    Send(Vn100Command(body));
  }
  if (async_mode_ == 0 || samples_ % rate_divisor_ != 0) return;
  if (fields_ != kVn100KestrelFields) return;  // only Kestrel's set is emulated as a frame
  const std::vector<uint8_t> frame = EncodeVn100Frame(sample);
  Send(std::string(frame.begin(), frame.end()));
  ++frames_sent_;
}

}  // namespace kestrel
