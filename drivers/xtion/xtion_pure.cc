#include "drivers/xtion/xtion_pure.h"

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

}  // namespace kestrel
