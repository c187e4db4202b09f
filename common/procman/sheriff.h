#pragma once
/// @file
/// A bot-procman sheriff for one order (kestrel-cmd procman): asks every deputy to report
/// (discovery_t), orders the ones holding the targeted commands with their full desired state
/// (MakeOrders, bot_procman.h), re-sends those orders every second as a sheriff does, and tells
/// when every deputy's report shows them carried out. Works with kestrel-procman and with
/// libbot2's own bot-procman-deputy (docs/protocols.md §5).

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "bot_procman/info2_t.hpp"
#include "bot_procman/orders2_t.hpp"
#include "common/clock.h"
#include "common/lcm_decode.h"
#include "common/procman/bot_procman.h"

namespace kestrel::procman {

class Sheriff {
 public:
  /// `name` goes into orders2_t.sheriff_name (bot-procman: "<host>:<pid>:<utime>").
  Sheriff(lcm::LCM& lcm, const Clock& clock, std::string name);

  /// Asks every deputy to report now.
  void Discover();
  /// Handles what arrived; re-sends the orders once a second until carried out.
  void Poll();

  /// The latest report of every deputy heard from, by name.
  [[nodiscard]] const std::map<std::string, bot_procman::info2_t>& deputies() const {
    return deputies_;
  }
  /// Orders `verb` on `target` to every deputy heard from (only `host` if not empty) that holds
  /// a targeted command, from its latest report. Returns the names of the deputies ordered.
  std::vector<std::string> Order(SheriffVerb verb, const CommandTarget& target,
                                 const std::string& host);
  /// The deputies ordered whose latest report does not yet show their orders carried out.
  [[nodiscard]] std::vector<std::string> Pending() const;

 private:
  lcm::LCM& lcm_;
  const Clock& clock_;
  std::string name_;
  GuardedSubscriptions subscriptions_;
  std::map<std::string, bot_procman::info2_t> deputies_;
  std::map<std::string, bot_procman::orders2_t> orders_;  // by deputy
  int64_t last_sent_utime_{0};
};

/// A sheriff's view of the deputies: one block per deputy (load, memory, commands), one line per
/// command: name, running or stopped, pid, runid, the last exit (code or signal), CPU, memory,
/// group.
[[nodiscard]] std::string FormatDeputies(
    const std::map<std::string, bot_procman::info2_t>& deputies, int64_t now_utime);

}  // namespace kestrel::procman
