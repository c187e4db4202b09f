#pragma once
/// @file
/// Real-time settings of the vehicle's rate-loop processes (the controller, the IMU and the motor
/// drivers; docs/design.md §2.6): SCHED_FIFO at a priority, memory locked against page faults,
/// CPU affinity. Each is optional and off by default; a setting the machine refuses (no
/// CAP_SYS_NICE or RLIMIT_RTPRIO, a memlock limit, a CPU not there) is a warning that names the
/// cause and the remedy, and the process goes on with normal scheduling, as it would without it.
///
/// Apply before the process starts its threads (before lcm::LCM is built): Linux applies the
/// policy and the affinity to the calling thread, and threads inherit them when created, so
/// LCM's receive thread runs at the same priority as the loop that waits for it.
///
/// LoopTiming measures a periodic loop: each tick's lateness (when it ran, minus when it was
/// scheduled) in a histogram, from which the period jitter's quantiles are read.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace kestrel {

class ConfigNode;

/// A process's real-time request (the `realtime:` section of its configuration).
struct RealtimeConfig {
  int fifo_priority{0};     ///< SCHED_FIFO priority, 1..99; 0: the normal scheduler (SCHED_OTHER)
  bool lock_memory{false};  ///< mlockall(MCL_CURRENT | MCL_FUTURE): no page faults in the loop
  std::vector<int> cpus;    ///< CPUs the process may run on; empty: any
  /// The nice value under the normal scheduler (-20..19; 0: unchanged; below 0 needs
  /// CAP_SYS_NICE or an RLIMIT_NICE): a larger share of the CPU than normal processes without
  /// SCHED_FIFO's power to starve them (and the kernel's network threads) when it runs long.
  int nice{0};

  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
  /// True if anything differs from the defaults (a process that has nothing to apply says
  /// nothing about it).
  [[nodiscard]] bool requested() const {
    return fifo_priority > 0 || lock_memory || !cpus.empty() || nice != 0;
  }
};

/// Reads the optional `realtime:` section (keys fifo_priority, lock_memory, cpus, nice); an absent
/// section or key keeps the default. @throws ConfigError naming the key.
[[nodiscard]] RealtimeConfig ReadRealtimeConfig(const ConfigNode& root);

/// What ApplyRealtime did.
struct RealtimeOutcome {
  bool fifo{false};           ///< SCHED_FIFO is in force at the requested priority
  bool memory_locked{false};  ///< mlockall succeeded
  bool affinity{false};       ///< the CPU set is in force
  bool niced{false};          ///< the requested nice value is in force
  /// One line per refused setting: what, the errno text, and what would allow it.
  std::vector<std::string> warnings;
  /// A one-line summary for the log ("SCHED_FIFO 80, memory locked, CPUs 2,3" / "normal").
  [[nodiscard]] std::string Summary(const RealtimeConfig& requested) const;
};

/// Applies `config` to the calling thread (and so to the threads it starts afterwards) and to
/// the process's memory. Never throws for a refused setting: see RealtimeOutcome::warnings.
RealtimeOutcome ApplyRealtime(const RealtimeConfig& config);
/// ApplyRealtime, then one log line per warning and one "rate loop: <summary>" line: what every
/// rate-loop process does at start, before it builds its LCM object.
RealtimeOutcome ApplyRealtimeAndLog(const RealtimeConfig& config);

/// The lateness histogram of a periodic loop (docs/design.md §2.6): Record each tick's lateness
/// in microseconds; bins of 10 us up to 20 ms, then one overflow bin.
class LoopTiming {
 public:
  static constexpr int64_t kBinUs = 10;  ///< bin width, us
  static constexpr size_t kBins = 2000;  ///< bins below the overflow bin
  /// Adds one tick that ran `late_us` after its scheduled time (negative: counted as 0).
  void Record(int64_t late_us);
  /// Ticks recorded.
  [[nodiscard]] int64_t count() const { return count_; }
  /// The largest lateness recorded, us (0 before any).
  [[nodiscard]] int64_t max_us() const { return max_us_; }
  /// The q-quantile (0 < q <= 1) of the lateness, us: the upper edge of the bin it falls in
  /// (exact to kBinUs); max_us() beyond the last bin; 0 before any tick.
  [[nodiscard]] int64_t QuantileUs(double q) const;
  /// Bin counts (bin i: [i kBinUs, (i+1) kBinUs) us; the last, overflow).
  [[nodiscard]] const std::array<int64_t, kBins + 1>& bins() const { return bins_; }
  /// Forgets every tick.
  void Reset();

 private:
  std::array<int64_t, kBins + 1> bins_{};
  int64_t count_{0};
  int64_t max_us_{0};
};

/// The histograms as CSV for plots: a header "bin_start_us,<name>,..." and one row per bin up to
/// the last non-empty one (the overflow bin's start is kBins * kBinUs). Histograms share bins.
[[nodiscard]] std::string LoopTimingCsv(const std::vector<std::string>& names,
                                        const std::vector<const LoopTiming*>& timings);

}  // namespace kestrel
