#pragma once
/// @file
/// A bot-procman sheriff without a GUI (docs/protocols.md §5.4): asks every deputy to report
/// (discovery_t), keeps each deputy's latest report (info2_t), and orders deputies with their
/// full desired state (orders2_t): every command the deputy reports, as it is, except those this
/// sheriff wants otherwise (started, stopped, restarted, or created from a sheet). Orders are
/// re-sent every second until the deputy's report shows them carried out, then forgotten, so that
/// the next order starts again from the deputy's report and this sheriff never holds a deputy to
/// a stale state (another sheriff may order it meanwhile). Works with kestrel-procman and with
/// libbot2's own bot-procman-deputy. Used by kestrel-cmd procman and by kestrel-procman's
/// scripts, which order other hosts' commands through it (common/procman/deputy.h).

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "bot_procman/info2_t.hpp"
#include "bot_procman/orders2_t.hpp"
#include "bot_procman/printf_t.hpp"
#include "common/clock.h"
#include "common/lcm_decode.h"
#include "common/procman/bot_procman.h"
#include "common/procman/sheet.h"

namespace kestrel::procman {

class Sheriff {
 public:
  /// `name` goes into orders2_t.sheriff_name (bot-procman: "<host>:<pid>:<utime>"). Orders not
  /// carried out within `give_up_s` (of `clock`) are dropped with a warning.
  Sheriff(lcm::LCM& lcm, const Clock& clock, std::string name, double give_up_s = 30.0);

  /// Asks every deputy to report now.
  void Discover();
  /// Handles what arrived on `lcm`, then Resend().
  void Poll();
  /// Sends the orders of every deputy whose report does not show them carried out yet (at most
  /// once a second per deputy, and at once to a deputy that reports for the first time), forgets
  /// those carried out or given up. For a caller that handles LCM itself.
  void Resend();

  /// The latest report of every deputy heard from, by name.
  [[nodiscard]] const std::map<std::string, bot_procman::info2_t>& deputies() const {
    return deputies_;
  }
  /// Orders `verb` on `target` to every deputy heard from (only `host` if not empty) that holds
  /// a targeted command, from its latest report. Returns the names of the deputies ordered.
  std::vector<std::string> Order(SheriffVerb verb, const CommandTarget& target,
                                 const std::string& host);
  /// Orders `verb` on the commands `targets` of deputy `host`, creating on it those it does not
  /// report (from the sheet's definition, sheriff id SheetSheriffId) and, with `create_all`,
  /// every other command of `sheet` for that host, stopped. Commands the deputy reports are
  /// matched by sheriff id, then by name. A deputy not heard from yet is ordered once it reports
  /// (Discover() asks it).
  void OrderSheetCommands(SheriffVerb verb, const std::string& host,
                          const std::vector<const Command*>& targets, const Sheet& sheet,
                          bool create_all);
  /// Creates `sheet`'s commands (only `host`'s if not empty) on their deputies, stopped, and
  /// brings the settings (exec, group, auto_respawn, stop signal and time) of those a deputy
  /// already has to the sheet's; other commands a deputy has are kept. Returns the hosts of the
  /// sheet that no deputy reported for (nothing is sent to them).
  std::vector<std::string> Load(const Sheet& sheet, const std::string& host);

  /// The deputies ordered whose latest report does not yet show their orders carried out.
  [[nodiscard]] std::vector<std::string> Pending() const;
  /// The deputies whose orders were given up on (not carried out within give_up_s).
  [[nodiscard]] const std::vector<std::string>& given_up() const { return given_up_; }

  /// True while this sheriff's order for command `id` (by name) of deputy `host` is not yet
  /// carried out in its report (a wait on the command's state must not read the state before it).
  [[nodiscard]] bool OrderPending(const std::string& host, const std::string& id) const;
  /// The report of command `id` by deputy `host` (by name), nullptr if none.
  [[nodiscard]] const bot_procman::deputy_cmd2_t* Reported(const std::string& host,
                                                           const std::string& id) const;

  /// Called for every printf_t (a command's output; `command` is "" for the deputy's own words,
  /// sheriff_id 0, or a command no report names). Subscribes to PMD_PRINTF on first use.
  using OutputHandler = std::function<void(const std::string& deputy, const std::string& command,
                                           const bot_procman::printf_t& message)>;
  void FollowOutput(OutputHandler handler);

 private:
  struct DeputyOrders {
    WantedCommands wanted;
    int64_t next_send_utime{0};
    int64_t give_up_utime{0};
  };
  /// What this sheriff wants of `host`'s deputy (created, with its give-up time, if none).
  DeputyOrders& OrdersFor(const std::string& host);
  /// The command of `sheet` in what `host` reports or wants: its sheriff id.
  [[nodiscard]] int32_t SheriffIdOf(const std::string& host, const Command& c) const;
  void Send(const std::string& host, DeputyOrders* orders, int64_t now);

  lcm::LCM& lcm_;
  const Clock& clock_;
  std::string name_;
  int64_t give_up_utime_;
  GuardedSubscriptions subscriptions_;
  std::map<std::string, bot_procman::info2_t> deputies_;
  std::map<std::string, DeputyOrders> orders_;  // by deputy, until carried out
  std::vector<std::string> given_up_;
  OutputHandler output_;
};

/// A sheriff's view of the deputies: one block per deputy (load, memory, commands), one line per
/// command: name, running or stopped, pid, runid, the last exit (code or signal), CPU, memory,
/// group.
[[nodiscard]] std::string FormatDeputies(
    const std::map<std::string, bot_procman::info2_t>& deputies, int64_t now_utime);

}  // namespace kestrel::procman
