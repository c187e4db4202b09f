#include "drivers/usb/usb_discovery.h"

#include <libusb.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <sstream>

namespace kestrel {

std::string UsbSensor::Describe() const {
  char ids[16];
  std::snprintf(ids, sizeof(ids), "%04x:%04x", vendor_id, product_id);
  std::ostringstream s;
  s << SensorKindName(kind) << ' ' << ids << " bus " << bus << " address " << address << " serial "
    << (serial.empty() ? "(unreadable)" : serial);
  if (!tty.empty()) s << " tty " << tty;
  if (!sysfs_name.empty()) s << " sysfs " << sysfs_name;
  return s.str();
}

std::vector<UsbSensor> SensorsFromSysfs(const std::vector<SysfsUsbDevice>& devices) {
  std::vector<UsbSensor> sensors;
  for (const SysfsUsbDevice& d : devices) {
    const auto kind = MatchSensor(d.vendor_id, d.product_id);
    if (!kind) continue;
    UsbSensor s;
    s.kind = *kind;
    s.vendor_id = d.vendor_id;
    s.product_id = d.product_id;
    s.bus = d.bus;
    s.address = d.address;
    s.serial = d.serial;
    s.tty = d.ttys.empty() ? "" : d.ttys.front();
    s.sysfs_name = d.name;
    sensors.push_back(std::move(s));
  }
  return sensors;
}

std::vector<std::string> FindHokuyoTtys(const std::string& sysfs_root) {
  std::vector<std::string> ttys;
  for (const UsbSensor& s : SensorsFromSysfs(ScanSysfsUsbDevices(sysfs_root))) {
    if (s.kind == SensorKind::kHokuyo && !s.tty.empty()) ttys.push_back(s.tty);
  }
  return ttys;
}

std::string OpenNiUri(const UsbSensor& sensor) {
  char uri[64];
  std::snprintf(uri, sizeof(uri), "%04x/%04x@%d/%d", sensor.vendor_id, sensor.product_id,
                sensor.bus, sensor.address);
  return uri;
}

bool DevicePresence::Arrive(int bus, int address) {
  if (present_.insert({bus, address}).second) return true;
  ++duplicates_;
  return false;
}

bool DevicePresence::Leave(int bus, int address) {
  if (present_.erase({bus, address}) > 0) return true;
  ++duplicates_;
  return false;
}

std::unique_ptr<UsbDiscovery> UsbDiscovery::Open(const std::string& sysfs_root,
                                                 std::string* error) {
  libusb_context* context = nullptr;
  const int rc = libusb_init(&context);
  if (rc != LIBUSB_SUCCESS) {
    if (error != nullptr) {
      *error = std::string("libusb_init failed: ") + libusb_error_name(rc) +
               " (no USB device nodes, e.g. /dev/bus/usb absent in a container)";
    }
    return nullptr;
  }
  return std::unique_ptr<UsbDiscovery>(new UsbDiscovery(context, sysfs_root));
}

UsbDiscovery::UsbDiscovery(libusb_context* context, std::string sysfs_root)
    : context_(context), sysfs_root_(std::move(sysfs_root)) {}

UsbDiscovery::~UsbDiscovery() {
  StopWatch();
  libusb_exit(context_);
}

UsbSensor UsbDiscovery::Describe(libusb_device* device, SensorKind kind, bool try_open) const {
  libusb_device_descriptor descriptor{};
  libusb_get_device_descriptor(device, &descriptor);  // cached: cannot fail since libusb 1.0.16
  UsbSensor sensor;
  sensor.kind = kind;
  sensor.vendor_id = descriptor.idVendor;
  sensor.product_id = descriptor.idProduct;
  sensor.bus = libusb_get_bus_number(device);
  sensor.address = libusb_get_device_address(device);
  if (try_open && descriptor.iSerialNumber != 0) {
    libusb_device_handle* handle = nullptr;
    if (libusb_open(device, &handle) == LIBUSB_SUCCESS) {
      unsigned char text[256];
      const int n =
          libusb_get_string_descriptor_ascii(handle, descriptor.iSerialNumber, text, sizeof(text));
      if (n > 0) sensor.serial.assign(reinterpret_cast<const char*>(text), static_cast<size_t>(n));
      libusb_close(handle);
    }
  }
  if (const auto sysfs = FindSysfsDevice(sysfs_root_, sensor.bus, sensor.address)) {
    if (sensor.serial.empty()) sensor.serial = sysfs->serial;
    sensor.tty = sysfs->ttys.empty() ? "" : sysfs->ttys.front();
    sensor.sysfs_name = sysfs->name;
  }
  return sensor;
}

std::vector<UsbSensor> UsbDiscovery::List() {
  std::vector<UsbSensor> sensors;
  libusb_device** list = nullptr;
  const ssize_t n = libusb_get_device_list(context_, &list);
  for (ssize_t i = 0; i < n; ++i) {
    libusb_device_descriptor descriptor{};
    if (libusb_get_device_descriptor(list[i], &descriptor) != LIBUSB_SUCCESS) continue;
    const auto kind = MatchSensor(descriptor.idVendor, descriptor.idProduct);
    if (kind) sensors.push_back(Describe(list[i], *kind, /*try_open=*/true));
  }
  if (list != nullptr) libusb_free_device_list(list, 1);
  std::sort(sensors.begin(), sensors.end(),
            [](const UsbSensor& a, const UsbSensor& b) { return a.key() < b.key(); });
  return sensors;
}

bool UsbDiscovery::has_hotplug() const {
  return libusb_has_capability(LIBUSB_CAP_HAS_HOTPLUG) != 0;
}

struct UsbHotplugAccess {
  static int Callback(libusb_context*, libusb_device* device, libusb_hotplug_event event,
                      void* user_data) {
    static_cast<UsbDiscovery*>(user_data)->HandleHotplug(
        device, event == LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED);
    return 0;  // stay registered
  }
};

void UsbDiscovery::HandleHotplug(libusb_device* device, bool arrived) {
  libusb_device_descriptor descriptor{};
  if (libusb_get_device_descriptor(device, &descriptor) != LIBUSB_SUCCESS) return;
  const auto kind = MatchSensor(descriptor.idVendor, descriptor.idProduct);
  if (!kind) return;
  // libusb_open is not allowed inside a hot-plug callback: serial and tty come from sysfs.
  UsbEvent e;
  e.arrived = arrived;
  e.sensor = Describe(device, *kind, /*try_open=*/false);
  bool real;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    real = arrived ? presence_.Arrive(e.sensor.bus, e.sensor.address)
                   : presence_.Leave(e.sensor.bus, e.sensor.address);
  }
  if (real && callback_) callback_(e);
}

