#pragma once
/// @file
/// Process logging to stderr with a time stamp and the process name, and a rate-limited
/// "drop report" so that a flood of bad input is logged once per kind and period, never once
/// per message, while every drop is still counted.

#include <cstdint>
#include <map>
#include <string>
#include <utility>

#include "common/clock.h"

namespace kestrel {

enum class LogLevel { kInfo, kWarning, kError };

/// Writes "[utime s] process: LEVEL message" to stderr. Thread-safe (one write per line).
void Log(LogLevel level, const std::string& message);
/// Sets the process name used by Log (defaults to "kestrel").
void SetLogProcessName(const std::string& name);

/// Counts events by kind (e.g. "malformed depth_image_t", "nan_pose") and logs the first of each
/// kind at once, then at most one summary line per kind every `period_s`, with the count since.
/// The lines read "<label> <kind>: <reason>" at `level`: "dropped ..." warnings by default; a
/// node also counts events that are not drops with its own counter (e.g. label "event", info).
class DropCounter {
 public:
  DropCounter(const Clock& clock, double period_s = 5.0, std::string label = "dropped",
              LogLevel level = LogLevel::kWarning)
      : clock_(clock), period_s_(period_s), label_(std::move(label)), level_(level) {}
  /// Counts one event of `kind` with its reason; logs per the rate limit.
  void Count(const std::string& kind, const std::string& reason);
  /// Total events of `kind` (0 if never seen).
  [[nodiscard]] int64_t count(const std::string& kind) const;
  /// Total over all kinds.
  [[nodiscard]] int64_t total() const;
  /// Every kind with its total.
  [[nodiscard]] const std::map<std::string, int64_t>& counts() const { return counts_; }
  /// The most recent reason, "" if none.
  [[nodiscard]] const std::string& last_reason() const { return last_reason_; }

 private:
  struct Pending {
    int64_t last_log_utime{0};
    int64_t unlogged{0};
  };
  const Clock& clock_;
  double period_s_;
  std::string label_;
  LogLevel level_;
  std::map<std::string, int64_t> counts_;
  std::map<std::string, Pending> pending_;
  std::string last_reason_;
};

}  // namespace kestrel
