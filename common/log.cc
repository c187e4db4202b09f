#include "common/log.h"

#include <cstdio>
#include <mutex>

namespace kestrel {

namespace {
std::mutex g_log_mutex;
std::string& ProcessName() {
  static std::string name = "kestrel";
  return name;
}
}  // namespace

void SetLogProcessName(const std::string& name) {
  const std::lock_guard<std::mutex> lock(g_log_mutex);
  ProcessName() = name;
}

void Log(LogLevel level, const std::string& message) {
  static const WallClock clock;
  const char* tag = level == LogLevel::kInfo      ? "info"
                    : level == LogLevel::kWarning ? "WARN"
                                                  : "ERROR";
  const std::lock_guard<std::mutex> lock(g_log_mutex);
  std::fprintf(stderr, "[%.3f] %s: %s %s\n", UtimeToSeconds(clock.NowUtime()),
               ProcessName().c_str(), tag, message.c_str());
}

void DropCounter::Count(const std::string& kind, const std::string& reason) {
  ++counts_[kind];
  last_reason_ = kind + ": " + reason;
  Pending& p = pending_[kind];
  const int64_t now = clock_.NowUtime();
  const bool first = counts_[kind] == 1;
  if (first || now - p.last_log_utime >= SecondsToUtime(period_s_)) {
    const std::string suffix =
        first ? "" : " (" + std::to_string(p.unlogged + 1) + " of this kind since the last report)";
    Log(level_, label_ + " " + kind + ": " + reason + suffix);
    p.last_log_utime = now;
    p.unlogged = 0;
  } else {
    ++p.unlogged;
  }
}

int64_t DropCounter::count(const std::string& kind) const {
  const auto it = counts_.find(kind);
  return it == counts_.end() ? 0 : it->second;
}

int64_t DropCounter::total() const {
  int64_t sum = 0;
  for (const auto& [kind, n] : counts_) sum += n;
  return sum;
}

}  // namespace kestrel
