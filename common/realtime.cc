#include "common/realtime.h"

#include <sched.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <sstream>

#include "common/check.h"
#include "common/config.h"
#include "common/log.h"

namespace kestrel {

void RealtimeConfig::Validate() const {
  KESTREL_THROW_UNLESS(fifo_priority >= 0 && fifo_priority <= 99,
                       "realtime.fifo_priority = " << fifo_priority << ": 0 (off) or 1..99");
  KESTREL_THROW_UNLESS(nice >= -20 && nice <= 19, "realtime.nice = " << nice << ": -20..19");
  const long online = sysconf(_SC_NPROCESSORS_CONF);
  for (const int cpu : cpus) {
    KESTREL_THROW_UNLESS(cpu >= 0 && cpu < CPU_SETSIZE,
                         "realtime.cpus: CPU " << cpu << " is not in 0.." << CPU_SETSIZE - 1
                                               << " (this machine has " << online << ")");
  }
}

RealtimeConfig ReadRealtimeConfig(const ConfigNode& root) {
  RealtimeConfig config;
  if (!root.Has("realtime")) return config;
  const ConfigNode node = root.Child("realtime");
  node.Read("fifo_priority", &config.fifo_priority, Range::Closed(0, 99));
  std::vector<double> cpus;
  node.Read("cpus", &cpus, Range::Closed(0, CPU_SETSIZE - 1));
  for (const double cpu : cpus) {
    KESTREL_THROW_UNLESS(cpu == std::floor(cpu), "realtime.cpus: " << cpu << " is not a CPU index");
    config.cpus.push_back(static_cast<int>(cpu));
  }
  node.Read("lock_memory", &config.lock_memory);
  node.Read("nice", &config.nice, Range::Closed(-20, 19));
  config.Validate();
  return config;
}

std::string RealtimeOutcome::Summary(const RealtimeConfig& requested) const {
  std::ostringstream out;
  out << (fifo ? "SCHED_FIFO " + std::to_string(requested.fifo_priority) : "normal scheduling");
  if (niced) out << " at nice " << requested.nice;
  out << (memory_locked ? ", memory locked" : ", memory not locked");
  if (affinity) {
    out << ", CPUs";
    for (size_t i = 0; i < requested.cpus.size(); ++i) {
      out << (i == 0 ? " " : ",") << requested.cpus[i];
    }
  } else {
    out << ", any CPU";
  }
  return out.str();
}

RealtimeOutcome ApplyRealtime(const RealtimeConfig& config) {
  config.Validate();
  RealtimeOutcome outcome;
  if (!config.cpus.empty()) {
    cpu_set_t set;
    CPU_ZERO(&set);
    for (const int cpu : config.cpus) CPU_SET(cpu, &set);
    if (sched_setaffinity(0, sizeof(set), &set) == 0) {
      outcome.affinity = true;
    } else {
      outcome.warnings.push_back(std::string("CPU affinity refused (") + std::strerror(errno) +
                                 "): a CPU not on this machine or outside the cgroup's cpuset; "
                                 "running on any CPU");
    }
  }
  if (config.lock_memory) {
    if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) {
      outcome.memory_locked = true;
    } else {
      outcome.warnings.push_back(std::string("mlockall refused (") + std::strerror(errno) +
                                 "): raise RLIMIT_MEMLOCK (ulimit -l, LimitMEMLOCK=infinity in a "
                                 "systemd unit) or grant CAP_IPC_LOCK; pages may fault");
    }
  }
  if (config.nice != 0) {
    // The calling thread's (Linux: nice is per thread), inherited by the threads it starts.
    if (setpriority(PRIO_PROCESS, 0, config.nice) == 0) {
      outcome.niced = true;
    } else {
      outcome.warnings.push_back(
          "nice " + std::to_string(config.nice) + " refused (" + std::strerror(errno) +
          "): grant CAP_SYS_NICE or a nice limit (ulimit -e, LimitNICE in a systemd unit, nice "
          "in /etc/security/limits.conf); running at the inherited nice value");
    }
  }
  if (config.fifo_priority > 0) {
    sched_param param{};
    param.sched_priority = config.fifo_priority;
    if (sched_setscheduler(0, SCHED_FIFO, &param) == 0) {
      outcome.fifo = true;
    } else {
      outcome.warnings.push_back(
          std::string("SCHED_FIFO ") + std::to_string(config.fifo_priority) + " refused (" +
          std::strerror(errno) +
          "): grant CAP_SYS_NICE or an rtprio limit (ulimit -r, LimitRTPRIO in a systemd unit, "
          "rtprio in /etc/security/limits.conf); running with normal scheduling");
    }
  }
  return outcome;
}

RealtimeOutcome ApplyRealtimeAndLog(const RealtimeConfig& config) {
  const RealtimeOutcome outcome = ApplyRealtime(config);
  for (const std::string& warning : outcome.warnings) Log(LogLevel::kWarning, warning);
  Log(LogLevel::kInfo, "rate loop: " + outcome.Summary(config));
  return outcome;
}

void LoopTiming::Record(int64_t late_us) {
  late_us = std::max<int64_t>(0, late_us);
  const auto bin = static_cast<size_t>(std::min<int64_t>(late_us / kBinUs, kBins));
  ++bins_[bin];
  ++count_;
  max_us_ = std::max(max_us_, late_us);
}

int64_t LoopTiming::QuantileUs(double q) const {
  KESTREL_THROW_UNLESS(q > 0.0 && q <= 1.0, "quantile " << q << " is not in (0, 1]");
  if (count_ == 0) return 0;
  const auto rank = static_cast<int64_t>(std::ceil(q * static_cast<double>(count_)));
  int64_t seen = 0;
  for (size_t i = 0; i < kBins; ++i) {
    seen += bins_[i];
    if (seen >= rank) return std::min(static_cast<int64_t>(i + 1) * kBinUs, max_us_);
  }
  return max_us_;
}

void LoopTiming::Reset() {
  bins_.fill(0);
  count_ = 0;
  max_us_ = 0;
}

std::string LoopTimingCsv(const std::vector<std::string>& names,
                          const std::vector<const LoopTiming*>& timings) {
  KESTREL_THROW_UNLESS(names.size() == timings.size(),
                       names.size() << " names for " << timings.size() << " histograms");
  size_t last = 0;
  for (const LoopTiming* timing : timings) {
    for (size_t i = 0; i <= LoopTiming::kBins; ++i) {
      if (timing->bins()[i] > 0) last = std::max(last, i);
    }
  }
  std::ostringstream out;
  out << "bin_start_us";
  for (const std::string& name : names) out << ',' << name;
  out << '\n';
  for (size_t i = 0; i <= last; ++i) {
    out << static_cast<int64_t>(i) * LoopTiming::kBinUs;
    for (const LoopTiming* timing : timings) out << ',' << timing->bins()[i];
    out << '\n';
  }
  return out.str();
}

}  // namespace kestrel
