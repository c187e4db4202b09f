#pragma once
/// @file
/// Reads an LCM log file that may still be growing (lcm-logger writing it, flushing every
/// 100 ms): events are returned whole, in file order; at the end of what has been written so far,
/// including an event only partly written, Next() returns nothing and a later call goes on from
/// the same place. Built on lcm::LogFile (the LCM library's own reader); a node catching up from
/// its run's log uses it (docs/design.md §3.6).

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

namespace kestrel {

/// One logged message.
struct LoggedEvent {
  int64_t timestamp{0};  ///< when the logger received it, us
  std::string channel;
  std::vector<uint8_t> data;
};

class LogTail {
 public:
  /// Opens `path` for reading. @throws std::runtime_error if it cannot be opened.
  explicit LogTail(const std::string& path);
  LogTail(const LogTail&) = delete;
  LogTail& operator=(const LogTail&) = delete;

  /// The next whole event, or nothing at the (current) end of the file.
  std::optional<LoggedEvent> Next();
  /// Events returned so far.
  [[nodiscard]] int64_t events_read() const { return events_read_; }

 private:
  lcm::LogFile log_;
  int64_t events_read_{0};
};

/// Cuts an event that a writer killed mid-write left at the end of the LCM log `path`, so that
/// a new writer appending to it (mode "a") does not put its events behind a broken one, which
/// every reader stops at. Returns the bytes cut (0: the log ends with a whole event, or does not
/// exist). Only for a log no one else writes to. It reads the events' headers and skips their
/// channels and data (the whole log only where a header is broken), so that a respawn reads
/// 28 bytes per event however large the events. @throws std::runtime_error if it cannot be read
/// or cut.
int64_t TrimPartialLastEvent(const std::string& path);

}  // namespace kestrel
