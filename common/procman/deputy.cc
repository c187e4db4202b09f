#include "common/procman/deputy.h"

#include <fcntl.h>
#include <pty.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "bot_procman/printf_t.hpp"
#include "common/check.h"
#include "common/identity.h"
#include "common/log.h"
#include "common/procman/bot_procman.h"
#include "common/procman/exec_line.h"

namespace kestrel::procman {
namespace {

/// Signals a command and everything in its process group. Right after fork the child may not
/// have made its own session yet (forkpty's setsid): then the group does not exist and the child
/// itself is signalled (it blocks signals until it has reset their handlers, so none is lost).
void SignalCommand(pid_t pid, int signal_number) {
  if (kill(-pid, signal_number) != 0 && errno == ESRCH) kill(pid, signal_number);
}

std::string ReadWholeFile(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

void DeputyConfig::Validate() const {
  KESTREL_THROW_UNLESS(!host.empty(), "host must name this runner's host in the sheet");
  KESTREL_THROW_UNLESS(respawn_backoff_min_s > 0 && respawn_backoff_min_s <= respawn_backoff_max_s,
                       "respawn_backoff_min_s = " << respawn_backoff_min_s
                                                  << " must be in (0, respawn_backoff_max_s = "
                                                  << respawn_backoff_max_s << "]");
  KESTREL_THROW_UNLESS(stable_run_s > 0, "stable_run_s = " << stable_run_s << " must be > 0");
}

Deputy::Deputy(lcm::LCM& lcm, Sheet sheet, DeputyConfig config, const Clock& clock)
    : lcm_(lcm),
      sheet_(std::move(sheet)),
      config_(std::move(config)),
      clock_(clock),
      subscriptions_(lcm),
      sheriff_(lcm, clock, "kestrel-procman:" + config_.host + ":" + std::to_string(getpid())),
      epoch_(NewPublisherEpoch()),
      nonce_(config_.discovery_nonce != 0 ? config_.discovery_nonce : getpid()),
      started_utime_(clock.NowUtime()) {
  config_.Validate();
  for (const Command& c : sheet_.commands) {
    if (c.host != config_.host) continue;
    CommandState& s = local_[c.id];
    s.command = c;
    s.sheriff_id = SheetSheriffId(c.host, c.id);
    const auto taken = [this, &s] {
      for (const auto& [other_id, other] : local_) {
        if (&other != &s && other.sheriff_id == s.sheriff_id) return true;
      }
      return false;
    };
    while (taken()) s.sheriff_id = s.sheriff_id % 0x7ffffffe + 1;
  }
  mkdir(config_.log_dir.c_str(), 0755);
  const auto drop = [](const std::string& ch, const std::string& why) {
    Log(LogLevel::kWarning, "dropped bot-procman message on " + ch + ": " + why);
  };
  subscriptions_.Add<bot_procman::discovery_t>(
      kDiscoverChannel,
      [this](const std::string&, const bot_procman::discovery_t& d) { OnDiscovery(d); }, drop);
  subscriptions_.Add<bot_procman::info2_t>(
      kInfoChannel,
      [this](const std::string&, const bot_procman::info2_t& i) { OnInfoDuringDiscovery(i); },
      drop);
  subscriptions_.Add<bot_procman::orders2_t>(
      kOrdersChannel, [this](const std::string&, const bot_procman::orders2_t& o) { OnOrders2(o); },
      drop);
}

Deputy::~Deputy() {
  for (auto& [id, s] : local_) {
    if (s.pid > 0) {
      kill(-s.pid, SIGKILL);
      waitpid(s.pid, nullptr, 0);
    }
    CloseOutput(&s);
  }
}

CommandState* Deputy::FindBySheriffId(int32_t sheriff_id) {
  for (auto& [id, s] : local_) {
    if (s.sheriff_id == sheriff_id) return &s;
  }
  return nullptr;
}

void Deputy::Printf(int32_t sheriff_id, const std::string& text) {
  bot_procman::printf_t msg{};
  msg.utime = clock_.NowUtime();
  msg.deputy_name = config_.host;
  msg.sheriff_id = sheriff_id;
  msg.text = text;
  lcm_.publish(kPrintfChannel, &msg);
}

void Deputy::Discover() {
  const int64_t now = clock_.NowUtime();
  if (discovery_done_ || now < next_discovery_utime_) return;
  if (now >= started_utime_ + kDiscoveryUtime) {
    discovery_done_ = true;
    info_due_ = true;
    Log(LogLevel::kInfo, "bot-procman: no other deputy named '" + config_.host +
                             "'; taking orders on " + kOrdersChannel);
    return;
  }
  bot_procman::discovery_t msg{};
  msg.utime = now;
  msg.host = config_.host;
  msg.nonce = nonce_;
  lcm_.publish(kDiscoverChannel, &msg);
  next_discovery_utime_ = now + kDiscoveryPeriodUtime;
}

void Deputy::OnDiscovery(const bot_procman::discovery_t& discovery) {
  if (!discovery_done_) {
    if (discovery.host == config_.host && discovery.nonce != nonce_ && name_conflict_.empty()) {
      name_conflict_ = "another bot-procman deputy named '" + config_.host +
                       "' is running (discovery nonce " + std::to_string(discovery.nonce) + ")";
    }
    return;
  }
  info_due_ = true;  // a sheriff (or a new deputy) asks who is there
}

void Deputy::OnInfoDuringDiscovery(const bot_procman::info2_t& info) {
  if (discovery_done_ || info.host != config_.host || !name_conflict_.empty()) return;
  name_conflict_ =
      "another bot-procman deputy named '" + config_.host + "' reports on " + kInfoChannel;
}

void Deputy::OnOrders2(const bot_procman::orders2_t& orders) {
  if (!discovery_done_ || orders.host != config_.host) return;
  const int64_t now = clock_.NowUtime();
  if (now - orders.utime > kMaxOrderAgeUtime) {
    const std::string why = "ignoring stale orders from " + orders.sheriff_name + " (utime " +
                            std::to_string((now - orders.utime) / 1000000) +
                            " seconds ago). You may want to check the system clocks!\n";
    for (const bot_procman::sheriff_cmd2_t& c : orders.cmds) Printf(c.sheriff_id, why);
    Log(LogLevel::kWarning, why.substr(0, why.size() - 1));
    return;
  }
  bool changed = false;
  std::vector<int32_t> listed;
  for (const bot_procman::sheriff_cmd2_t& order : orders.cmds) {
    listed.push_back(order.sheriff_id);
    CommandState* s = FindBySheriffId(order.sheriff_id);
    if (s == nullptr) {
      // A command this runner's sheet does not have: the sheriff's sheet is the authority.
      std::string id = order.cmd.command_name.empty() ? "cmd" + std::to_string(order.sheriff_id)
                                                      : order.cmd.command_name;
      if (local_.count(id) != 0) id += "#" + std::to_string(order.sheriff_id);
      s = &local_[id];
      s->command.id = id;
      s->command.host = config_.host;
      s->sheriff_id = order.sheriff_id;
      Log(LogLevel::kInfo, "bot-procman: " + orders.sheriff_name + " adds command " + id);
      changed = true;
    }
    s->remove_requested = false;  // listed again
    // Takes effect at the next start, as with the deputy. A stop signal or time a stop could not
    // use keeps the sheet's (or procman's default) and is reported.
    s->command.exec = order.cmd.exec_str;
    s->command.group = order.cmd.group;
    s->command.auto_respawn = order.cmd.auto_respawn;
    if (order.cmd.stop_signal >= 1 && order.cmd.stop_signal <= SIGRTMAX) {
      s->command.stop_signal = order.cmd.stop_signal;
    } else {
      Printf(order.sheriff_id, "ignoring stop_signal " + std::to_string(order.cmd.stop_signal) +
                                   " (not a signal); keeping " +
                                   std::to_string(s->command.stop_signal) + "\n");
    }
    if (std::isfinite(order.cmd.stop_time_allowed) && order.cmd.stop_time_allowed >= 0 &&
        order.cmd.stop_time_allowed <= 3600) {
      s->command.stop_time_allowed_s = order.cmd.stop_time_allowed;
    } else {
      Printf(order.sheriff_id, "ignoring stop_time_allowed " +
                                   std::to_string(order.cmd.stop_time_allowed) +
                                   " s (accepted: 0 to 3600); keeping " +
                                   std::to_string(s->command.stop_time_allowed_s) + " s\n");
    }
    if (order.force_quit != 0 && s->pid == 0 && s->desired_running) {
      s->desired_running = false;  // no respawn
      s->state = procman_command_t::STATE_STOPPED;
      changed = true;
    }
    switch (DecideOrder(s->pid != 0, s->actual_runid, order)) {
      case OrderAction::kStart:
        s->actual_runid = order.desired_runid;
        s->desired_running = true;
        s->restarts = 0;
        s->consecutive_quick_exits = 0;
        Spawn(s);
        changed = true;
        break;
      case OrderAction::kStop:
        if (s->state != procman_command_t::STATE_STOPPING) changed = true;
        s->desired_running = false;
        SendStop(s);
        break;
      case OrderAction::kAdopt:
        s->actual_runid = order.desired_runid;
        break;
    }
  }
  for (auto it = local_.begin(); it != local_.end();) {
    CommandState& s = it->second;
    if (std::find(listed.begin(), listed.end(), s.sheriff_id) != listed.end()) {
      ++it;
      continue;
    }
    changed = true;
    if (s.pid == 0) {
      Log(LogLevel::kInfo, "bot-procman: " + orders.sheriff_name + " removes command " + it->first);
      CloseOutput(&s);
      it = local_.erase(it);
      continue;
    }
    s.remove_requested = true;
    s.desired_running = false;
    SendStop(&s);
    ++it;
  }
  if (changed) info_due_ = true;
}

const CommandState* Deputy::state(const std::string& id) const {
  const auto it = local_.find(id);
  return it == local_.end() ? nullptr : &it->second;
}

void Deputy::OrderLocal(SheriffVerb verb, CommandState* s) {
  switch (verb) {
    case SheriffVerb::kStart:
      Start(s);
      break;
    case SheriffVerb::kStop:
      s->desired_running = false;
      SendStop(s);
      break;
    case SheriffVerb::kRestart:
      if (s->pid == 0) {
        Start(s);
      } else {
        SendStop(s);
        s->desired_running = true;  // Reap() starts it again once it has stopped
        s->restarts = 0;
      }
      break;
  }
  info_due_ = true;
}

void Deputy::Order(SheriffVerb verb, bool is_group, const std::string& target) {
  const CommandTarget wanted{is_group, target};
  // This host's commands directly.
  for (auto& [id, s] : local_) {
    if (wanted.Matches(s.command.id, s.command.group)) OrderLocal(verb, &s);
  }
  // Every other host's through its deputy, as a sheriff (docs/protocols.md §5.4).
  std::map<std::string, std::vector<const Command*>> remote;  // by host
  for (const Command& c : sheet_.commands) {
    if (c.host != config_.host && wanted.Matches(c.id, c.group)) remote[c.host].push_back(&c);
  }
  for (const auto& [host, commands] : remote) {
    sheriff_.OrderSheetCommands(verb, host, commands, sheet_, true);
    Log(LogLevel::kInfo, "ordered " + std::to_string(commands.size()) + " command(s) of " + host +
                             " (" + commands.front()->id + (commands.size() > 1 ? ", ..." : "") +
                             ") through its deputy");
  }
}

void Deputy::Start(CommandState* s) {
  s->desired_running = true;
  s->restarts = 0;
  s->consecutive_quick_exits = 0;
  if (s->pid == 0) {
    ++s->actual_runid;  // a new run, as a sheriff's start would make it
    Spawn(s);
  }
  info_due_ = true;
}

void Deputy::Spawn(CommandState* s) {
  const Command& c = s->command;
  const ExecLine line = ParseExecLine(c.exec, EnvironmentLookup());
  s->wait_status = 0;
  if (line.argv.empty()) {
    const std::string why = "[" + c.id + "] nothing to run in exec \"" + c.exec + "\"\n";
    Log(LogLevel::kError, why.substr(0, why.size() - 1));
    Printf(s->sheriff_id, why);
    s->state = procman_command_t::STATE_EXITED;
    return;
  }
  CloseOutput(s);
  const std::string log_path = config_.log_dir + "/" + c.id + ".log";
  s->log_fd = open(log_path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (s->log_fd < 0) {
    Log(LogLevel::kWarning, "cannot open " + log_path + ": " + std::strerror(errno) + "; " + c.id +
                                "'s output goes to " + kPrintfChannel + " only");
  }
  // argv and environment prepared before fork: the child only calls async-signal-safe functions.
  std::vector<char*> argv;
  for (const std::string& a : line.argv) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  int pty_fd = -1;
  sigset_t all_signals;
  sigset_t old_mask;
  sigfillset(&all_signals);
  sigprocmask(SIG_BLOCK, &all_signals, &old_mask);
  const pid_t pid = forkpty(&pty_fd, nullptr, nullptr, nullptr);
  if (pid != 0) sigprocmask(SIG_SETMASK, &old_mask, nullptr);
  if (pid < 0) {
    const std::string why =
        "[" + c.id + "] couldn't start [" + c.exec + "]: forkpty: " + std::strerror(errno) + "\n";
    Log(LogLevel::kError, why.substr(0, why.size() - 1));
    Printf(s->sheriff_id, why);
    CloseOutput(s);
    s->state = procman_command_t::STATE_EXITED;
    return;
  }
  if (pid == 0) {
    // The child: its own session and process group (forkpty), the terminal as stdin, stdout
    // and stderr. Output as written: no "\n" to "\r\n" translation.
    termios t{};
    if (tcgetattr(STDOUT_FILENO, &t) == 0) {
      t.c_oflag &= ~static_cast<tcflag_t>(ONLCR);
      tcsetattr(STDOUT_FILENO, TCSANOW, &t);
    }
    for (const int sig : {SIGINT, SIGTERM, SIGHUP, SIGQUIT, SIGPIPE, SIGCHLD}) signal(sig, SIG_DFL);
    sigprocmask(SIG_SETMASK, &old_mask, nullptr);  // a stop sent meanwhile is acted on now
    for (const auto& [name, value] : line.environment) setenv(name.c_str(), value.c_str(), 1);
    execvp(argv[0], argv.data());
    const int error = errno;
    dprintf(STDERR_FILENO, "kestrel-procman: [%s] cannot execute [%s]: %s\n", c.id.c_str(), argv[0],
            std::strerror(error));
    _exit(127);
  }
  fcntl(pty_fd, F_SETFL, fcntl(pty_fd, F_GETFL) | O_NONBLOCK);
  fcntl(pty_fd, F_SETFD, FD_CLOEXEC);
  s->pty_fd = pty_fd;
  s->pid = pid;
  s->state = procman_command_t::STATE_RUNNING;
  s->started_utime = clock_.NowUtime();
  s->last_cpu_ticks = 0;
  s->last_cpu_utime = 0;
  s->last_machine_jiffies = 0;
  info_due_ = true;
  Log(LogLevel::kInfo, "started " + c.id + " (pid " + std::to_string(pid) + "): " + c.exec);
}

void Deputy::ReadOutput(CommandState* s) {
  if (s->pty_fd < 0) return;
  char buffer[kPrintfChunkBytes];
  for (;;) {
    const ssize_t n = read(s->pty_fd, buffer, sizeof(buffer));
    if (n > 0) {
      if (s->log_fd >= 0 && write(s->log_fd, buffer, static_cast<size_t>(n)) != n) {
        Log(LogLevel::kWarning,
            "short write to " + s->command.id + ".log: " + std::strerror(errno));
      }
      Printf(s->sheriff_id, std::string(buffer, static_cast<size_t>(n)));
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    // EAGAIN: nothing more for now. EIO or 0: every writer has closed the terminal.
    if (n == 0 || errno != EAGAIN) {
      close(s->pty_fd);
      s->pty_fd = -1;
    }
    return;
  }
}

void Deputy::CloseOutput(CommandState* s) {
  if (s->pty_fd >= 0) close(s->pty_fd);
  if (s->log_fd >= 0) close(s->log_fd);
  s->pty_fd = -1;
  s->log_fd = -1;
}

void Deputy::SendStop(CommandState* s) {
  if (s->pid == 0) {
    if (!s->desired_running) s->state = procman_command_t::STATE_STOPPED;
    return;
  }
  if (s->state == procman_command_t::STATE_STOPPING) return;
  SignalCommand(s->pid, s->command.stop_signal);
  s->state = procman_command_t::STATE_STOPPING;
  s->stop_sent_utime = clock_.NowUtime();
}

void Deputy::Reap() {
  const int64_t now = clock_.NowUtime();
  for (auto& [id, s] : local_) {
    if (s.pid == 0) continue;
    int status = 0;
    const pid_t r = waitpid(s.pid, &status, WNOHANG);
    if (r == 0) {
      if (s.state == procman_command_t::STATE_STOPPING &&
          now - s.stop_sent_utime >= SecondsToUtime(s.command.stop_time_allowed_s)) {
        Log(LogLevel::kWarning, id + " did not stop within " +
                                    std::to_string(s.command.stop_time_allowed_s) + " s: SIGKILL");
        SignalCommand(s.pid, SIGKILL);
      }
      continue;
    }
    // Exited (or already reaped elsewhere).
    s.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
    s.wait_status = status;
    kill(-s.pid, SIGKILL);  // whatever it left behind in its group
    s.pid = 0;
    ReadOutput(&s);  // what it wrote last
    CloseOutput(&s);
    if (WIFSIGNALED(status)) Printf(s.sheriff_id, std::string(strsignal(WTERMSIG(status))) + "\n");
    info_due_ = true;
    const bool was_stopping = s.state == procman_command_t::STATE_STOPPING;
    const double ran_s = UtimeToSeconds(now - s.started_utime);
    if (s.remove_requested) {
      s.state = procman_command_t::STATE_STOPPED;
    } else if (s.desired_running && was_stopping) {
      ++s.actual_runid;
      Spawn(&s);  // a restart order
    } else if (!s.desired_running) {
      s.state = procman_command_t::STATE_STOPPED;
    } else if (s.command.auto_respawn) {
      s.consecutive_quick_exits = ran_s >= config_.stable_run_s ? 0 : s.consecutive_quick_exits + 1;
      // After a stable run at once (a controller killed in flight must be back before the ESC
      // hold ends); quick exits back off, doubling.
      const double delay = s.consecutive_quick_exits == 0
                               ? 0.0
                               : std::min(config_.respawn_backoff_max_s,
                                          config_.respawn_backoff_min_s *
                                              std::pow(2.0, s.consecutive_quick_exits - 1));
      s.state = procman_command_t::STATE_RESPAWN_WAIT;
      s.respawn_at_utime = now + SecondsToUtime(delay);
      Log(LogLevel::kWarning, id + " exited with " + std::to_string(s.exit_code) + " after " +
                                  std::to_string(ran_s) + " s; respawning in " +
                                  std::to_string(delay) + " s");
    } else {
      s.state = procman_command_t::STATE_EXITED;
      Log(LogLevel::kInfo, id + " exited with " + std::to_string(s.exit_code));
    }
  }
  for (auto it = local_.begin(); it != local_.end();) {
    CommandState& s = it->second;
    if (s.state == procman_command_t::STATE_RESPAWN_WAIT && s.desired_running &&
        now >= s.respawn_at_utime) {
      ++s.restarts;
      Spawn(&s);  // same runid, as the deputy's respawn
    }
    if (s.remove_requested && s.pid == 0) {
      Log(LogLevel::kInfo, "bot-procman: removed command " + it->first);
      it = local_.erase(it);
    } else {
      ++it;
    }
  }
}

void Deputy::SampleUsage(CommandState* s, uint64_t machine_jiffies) {
  if (s->pid == 0) {
    s->cpu_percent = 0;
    s->machine_cpu_fraction = 0;
    s->rss_mb = 0;
    s->rss_bytes = 0;
    s->vsize_bytes = 0;
    return;
  }
  ProcessFigures p;
  try {
    p = ParseProcessStat(ReadWholeFile("/proc/" + std::to_string(s->pid) + "/stat"));
  } catch (const std::runtime_error&) {
    return;  // exited in between: reaped at the next Poll
  }
  const int64_t now = clock_.NowUtime();
  if (s->last_cpu_utime > 0 && now > s->last_cpu_utime && p.cpu_jiffies >= s->last_cpu_ticks) {
    const double ticks = static_cast<double>(p.cpu_jiffies - s->last_cpu_ticks);
    const double dt = UtimeToSeconds(now - s->last_cpu_utime);
    s->cpu_percent = 100.0 * ticks / static_cast<double>(sysconf(_SC_CLK_TCK)) / dt;
    if (machine_jiffies > s->last_machine_jiffies && s->last_machine_jiffies > 0) {
      s->machine_cpu_fraction =
          ticks / static_cast<double>(machine_jiffies - s->last_machine_jiffies);
    }
  }
  s->last_cpu_ticks = p.cpu_jiffies;
  s->last_cpu_utime = now;
  s->last_machine_jiffies = machine_jiffies;
  s->vsize_bytes = p.vsize_bytes;
  s->rss_bytes = p.rss_pages * sysconf(_SC_PAGESIZE);
  s->rss_mb = static_cast<double>(s->rss_bytes) / (1024.0 * 1024.0);
}

bool Deputy::TargetHasStatus(bool is_group, const std::string& target,
                             const std::string& status) const {
  std::vector<const Command*> targets;
  if (is_group) {
    targets = sheet_.CommandsInGroup(target);
  } else if (const Command* c = sheet_.FindCommand(target)) {
    targets.push_back(c);
  }
  for (const Command* c : targets) {
    bool running = false;
    bool stopped = false;
    const auto local = local_.find(c->id);
    if (c->host == config_.host) {
      if (local == local_.end()) return false;
      const int8_t state = local->second.state;
      running = state == procman_command_t::STATE_RUNNING;
      stopped =
          state == procman_command_t::STATE_STOPPED || state == procman_command_t::STATE_EXITED;
    } else {
      // Another host's: its deputy's latest report (bot-procman reports only a pid), once it
      // shows the script's order for it carried out (a restart: the new run).
      const bot_procman::deputy_cmd2_t* reported = sheriff_.Reported(c->host, c->id);
      if (reported == nullptr || sheriff_.OrderPending(c->host, c->id)) return false;
      running = reported->pid > 0;
      stopped = reported->pid == 0;
    }
    if (status == "running" ? !running : !stopped) return false;
  }
  return true;
}

void Deputy::RunScript(const std::string& name) {
  const Script* script = sheet_.FindScript(name);
  KESTREL_THROW_UNLESS(script != nullptr, "no script \"" << name << "\" in " << sheet_.file);
  script_stack_.push_back(ScriptFrame{script, 0, 0, nullptr});
  sheriff_.Discover();  // the other hosts' deputies report at once, for its orders and waits
  Log(LogLevel::kInfo, "running script \"" + name + "\"");
}

void Deputy::AdvanceScript() {
  const int64_t now = clock_.NowUtime();
  while (!script_stack_.empty()) {
    ScriptFrame& frame = script_stack_.back();
    if (frame.waiting_on != nullptr) {
      if (!TargetHasStatus(frame.waiting_on->target_is_group, frame.waiting_on->target,
                           frame.waiting_on->wait_status)) {
        return;
      }
      frame.waiting_on = nullptr;
    }
    if (frame.wait_until_utime > 0) {
      if (now < frame.wait_until_utime) return;
      frame.wait_until_utime = 0;
    }
    if (frame.next_action >= frame.script->actions.size()) {
      Log(LogLevel::kInfo, "script \"" + frame.script->name + "\" done");
      script_stack_.pop_back();
      continue;
    }
    const ScriptAction& a = frame.script->actions[frame.next_action++];
    switch (a.kind) {
      case ScriptAction::Kind::kStart:
        Order(SheriffVerb::kStart, a.target_is_group, a.target);
        break;
      case ScriptAction::Kind::kStop:
        Order(SheriffVerb::kStop, a.target_is_group, a.target);
        break;
      case ScriptAction::Kind::kRestart:
        Order(SheriffVerb::kRestart, a.target_is_group, a.target);
        break;
      case ScriptAction::Kind::kWaitMs:
        frame.wait_until_utime = now + int64_t{a.wait_ms} * 1000;
        break;
      case ScriptAction::Kind::kWaitStatus:
        frame.waiting_on = &a;
        break;
      case ScriptAction::Kind::kRunScript:
        script_stack_.push_back(ScriptFrame{sheet_.FindScript(a.target), 0, 0, nullptr});
        continue;
    }
    if (!a.wait_status.empty() && a.kind != ScriptAction::Kind::kWaitStatus) {
      script_stack_.back().waiting_on = &a;
    }
  }
}

void Deputy::Poll() {
  while (lcm_.handleTimeout(0) > 0) {
  }
  Discover();
  for (auto& [id, s] : local_) ReadOutput(&s);
  Reap();
  AdvanceScript();
  sheriff_.Resend();
  if (info_due_ && discovery_done_) {
    bot_procman::info2_t info = MakeInfo();
    lcm_.publish(kInfoChannel, &info);
    info_due_ = false;
  }
}

bot_procman::info2_t Deputy::MakeInfo() {
  bot_procman::info2_t info{};
  info.utime = clock_.NowUtime();
  info.host = config_.host;
  info.cpu_load = cpu_load_;
  const MemoryFigures memory = ParseMeminfo(ReadWholeFile("/proc/meminfo"));
  info.phys_mem_total_bytes = memory.phys_total_bytes;
  info.phys_mem_free_bytes = memory.phys_free_bytes;
  info.swap_total_bytes = memory.swap_total_bytes;
  info.swap_free_bytes = memory.swap_free_bytes;
  for (const auto& [id, s] : local_) {
    bot_procman::deputy_cmd2_t d{};
    d.cmd.exec_str = s.command.exec;
    d.cmd.command_name = id;
    d.cmd.group = s.command.group;
    d.cmd.auto_respawn = s.command.auto_respawn;
    d.cmd.stop_signal = static_cast<int8_t>(s.command.stop_signal);
    d.cmd.stop_time_allowed = static_cast<float>(s.command.stop_time_allowed_s);
    d.cmd.num_options = 0;
    d.pid = s.pid;
    d.actual_runid = s.actual_runid;
    d.exit_code = s.wait_status;
    d.cpu_usage = static_cast<float>(s.machine_cpu_fraction);
    d.mem_vsize_bytes = s.vsize_bytes;
    d.mem_rss_bytes = s.rss_bytes;
    d.sheriff_id = s.sheriff_id;
    info.cmds.push_back(d);
  }
  info.ncmds = static_cast<int32_t>(info.cmds.size());
  info.num_options = 0;
  return info;
}

void Deputy::PublishStatus() {
  procman_status_t msg;
  msg.utime = clock_.NowUtime();
  msg.seq = status_seq_++;
  msg.epoch = epoch_;
  msg.host = config_.host;
  msg.sheet = sheet_.file;
  msg.script = script_stack_.empty() ? "" : script_stack_.back().script->name;
  CpuTimes cpu;
  try {
    cpu = ParseProcStatCpu(ReadWholeFile("/proc/stat"));
  } catch (const std::runtime_error& e) {
    Log(LogLevel::kWarning, std::string("CPU load unknown: ") + e.what());
  }
  if (cpu.total > last_cpu_total_ && last_cpu_total_ > 0 && cpu.busy >= last_cpu_busy_) {
    cpu_load_ = static_cast<float>(static_cast<double>(cpu.busy - last_cpu_busy_) /
                                   static_cast<double>(cpu.total - last_cpu_total_));
  }
  last_cpu_busy_ = cpu.busy;
  last_cpu_total_ = cpu.total;
  for (auto& [id, s] : local_) {
    SampleUsage(&s, cpu.total);
    procman_command_t c;
    c.id = id;
    c.group = s.command.group;
    c.exec = s.command.exec;
    c.desired_running = static_cast<int8_t>(s.desired_running);
    c.state = s.state;
    c.pid = s.pid;
    c.exit_code = s.exit_code;
    c.restarts = s.restarts;
    c.cpu_percent = s.cpu_percent;
    c.rss_mb = s.rss_mb;
    c.uptime_s = s.pid > 0 ? UtimeToSeconds(msg.utime - s.started_utime) : 0.0;
    msg.commands.push_back(c);
  }
  msg.num_commands = static_cast<int32_t>(msg.commands.size());
  lcm_.publish(config_.status_channel, &msg);
  if (discovery_done_) {
    bot_procman::info2_t info = MakeInfo();
    lcm_.publish(kInfoChannel, &info);
    info_due_ = false;
  }
}

void Deputy::StopAll() {
  script_stack_.clear();
  for (auto& [id, s] : local_) {
    s.desired_running = false;
    SendStop(&s);
  }
}

bool Deputy::AllStopped() const {
  for (const auto& [id, s] : local_) {
    if (s.pid != 0) return false;
  }
  return true;
}

}  // namespace kestrel::procman
