#include "common/process_usage.h"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>

namespace kestrel {

ProcessUsage ParseProcStatus(const std::string& status_text) {
  ProcessUsage u;
  std::istringstream in(status_text);
  std::string line;
  while (std::getline(in, line)) {
    const size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    const std::string key = line.substr(0, colon);
    std::istringstream value(line.substr(colon + 1));
    int64_t number = 0;
    if (!(value >> number)) continue;
    if (key == "VmRSS") {
      u.rss_kib = number;
    } else if (key == "VmHWM") {
      u.peak_rss_kib = number;
    } else if (key == "Threads") {
      u.threads = static_cast<int>(number);
    }
  }
  return u;
}

std::optional<ProcessUsage> ReadProcessUsage() {
  std::ifstream status("/proc/self/status");
  if (!status) return std::nullopt;
  std::ostringstream text;
  text << status.rdbuf();
  ProcessUsage u = ParseProcStatus(text.str());
  std::error_code error;
  int files = 0;
  for (std::filesystem::directory_iterator it("/proc/self/fd", error), end; !error && it != end;
       it.increment(error)) {
    ++files;
  }
  // The iterator's own descriptor was open while it counted.
  if (!error) u.open_files = files - 1;
  return u;
}

}  // namespace kestrel
