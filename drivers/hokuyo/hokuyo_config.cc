#include "drivers/hokuyo/hokuyo_config.h"

#include <sstream>

namespace kestrel {
namespace {

[[noreturn]] void Reject(const std::string& key, const std::string& value,
                         const std::string& accepted) {
  throw ConfigError("hokuyo config: " + key + " = " + value + " is outside " + accepted);
}

template <typename T>
std::string Str(const T& v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

}  // namespace

void HokuyoConfig::Validate() const {
  if (port.empty()) Reject("port", "\"\"", "a device path");
  if (profile != "auto" && profile != "URG-04LX" && profile != "UTM-30LX") {
    Reject("profile", profile, "{auto, URG-04LX, UTM-30LX}");
  }
  if (sensor_name.empty()) Reject("sensor_name", "\"\"", "a non-empty name");
  if (channel.empty()) Reject("channel", "\"\"", "a non-empty channel");
  if (heartbeat_channel.empty()) Reject("heartbeat_channel", "\"\"", "a non-empty channel");
  if (scan_skip < 0 || scan_skip > 9) Reject("scan_skip", Str(scan_skip), "[0, 9]");
  if (start_step < -1 || start_step > 9999) Reject("start_step", Str(start_step), "[-1, 9999]");
  if (end_step < -1 || end_step > 9999) Reject("end_step", Str(end_step), "[-1, 9999]");
  if (start_step >= 0 && end_step >= 0 && end_step < start_step) {
    Reject("end_step", Str(end_step), "[start_step = " + Str(start_step) + ", 9999]");
  }
  if (!(reply_timeout_s > 0.0 && reply_timeout_s <= 60.0)) {
    Reject("reply_timeout_s", Str(reply_timeout_s), "(0, 60]");
  }
  if (command_retries < 0 || command_retries > 100) {
    Reject("command_retries", Str(command_retries), "[0, 100]");
  }
  if (!(scan_timeout_s > 0.0 && scan_timeout_s <= 60.0)) {
    Reject("scan_timeout_s", Str(scan_timeout_s), "(0, 60]");
  }
  if (!(reopen_backoff_min_s > 0.0)) {
    Reject("reopen_backoff_min_s", Str(reopen_backoff_min_s), "(0, inf)");
  }
  if (!(reopen_backoff_max_s >= reopen_backoff_min_s)) {
    Reject("reopen_backoff_max_s", Str(reopen_backoff_max_s),
           "[reopen_backoff_min_s = " + Str(reopen_backoff_min_s) + ", inf)");
  }
  if (clock_sync_samples < 1 || clock_sync_samples > 1000) {
    Reject("clock_sync_samples", Str(clock_sync_samples), "[1, 1000]");
  }
  if (!(clock_sync_spacing_s >= 0.0 && clock_sync_spacing_s <= 1.0)) {
    Reject("clock_sync_spacing_s", Str(clock_sync_spacing_s), "[0, 1]");
  }
  if (!(drift_window_s > 0.0)) Reject("drift_window_s", Str(drift_window_s), "(0, inf)");
  if (drift_windows < 3 || drift_windows > 100000) {
    Reject("drift_windows", Str(drift_windows), "[3, 100000]");
  }
  if (!(max_drift_ppm >= 0.0 && max_drift_ppm <= 1e5)) {
    Reject("max_drift_ppm", Str(max_drift_ppm), "[0, 1e5]");
  }
  if (!(heartbeat_period_s > 0.0)) {
    Reject("heartbeat_period_s", Str(heartbeat_period_s), "(0, inf)");
  }
}

HokuyoConfig LoadHokuyoConfig(const ConfigNode& node) {
  HokuyoConfig c;
  node.Read("port", &c.port);
  node.Read("profile", &c.profile, std::vector<std::string>{"auto", "URG-04LX", "UTM-30LX"});
  node.Read("baud", &c.baud, Range::Positive());
  node.Read("sensor_name", &c.sensor_name);
  node.Read("channel", &c.channel);
  node.Read("heartbeat_channel", &c.heartbeat_channel);
  node.Read("intensities", &c.intensities);
  node.Read("scan_skip", &c.scan_skip, Range::Closed(0, 9));
  node.Read("start_step", &c.start_step, Range::Closed(-1, 9999));
  node.Read("end_step", &c.end_step, Range::Closed(-1, 9999));
  node.Read("reply_timeout_s", &c.reply_timeout_s, Range{0.0, 60.0, false, true});
  node.Read("command_retries", &c.command_retries, Range::Closed(0, 100));
  node.Read("scan_timeout_s", &c.scan_timeout_s, Range{0.0, 60.0, false, true});
  node.Read("reopen_backoff_min_s", &c.reopen_backoff_min_s, Range::Positive());
  node.Read("reopen_backoff_max_s", &c.reopen_backoff_max_s, Range::Positive());
  node.Read("clock_sync_samples", &c.clock_sync_samples, Range::Closed(1, 1000));
  node.Read("clock_sync_spacing_s", &c.clock_sync_spacing_s, Range::Closed(0, 1));
  node.Read("drift_window_s", &c.drift_window_s, Range::Positive());
  node.Read("drift_windows", &c.drift_windows, Range::Closed(3, 100000));
  node.Read("max_drift_ppm", &c.max_drift_ppm, Range::Closed(0, 1e5));
  node.Read("heartbeat_period_s", &c.heartbeat_period_s, Range::Positive());
  try {
    c.Validate();
  } catch (const ConfigError& e) {
    throw ConfigError(node.file() + ": " + e.what());  // cross-field checks name the file too
  }
  return c;
}

}  // namespace kestrel
