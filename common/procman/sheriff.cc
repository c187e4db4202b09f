#include "common/procman/sheriff.h"

#include <sys/wait.h>

#include <cstdio>

#include "bot_procman/discovery_t.hpp"
#include "common/log.h"

namespace kestrel::procman {

Sheriff::Sheriff(lcm::LCM& lcm, const Clock& clock, std::string name)
    : lcm_(lcm), clock_(clock), name_(std::move(name)), subscriptions_(lcm) {
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
  const int64_t now = clock_.NowUtime();
  if (orders_.empty() || now - last_sent_utime_ < 1'000'000) return;
  for (const std::string& deputy : Pending()) {
    bot_procman::orders2_t& orders = orders_.at(deputy);
    orders.utime = now;
    lcm_.publish(kOrdersChannel, &orders);
  }
  last_sent_utime_ = now;
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
    orders_[deputy] = MakeOrders(info, name_, verb, target, now);
    lcm_.publish(kOrdersChannel, &orders_[deputy]);
    ordered.push_back(deputy);
  }
  last_sent_utime_ = now;
  return ordered;
}

std::vector<std::string> Sheriff::Pending() const {
  std::vector<std::string> pending;
  for (const auto& [deputy, orders] : orders_) {
    if (!OrdersFulfilled(deputies_.at(deputy), orders)) pending.push_back(deputy);
  }
  return pending;
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
