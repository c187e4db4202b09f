#pragma once
/// @file
/// The run loop of every Kestrel process: LCM messages, periodic timers on an injected Clock,
/// and a clean exit on SIGINT/SIGTERM that runs the shutdown hooks (final flush: checkpoint,
/// last heartbeat) before returning.
///
/// With a WallClock, Run() waits on LCM's descriptor until the next timer is due (or 100 ms), to
/// the microsecond (RunOnceMicroseconds), and a timer that fell behind by whole periods skips them
/// (counted in skipped_ticks()). With a simulated clock, timers catch up exactly: every due tick
/// fires once, in time order, with its scheduled time, so a lockstep simulation is deterministic.

#include <csignal>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"

namespace kestrel {

class NodeLoop {
 public:
  /// A timer callback receives the tick's scheduled time (utime), not the time it ran.
  using TimerCallback = std::function<void(int64_t scheduled_utime)>;

  NodeLoop(lcm::LCM& lcm, const Clock& clock);
  NodeLoop(const NodeLoop&) = delete;
  NodeLoop& operator=(const NodeLoop&) = delete;

  /// Adds a periodic timer whose first tick is one period after the first RunOnce/Run.
  /// @throws std::invalid_argument if period_us <= 0.
  void AddTimer(const std::string& name, int64_t period_us, TimerCallback callback);
  /// Runs at exit (after a signal or RequestStop), in the order added.
  void AddShutdownHook(std::function<void()> hook);

  /// Handles LCM messages for at most timeout_ms (0: only what is queued), then fires due timers.
  /// Returns false if LCM reported an error.
  bool RunOnce(int timeout_ms);
  /// As RunOnce, with the wait in microseconds (ppoll on LCM's descriptor; RunOnce's rounding to
  /// whole milliseconds where LCM has no descriptor).
  bool RunOnceMicroseconds(int64_t timeout_us);
  /// Fires the timers due at the clock's current time without touching LCM (lockstep simulation).
  void FireDueTimers();
  /// Loops until RequestStop() or SIGINT/SIGTERM (after InstallSignalHandlers), then runs the
  /// shutdown hooks. Returns 0 on a clean stop, 1 if LCM failed.
  int Run();
  /// Asks Run() to return after the current iteration (thread- and signal-safe).
  void RequestStop() { stop_requested_ = 1; }
  /// Routes SIGINT and SIGTERM to a stop request of every NodeLoop in the process.
  static void InstallSignalHandlers();
  /// Gives SIGINT and SIGTERM back their default action (the process ends at once): for a batch
  /// tool (a log replayed, a map scored) whose work has no loop that asks signal_received() and
  /// nothing to save when stopped half-way.
  static void RestoreDefaultSignalActions();
  /// True once SIGINT or SIGTERM arrived (after InstallSignalHandlers).
  [[nodiscard]] static bool signal_received();
  /// The signal that arrived last (SIGINT or SIGTERM), 0 if none.
  [[nodiscard]] static int received_signal();
  /// A shell's exit code for a run ended by `signum`: 128 + signum (130 for SIGINT, 143 for
  /// SIGTERM); 0 for no signal.
  [[nodiscard]] static int ExitCodeForSignal(int signum);

  [[nodiscard]] int64_t skipped_ticks() const { return skipped_ticks_; }

 private:
  struct Timer {
    std::string name;
    int64_t period_us;
    int64_t next_due_utime;  // -1 until the loop first runs
    TimerCallback callback;
  };
  [[nodiscard]] int64_t MicrosecondsToNextTimer();
  void RunShutdownHooks();

  lcm::LCM& lcm_;
  const Clock& clock_;
  std::vector<Timer> timers_;
  std::vector<std::function<void()>> shutdown_hooks_;
  volatile std::sig_atomic_t stop_requested_{0};
  bool shut_down_{false};
  int64_t skipped_ticks_{0};
};

}  // namespace kestrel
