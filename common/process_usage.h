#pragma once
/// @file
/// What a process holds: resident memory, threads and open files, from Linux's /proc (the soak
/// run's figures, bench/soak; docs/design.md §7.9). ParseProcStatus is pure; ReadProcessUsage
/// reads /proc/self.

#include <cstdint>
#include <optional>
#include <string>

namespace kestrel {

/// One reading of a process's resources.
struct ProcessUsage {
  int64_t rss_kib{-1};       ///< resident set size (VmRSS), KiB; -1 if not reported
  int64_t peak_rss_kib{-1};  ///< its peak so far (VmHWM), KiB; -1 if not reported
  int threads{-1};           ///< Threads; -1 if not reported
  int open_files{-1};        ///< entries of /proc/<pid>/fd; -1 if not read
};

/// The VmRSS, VmHWM and Threads lines of a /proc/<pid>/status text (proc(5): "VmRSS:\t  1234 kB");
/// fields it does not find stay -1. open_files is left -1.
[[nodiscard]] ProcessUsage ParseProcStatus(const std::string& status_text);

/// This process's usage now (/proc/self/status and /proc/self/fd); nullopt without /proc.
[[nodiscard]] std::optional<ProcessUsage> ReadProcessUsage();

}  // namespace kestrel
