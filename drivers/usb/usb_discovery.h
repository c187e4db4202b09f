#pragma once
/// @file
/// USB discovery of Kestrel's sensors with libusb-1.0 (docs/protocols.md §4.2): list the
/// attached Hokuyo and Xtion devices (VID:PID, bus/address, serial, the CDC-ACM tty from sysfs),
/// and watch hot-plug (libusb_hotplug_register_callback with ENUMERATE, callbacks on an event
/// thread, double arrivals de-duplicated). Where libusb cannot start (a container without
/// /dev/bus/usb) or has no hot-plug support, the same answers come from sysfs alone.

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "drivers/usb/usb_sysfs.h"

struct libusb_context;
struct libusb_device;

namespace kestrel {

/// One attached sensor.
struct UsbSensor {
  SensorKind kind{SensorKind::kHokuyo};  ///< which sensor the VID:PID says
  uint16_t vendor_id{0};                 ///< idVendor
  uint16_t product_id{0};                ///< idProduct
  int bus{0};                            ///< USB bus number
  int address{0};                        ///< device address on the bus (changes on replug)
  std::string serial;                    ///< "" when neither libusb nor sysfs could read it
  std::string tty;                       ///< "/dev/ttyACM0" for a CDC-ACM sensor, "" otherwise
  std::string sysfs_name;                ///< e.g. "1-1.2", "" if sysfs does not show the device

  /// "hokuyo 15d1:0000 bus 1 address 5 serial H123 tty /dev/ttyACM0".
  [[nodiscard]] std::string Describe() const;
  /// Identity for de-duplication: (bus, address) is unique while the device is attached.
  [[nodiscard]] std::tuple<int, int> key() const { return {bus, address}; }
};

/// The sensors among sysfs devices (pure over the list).
[[nodiscard]] std::vector<UsbSensor> SensorsFromSysfs(const std::vector<SysfsUsbDevice>& devices);

/// The ttys of the attached Hokuyos in (bus, address) order, from sysfs alone (no libusb needed):
/// what kestrel-hokuyo can open when no port is named. Hokuyos without a tty are skipped.
[[nodiscard]] std::vector<std::string> FindHokuyoTtys(const std::string& sysfs_root);

/// OpenNI2's device URI for a PS1080-family sensor, "vvvv/pppp@bus/address" (lowercase hex ids,
/// decimal bus and address, e.g. "1d27/0601@2/7"): the "%04hx/%04hx@%hhu/%hhu" that OpenNI's
/// Linux USB layer (XnUSBLinux.cpp, xnUSBEnumerateDevices) gives each device; for kestrel-xtion's
/// bus@address selection.
[[nodiscard]] std::string OpenNiUri(const UsbSensor& sensor);

/// De-duplicates hot-plug events: libusb may report an arrival twice (ENUMERATE racing a real
/// arrival) and a departure for a device never reported. Not thread-safe; guard it.
class DevicePresence {
 public:
  /// True if the device was not present (a real arrival); false for a duplicate.
  bool Arrive(int bus, int address);
  /// True if the device was present (a real departure); false otherwise.
  bool Leave(int bus, int address);
  [[nodiscard]] size_t size() const { return present_.size(); }
  [[nodiscard]] int64_t duplicates() const { return duplicates_; }

 private:
  std::set<std::pair<int, int>> present_;
  int64_t duplicates_{0};
};

/// A hot-plug event delivered to the user.
struct UsbEvent {
  bool arrived{true};  ///< false: left
  UsbSensor sensor;    ///< the sensor (for "left": as it was described at that moment)
};

/// libusb-1.0 context for listing and watching. Neither copyable nor movable.
class UsbDiscovery {
 public:
  /// Receives each real arrival or departure.
  using Callback = std::function<void(const UsbEvent&)>;

  /// Initialises libusb. Returns nullptr and sets *error (libusb's error name and a hint) when
  /// libusb_init fails, e.g. in a container without /dev/bus/usb. `sysfs_root` ("/sys") is where
  /// serials and ttys are looked up.
  static std::unique_ptr<UsbDiscovery> Open(const std::string& sysfs_root, std::string* error);
  /// Stops any watch and calls libusb_exit.
  ~UsbDiscovery();
  UsbDiscovery(const UsbDiscovery&) = delete;
  UsbDiscovery& operator=(const UsbDiscovery&) = delete;

  /// The attached sensors, sorted by (bus, address). The serial comes from the device (if it can
  /// be opened) or else from sysfs.
  [[nodiscard]] std::vector<UsbSensor> List();

  /// True when this libusb supports hot-plug on this platform.
  [[nodiscard]] bool has_hotplug() const;
  /// Registers the hot-plug callback (ENUMERATE: present devices arrive first) and starts the
  /// event thread. `callback` runs once per real arrival or departure, on the event thread or,
  /// for devices already present, on the calling thread during StartWatch (as libusb does);
  /// it must be thread-safe.
  /// Returns false with *error if registration fails.
  bool StartWatch(Callback callback, std::string* error);
  /// Deregisters and joins the event thread (also done by the destructor).
  void StopWatch();
  /// Hot-plug events dropped as duplicates so far.
  [[nodiscard]] int64_t duplicate_events() const;

 private:
  UsbDiscovery(libusb_context* context, std::string sysfs_root);
  friend struct UsbHotplugAccess;  // the C callback in the .cc
  void HandleHotplug(::libusb_device* device, bool arrived);
  [[nodiscard]] UsbSensor Describe(::libusb_device* device, SensorKind kind, bool try_open) const;

  libusb_context* context_;
  std::string sysfs_root_;
  Callback callback_;
  int hotplug_handle_{0};
  bool watching_{false};
  std::atomic<bool> stop_{false};
  std::thread thread_;
  mutable std::mutex mutex_;
  DevicePresence presence_;
};

/// Sysfs-only watch (no libusb): scans every `period_s` and reports differences, each arrival or
/// departure once, until `duration_s` has passed or `stop` becomes true. Present devices arrive
/// first, as with ENUMERATE.
void WatchSysfs(const std::string& sysfs_root, double duration_s, double period_s,
                const std::function<void(const UsbEvent&)>& callback,
                const std::atomic<bool>* stop = nullptr);

}  // namespace kestrel
