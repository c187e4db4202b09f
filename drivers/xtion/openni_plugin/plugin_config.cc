#include "drivers/xtion/openni_plugin/plugin_config.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace kestrel::oni_plugin {
namespace {

double ParseDouble(const char* name, const char* text, double lo, double hi) {
  char* end = nullptr;
  const double v = std::strtod(text, &end);
  if (end == text || *end != '\0' || !std::isfinite(v) || v < lo || v > hi) {
    throw std::invalid_argument(std::string(name) + "='" + text + "': expected a number in [" +
                                std::to_string(lo) + ", " + std::to_string(hi) + "]");
  }
  return v;
}

int64_t ParseInt(const char* name, const char* text, int64_t lo, int64_t hi) {
  char* end = nullptr;
  const long long v = std::strtoll(text, &end, 10);
  if (end == text || *end != '\0' || v < lo || v > hi) {
    throw std::invalid_argument(std::string(name) + "='" + text + "': expected an integer in [" +
                                std::to_string(lo) + ", " + std::to_string(hi) + "]");
  }
  return v;
}

}  // namespace

PluginConfig ReadPluginConfig(const std::function<const char*(const char*)>& getenv_fn) {
  PluginConfig c;
  if (const char* s = getenv_fn("KESTREL_ONI_SOURCE")) {
    const std::string v = s;
    if (v == "synthetic") {
      c.source = v;
    } else if (v.rfind("files:", 0) == 0 && v.size() > 6) {
      c.source = "files";
      c.files_dir = v.substr(6);
    } else if (v.rfind("lcm:", 0) == 0 && v.size() > 4) {
      c.source = "lcm";
      c.lcm_url = v.substr(4);
    } else {
      throw std::invalid_argument("KESTREL_ONI_SOURCE='" + v +
                                  "': expected 'synthetic', 'files:DIR' or 'lcm:URL'");
    }
  }
  if (const char* s = getenv_fn("KESTREL_ONI_LCM_CHANNEL")) {
    if (*s == '\0') throw std::invalid_argument("KESTREL_ONI_LCM_CHANNEL is empty");
    c.lcm_channel = s;
  }
  if (const char* s = getenv_fn("KESTREL_ONI_DEVICES")) {
    c.num_devices = static_cast<int>(ParseInt("KESTREL_ONI_DEVICES", s, 1, 8));
  }
  if (const char* s = getenv_fn("KESTREL_ONI_WALL_M")) {
    c.wall.distance_m = ParseDouble("KESTREL_ONI_WALL_M", s, 0.1, 9.0);
  }
  c.wall.tilt_rad = 17.0 * M_PI / 180.0;
  if (const char* s = getenv_fn("KESTREL_ONI_WALL_TILT_DEG")) {
    c.wall.tilt_rad = ParseDouble("KESTREL_ONI_WALL_TILT_DEG", s, -60.0, 60.0) * M_PI / 180.0;
  }
  c.wall.pitch_rad = 8.0 * M_PI / 180.0;
  if (const char* s = getenv_fn("KESTREL_ONI_WALL_PITCH_DEG")) {
    c.wall.pitch_rad = ParseDouble("KESTREL_ONI_WALL_PITCH_DEG", s, -60.0, 60.0) * M_PI / 180.0;
  }
  if (const char* s = getenv_fn("KESTREL_ONI_CLOCK_OFFSET_US")) {
    c.clock_offset_given = true;
    c.clock_offset_us =
        ParseInt("KESTREL_ONI_CLOCK_OFFSET_US", s, -(int64_t{1} << 62), int64_t{1} << 62);
  }
  if (const char* s = getenv_fn("KESTREL_ONI_CLOCK_DRIFT_PPM")) {
    c.clock_drift_ppm = ParseDouble("KESTREL_ONI_CLOCK_DRIFT_PPM", s, -100000.0, 100000.0);
  }
  if (const char* s = getenv_fn("KESTREL_ONI_FAULT_LOSS_AFTER_FRAMES")) {
    c.loss_after_frames = ParseInt("KESTREL_ONI_FAULT_LOSS_AFTER_FRAMES", s, 0, 1000000000);
  }
  if (const char* s = getenv_fn("KESTREL_ONI_FAULT_LOSS_MS")) {
    c.loss_duration_ms = ParseInt("KESTREL_ONI_FAULT_LOSS_MS", s, 0, 600000);
  }
  if (const char* s = getenv_fn("KESTREL_ONI_FAULT_LOSS_COUNT")) {
    c.loss_count = static_cast<int>(ParseInt("KESTREL_ONI_FAULT_LOSS_COUNT", s, 0, 1000));
  }
  if (const char* s = getenv_fn("KESTREL_ONI_FAULT_STALL_AFTER_FRAMES")) {
    c.stall_after_frames = ParseInt("KESTREL_ONI_FAULT_STALL_AFTER_FRAMES", s, 0, 1000000000);
  }
  if (const char* s = getenv_fn("KESTREL_ONI_FAULT_STALL_MS")) {
    c.stall_duration_ms = ParseInt("KESTREL_ONI_FAULT_STALL_MS", s, 0, 600000);
  }
  if (const char* s = getenv_fn("KESTREL_ONI_FAULT_SKIP_EVERY")) {
    c.skip_every_frames = ParseInt("KESTREL_ONI_FAULT_SKIP_EVERY", s, 0, 1000000);
    if (c.skip_every_frames == 1) {
      throw std::invalid_argument(
          "KESTREL_ONI_FAULT_SKIP_EVERY='1': would skip every frame; "
          "expected 0 or >= 2");
    }
  }
  if (const char* s = getenv_fn("KESTREL_ONI_MIRROR_DEFAULT")) {
    c.mirror_default = ParseInt("KESTREL_ONI_MIRROR_DEFAULT", s, 0, 1) == 1;
  }
  if (const char* s = getenv_fn("KESTREL_ONI_VERBOSE")) c.verbose = std::string(s) == "1";
  return c;
}

std::string DeviceUri(int index) { return "1d27/0600@1/" + std::to_string(10 + index); }

std::string DeviceSerial(int index) {
  char text[16];
  std::snprintf(text, sizeof(text), "KXT%07d", index);
  return text;
}

}  // namespace kestrel::oni_plugin
