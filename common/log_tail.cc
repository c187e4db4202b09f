#include "common/log_tail.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
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

namespace {

// An LCM log event (lcm's eventlog format): the sync word, the event number (8 bytes), the
// timestamp (8), the channel's length (4) and the data's length (4), all big-endian, then the
// channel and the data.
constexpr uint8_t kSyncWord[4] = {0xED, 0xA1, 0xDA, 0x01};
constexpr size_t kEventHeader = 28;

uint32_t BigEndian32(const uint8_t* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | uint32_t{p[3]};
}

// The end of the log's whole events read header by header, each event's channel and data
// skipped rather than read; -1 where a header does not start with the sync word (the LCM reader
// then searches for the next one, which WholeEventsEndByReading does).
off_t WholeEventsEndBySkipping(FILE* f, off_t size) {
  off_t at = 0;
  uint8_t header[kEventHeader];
  while (at + static_cast<off_t>(kEventHeader) <= size) {
    if (fseeko(f, at, SEEK_SET) != 0 || std::fread(header, 1, kEventHeader, f) != kEventHeader) {
      return -1;
    }
    if (std::memcmp(header, kSyncWord, 4) != 0) return -1;
    const off_t end = at + static_cast<off_t>(kEventHeader) +
                      static_cast<off_t>(BigEndian32(header + 20)) +
                      static_cast<off_t>(BigEndian32(header + 24));
    if (end > size) break;  // the partly written event
    at = end;
  }
  return at;
}

off_t WholeEventsEndByReading(const std::string& path) {
  off_t end = 0;
  lcm::LogFile log(path, "r");
  if (!log.good()) throw std::runtime_error("cannot read the LCM log " + path);
  while (log.readNextEvent() != nullptr) end = ftello(log.getFilePtr());
  return end;
}

}  // namespace

int64_t TrimPartialLastEvent(const std::string& path) {
  struct stat st {};
  if (stat(path.c_str(), &st) != 0) return 0;
  // Header by header: a respawned writer must not read a long flight's whole log (a depth image
  // per event), only its headers.
  FILE* const f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) throw std::runtime_error("cannot read the LCM log " + path);
  off_t whole_end = WholeEventsEndBySkipping(f, st.st_size);
  std::fclose(f);
  if (whole_end < 0) whole_end = WholeEventsEndByReading(path);
  const int64_t cut = static_cast<int64_t>(st.st_size) - static_cast<int64_t>(whole_end);
  if (cut > 0 && truncate(path.c_str(), whole_end) != 0) {
    throw std::runtime_error("cannot cut the broken last event of " + path + ": " +
                             std::strerror(errno));
  }
  return cut;
}

}  // namespace kestrel
