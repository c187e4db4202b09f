#include "drivers/xtion/xtion_config.h"

#include <stdexcept>

#include "drivers/xtion/xtion_pure.h"

namespace kestrel {

void XtionConfig::Validate() const {
  const bool qvga = width == 320 && height == 240 && (fps == 30 || fps == 60);
  const bool vga = width == 640 && height == 480 && fps == 30;
  if (!qvga && !vga) {
    throw std::invalid_argument("width/height/fps = " + std::to_string(width) + "/" +
                                std::to_string(height) + "/" + std::to_string(fps) +
                                ": accepted 320/240/30, 320/240/60, 640/480/30");
  }
  if (pixel_format != "depth_1_mm" && pixel_format != "depth_100_um") {
    throw std::invalid_argument("pixel_format = '" + pixel_format +
                                "': accepted depth_1_mm, depth_100_um");
  }
  if (encoding != "raw" && encoding != "zlib") {
    throw std::invalid_argument("encoding = '" + encoding + "': accepted raw, zlib");
  }
  if (zlib_level < 0 || zlib_level > 9) {
    throw std::invalid_argument("zlib_level = " + std::to_string(zlib_level) + ": accepted [0, 9]");
  }
  if (!(range_min_m >= 0.0 && range_min_m < range_max_m)) {
    throw std::invalid_argument("range_min_m = " + std::to_string(range_min_m) +
                                ", range_max_m = " + std::to_string(range_max_m) +
                                ": accepted 0 <= range_min_m < range_max_m");
  }
  if (offset_window < 1) {
    throw std::invalid_argument("offset_window = " + std::to_string(offset_window) +
                                ": accepted >= 1");
  }
  if (!(reopen_initial_s > 0.0 && reopen_initial_s <= reopen_max_s)) {
    throw std::invalid_argument("reopen_initial_s = " + std::to_string(reopen_initial_s) +
                                ", reopen_max_s = " + std::to_string(reopen_max_s) +
                                ": accepted 0 < reopen_initial_s <= reopen_max_s");
  }
  if (channel.empty() || heartbeat_channel.empty()) {
    throw std::invalid_argument("channel and heartbeat_channel must not be empty");
  }
  (void)ParseDeviceSelector(device);  // throws std::invalid_argument on a malformed device id
}

XtionConfig LoadXtionConfig(const ConfigNode& node) {
  XtionConfig c;
  node.Read("device", &c.device);
  node.Read("width", &c.width, Range::Positive());
  node.Read("height", &c.height, Range::Positive());
  node.Read("fps", &c.fps, Range::Positive());
  node.Read("pixel_format", &c.pixel_format, {"depth_1_mm", "depth_100_um"});
  node.Read("encoding", &c.encoding, {"raw", "zlib"});
  node.Read("zlib_level", &c.zlib_level, Range::Closed(0, 9));
  node.Read("sensor_name", &c.sensor_name);
  node.Read("channel", &c.channel);
  node.Read("heartbeat_channel", &c.heartbeat_channel);
  node.Read("range_min_m", &c.range_min_m, Range::NonNegative());
  node.Read("range_max_m", &c.range_max_m, Range::Positive());
  node.Read("offset_window", &c.offset_window, Range::Closed(1, 1001));
  node.Read("offset_reset_s", &c.offset_reset_s, Range::Positive());
  node.Read("frame_timeout_s", &c.frame_timeout_s, Range::Positive());
  node.Read("reopen_initial_s", &c.reopen_initial_s, Range::Positive());
  node.Read("reopen_max_s", &c.reopen_max_s, Range::Positive());
  node.Read("heartbeat_period_s", &c.heartbeat_period_s, Range::Closed(0.01, 1.0));
  try {
    c.Validate();
  } catch (const std::invalid_argument& e) {
    // The messages open with the key. ConfigNode::Fail needs the key present in the document (it
    // throws yaml-cpp's "invalid node" for an absent one), and a cross-field rule can trip on
    // defaults, so name the file and let the message name the key.
    const std::string what = e.what();
    const std::string key = what.substr(0, what.find_first_of(" /"));
    if (node.Has(key)) node.Fail(key, what);
    throw ConfigError(node.file() + ": " + what);
  }
  return c;
}

}  // namespace kestrel
