#pragma once
/// @file
/// A process clock that follows the simulator (multi-process simulation): time is the newest
/// stamp seen on the simulator's truth channel (sim_truth_t, published at its truth rate), so
/// kestrel-controller, kestrel-mapper and kestrel-explorer run in simulated time whatever the
/// simulator's speed factor. Timers on a NodeLoop then fire in bursts at each truth message
/// (e.g. 4 control ticks per 10 ms truth period), catching up exactly.

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/lcm_decode.h"

namespace kestrel {

class SimTruthClock final : public Clock {
 public:
  SimTruthClock(lcm::LCM& lcm, const std::string& channel);
  SimTruthClock(const SimTruthClock&) = delete;
  SimTruthClock& operator=(const SimTruthClock&) = delete;

  /// The newest truth stamp (us); 0 before the first.
  [[nodiscard]] int64_t NowUtime() const override { return utime_.load(); }
  [[nodiscard]] bool is_simulated() const override { return true; }
  /// Handles LCM until the first truth message arrived or `timeout_s` passed (wall time).
  bool WaitForFirst(lcm::LCM& lcm, double timeout_s);

 private:
  GuardedSubscriptions subscriptions_;
  std::atomic<int64_t> utime_{0};
};

/// The clock a process runs on: the wall clock, or a SimTruthClock on `sim_clock_channel`
/// (waiting, with a log line every few seconds, until the simulator's first truth message).
[[nodiscard]] std::unique_ptr<Clock> MakeProcessClock(lcm::LCM& lcm,
                                                      const std::string& sim_clock_channel);

}  // namespace kestrel
