#pragma once
/// @file
/// libbot2 bot-procman's wire protocol (docs/protocols.md §5), as pure functions: what a deputy
/// does with a sheriff's orders, how a sheriff builds orders from a deputy's report, and the
/// machine figures a deputy reports. kestrel-procman (common/procman/deputy.h) is the deputy;
/// kestrel-cmd procman is a one-shot sheriff.

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "bot_procman/info2_t.hpp"
#include "bot_procman/orders2_t.hpp"
#include "bot_procman/sheriff_cmd2_t.hpp"

namespace kestrel::procman {

/// bot-procman's channels.
inline constexpr const char* kInfoChannel = "PMD_INFO2";
inline constexpr const char* kOrdersChannel = "PMD_ORDERS2";
inline constexpr const char* kPrintfChannel = "PMD_PRINTF";
inline constexpr const char* kDiscoverChannel = "PMD_DISCOVER";

/// A deputy announces itself on PMD_DISCOVER for this long after start, and takes orders only
/// afterwards; every this often.
inline constexpr int64_t kDiscoveryUtime = 1'500'000;
inline constexpr int64_t kDiscoveryPeriodUtime = 200'000;
/// Orders older than this are ignored (the sheriff's clock is off).
inline constexpr int64_t kMaxOrderAgeUtime = 60'000'000;
/// Largest piece of a command's output in one printf_t (one read of its terminal).
inline constexpr int kPrintfChunkBytes = 1023;

/// A command's identity on the wire for a sheet command: a stable hash of host and command id
/// in [1, 2^31 - 1], so that a runner restarted with the same sheet reports the same ids.
[[nodiscard]] int32_t SheetSheriffId(const std::string& host, const std::string& command_id);

/// What a deputy does with one sheriff_cmd2_t for a command it knows (docs/protocols.md §5.2).
enum class OrderAction {
  kStart,  ///< stopped, another runid wanted, not force_quit: start, actual_runid = desired
  kStop,   ///< running and force_quit or another runid: stop (a restart's first half)
  kAdopt,  ///< nothing to do: actual_runid = desired_runid
};
[[nodiscard]] OrderAction DecideOrder(bool running, int32_t actual_runid,
                                      const bot_procman::sheriff_cmd2_t& order);

/// The sheriff's verbs.
enum class SheriffVerb { kStart, kStop, kRestart };

/// Which commands of a report an order names: the command "cmd:ID", the group "group:PATH"
/// (and its subgroups), or "all".
struct CommandTarget {
  bool is_group{true};
  std::string name;  ///< command id, or group path ("" with is_group = every command)
  [[nodiscard]] bool Matches(const std::string& command_name, const std::string& group) const;
};

/// What a sheriff wants of some of one deputy's commands, by sheriff_id: each as the
/// sheriff_cmd2_t it will send (the command's settings, desired_runid, force_quit).
using WantedCommands = std::map<int32_t, bot_procman::sheriff_cmd2_t>;

/// The command `sheriff_id` in a deputy's report, nullptr if it is not there.
[[nodiscard]] const bot_procman::deputy_cmd2_t* FindReported(const bot_procman::info2_t& info,
                                                             int32_t sheriff_id);

/// What a sheriff sends to keep a reported command as it is: its settings, desired_runid = its
/// actual_runid, no force_quit.
[[nodiscard]] bot_procman::sheriff_cmd2_t AsReported(const bot_procman::deputy_cmd2_t& reported);

/// A verb applied to what a sheriff wants of one command, given the deputy's report of it
/// (nullptr: the deputy does not have it yet, its run id counts from 0). Start clears force_quit
/// and asks for the next run unless it runs (or a new run is already wanted); restart asks for
/// the run after the one wanted or reported, whichever is later; stop sets force_quit.
void ApplyVerb(SheriffVerb verb, const bot_procman::deputy_cmd2_t* reported,
               bot_procman::sheriff_cmd2_t* wanted);

/// The orders a sheriff sends the deputy that sent `info`: every reported command as it is
/// (desired_runid = its actual_runid, no force_quit) unless `wanted` has it, then every wanted
/// command (those the deputy does not report yet are created by it), in that order. A command
/// left out would be stopped and forgotten by the deputy, so none is.
[[nodiscard]] bot_procman::orders2_t BuildOrders(const bot_procman::info2_t& info,
                                                 const WantedCommands& wanted,
                                                 const std::string& sheriff_name, int64_t utime);

/// True once `info` shows every wanted command as wanted: reported with the desired run id, and
/// stopped (pid 0) where force_quit is set.
[[nodiscard]] bool WantedFulfilled(const bot_procman::info2_t& info, const WantedCommands& wanted);

/// The full desired state a sheriff sends to the deputy that sent `info` for one verb
/// (BuildOrders with the verb applied to the targeted commands): every command as it is, except
/// the targeted ones: start and restart add 1 to their runid and clear force_quit (start leaves
/// running ones alone), stop sets force_quit.
[[nodiscard]] bot_procman::orders2_t MakeOrders(const bot_procman::info2_t& info,
                                                const std::string& sheriff_name, SheriffVerb verb,
                                                const CommandTarget& target, int64_t utime);

/// True once `info` shows every command of `orders` as ordered: running with the desired runid,
/// or stopped where force_quit is set.
[[nodiscard]] bool OrdersFulfilled(const bot_procman::info2_t& info,
                                   const bot_procman::orders2_t& orders);

/// The whole machine's figures a deputy reports, from /proc/stat's "cpu" line and /proc/meminfo.
struct CpuTimes {
  uint64_t busy{0};   ///< user + nice + system jiffies
  uint64_t total{0};  ///< busy + idle
};
/// @throws std::runtime_error when the "cpu " line is missing or malformed.
[[nodiscard]] CpuTimes ParseProcStatCpu(const std::string& proc_stat);
struct MemoryFigures {
  int64_t phys_total_bytes{0};
  int64_t phys_free_bytes{0};  ///< MemFree (as the deputy reports), not MemAvailable
  int64_t swap_total_bytes{0};
  int64_t swap_free_bytes{0};
};
[[nodiscard]] MemoryFigures ParseMeminfo(const std::string& proc_meminfo);

/// One process's figures from /proc/<pid>/stat.
struct ProcessFigures {
  uint64_t cpu_jiffies{0};  ///< utime + stime
  int64_t vsize_bytes{0};
  int64_t rss_pages{0};
};
/// @throws std::runtime_error when the line is malformed.
[[nodiscard]] ProcessFigures ParseProcessStat(const std::string& proc_pid_stat);

}  // namespace kestrel::procman
