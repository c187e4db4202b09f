#include "common/sim_truth_clock.h"

#include <chrono>

#include "common/log.h"
#include "common/node_loop.h"
#include "kestrel/sim_truth_t.hpp"

namespace kestrel {

SimTruthClock::SimTruthClock(lcm::LCM& lcm, const std::string& channel) : subscriptions_(lcm) {
  subscriptions_.Add<sim_truth_t>(
      channel,
      [this](const std::string&, const sim_truth_t& m) {
        int64_t now = utime_.load();
        while (m.utime > now && !utime_.compare_exchange_weak(now, m.utime)) {
        }
      },
      [](const std::string& ch, const std::string& why) {
        Log(LogLevel::kWarning, "clock: dropped on " + ch + ": " + why);
      });
}

bool SimTruthClock::WaitForFirst(lcm::LCM& lcm, double timeout_s) {
  const auto end = std::chrono::steady_clock::now() +
                   std::chrono::milliseconds(static_cast<int64_t>(timeout_s * 1000));
  while (utime_.load() == 0 && std::chrono::steady_clock::now() < end &&
         !NodeLoop::signal_received()) {
    lcm.handleTimeout(50);
  }
  return utime_.load() != 0;
}

std::unique_ptr<Clock> MakeProcessClock(lcm::LCM& lcm, const std::string& sim_clock_channel) {
  if (sim_clock_channel.empty()) return std::make_unique<WallClock>();
  auto clock = std::make_unique<SimTruthClock>(lcm, sim_clock_channel);
  while (!clock->WaitForFirst(lcm, 5.0)) {
    if (NodeLoop::signal_received()) break;
    Log(LogLevel::kInfo, "waiting for the simulator's clock on " + sim_clock_channel);
  }
  return clock;
}

}  // namespace kestrel
