#pragma once
/// @file
/// A process-sheet runner for one host, a bot-procman deputy: starts the sheet's commands for its
/// host as child processes the way the deputy does (exec_line.h: no shell; each on its own
/// terminal, in its own session and process group; output appended to LOG_DIR/<id>.log and
/// published as bot-procman printf_t), respawns those marked auto_respawn with exponential
/// back-off, stops them with their stop_signal and then SIGKILL after stop_time_allowed.
/// It speaks libbot2 bot-procman's protocol (docs/protocols.md §5): discovery, info2_t on
/// PMD_INFO2 at 1 Hz and after every change, orders2_t from a sheriff (bot-procman-sheriff,
/// kestrel-cmd procman), which is then the authority over what runs, printf_t on PMD_PRINTF.
/// A sheet's script orders the commands of other hosts as a sheriff does (a Sheriff inside the
/// runner: orders2_t to the deputy of that host, whichever deputy it is, creating the sheet's
/// commands on it when it does not have them), and its waits read those deputies' info2_t
/// (docs/design.md §7.2). Beside that it publishes Kestrel's procman_status_t (state names,
/// restarts, uptime, the script) for kestrel-cmd status.

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "bot_procman/discovery_t.hpp"
#include "bot_procman/info2_t.hpp"
#include "bot_procman/orders2_t.hpp"
#include "common/clock.h"
#include "common/lcm_decode.h"
#include "common/procman/bot_procman.h"
#include "common/procman/sheet.h"
#include "common/procman/sheriff.h"
#include "kestrel/procman_status_t.hpp"

namespace kestrel::procman {

struct DeputyConfig {
  std::string host;                             ///< this runner's host name in the sheet
  std::string log_dir{"/tmp/kestrel-procman"};  ///< per-command output logs
  std::string status_channel{"PROCMAN_STATUS"};
  /// Respawn delay after a quick exit (a run shorter than stable_run_s); it doubles per further
  /// quick exit, up to respawn_backoff_max_s. A command that ran stable_run_s or longer (a
  /// controller killed in flight) is respawned at once, at the next poll (docs/design.md §2.5).
  double respawn_backoff_min_s{0.5};
  double respawn_backoff_max_s{30.0};  ///< the longest respawn delay, s
  double stable_run_s{10.0};           ///< a run this long resets the back-off, s
  /// bot-procman discovery nonce (the deputy uses its pid); 0 = this process's pid.
  int64_t discovery_nonce{0};
  /// @throws std::invalid_argument naming the field, value and accepted range.
  void Validate() const;
};

/// What a runner knows about one of its commands.
struct CommandState {
  Command command;  ///< from the sheet, or from a sheriff's orders; exec etc. updated by orders
  int32_t sheriff_id{0};    ///< identity on the bot-procman wire
  int32_t actual_runid{0};  ///< bot-procman run id: bumped at each ordered start
  bool desired_running{false};
  bool remove_requested{false};  ///< a sheriff's orders no longer list it: forget once stopped
  int8_t state{procman_command_t::STATE_STOPPED};
  int pid{0};
  int exit_code{0};
  int wait_status{0};  ///< raw waitpid status of the last exit (bot-procman's exit_code)
  int pty_fd{-1};      ///< the controlling terminal's master side while its output is read
  int log_fd{-1};      ///< LOG_DIR/<id>.log while running
  int restarts{0};
  int consecutive_quick_exits{0};
  int64_t started_utime{0};
  int64_t stop_sent_utime{0};
  int64_t respawn_at_utime{0};
  double cpu_percent{0};
  double rss_mb{0};
  double machine_cpu_fraction{0};  ///< share of the whole machine (bot-procman's cpu_usage)
  int64_t vsize_bytes{0};
  int64_t rss_bytes{0};
  uint64_t last_cpu_ticks{0};
  int64_t last_cpu_utime{0};
  uint64_t last_machine_jiffies{0};
};

class Deputy {
 public:
  /// The clock must advance with real time (children run in real time).
  Deputy(lcm::LCM& lcm, Sheet sheet, DeputyConfig config, const Clock& clock);
  Deputy(const Deputy&) = delete;
  Deputy& operator=(const Deputy&) = delete;
  /// Kills every child still running (SIGKILL to its process group).
  ~Deputy();

