#include "common/procman/bot_procman.h"

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

bot_procman::orders2_t MakeOrders(const bot_procman::info2_t& info, const std::string& sheriff_name,
                                  SheriffVerb verb, const CommandTarget& target, int64_t utime) {
  bot_procman::orders2_t orders{};
  orders.utime = utime;
  orders.host = info.host;
  orders.sheriff_name = sheriff_name;
  for (const bot_procman::deputy_cmd2_t& d : info.cmds) {
    bot_procman::sheriff_cmd2_t s{};
    s.cmd = d.cmd;
    s.cmd.num_options = 0;
    s.cmd.option_names.clear();
    s.cmd.option_values.clear();
    s.sheriff_id = d.sheriff_id;
    s.desired_runid = d.actual_runid;
    s.force_quit = 0;
    if (target.Matches(d.cmd.command_name, d.cmd.group)) {
      const bool running = d.pid > 0;
      if (verb == SheriffVerb::kStop) {
        s.force_quit = 1;
      } else if (verb == SheriffVerb::kRestart || !running) {
        s.desired_runid = d.actual_runid + 1;
      }
    }
    orders.cmds.push_back(s);
  }
  orders.ncmds = static_cast<int32_t>(orders.cmds.size());
  orders.num_options = 0;
  return orders;
}

bool OrdersFulfilled(const bot_procman::info2_t& info, const bot_procman::orders2_t& orders) {
  for (const bot_procman::sheriff_cmd2_t& s : orders.cmds) {
    const bot_procman::deputy_cmd2_t* reported = nullptr;
    for (const bot_procman::deputy_cmd2_t& d : info.cmds) {
      if (d.sheriff_id == s.sheriff_id) reported = &d;
    }
    if (reported == nullptr) return false;
    if (s.force_quit != 0 ? reported->pid != 0 : reported->actual_runid != s.desired_runid) {
      return false;
    }
  }
  return true;
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
