#include "common/log_tail.h"

#include <cstdio>
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

}  // namespace kestrel
