#include "common/node_loop.h"

#include <poll.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <ctime>

#include "common/check.h"

namespace kestrel {

namespace {
volatile std::sig_atomic_t g_signal_received = 0;
extern "C" void OnStopSignal(int signum) { g_signal_received = signum; }
}  // namespace

NodeLoop::NodeLoop(lcm::LCM& lcm, const Clock& clock) : lcm_(lcm), clock_(clock) {}

void NodeLoop::AddTimer(const std::string& name, int64_t period_us, TimerCallback callback) {
  KESTREL_THROW_UNLESS(period_us > 0,
                       "timer '" << name << "' needs a period > 0 us, got " << period_us);
  timers_.push_back(Timer{name, period_us, -1, std::move(callback)});
}

void NodeLoop::AddShutdownHook(std::function<void()> hook) {
  shutdown_hooks_.push_back(std::move(hook));
}

void NodeLoop::InstallSignalHandlers() {
  struct sigaction action {};
  action.sa_handler = OnStopSignal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

void NodeLoop::RestoreDefaultSignalActions() {
  signal(SIGINT, SIG_DFL);
  signal(SIGTERM, SIG_DFL);
}

bool NodeLoop::signal_received() { return g_signal_received != 0; }

int NodeLoop::received_signal() { return static_cast<int>(g_signal_received); }

int NodeLoop::ExitCodeForSignal(int signum) { return signum > 0 ? 128 + signum : 0; }

void NodeLoop::FireDueTimers() {
  const int64_t now = clock_.NowUtime();
  for (Timer& timer : timers_) {
    if (timer.next_due_utime < 0) timer.next_due_utime = now + timer.period_us;
  }
  // Fire in global time order so two timers interleave as they would in real time.
  while (true) {
    Timer* next = nullptr;
    for (Timer& timer : timers_) {
      if (timer.next_due_utime <= now &&
          (next == nullptr || timer.next_due_utime < next->next_due_utime)) {
        next = &timer;
      }
    }
    if (next == nullptr) break;
    const int64_t scheduled = next->next_due_utime;
    next->next_due_utime += next->period_us;
    // Wall clock behind by whole periods, or a simulated clock that jumped (a simulator restarted):
    // skip rather than burst (a simulated clock catches up exactly up to 1000 periods).
    if (next->next_due_utime <= now &&
        (!clock_.is_simulated() || now - next->next_due_utime > 1000 * next->period_us)) {
      const int64_t behind = (now - next->next_due_utime) / next->period_us + 1;
      skipped_ticks_ += behind;
      next->next_due_utime += behind * next->period_us;
    }
    next->callback(scheduled);
  }
}

int64_t NodeLoop::MicrosecondsToNextTimer() {
  const int64_t now = clock_.NowUtime();
  int64_t wait = 100000;
  for (const Timer& timer : timers_) {
    const int64_t due = timer.next_due_utime < 0 ? now + timer.period_us : timer.next_due_utime;
    wait = std::min(wait, std::max<int64_t>(0, due - now));
  }
  return wait;
}

bool NodeLoop::RunOnce(int timeout_ms) {
  errno = 0;
  const int status = lcm_.handleTimeout(std::max(0, timeout_ms));
  // A signal interrupting select() is not an LCM failure.
  const bool failed = status < 0 && errno != EINTR && g_signal_received == 0;
  FireDueTimers();
  return !failed;
}

bool NodeLoop::RunOnceMicroseconds(int64_t timeout_us) {
  const int fd = lcm_.getFileno();
  if (fd < 0) return RunOnce(static_cast<int>((timeout_us + 999) / 1000));
  pollfd readable{fd, POLLIN, 0};
  timeout_us = std::max<int64_t>(0, timeout_us);
  const timespec timeout{static_cast<time_t>(timeout_us / 1000000),
                         static_cast<long>(timeout_us % 1000000) * 1000};
  errno = 0;
  const int ready = ppoll(&readable, 1, &timeout, nullptr);
  bool failed = ready < 0 && errno != EINTR && g_signal_received == 0;
  // The descriptor is readable: a message is queued, so handle() returns without waiting.
  if (ready > 0) failed = lcm_.handle() < 0 && errno != EINTR && g_signal_received == 0;
  FireDueTimers();
  return !failed;
}

void NodeLoop::RunShutdownHooks() {
  if (shut_down_) return;
  shut_down_ = true;
  for (auto& hook : shutdown_hooks_) hook();
}

int NodeLoop::Run() {
  int exit_code = 0;
  FireDueTimers();  // arms the timers
  while (stop_requested_ == 0 && g_signal_received == 0) {
    // In simulation the clock only moves when the simulator's messages arrive: poll briefly.
    // On the wall clock, wait to the microsecond, not to the next whole millisecond: a 400 Hz
    // loop would otherwise tick up to 1 ms late (docs/design.md §2.6).
    const int64_t wait_us = clock_.is_simulated() ? 10000 : MicrosecondsToNextTimer();
    if (!RunOnceMicroseconds(wait_us)) {
      std::fprintf(stderr, "kestrel: LCM handle failed; stopping\n");
      exit_code = 1;
      break;
    }
  }
  RunShutdownHooks();
  return exit_code;
}

}  // namespace kestrel
