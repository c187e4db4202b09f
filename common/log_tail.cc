#include "common/log_tail.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace kestrel {

LogTail::LogTail(const std::string& path) : log_(path, "r") {
  if (!log_.good()) throw std::runtime_error("cannot open the LCM log " + path);
}

std::optional<LoggedEvent> LogTail::Next() {
  FILE* const file = log_.getFilePtr();
  const off_t start = ftello(file);
  const lcm::LogEvent* event = log_.readNextEvent();
  if (event == nullptr) {
    // The end so far, or an event the logger has only partly written: the LCM reader has
    // consumed what it could; come back to the event's start and read it again later.
    clearerr(file);
    fseeko(file, start, SEEK_SET);
    return std::nullopt;
  }
  LoggedEvent out;
  out.timestamp = event->timestamp;
  out.channel = event->channel;
  const auto* bytes = static_cast<const uint8_t*>(event->data);
  out.data.assign(bytes, bytes + event->datalen);
  ++events_read_;
  return out;
}

int64_t TrimPartialLastEvent(const std::string& path) {
  struct stat st {};
  if (stat(path.c_str(), &st) != 0) return 0;
  off_t whole_end = 0;
  {
    lcm::LogFile log(path, "r");
    if (!log.good()) throw std::runtime_error("cannot read the LCM log " + path);
    while (log.readNextEvent() != nullptr) whole_end = ftello(log.getFilePtr());
  }
  const int64_t cut = static_cast<int64_t>(st.st_size) - static_cast<int64_t>(whole_end);
  if (cut > 0 && truncate(path.c_str(), whole_end) != 0) {
    throw std::runtime_error("cannot cut the broken last event of " + path + ": " +
                             std::strerror(errno));
  }
  return cut;
}

}  // namespace kestrel
