#pragma once
/// @file
/// Kestrel's USB sensors by VID:PID, and the Linux sysfs side of discovery: the attributes of each
/// USB device under <root>/bus/usb/devices/<name>/ (idVendor, idProduct, busnum, devnum, serial,
/// manufacturer, product) and the tty a CDC-ACM interface exposes
/// (<device>/<name>:<config>.<interface>/tty/ttyACM<n>, or the older .../tty:ttyACM<n>).
/// These functions only read files under the given root, so tests run them on a fake tree.
/// docs/protocols.md §4.1.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace kestrel {

/// The sensors Kestrel looks for.
enum class SensorKind { kHokuyo, kXtion };

/// "hokuyo" / "xtion".
[[nodiscard]] const char* SensorKindName(SensorKind kind);

/// USB ids: Hokuyo URG/UTM (CDC-ACM) 15d1:0000; ASUS Xtion (PrimeSense PS1080) 1d27:0600, 0601.
inline constexpr uint16_t kHokuyoVendorId = 0x15d1;
inline constexpr uint16_t kHokuyoProductId = 0x0000;
inline constexpr uint16_t kXtionVendorId = 0x1d27;
inline constexpr uint16_t kXtionProductIds[] = {0x0600, 0x0601};

/// The sensor a VID:PID belongs to, or nullopt for any other device.
[[nodiscard]] std::optional<SensorKind> MatchSensor(uint16_t vendor_id, uint16_t product_id);

/// Parses a sysfs id file's text ("15d1\n") as 1..4 hex digits; nullopt otherwise.
[[nodiscard]] std::optional<uint16_t> ParseHex16(const std::string& text);
/// Parses a sysfs decimal file's text ("3\n") as a non-negative int; nullopt otherwise.
[[nodiscard]] std::optional<int> ParseDecimal(const std::string& text);

/// One USB device as sysfs describes it.
struct SysfsUsbDevice {
  std::string name;               ///< sysfs name, e.g. "1-1.2" (bus 1, port path 1.2)
  uint16_t vendor_id{0};          ///< idVendor
  uint16_t product_id{0};         ///< idProduct
  int bus{0};                     ///< busnum
  int address{0};                 ///< devnum (the libusb device address)
  std::string serial;             ///< "serial" attribute, "" if absent
  std::string manufacturer;       ///< "manufacturer", "" if absent
  std::string product;            ///< "product", "" if absent
  std::vector<std::string> ttys;  ///< "/dev/ttyACM0"... of its interfaces, sorted
};

/// Every USB device (entries with idVendor; interfaces and unreadable entries are skipped) under
/// `sysfs_root`/bus/usb/devices, sorted by (bus, address). An absent directory gives {}.
[[nodiscard]] std::vector<SysfsUsbDevice> ScanSysfsUsbDevices(const std::string& sysfs_root);

/// The ttys under one device directory: for each interface subdirectory "<name>:<c>.<i>", the
/// entries of its "tty/" subdirectory and any "tty:<x>" entry, as "/dev/<x>", sorted.
[[nodiscard]] std::vector<std::string> FindTtys(const std::string& device_dir,
                                                const std::string& device_name);

/// The device at (bus, address), if sysfs has it.
[[nodiscard]] std::optional<SysfsUsbDevice> FindSysfsDevice(const std::string& sysfs_root, int bus,
                                                            int address);

}  // namespace kestrel
