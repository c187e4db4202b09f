#pragma once
/// @file
/// An injectable clock. Real runs stamp with the host's wall clock (microseconds since the Unix
/// epoch, as LCM's `utime` convention and lcm-logger use); simulation runs take time from the
/// simulator through a SimClock, so every node in a one-process regression sees the same,
/// deterministic time and runs as fast as the CPU allows.

#include <atomic>
#include <cstdint>

namespace kestrel {

/// Source of "now" for a node. Implementations must be monotonic non-decreasing.
class Clock {
 public:
  virtual ~Clock() = default;
  /// Current time in microseconds (utime).
  [[nodiscard]] virtual int64_t NowUtime() const = 0;
  /// True when time advances only when the simulator says so (timers then catch up exactly).
  [[nodiscard]] virtual bool is_simulated() const = 0;
};

/// The host clock (CLOCK_REALTIME, microseconds since the epoch).
class WallClock final : public Clock {
 public:
  [[nodiscard]] int64_t NowUtime() const override;
  [[nodiscard]] bool is_simulated() const override { return false; }
};

/// A clock driven by the simulator. Thread-safe reads; time never goes backwards.
class SimClock final : public Clock {
 public:
  explicit SimClock(int64_t start_utime = 0) : utime_(start_utime) {}
  SimClock(const SimClock&) = delete;
  SimClock& operator=(const SimClock&) = delete;

  [[nodiscard]] int64_t NowUtime() const override { return utime_.load(); }
  [[nodiscard]] bool is_simulated() const override { return true; }
  /// Sets the time. @throws std::invalid_argument if utime is earlier than the current time.
  void SetUtime(int64_t utime);
  /// Advances by dt_us >= 0. @throws std::invalid_argument if dt_us < 0.
  void AdvanceUtime(int64_t dt_us);

 private:
  std::atomic<int64_t> utime_;
};

/// Seconds to microseconds, rounded to the nearest microsecond.
[[nodiscard]] int64_t SecondsToUtime(double seconds);
[[nodiscard]] inline double UtimeToSeconds(int64_t utime) {
  return static_cast<double>(utime) * 1e-6;
}

}  // namespace kestrel
