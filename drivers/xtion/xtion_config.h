#pragma once
/// @file
/// Configuration of kestrel-xtion (config/drivers/xtion.yaml): which device, the depth mode, the
/// payload encoding, the clock offset filter and the recovery timing.

#include <string>

#include "common/config.h"

namespace kestrel {

struct XtionConfig {
  std::string device;                      ///< "" first, "#N" (1-based), "BUS@ADDRESS" or a serial
  int width{640};                          ///< depth mode width, pixels (320 or 640)
  int height{480};                         ///< depth mode height, pixels (240 or 480)
  int fps{30};                             ///< depth mode frame rate, Hz (QVGA: 30/60, VGA: 30)
  std::string pixel_format{"depth_1_mm"};  ///< "depth_1_mm" or "depth_100_um"
  std::string encoding{"zlib"};            ///< "raw" or "zlib" (depth_image_t ENCODING_*)
  int zlib_level{1};                       ///< compress2 level, 0..9
  std::string sensor_name{"xtion"};        ///< depth_image_t.sensor_name
  std::string channel{"DEPTH_XTION"};      ///< output channel
  std::string heartbeat_channel{"HEARTBEAT_XTION"};  ///< heartbeat channel
  double range_min_m{0.8};         ///< valid range published with each image, m (ASUS spec)
  double range_max_m{3.5};         ///< valid range published with each image, m
  int offset_window{31};           ///< frames in the median clock-offset window, >= 1
  double offset_reset_s{0.5};      ///< a sample this far from the median restarts the window
  double frame_timeout_s{1.0};     ///< no frame for this long while streaming = device lost
  double reopen_initial_s{0.25};   ///< first wait before reopening after a loss, s
  double reopen_max_s{4.0};        ///< back-off ceiling (the wait doubles per failure), s
  double heartbeat_period_s{1.0};  ///< heartbeat period, s (<= 1 s, docs/design.md §2.2)

  /// Checks the cross-field rules (supported mode, min < max, device id syntax).
  /// @throws std::invalid_argument whose text opens with the key, then value and accepted range.
  void Validate() const;
};

/// Reads every key of `node` into an XtionConfig (absent keys keep their defaults) and validates.
/// @throws ConfigError
[[nodiscard]] XtionConfig LoadXtionConfig(const ConfigNode& node);

}  // namespace kestrel