  /// Orders for a command id or group path ("" group = every command). This host's commands
  /// directly; every other host's through bot-procman's orders2_t to the deputy of that host
  /// (Sheriff::OrderSheetCommands: the sheet's commands for that host are created on it if it
  /// does not have them), re-sent every second until its report shows them carried out (or for
  /// 30 s), so a lost datagram does not lose the order; a restart is a new run id, so re-sending
  /// it never restarts twice.
  void Order(SheriffVerb verb, bool is_group, const std::string& target);
  /// Starts running script `name` (advanced by Poll). @throws std::invalid_argument if unknown.
  void RunScript(const std::string& name);
  /// True while a script is running.
  [[nodiscard]] bool script_running() const { return !script_stack_.empty(); }

  /// Reaps exited children, escalates stops, respawns, advances the script. Call at >= 10 Hz.
  void Poll();
  /// Publishes procman_status_t and, once discovery is over, bot-procman's info2_t (call at
  /// 1 Hz).
  void PublishStatus();
  /// True once the bot-procman discovery window is over and sheriff orders are taken.
  [[nodiscard]] bool discovery_done() const { return discovery_done_; }
  /// Set when another deputy with this host name answered during discovery: the caller must
  /// exit (as a bot-procman deputy does). Empty otherwise.
  [[nodiscard]] const std::string& name_conflict() const { return name_conflict_; }
  /// Orders every local command to stop; true once all are stopped.
  void StopAll();
  [[nodiscard]] bool AllStopped() const;

  [[nodiscard]] const CommandState* state(const std::string& id) const;
  /// The info2_t this runner would publish now.
  [[nodiscard]] bot_procman::info2_t MakeInfo();
  [[nodiscard]] const Sheet& sheet() const { return sheet_; }
  /// The publisher epoch stamped on its status and orders (common/identity.h).
  [[nodiscard]] int64_t epoch() const { return epoch_; }

 private:
  void Start(CommandState* s);
  void SendStop(CommandState* s);
  void Spawn(CommandState* s);
  void Reap();
  void SampleUsage(CommandState* s, uint64_t machine_jiffies);
  void ReadOutput(CommandState* s);
  void CloseOutput(CommandState* s);
  void Printf(int32_t sheriff_id, const std::string& text);
  void Discover();
  void OnOrders2(const bot_procman::orders2_t& orders);
  void OnDiscovery(const bot_procman::discovery_t& discovery);
  void OnInfoDuringDiscovery(const bot_procman::info2_t& info);
  CommandState* FindBySheriffId(int32_t sheriff_id);
  void AdvanceScript();
  [[nodiscard]] bool TargetHasStatus(bool is_group, const std::string& target,
                                     const std::string& status) const;
  void OrderLocal(SheriffVerb verb, CommandState* s);

  lcm::LCM& lcm_;
  Sheet sheet_;
  DeputyConfig config_;
  const Clock& clock_;
  std::map<std::string, CommandState> local_;  // by command id, this host's only
  GuardedSubscriptions subscriptions_;
  Sheriff sheriff_;  // orders other hosts' deputies for the scripts; their reports for the waits
  int64_t epoch_;    // this publisher's epoch (common/identity.h)
  int64_t status_seq_{0};

  // bot-procman
  int64_t nonce_;
  int64_t started_utime_;
  int64_t next_discovery_utime_{0};
  bool discovery_done_{false};
  bool info_due_{false};  // something changed: publish info2_t at the next Poll
  std::string name_conflict_;
  uint64_t last_cpu_busy_{0};
  uint64_t last_cpu_total_{0};
  float cpu_load_{0};

  struct ScriptFrame {
    const Script* script;
    size_t next_action;
    int64_t wait_until_utime;        // for wait ms
    const ScriptAction* waiting_on;  // for wait status / start ... wait
  };
  std::vector<ScriptFrame> script_stack_;
};

}  // namespace kestrel::procman
