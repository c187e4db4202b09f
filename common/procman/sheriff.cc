#include "common/procman/sheriff.h"

#include <sys/wait.h>

#include <algorithm>
#include <cstdio>

#include "bot_procman/discovery_t.hpp"
#include "common/log.h"

namespace kestrel::procman {

namespace {
/// A sheet command as a sheriff creates it on a deputy: stopped (run 0, force_quit).
bot_procman::sheriff_cmd2_t FromSheet(const Command& c, int32_t sheriff_id) {
  bot_procman::sheriff_cmd2_t s{};
  s.cmd.exec_str = c.exec;
  s.cmd.command_name = c.id;
  s.cmd.group = c.group;
  s.cmd.auto_respawn = static_cast<int8_t>(c.auto_respawn ? 1 : 0);
  s.cmd.stop_signal = static_cast<int8_t>(c.stop_signal);
  s.cmd.stop_time_allowed = static_cast<float>(c.stop_time_allowed_s);
  s.cmd.num_options = 0;
  s.sheriff_id = sheriff_id;
  s.desired_runid = 0;
  s.force_quit = 1;
  return s;
}
}  // namespace

Sheriff::Sheriff(lcm::LCM& lcm, const Clock& clock, std::string name, double give_up_s)
    : lcm_(lcm),
      clock_(clock),
      name_(std::move(name)),
      give_up_utime_(SecondsToUtime(give_up_s)),
      subscriptions_(lcm) {
  subscriptions_.Add<bot_procman::info2_t>(
      kInfoChannel,
      [this](const std::string&, const bot_procman::info2_t& info) { deputies_[info.host] = info; },
      [](const std::string& channel, const std::string& why) {
        Log(LogLevel::kWarning, "dropped a deputy report on " + channel + ": " + why);
      });
}

void Sheriff::Discover() {
  bot_procman::discovery_t msg{};
  msg.utime = clock_.NowUtime();
  msg.host = "";
  msg.nonce = 0;
  lcm_.publish(kDiscoverChannel, &msg);
}

void Sheriff::Poll() {
  while (lcm_.handleTimeout(0) > 0) {
  }
  Resend();
}

void Sheriff::Send(const std::string& host, DeputyOrders* orders, int64_t now) {
  const bot_procman::orders2_t message =
      BuildOrders(deputies_.at(host), orders->wanted, name_, now);
  lcm_.publish(kOrdersChannel, &message);
  orders->next_send_utime = now + 1'000'000;
}

void Sheriff::Resend() {
  const int64_t now = clock_.NowUtime();
  for (auto it = orders_.begin(); it != orders_.end();) {
    const auto report = deputies_.find(it->first);
    if (report != deputies_.end() && WantedFulfilled(report->second, it->second.wanted)) {
      it = orders_.erase(it);
      continue;
    }
    if (now >= it->second.give_up_utime) {
      std::string names;
      for (const auto& [id, w] : it->second.wanted) names += " " + w.cmd.command_name;
      Log(LogLevel::kWarning,
          (report == deputies_.end() ? "no deputy named '" + it->first + "' reported"
                                     : "deputy '" + it->first + "' did not report its orders (" +
                                           names.substr(1) + ") carried out") +
              " within " + std::to_string(UtimeToSeconds(give_up_utime_)) +
              " s; no longer ordering it");
      given_up_.push_back(it->first);
      it = orders_.erase(it);
      continue;
    }
    if (report != deputies_.end() && now >= it->second.next_send_utime) {
      Send(it->first, &it->second, now);
    }
    ++it;
  }
}

Sheriff::DeputyOrders& Sheriff::OrdersFor(const std::string& host) {
  const auto [it, created] = orders_.try_emplace(host);
  if (created) it->second.give_up_utime = clock_.NowUtime() + give_up_utime_;
  return it->second;
}

std::vector<std::string> Sheriff::Order(SheriffVerb verb, const CommandTarget& target,
                                        const std::string& host) {
  std::vector<std::string> ordered;
  const int64_t now = clock_.NowUtime();
  for (const auto& [deputy, info] : deputies_) {
    if (!host.empty() && deputy != host) continue;
    bool holds = false;
    for (const bot_procman::deputy_cmd2_t& c : info.cmds) {
      holds = holds || target.Matches(c.cmd.command_name, c.cmd.group);
    }
    if (!holds) continue;
    DeputyOrders& orders = OrdersFor(deputy);
    for (const bot_procman::deputy_cmd2_t& c : info.cmds) {
      if (!target.Matches(c.cmd.command_name, c.cmd.group)) continue;
      const auto [w, created] = orders.wanted.try_emplace(c.sheriff_id, AsReported(c));
      ApplyVerb(verb, &c, &w->second);
    }
    Send(deputy, &orders, now);
    ordered.push_back(deputy);
  }
  return ordered;
}

int32_t Sheriff::SheriffIdOf(const std::string& host, const Command& c) const {
  const int32_t sheet_id = SheetSheriffId(host, c.id);
  const auto report = deputies_.find(host);
  const auto order = orders_.find(host);
  std::vector<int32_t> taken;
  if (report != deputies_.end()) {
    if (FindReported(report->second, sheet_id) != nullptr) return sheet_id;
    for (const bot_procman::deputy_cmd2_t& d : report->second.cmds) {
      if (d.cmd.command_name == c.id) return d.sheriff_id;  // created by another sheriff
      taken.push_back(d.sheriff_id);
    }
  }
  if (order != orders_.end()) {
    for (const auto& [id, w] : order->second.wanted) {
      if (w.cmd.command_name == c.id) return id;
      taken.push_back(id);
    }
  }
  // A sheet id another command of that deputy already has: the next free one, as the runner's.
  int32_t id = sheet_id;
  while (std::find(taken.begin(), taken.end(), id) != taken.end()) id = id % 0x7ffffffe + 1;
  return id;
}

void Sheriff::OrderSheetCommands(SheriffVerb verb, const std::string& host,
                                 const std::vector<const Command*>& targets, const Sheet& sheet,
                                 bool create_all) {
  const auto report = deputies_.find(host);
  DeputyOrders& orders = OrdersFor(host);
  for (const Command& c : sheet.commands) {
    if (c.host != host) continue;
    const bool targeted = std::find(targets.begin(), targets.end(), &c) != targets.end();
    if (!targeted && !create_all) continue;
    const int32_t id = SheriffIdOf(host, c);
    const bot_procman::deputy_cmd2_t* reported =
        report == deputies_.end() ? nullptr : FindReported(report->second, id);
    auto w = orders.wanted.find(id);
    if (w == orders.wanted.end()) {
      if (reported != nullptr && !targeted) continue;  // has it, not ordered: left alone
      w = orders.wanted.emplace(id, reported != nullptr ? AsReported(*reported) : FromSheet(c, id))
              .first;
    }
    if (targeted) ApplyVerb(verb, reported, &w->second);
  }
  if (report != deputies_.end()) {
    Send(host, &orders, clock_.NowUtime());
  } else {
    Discover();  // ordered once it reports
  }
}

std::vector<std::string> Sheriff::Load(const Sheet& sheet, const std::string& host) {
  std::vector<std::string> missing;
  const int64_t now = clock_.NowUtime();
  for (const Command& c : sheet.commands) {
    if (!host.empty() && c.host != host) continue;
    const auto report = deputies_.find(c.host);
    if (report == deputies_.end()) {
      if (std::find(missing.begin(), missing.end(), c.host) == missing.end()) {
        missing.push_back(c.host);
      }
      continue;
    }
    DeputyOrders& orders = OrdersFor(c.host);
    const int32_t id = SheriffIdOf(c.host, c);
    const bot_procman::deputy_cmd2_t* reported = FindReported(report->second, id);
    auto w = orders.wanted.find(id);
    if (w == orders.wanted.end()) {
      w = orders.wanted.emplace(id, reported != nullptr ? AsReported(*reported) : FromSheet(c, id))
              .first;
    }
    // The sheet's settings (they take effect at the command's next start).
    const bot_procman::sheriff_cmd2_t sheet_settings = FromSheet(c, id);
    w->second.cmd = sheet_settings.cmd;
  }
  for (auto& [deputy, orders] : orders_) {
    if (deputies_.count(deputy) != 0 && (host.empty() || deputy == host)) {
      Send(deputy, &orders, now);
    }
  }
  return missing;
}

std::vector<std::string> Sheriff::Pending() const {
  std::vector<std::string> pending;
  for (const auto& [deputy, orders] : orders_) {
    const auto report = deputies_.find(deputy);
    if (report == deputies_.end() || !WantedFulfilled(report->second, orders.wanted)) {
      pending.push_back(deputy);
    }
  }
  return pending;
}

bool Sheriff::OrderPending(const std::string& host, const std::string& id) const {
  const auto orders = orders_.find(host);
  if (orders == orders_.end()) return false;
  for (const auto& [sheriff_id, w] : orders->second.wanted) {
    if (w.cmd.command_name != id) continue;
    const auto report = deputies_.find(host);
    if (report == deputies_.end()) return true;
    return !WantedFulfilled(report->second, WantedCommands{{sheriff_id, w}});
  }
  return false;
}

const bot_procman::deputy_cmd2_t* Sheriff::Reported(const std::string& host,
                                                    const std::string& id) const {
  const auto report = deputies_.find(host);
  if (report == deputies_.end()) return nullptr;
  for (const bot_procman::deputy_cmd2_t& d : report->second.cmds) {
    if (d.cmd.command_name == id) return &d;
  }
  return nullptr;
}

void Sheriff::FollowOutput(OutputHandler handler) {
  const bool subscribe = !output_;
  output_ = std::move(handler);
  if (!subscribe) return;
  subscriptions_.Add<bot_procman::printf_t>(
      kPrintfChannel,
      [this](const std::string&, const bot_procman::printf_t& m) {
        std::string command;
        const auto report = deputies_.find(m.deputy_name);
        if (report != deputies_.end() && m.sheriff_id != 0) {
          if (const bot_procman::deputy_cmd2_t* d = FindReported(report->second, m.sheriff_id)) {
            command = d->cmd.command_name;
          }
        }
        if (output_) output_(m.deputy_name, command, m);
      },
      [](const std::string& channel, const std::string& why) {
        Log(LogLevel::kWarning, "dropped a command's output on " + channel + ": " + why);
      });
}

std::string FormatDeputies(const std::map<std::string, bot_procman::info2_t>& deputies,
                           int64_t now_utime) {
  std::string out;
  char line[512];
  for (const auto& [name, info] : deputies) {
    std::snprintf(line, sizeof(line),
                  "deputy %s: cpu %.0f%%, memory %.0f of %.0f MiB free, %d commands, report %.1f s "
                  "old\n",
                  name.c_str(), 100.0 * info.cpu_load,
                  static_cast<double>(info.phys_mem_free_bytes) / (1 << 20),
                  static_cast<double>(info.phys_mem_total_bytes) / (1 << 20), info.ncmds,
                  static_cast<double>(now_utime - info.utime) * 1e-6);
    out += line;
    for (const bot_procman::deputy_cmd2_t& c : info.cmds) {
      std::string last = "-";
      if (c.exit_code != 0 || c.actual_runid != 0) {
        if (WIFSIGNALED(c.exit_code)) {
          last = "signal " + std::to_string(WTERMSIG(c.exit_code));
        } else if (WIFEXITED(c.exit_code)) {
          last = "code " + std::to_string(WEXITSTATUS(c.exit_code));
        }
      }
      std::snprintf(line, sizeof(line),
                    "  %-12s %-8s pid %-7d runid %-4d last %-10s cpu %5.1f%% rss %7.1f MiB  "
                    "group %s  id %d\n",
                    c.cmd.command_name.c_str(), c.pid > 0 ? "running" : "stopped", c.pid,
                    c.actual_runid, last.c_str(), 100.0 * c.cpu_usage,
                    static_cast<double>(c.mem_rss_bytes) / (1 << 20),
                    c.cmd.group.empty() ? "-" : c.cmd.group.c_str(), c.sheriff_id);
      out += line;
    }
  }
  return out;
}

}  // namespace kestrel::procman
