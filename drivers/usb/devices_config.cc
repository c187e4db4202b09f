#include "drivers/usb/devices_config.h"

#include <cmath>
#include <stdexcept>

#include "common/check.h"
#include "common/config.h"

namespace kestrel {

void DevicesConfig::Validate() const {
  KESTREL_THROW_UNLESS(!sysfs_root.empty(), "devices.sysfs_root is empty, accepted a directory");
  KESTREL_THROW_UNLESS(std::isfinite(poll_period_s) && poll_period_s > 0.0 && poll_period_s <= 10.0,
                       "devices.poll_period_s = " << poll_period_s << ", accepted (0, 10]");
}

DevicesConfig LoadDevicesConfig(const ConfigNode& node) {
  DevicesConfig config;
  node.Read("sysfs_root", &config.sysfs_root);
  node.Read("use_libusb", &config.use_libusb);
  node.Read("poll_period_s", &config.poll_period_s, Range{0.0, 10.0, false, true});
  try {
    config.Validate();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(node.file() + ": " + e.what());
  }
  return config;
}

}  // namespace kestrel
