#pragma once
/// @file
/// Configuration of Kestrel's OpenNI2 test plugin, read from environment variables when OpenNI2
/// initializes the driver (a driver plugin has no other input):
///
///   KESTREL_ONI_SOURCE              synthetic (default) | files:DIR | lcm:URL
///   KESTREL_ONI_LCM_CHANNEL         channel of depth_image_t for lcm:URL (default
///   SIM_DEPTH_XTION);
///                                   one OpenNI2 frame per message, device time = message utime
///                                   + clock offset (default offset 0 for this source)
///   KESTREL_ONI_DEVICES             number of devices announced, 1..8 (default 1)
///   KESTREL_ONI_WALL_M              synthetic wall distance at frame 0, metres (default 2.0);
///                                   device i (0-based) sees it at WALL_M + 0.25 * i
///   KESTREL_ONI_WALL_TILT_DEG       wall rotation about the camera y axis, degrees (default 17)
///   KESTREL_ONI_WALL_PITCH_DEG      wall normal's tilt towards +y, degrees (default 8)
///   KESTREL_ONI_CLOCK_OFFSET_US     device clock minus host clock (CLOCK_REALTIME), us; default:
///                                   the device clock reads 1 s when the plugin is loaded
///   KESTREL_ONI_CLOCK_DRIFT_PPM     the device clock runs fast by this many ppm (default 0)
///   KESTREL_ONI_FAULT_LOSS_AFTER_FRAMES  N > 0: after N frames (over all streams) the device
///                                   is lost (state ERROR, disconnected, streams fall silent)
///   KESTREL_ONI_FAULT_LOSS_MS       ... and is announced again after this many ms (default 1000)
///   KESTREL_ONI_FAULT_LOSS_COUNT    how many losses in total, each N frames after the previous
///                                   return (default 1)
///   KESTREL_ONI_FAULT_STALL_AFTER_FRAMES  N > 0: after N frames every stream falls silent for
///                                   KESTREL_ONI_FAULT_STALL_MS (default 1000) while the device
///                                   stays connected and no event is raised (a USB hiccup), once
///   KESTREL_ONI_FAULT_SKIP_EVERY    N > 1: frame indices N, 2N, ... are never delivered (drops)
///   KESTREL_ONI_MIRROR_DEFAULT      1: depth streams start mirrored (left-right), 0 (default): not
///   KESTREL_ONI_VERBOSE             1: log the plugin's events to stderr
///
/// Unless KESTREL_ONI_CLOCK_OFFSET_US is given, the device clock restarts at 1 s whenever a lost
/// device returns (as a re-plugged PS1080's does).

#include <cstdint>
#include <functional>
#include <string>

#include "drivers/xtion/openni_plugin/synthetic_scene.h"

namespace kestrel::oni_plugin {

struct PluginConfig {
  std::string source{"synthetic"};             ///< "synthetic", "files" or "lcm"
  std::string files_dir;                       ///< folder of *.raw frames when source == "files"
  std::string lcm_url;                         ///< LCM provider URL when source == "lcm"
  std::string lcm_channel{"SIM_DEPTH_XTION"};  ///< depth_image_t channel when source == "lcm"
  int num_devices{1};                          ///< devices announced, 1..8
  WallScene wall;                              ///< the synthetic scene of device 0
  bool clock_offset_given{false};              ///< true if KESTREL_ONI_CLOCK_OFFSET_US was set
  int64_t clock_offset_us{0};                  ///< device minus host time, us (when given)
  double clock_drift_ppm{0.0};      ///< device clock rate error, ppm (synthetic / files sources)
  int64_t loss_after_frames{0};     ///< 0: no fault
  int64_t loss_duration_ms{1000};   ///< time the device stays away, ms
  int loss_count{1};                ///< number of losses
  int64_t stall_after_frames{0};    ///< 0: no stall
  int64_t stall_duration_ms{1000};  ///< silence of the stall, ms
  int64_t skip_every_frames{0};     ///< 0: no skipped frames
  bool mirror_default{false};       ///< streams start mirrored
  bool verbose{false};              ///< log events to stderr
};

/// Reads the configuration through `getenv` (std::getenv in the plugin, a map in tests).
/// @throws std::invalid_argument naming the variable and the accepted values on a bad value.
[[nodiscard]] PluginConfig ReadPluginConfig(
    const std::function<const char*(const char*)>& getenv_fn);

/// The URI of device `index` (0-based), in the PS1080 style "1d27/0600@1/<10+index>".
[[nodiscard]] std::string DeviceUri(int index);
/// The serial number of device `index`: "KXT000<index>" style, 10 characters.
[[nodiscard]] std::string DeviceSerial(int index);

}  // namespace kestrel::oni_plugin