bool UsbDiscovery::StartWatch(Callback callback, std::string* error) {
  if (watching_) return true;
  if (!has_hotplug()) {
    if (error != nullptr) *error = "libusb has no hot-plug support on this platform";
    return false;
  }
  callback_ = std::move(callback);
  stop_ = false;
  thread_ = std::thread([this] {
    while (!stop_) {
      timeval tv{0, 100000};
      libusb_handle_events_timeout_completed(context_, &tv, nullptr);
    }
  });
  // ENUMERATE: the callback runs for every device already present from inside this call (this
  // thread); the event thread may report the same arrival again: DevicePresence drops it.
  const int rc = libusb_hotplug_register_callback(
      context_,
      static_cast<libusb_hotplug_event>(LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED |
                                        LIBUSB_HOTPLUG_EVENT_DEVICE_LEFT),
      LIBUSB_HOTPLUG_ENUMERATE, LIBUSB_HOTPLUG_MATCH_ANY, LIBUSB_HOTPLUG_MATCH_ANY,
      LIBUSB_HOTPLUG_MATCH_ANY, &UsbHotplugAccess::Callback, this, &hotplug_handle_);
  if (rc != LIBUSB_SUCCESS) {
    stop_ = true;
    thread_.join();
    if (error != nullptr) {
      *error = std::string("libusb_hotplug_register_callback: ") + libusb_error_name(rc);
    }
    return false;
  }
  watching_ = true;
  return true;
}

void UsbDiscovery::StopWatch() {
  if (watching_) {
    libusb_hotplug_deregister_callback(context_, hotplug_handle_);  // wakes the event thread
    watching_ = false;
  }
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

int64_t UsbDiscovery::duplicate_events() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return presence_.duplicates();
}

void WatchSysfs(const std::string& sysfs_root, double duration_s, double period_s,
                const std::function<void(const UsbEvent&)>& callback,
                const std::atomic<bool>* stop) {
  using Clock = std::chrono::steady_clock;
  const auto end = Clock::now() + std::chrono::duration<double>(duration_s);
  std::map<std::tuple<int, int>, UsbSensor> present;
  while (true) {
    std::map<std::tuple<int, int>, UsbSensor> now;
    for (UsbSensor& s : SensorsFromSysfs(ScanSysfsUsbDevices(sysfs_root))) {
      now.emplace(s.key(), std::move(s));
    }
    for (const auto& [key, sensor] : present) {
      if (now.count(key) == 0) callback(UsbEvent{false, sensor});
    }
    for (const auto& [key, sensor] : now) {
      if (present.count(key) == 0) callback(UsbEvent{true, sensor});
    }
    present = std::move(now);
    if (Clock::now() >= end || (stop != nullptr && *stop)) break;
    std::this_thread::sleep_for(std::chrono::duration<double>(period_s));
  }
}

}  // namespace kestrel
