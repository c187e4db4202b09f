#pragma once
/// @file
/// Configuration of kestrel-devices (config/drivers/devices.yaml).

#include <string>

namespace kestrel {

class ConfigNode;

struct DevicesConfig {
  std::string sysfs_root{"/sys"};  ///< sysfs mount point (tests point it at a fake tree)
  bool use_libusb{true};           ///< false: sysfs only (also the fallback when libusb_init fails)
  double poll_period_s{0.5};       ///< sysfs watch scan period, s, (0, 10]

  /// Throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// Reads and validates a DevicesConfig. @throws ConfigError
[[nodiscard]] DevicesConfig LoadDevicesConfig(const ConfigNode& node);

}  // namespace kestrel
