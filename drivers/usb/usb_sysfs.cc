#include "drivers/usb/usb_sysfs.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>

namespace kestrel {
namespace {

namespace fs = std::filesystem;

// The first line of a small attribute file, without trailing whitespace; nullopt if unreadable.
std::optional<std::string> ReadAttribute(const fs::path& path) {
  std::ifstream in(path);
  if (!in) return std::nullopt;
  std::string line;
  std::getline(in, line);
  while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
  return line;
}

std::string Trim(const std::string& text) {
  size_t begin = 0, end = text.size();
  while (begin < end && std::isspace(static_cast<unsigned char>(text[begin]))) ++begin;
  while (end > begin && std::isspace(static_cast<unsigned char>(text[end - 1]))) --end;
  return text.substr(begin, end - begin);
}

}  // namespace

const char* SensorKindName(SensorKind kind) {
  return kind == SensorKind::kHokuyo ? "hokuyo" : "xtion";
}

std::optional<SensorKind> MatchSensor(uint16_t vendor_id, uint16_t product_id) {
  if (vendor_id == kHokuyoVendorId && product_id == kHokuyoProductId) return SensorKind::kHokuyo;
  if (vendor_id == kXtionVendorId) {
    for (const uint16_t pid : kXtionProductIds) {
      if (product_id == pid) return SensorKind::kXtion;
    }
  }
  return std::nullopt;
}

std::optional<uint16_t> ParseHex16(const std::string& text) {
  const std::string t = Trim(text);
  if (t.empty() || t.size() > 4) return std::nullopt;
  uint16_t value = 0;
  for (const char c : t) {
    if (!std::isxdigit(static_cast<unsigned char>(c))) return std::nullopt;
    const int digit = std::isdigit(static_cast<unsigned char>(c))
                          ? c - '0'
                          : std::tolower(static_cast<unsigned char>(c)) - 'a' + 10;
    value = static_cast<uint16_t>(value * 16 + digit);
  }
  return value;
}

std::optional<int> ParseDecimal(const std::string& text) {
  const std::string t = Trim(text);
  if (t.empty() || t.size() > 9) return std::nullopt;
  int value = 0;
  for (const char c : t) {
    if (!std::isdigit(static_cast<unsigned char>(c))) return std::nullopt;
    value = value * 10 + (c - '0');
  }
  return value;
}

std::vector<std::string> FindTtys(const std::string& device_dir, const std::string& device_name) {
  std::vector<std::string> ttys;
  std::error_code ec;
  const std::string interface_prefix = device_name + ":";
  for (fs::directory_iterator it(device_dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string interface_name = it->path().filename().string();
    if (interface_name.rfind(interface_prefix, 0) != 0) continue;  // not an interface of it
    std::error_code inner;
    // Current layout: <interface>/tty/ttyACM0/
    for (fs::directory_iterator t(it->path() / "tty", inner), tend; !inner && t != tend;
         t.increment(inner)) {
      ttys.push_back("/dev/" + t->path().filename().string());
    }
    // Older layout: <interface>/tty:ttyACM0
    inner.clear();
    for (fs::directory_iterator t(it->path(), inner), tend; !inner && t != tend;
         t.increment(inner)) {
      const std::string entry = t->path().filename().string();
      if (entry.rfind("tty:", 0) == 0 && entry.size() > 4)
        ttys.push_back("/dev/" + entry.substr(4));
    }
  }
  std::sort(ttys.begin(), ttys.end());
  ttys.erase(std::unique(ttys.begin(), ttys.end()), ttys.end());
  return ttys;
}

std::vector<SysfsUsbDevice> ScanSysfsUsbDevices(const std::string& sysfs_root) {
  std::vector<SysfsUsbDevice> devices;
  const fs::path devices_dir = fs::path(sysfs_root) / "bus" / "usb" / "devices";
  std::error_code ec;
  for (fs::directory_iterator it(devices_dir, ec), end; !ec && it != end; it.increment(ec)) {
    const fs::path dir = it->path();  // usually a symlink into /sys/devices
    const std::string name = dir.filename().string();
    const auto vid = ReadAttribute(dir / "idVendor");
    const auto pid = ReadAttribute(dir / "idProduct");
    const auto bus = ReadAttribute(dir / "busnum");
    const auto address = ReadAttribute(dir / "devnum");
    if (!vid || !pid || !bus || !address) continue;  // an interface, or not readable
    SysfsUsbDevice device;
    device.name = name;
    const auto v = ParseHex16(*vid);
    const auto p = ParseHex16(*pid);
    const auto b = ParseDecimal(*bus);
    const auto a = ParseDecimal(*address);
    if (!v || !p || !b || !a) continue;  // malformed attributes: not a device we can name
    device.vendor_id = *v;
    device.product_id = *p;
    device.bus = *b;
    device.address = *a;
    device.serial = ReadAttribute(dir / "serial").value_or("");
    device.manufacturer = ReadAttribute(dir / "manufacturer").value_or("");
    device.product = ReadAttribute(dir / "product").value_or("");
    device.ttys = FindTtys(dir.string(), name);
    devices.push_back(std::move(device));
  }
  std::sort(devices.begin(), devices.end(), [](const SysfsUsbDevice& x, const SysfsUsbDevice& y) {
    return x.bus != y.bus ? x.bus < y.bus : x.address < y.address;
  });
  return devices;
}

std::optional<SysfsUsbDevice> FindSysfsDevice(const std::string& sysfs_root, int bus, int address) {
  for (SysfsUsbDevice& device : ScanSysfsUsbDevices(sysfs_root)) {
    if (device.bus == bus && device.address == address) return std::move(device);
  }
  return std::nullopt;
}

}  // namespace kestrel
