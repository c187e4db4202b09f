#pragma once
/// @file
/// Configuration of kestrel-hokuyo (config/drivers/hokuyo*.yaml).

#include <string>

#include "common/config.h"

namespace kestrel {

struct HokuyoConfig {
  std::string port{"/dev/ttyACM0"};    ///< serial device (or a stable /dev/serial/by-id link)
  std::string profile{"auto"};         ///< expected model: "auto", "URG-04LX" or "UTM-30LX"
  int baud{115200};                    ///< termios baud rate (USB CDC-ACM ignores it)
  std::string sensor_name{"hokuyo"};   ///< planar_scan_t.sensor_name (selects model + X_BS)
  std::string channel{"SCAN_HOKUYO"};  ///< LCM channel of the scans
  std::string heartbeat_channel{"HEARTBEAT_HOKUYO"};  ///< LCM channel of the heartbeat
  bool intensities{false};           ///< stream ME (range + intensity) instead of MD
  int scan_skip{0};                  ///< SCIP scan interval: scans skipped between two sent, 0..9
  int start_step{-1};                ///< first step streamed, -1 = AMIN of the sensor
  int end_step{-1};                  ///< last step streamed, -1 = AMAX of the sensor
  double reply_timeout_s{0.5};       ///< wait for a command's reply before retrying, s
  int command_retries{2};            ///< retries of a command before reopening the port
  double scan_timeout_s{0.5};        ///< no valid scan for this long while streaming: reopen, s
  double reopen_backoff_min_s{0.1};  ///< first delay before reopening the port, s
  double reopen_backoff_max_s{2.0};  ///< the delay doubles up to this, s
  int clock_sync_samples{15};        ///< TM1 round trips for the clock offset (median)
  /// Pause between TM1 round trips, s. Not a whole number of ms, so the samples fall at
  /// different phases of the sensor's millisecond and the median averages its quantisation.
  double clock_sync_spacing_s{0.0073};
  double drift_window_s{1.0};      ///< drift tracking: one minimum-latency sample per window, s
  int drift_windows{60};           ///< drift tracking: windows in the least-squares fit
  double max_drift_ppm{2000.0};    ///< drift estimates are clamped to +-this, 1e-6
  double heartbeat_period_s{1.0};  ///< heartbeat period, s

  /// @throws ConfigError naming the key, the value and the accepted range.
  void Validate() const;
};

/// Reads every key of HokuyoConfig that is present (absent keys keep their defaults) and
/// validates. @throws ConfigError
[[nodiscard]] HokuyoConfig LoadHokuyoConfig(const ConfigNode& node);

}  // namespace kestrel
