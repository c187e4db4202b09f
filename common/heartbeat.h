#pragma once
/// @file
/// The heartbeat every process publishes at >= 1 Hz (docs/design.md §2.2): state, uptime, last
/// error and named counters (rates, drops, queue depths), on HEARTBEAT_<NAME> by default.

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/log.h"
#include "kestrel/heartbeat_t.hpp"

namespace kestrel {

class Heartbeat {
 public:
  /// `process` e.g. "kestrel-mapper"; `channel` e.g. "HEARTBEAT_MAPPER".
  Heartbeat(lcm::LCM& lcm, const Clock& clock, std::string process, std::string channel);
  Heartbeat(const Heartbeat&) = delete;
  Heartbeat& operator=(const Heartbeat&) = delete;

  /// STATE_* of heartbeat_t.
  void SetState(int8_t state) { state_ = state; }
  void SetLastError(const std::string& error) { last_error_ = error; }
  /// Sets a named value reported in the next heartbeat (kept until changed).
  void SetValue(const std::string& name, double value) { values_[name] = value; }
  /// Sets "dropped.<kind>" to the count of every kind `drops` has seen (spaces in a kind become
  /// '_'), and of each of `always` even when 0, e.g. "dropped.malformed": what the guarded
  /// decoder refused (docs/design.md §7.11).
  void SetDropValues(const DropCounter& drops,
                     const std::vector<std::string>& always = {"malformed"});
  /// Publishes one heartbeat now (call from a 1 Hz NodeLoop timer and at shutdown).
  void Publish();

  [[nodiscard]] const std::string& channel() const { return channel_; }
  /// The publisher epoch stamped on every heartbeat (common/identity.h).
  [[nodiscard]] int64_t epoch() const { return epoch_; }

 private:
  lcm::LCM& lcm_;
  const Clock& clock_;
  std::string process_;
  std::string channel_;
  std::string host_;
  int64_t start_utime_;
  int64_t epoch_;
  int64_t seq_{0};
  int8_t state_{heartbeat_t::STATE_STARTING};
  std::string last_error_;
  std::map<std::string, double> values_;
};

}  // namespace kestrel
