#pragma once
/// @file
/// A process-sheet runner for one host, like a bot-procman deputy: starts the sheet's commands
/// for its host as child processes (each in its own process group, output appended to
/// LOG_DIR/<id>.log), respawns those marked auto_respawn with exponential back-off, stops them
/// with their stop_signal and then SIGKILL after stop_time_allowed, reports every command's
/// state (pid, running or exited with code, restarts, CPU, memory) on the status channel, obeys
/// orders for its host from the orders channel, and runs the sheet's scripts (orders for other
/// hosts' commands are published for their runners; waits use their status reports).

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/lcm_decode.h"
#include "common/procman/sheet.h"
#include "kestrel/procman_order_t.hpp"
#include "kestrel/procman_status_t.hpp"

namespace kestrel::procman {

struct DeputyConfig {
  std::string host;                             ///< this runner's host name in the sheet
  std::string log_dir{"/tmp/kestrel-procman"};  ///< per-command output logs
  std::string status_channel{"PROCMAN_STATUS"};
  std::string orders_channel{"PROCMAN_ORDERS"};
  double respawn_backoff_min_s{0.5};   ///< first respawn delay
  double respawn_backoff_max_s{30.0};  ///< delay doubles per quick exit, up to this
  double stable_run_s{10.0};           ///< a run this long resets the back-off
  /// @throws std::invalid_argument naming the field, value and accepted range.
  void Validate() const;
};

/// What a runner knows about one of its commands.
struct CommandState {
  const Command* command{nullptr};
  bool desired_running{false};
  int8_t state{procman_command_t::STATE_STOPPED};
  int pid{0};
  int exit_code{0};
  int restarts{0};
  int consecutive_quick_exits{0};
  int64_t started_utime{0};
  int64_t stop_sent_utime{0};
  int64_t respawn_at_utime{0};
  double cpu_percent{0};
  double rss_mb{0};
  uint64_t last_cpu_ticks{0};
  int64_t last_cpu_utime{0};
};

class Deputy {
 public:
  /// The clock must advance with real time (children run in real time).
  Deputy(lcm::LCM& lcm, Sheet sheet, DeputyConfig config, const Clock& clock);
  Deputy(const Deputy&) = delete;
  Deputy& operator=(const Deputy&) = delete;
  /// Kills every child still running (SIGKILL to its process group).
  ~Deputy();

  /// Orders for a command id or group path ("" group = every command). Commands of other hosts
  /// are ordered through the orders channel.
  void Order(int8_t action, bool is_group, const std::string& target);
  /// Starts running script `name` (advanced by Poll). @throws std::invalid_argument if unknown.
  void RunScript(const std::string& name);
  /// True while a script is running.
  [[nodiscard]] bool script_running() const { return !script_stack_.empty(); }

  /// Reaps exited children, escalates stops, respawns, advances the script. Call at >= 10 Hz.
  void Poll();
  /// Publishes procman_status_t (call at >= 1 Hz).
  void PublishStatus();
  /// Orders every local command to stop; true once all are stopped.
  void StopAll();
  [[nodiscard]] bool AllStopped() const;

  [[nodiscard]] const CommandState* state(const std::string& id) const;
  [[nodiscard]] const Sheet& sheet() const { return sheet_; }
  /// The publisher epoch stamped on its status and orders (common/identity.h).
  [[nodiscard]] int64_t epoch() const { return epoch_; }

 private:
  void Start(CommandState* s);
  void SendStop(CommandState* s);
  void Spawn(CommandState* s);
  void Reap();
  void SampleUsage(CommandState* s);
  void AdvanceScript();
  [[nodiscard]] bool TargetHasStatus(bool is_group, const std::string& target,
                                     const std::string& status) const;
  void OnOrder(const procman_order_t& order);
  void OnRemoteStatus(const procman_status_t& status);

  lcm::LCM& lcm_;
  Sheet sheet_;
  DeputyConfig config_;
  const Clock& clock_;
  std::map<std::string, CommandState> local_;        // by command id, this host's only
  std::map<std::string, procman_command_t> remote_;  // other hosts' reports, by command id
  GuardedSubscriptions subscriptions_;
  int64_t epoch_;  // this publisher's epoch (common/identity.h)
  int64_t status_seq_{0};
  int64_t order_seq_{0};

  struct ScriptFrame {
    const Script* script;
    size_t next_action;
    int64_t wait_until_utime;        // for wait ms
    const ScriptAction* waiting_on;  // for wait status / start ... wait
  };
  std::vector<ScriptFrame> script_stack_;
};

}  // namespace kestrel::procman
