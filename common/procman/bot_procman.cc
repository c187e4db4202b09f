#include "common/procman/bot_procman.h"

#include <algorithm>
#include <sstream>
#include <stdexcept>

#include "common/fnv1a.h"

namespace kestrel::procman {

int32_t SheetSheriffId(const std::string& host, const std::string& command_id) {
  // FNV-1a over "host/command_id", folded into [1, 2^31 - 1].
  const uint64_t h = Fnv1a(host + "/" + command_id);
  const auto id = static_cast<int32_t>((h ^ (h >> 31)) & 0x7fffffffULL);
  return id == 0 ? 1 : id;
}

OrderAction DecideOrder(bool running, int32_t actual_runid,
                        const bot_procman::sheriff_cmd2_t& order) {
  const bool other_run = order.desired_runid != actual_runid;
  if (!running && other_run && order.force_quit == 0) return OrderAction::kStart;
  if (running && (order.force_quit != 0 || other_run)) return OrderAction::kStop;
  return OrderAction::kAdopt;
}

bool CommandTarget::Matches(const std::string& command_name, const std::string& group) const {
  if (!is_group) return command_name == name;
  return name.empty() || group == name || group.rfind(name + "/", 0) == 0;
}

const bot_procman::deputy_cmd2_t* FindReported(const bot_procman::info2_t& info,
                                               int32_t sheriff_id) {
  for (const bot_procman::deputy_cmd2_t& d : info.cmds) {
    if (d.sheriff_id == sheriff_id) return &d;
  }
  return nullptr;
}

void ApplyVerb(SheriffVerb verb, const bot_procman::deputy_cmd2_t* reported,
               bot_procman::sheriff_cmd2_t* wanted) {
  const int32_t actual = reported != nullptr ? reported->actual_runid : 0;
  const bool running = reported != nullptr && reported->pid > 0;
  switch (verb) {
    case SheriffVerb::kStart:
      wanted->force_quit = 0;
      if (running) {
        wanted->desired_runid = std::max(wanted->desired_runid, actual);
      } else if (wanted->desired_runid <= actual) {
        wanted->desired_runid = actual + 1;
      }
      break;
    case SheriffVerb::kRestart:
      wanted->force_quit = 0;
      wanted->desired_runid = std::max(wanted->desired_runid, actual) + 1;
      break;
    case SheriffVerb::kStop:
      wanted->force_quit = 1;
      wanted->desired_runid = std::max(wanted->desired_runid, actual);
      break;
  }
}

bot_procman::sheriff_cmd2_t AsReported(const bot_procman::deputy_cmd2_t& d) {
  bot_procman::sheriff_cmd2_t s{};
  s.cmd = d.cmd;
  s.cmd.num_options = 0;
  s.cmd.option_names.clear();
  s.cmd.option_values.clear();
  s.sheriff_id = d.sheriff_id;
  s.desired_runid = d.actual_runid;
  s.force_quit = 0;
  return s;
}

bot_procman::orders2_t BuildOrders(const bot_procman::info2_t& info, const WantedCommands& wanted,
                                   const std::string& sheriff_name, int64_t utime) {
  bot_procman::orders2_t orders{};
  orders.utime = utime;
  orders.host = info.host;
  orders.sheriff_name = sheriff_name;
  for (const bot_procman::deputy_cmd2_t& d : info.cmds) {
    const auto w = wanted.find(d.sheriff_id);
    orders.cmds.push_back(w != wanted.end() ? w->second : AsReported(d));
  }
  for (const auto& [id, w] : wanted) {
    if (FindReported(info, id) == nullptr) orders.cmds.push_back(w);
  }
  orders.ncmds = static_cast<int32_t>(orders.cmds.size());
  orders.num_options = 0;
  return orders;
}

bool WantedFulfilled(const bot_procman::info2_t& info, const WantedCommands& wanted) {
  for (const auto& [id, w] : wanted) {
    const bot_procman::deputy_cmd2_t* reported = FindReported(info, id);
    if (reported == nullptr) return false;
    if (w.force_quit != 0 ? reported->pid != 0 : reported->actual_runid != w.desired_runid) {
      return false;
    }
  }
  return true;
}

bot_procman::orders2_t MakeOrders(const bot_procman::info2_t& info, const std::string& sheriff_name,
                                  SheriffVerb verb, const CommandTarget& target, int64_t utime) {
  WantedCommands wanted;
  for (const bot_procman::deputy_cmd2_t& d : info.cmds) {
    if (!target.Matches(d.cmd.command_name, d.cmd.group)) continue;
    bot_procman::sheriff_cmd2_t w = AsReported(d);
    ApplyVerb(verb, &d, &w);
    wanted[d.sheriff_id] = w;
  }
  return BuildOrders(info, wanted, sheriff_name, utime);
}

bool OrdersFulfilled(const bot_procman::info2_t& info, const bot_procman::orders2_t& orders) {
  WantedCommands wanted;
  for (const bot_procman::sheriff_cmd2_t& s : orders.cmds) wanted[s.sheriff_id] = s;
  return WantedFulfilled(info, wanted);
}

CpuTimes ParseProcStatCpu(const std::string& proc_stat) {
  std::istringstream lines(proc_stat);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("cpu ", 0) != 0) continue;
    std::istringstream fields(line.substr(4));
    uint64_t user = 0, nice = 0, system = 0, idle = 0;
    if (!(fields >> user >> nice >> system >> idle)) {
      throw std::runtime_error("/proc/stat: malformed cpu line '" + line + "'");
    }
    return CpuTimes{user + nice + system, user + nice + system + idle};
  }
  throw std::runtime_error("/proc/stat: no 'cpu ' line");
}

MemoryFigures ParseMeminfo(const std::string& proc_meminfo) {
  MemoryFigures m;
  std::istringstream lines(proc_meminfo);
  for (std::string line; std::getline(lines, line);) {
    std::istringstream fields(line);
    std::string key;
    int64_t kib = 0;
    if (!(fields >> key >> kib)) continue;
    const int64_t bytes = kib * 1024;
    if (key == "MemTotal:") m.phys_total_bytes = bytes;
    if (key == "MemFree:") m.phys_free_bytes = bytes;
    if (key == "SwapTotal:") m.swap_total_bytes = bytes;
    if (key == "SwapFree:") m.swap_free_bytes = bytes;
  }
  return m;
}

ProcessFigures ParseProcessStat(const std::string& proc_pid_stat) {
  // "pid (comm) state ppid ...": comm may hold spaces and parentheses; fields count from the
  // last ')'. After it, field 3 (state) is word 0, so field N is word N - 3.
  const size_t close = proc_pid_stat.rfind(')');
  if (close == std::string::npos) throw std::runtime_error("/proc/<pid>/stat: no ')'");
  std::istringstream fields(proc_pid_stat.substr(close + 1));
  std::vector<std::string> w;
  for (std::string x; fields >> x;) w.push_back(x);
  if (w.size() < 22) {
    throw std::runtime_error("/proc/<pid>/stat: " + std::to_string(w.size()) +
                             " fields after the command name, expected at least 22");
  }
  try {
    ProcessFigures p;
    p.cpu_jiffies = std::stoull(w[14 - 3]) + std::stoull(w[15 - 3]);  // utime, stime
    p.vsize_bytes = std::stoll(w[23 - 3]);
    p.rss_pages = std::stoll(w[24 - 3]);
    return p;
  } catch (const std::logic_error& e) {
    throw std::runtime_error(std::string("/proc/<pid>/stat: malformed number: ") + e.what());
  }
}

}  // namespace kestrel::procman
