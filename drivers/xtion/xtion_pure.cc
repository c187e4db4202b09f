#include "drivers/xtion/xtion_pure.h"

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <stdexcept>

#include "common/check.h"

namespace kestrel {
namespace {

// Parses a whole string as a non-negative decimal integer.
std::optional<int> ParseCount(const std::string& text) {
  if (text.empty() || text.size() > 9) return std::nullopt;
  for (const char c : text) {
    if (c < '0' || c > '9') return std::nullopt;
  }
  return std::atoi(text.c_str());
}

}  // namespace

PinholeIntrinsics IntrinsicsFromFov(int width, int height, double hfov_rad, double vfov_rad) {
  KESTREL_THROW_UNLESS(width > 0 && height > 0, "image size " << width << "x" << height);
  KESTREL_THROW_UNLESS(hfov_rad > 0.0 && hfov_rad < M_PI && vfov_rad > 0.0 && vfov_rad < M_PI,
                       "fields of view " << hfov_rad << ", " << vfov_rad << " rad");
  PinholeIntrinsics k;
  k.fx_px = 0.5 * width / std::tan(0.5 * hfov_rad);
  k.fy_px = 0.5 * height / std::tan(0.5 * vfov_rad);
  k.cx_px = 0.5 * (width - 1);
  k.cy_px = 0.5 * (height - 1);
  return k;
}

DeviceSelector ParseDeviceSelector(const std::string& device_id) {
  DeviceSelector s;
  if (device_id.empty()) return s;
  if (device_id[0] == '#') {
    const auto n = ParseCount(device_id.substr(1));
    KESTREL_THROW_UNLESS(n.has_value() && *n >= 1,
                         "device '" << device_id << "': expected #N with N >= 1");
    s.kind = DeviceSelector::Kind::kIndex;
    s.index = *n;
    return s;
  }
  const size_t at = device_id.find('@');
  if (at != std::string::npos) {
    const auto bus = ParseCount(device_id.substr(0, at));
    const auto address = ParseCount(device_id.substr(at + 1));
    KESTREL_THROW_UNLESS(bus.has_value() && address.has_value(),
                         "device '" << device_id << "': expected BUS@ADDRESS (two integers)");
    s.kind = DeviceSelector::Kind::kBusAddress;
    s.bus = *bus;
    s.address = *address;
    return s;
  }
  s.kind = DeviceSelector::Kind::kSerial;
  s.serial = device_id;
  return s;
}

std::optional<std::pair<int, int>> UsbBusAddressOfUri(const std::string& uri) {
  const size_t at = uri.rfind('@');
  if (at == std::string::npos) return std::nullopt;
  const std::string rest = uri.substr(at + 1);
  const size_t slash = rest.find('/');
  if (slash == std::string::npos) return std::nullopt;
  const auto bus = ParseCount(rest.substr(0, slash));
  const auto address = ParseCount(rest.substr(slash + 1));
  if (!bus || !address) return std::nullopt;
  return std::make_pair(*bus, *address);
}

std::optional<size_t> SelectDevice(const DeviceSelector& selector,
                                   const std::vector<DeviceListing>& devices) {
  switch (selector.kind) {
    case DeviceSelector::Kind::kFirst:
      if (devices.empty()) return std::nullopt;
      return size_t{0};
    case DeviceSelector::Kind::kIndex:
      if (selector.index < 1 || static_cast<size_t>(selector.index) > devices.size()) {
        return std::nullopt;
      }
      return static_cast<size_t>(selector.index - 1);
    case DeviceSelector::Kind::kBusAddress:
      for (size_t i = 0; i < devices.size(); ++i) {
        const auto bus_address = UsbBusAddressOfUri(devices[i].uri);
        if (bus_address && bus_address->first == selector.bus &&
            bus_address->second == selector.address) {
          return i;
        }
      }
      return std::nullopt;
    case DeviceSelector::Kind::kSerial:
      for (size_t i = 0; i < devices.size(); ++i) {
        if (devices[i].serial == selector.serial) return i;
      }
      return std::nullopt;
  }
  return std::nullopt;
}

ClockOffsetFilter::ClockOffsetFilter(int window, int64_t reset_us)
    : window_(window), reset_us_(reset_us) {
  KESTREL_THROW_UNLESS(window >= 1, "window = " << window);
  KESTREL_THROW_UNLESS(reset_us > 0, "reset_us = " << reset_us);
}

bool ClockOffsetFilter::AddSample(int64_t device_us, int64_t host_us) {
  const int64_t sample = host_us - device_us;
  bool restarted = false;
  if (!samples_.empty() && std::llabs(sample - offset_us()) > reset_us_) {
    samples_.clear();
    ++resets_;
    restarted = true;
  }
  samples_.push_back(sample);
  while (static_cast<int>(samples_.size()) > window_) samples_.pop_front();
  return restarted;
}

int64_t ClockOffsetFilter::offset_us() const {
  if (samples_.empty()) return 0;
  std::vector<int64_t> sorted(samples_.begin(), samples_.end());
  const size_t mid = (sorted.size() - 1) / 2;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(mid), sorted.end());
  return sorted[mid];
}

int64_t ClockOffsetFilter::ToHostUtime(int64_t device_us) const {
  KESTREL_DEMAND(!samples_.empty());
  return device_us + offset_us();
}

std::vector<uint8_t> EncodeDepth(const std::vector<uint16_t>& counts, DepthEncoding encoding,
                                 int zlib_level) {
  std::vector<uint8_t> raw(counts.size() * 2);
  for (size_t i = 0; i < counts.size(); ++i) {
    raw[2 * i] = static_cast<uint8_t>(counts[i] & 0xff);
    raw[2 * i + 1] = static_cast<uint8_t>(counts[i] >> 8);
  }
  if (encoding == DepthEncoding::kRawU16) return raw;
  KESTREL_THROW_UNLESS(zlib_level >= 0 && zlib_level <= 9, "zlib_level = " << zlib_level);
  uLongf size = compressBound(static_cast<uLong>(raw.size()));
  std::vector<uint8_t> out(size);
  const int rc =
      compress2(out.data(), &size, raw.data(), static_cast<uLong>(raw.size()), zlib_level);
  if (rc != Z_OK) throw std::runtime_error("zlib compress2 failed: " + std::to_string(rc));
  out.resize(size);
  return out;
}

std::vector<uint16_t> DecodeDepth(const std::vector<uint8_t>& bytes, DepthEncoding encoding,
                                  size_t num_pixels) {
  std::vector<uint8_t> raw;
  if (encoding == DepthEncoding::kRawU16) {
    raw = bytes;
  } else {
    raw.resize(num_pixels * 2);
    uLongf size = static_cast<uLongf>(raw.size());
    const int rc = uncompress(raw.data(), &size, bytes.data(), static_cast<uLong>(bytes.size()));
    if (rc != Z_OK) throw std::runtime_error("zlib uncompress failed: " + std::to_string(rc));
    raw.resize(size);
  }
  if (raw.size() != num_pixels * 2) {
    throw std::runtime_error("depth payload holds " + std::to_string(raw.size()) +
                             " bytes, expected " + std::to_string(num_pixels * 2));
  }
  std::vector<uint16_t> counts(num_pixels);
  for (size_t i = 0; i < num_pixels; ++i) {
    counts[i] = static_cast<uint16_t>(raw[2 * i] | (raw[2 * i + 1] << 8));
  }
  return counts;
}

}  // namespace kestrel
