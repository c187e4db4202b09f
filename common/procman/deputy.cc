#include "common/procman/deputy.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "common/check.h"
#include "common/identity.h"
#include "common/log.h"

namespace kestrel::procman {

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
      epoch_(NewPublisherEpoch()) {
  config_.Validate();
  for (const Command& c : sheet_.commands) {
    if (c.host == config_.host) local_[c.id].command = &c;
  }
  mkdir(config_.log_dir.c_str(), 0755);
  subscriptions_.Add<procman_order_t>(
      config_.orders_channel, [this](const std::string&, const procman_order_t& o) { OnOrder(o); },
      [](const std::string& ch, const std::string& why) {
        Log(LogLevel::kWarning, "dropped order on " + ch + ": " + why);
      });
  subscriptions_.Add<procman_status_t>(
      config_.status_channel,
      [this](const std::string&, const procman_status_t& s) { OnRemoteStatus(s); },
      [](const std::string& ch, const std::string& why) {
        Log(LogLevel::kWarning, "dropped status on " + ch + ": " + why);
      });
}

Deputy::~Deputy() {
  for (auto& [id, s] : local_) {
    if (s.pid > 0) {
      kill(-s.pid, SIGKILL);
      waitpid(s.pid, nullptr, 0);
    }
  }
}

const CommandState* Deputy::state(const std::string& id) const {
  const auto it = local_.find(id);
  return it == local_.end() ? nullptr : &it->second;
}

void Deputy::OnOrder(const procman_order_t& order) {
  if (!order.host.empty() && order.host != config_.host) return;
  if (order.source == config_.host) return;  // our own order to others, echoed back
  for (auto& [id, s] : local_) {
    const Command& c = *s.command;
    const bool match = order.is_group ? (order.target.empty() || c.group == order.target ||
                                         c.group.rfind(order.target + "/", 0) == 0)
                                      : c.id == order.target;
    if (!match) continue;
    if (order.action == procman_order_t::ACTION_START) {
      Start(&s);
    } else if (order.action == procman_order_t::ACTION_STOP) {
      s.desired_running = false;
      SendStop(&s);
    } else if (order.action == procman_order_t::ACTION_RESTART) {
      SendStop(&s);
      s.desired_running = true;  // Reap() starts it again once it has stopped
      s.restarts = 0;
    }
  }
}

void Deputy::OnRemoteStatus(const procman_status_t& status) {
  if (status.host == config_.host) return;
  for (const procman_command_t& c : status.commands) remote_[c.id] = c;
}

void Deputy::Order(int8_t action, bool is_group, const std::string& target) {
  // Local commands directly; every other host through the orders channel.
  procman_order_t order;
  order.utime = clock_.NowUtime();
  order.seq = order_seq_++;
  order.epoch = epoch_;
  order.source = config_.host;
  order.host = "";
  order.action = action;
  order.is_group = static_cast<int8_t>(is_group);
  order.target = target;
  procman_order_t local = order;
  local.source = "";
  OnOrder(local);
  bool remote = false;
  for (const Command& c : sheet_.commands) {
    const bool match =
        is_group ? (target.empty() || c.group == target || c.group.rfind(target + "/", 0) == 0)
                 : c.id == target;
    if (match && c.host != config_.host) remote = true;
  }
  if (remote) lcm_.publish(config_.orders_channel, &order);
}

void Deputy::Start(CommandState* s) {
  s->desired_running = true;
  s->restarts = 0;
  s->consecutive_quick_exits = 0;
  if (s->pid == 0) Spawn(s);
}

void Deputy::Spawn(CommandState* s) {
  const Command& c = *s->command;
  const std::string log_path = config_.log_dir + "/" + c.id + ".log";
  const int log_fd = open(log_path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  const pid_t pid = fork();
  if (pid < 0) {
    Log(LogLevel::kError, "cannot fork for " + c.id + ": " + std::strerror(errno));
    if (log_fd >= 0) close(log_fd);
    s->state = procman_command_t::STATE_EXITED;
    return;
  }
  if (pid == 0) {
    setpgid(0, 0);  // own process group: stop signals reach its children too
    if (log_fd >= 0) {
      dup2(log_fd, STDOUT_FILENO);
      dup2(log_fd, STDERR_FILENO);
    }
    const int devnull = open("/dev/null", O_RDONLY);
    if (devnull >= 0) dup2(devnull, STDIN_FILENO);
    signal(SIGINT, SIG_DFL);
    signal(SIGTERM, SIG_DFL);
    execl("/bin/sh", "sh", "-c", c.exec.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  setpgid(pid, pid);
  if (log_fd >= 0) close(log_fd);
  s->pid = pid;
  s->state = procman_command_t::STATE_RUNNING;
  s->started_utime = clock_.NowUtime();
  s->last_cpu_ticks = 0;
  s->last_cpu_utime = 0;
  Log(LogLevel::kInfo, "started " + c.id + " (pid " + std::to_string(pid) + "): " + c.exec);
}

void Deputy::SendStop(CommandState* s) {
  if (s->pid == 0) {
    if (!s->desired_running) s->state = procman_command_t::STATE_STOPPED;
    return;
  }
  if (s->state == procman_command_t::STATE_STOPPING) return;
  kill(-s->pid, s->command->stop_signal);
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
          now - s.stop_sent_utime >= SecondsToUtime(s.command->stop_time_allowed_s)) {
        Log(LogLevel::kWarning, id + " did not stop within " +
                                    std::to_string(s.command->stop_time_allowed_s) + " s: SIGKILL");
        kill(-s.pid, SIGKILL);
      }
      continue;
    }
    // Exited (or already reaped elsewhere).
    s.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
    kill(-s.pid, SIGKILL);  // whatever it left behind in its group
    s.pid = 0;
    const bool was_stopping = s.state == procman_command_t::STATE_STOPPING;
    const double ran_s = UtimeToSeconds(now - s.started_utime);
    if (s.desired_running && was_stopping) {
      Spawn(&s);  // a restart order
    } else if (!s.desired_running) {
      s.state = procman_command_t::STATE_STOPPED;
    } else if (s.command->auto_respawn) {
      s.consecutive_quick_exits = ran_s >= config_.stable_run_s ? 0 : s.consecutive_quick_exits + 1;
      const double delay = std::min(config_.respawn_backoff_max_s,
                                    config_.respawn_backoff_min_s *
                                        std::pow(2.0, std::max(0, s.consecutive_quick_exits - 1)));
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
  for (auto& [id, s] : local_) {
    if (s.state == procman_command_t::STATE_RESPAWN_WAIT && s.desired_running &&
        now >= s.respawn_at_utime) {
      ++s.restarts;
      Spawn(&s);
    }
  }
}

void Deputy::SampleUsage(CommandState* s) {
  if (s->pid == 0) {
    s->cpu_percent = 0;
    s->rss_mb = 0;
    return;
  }
  std::ifstream stat("/proc/" + std::to_string(s->pid) + "/stat");
  std::string line;
  if (!std::getline(stat, line)) return;
  const size_t close_paren = line.rfind(')');
  if (close_paren == std::string::npos) return;
  std::istringstream fields(line.substr(close_paren + 2));
  std::vector<std::string> f;
  for (std::string x; fields >> x;) f.push_back(x);
  if (f.size() < 22) return;
  // After the command name: state is field 3; utime 14, stime 15; rss 24 (pages).
  const uint64_t ticks = std::stoull(f[11]) + std::stoull(f[12]);
  const int64_t now = clock_.NowUtime();
  if (s->last_cpu_utime > 0 && now > s->last_cpu_utime) {
    const double dt = UtimeToSeconds(now - s->last_cpu_utime);
    s->cpu_percent = 100.0 * static_cast<double>(ticks - s->last_cpu_ticks) /
                     static_cast<double>(sysconf(_SC_CLK_TCK)) / dt;
  }
  s->last_cpu_ticks = ticks;
  s->last_cpu_utime = now;
  s->rss_mb = static_cast<double>(std::stoll(f[21])) * static_cast<double>(sysconf(_SC_PAGESIZE)) /
              (1024.0 * 1024.0);
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
    int8_t state = procman_command_t::STATE_STOPPED;
    const auto local = local_.find(c->id);
    if (local != local_.end()) {
      state = local->second.state;
    } else {
      const auto remote = remote_.find(c->id);
      if (remote == remote_.end()) return false;  // no report yet
      state = remote->second.state;
    }
    const bool running = state == procman_command_t::STATE_RUNNING;
    const bool stopped =
        state == procman_command_t::STATE_STOPPED || state == procman_command_t::STATE_EXITED;
    if (status == "running" ? !running : !stopped) return false;
  }
  return true;
}

void Deputy::RunScript(const std::string& name) {
  const Script* script = sheet_.FindScript(name);
  KESTREL_THROW_UNLESS(script != nullptr, "no script \"" << name << "\" in " << sheet_.file);
  script_stack_.push_back(ScriptFrame{script, 0, 0, nullptr});
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
        Order(procman_order_t::ACTION_START, a.target_is_group, a.target);
        break;
      case ScriptAction::Kind::kStop:
        Order(procman_order_t::ACTION_STOP, a.target_is_group, a.target);
        break;
      case ScriptAction::Kind::kRestart:
        Order(procman_order_t::ACTION_RESTART, a.target_is_group, a.target);
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
  lcm_.handleTimeout(0);
  Reap();
  AdvanceScript();
}

void Deputy::PublishStatus() {
  procman_status_t msg;
  msg.utime = clock_.NowUtime();
  msg.seq = status_seq_++;
  msg.epoch = epoch_;
  msg.host = config_.host;
  msg.sheet = sheet_.file;
  msg.script = script_stack_.empty() ? "" : script_stack_.back().script->name;
  for (auto& [id, s] : local_) {
    SampleUsage(&s);
    procman_command_t c;
    c.id = id;
    c.group = s.command->group;
    c.exec = s.command->exec;
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
