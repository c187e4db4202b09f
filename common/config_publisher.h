#pragma once
/// @file
/// A process's effective configuration on the bus, so that a log describes itself
/// (docs/design.md §6): every key the process read, with the value it runs with and its source
/// (default, file, --set override), the files it included, its command line and its run id, as one
/// params_t on PARAMS_<PROCESS>. Published when built (after the configuration is loaded) and
/// again for every params_request_t on REQUEST_PARAMS that names the process or no process, so a
/// logger started later, or kestrel-cmd params, gets it too.
///
/// @code
///   kestrel::ConfigPublisher params(lcm, *clock, "kestrel-mapper", "PARAMS_MAPPER", args, node);
/// @endcode

#include <cstdint>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/config.h"
#include "common/lcm_decode.h"
#include "common/process.h"
#include "kestrel/params_request_t.hpp"
#include "kestrel/params_t.hpp"

namespace kestrel {

/// The channel on which every process listens for params_request_t.
inline constexpr const char* kParamsRequestChannel = "REQUEST_PARAMS";

/// PARAMS_<PROCESS> for a process whose heartbeat is on HEARTBEAT_<PROCESS> ("HEARTBEAT_MAPPER"
/// -> "PARAMS_MAPPER"), PARAMS_<PREFIX><PROCESS> for a vehicle's <PREFIX>HEARTBEAT_<PROCESS>
/// ("V2_HEARTBEAT_CONTROLLER" -> "PARAMS_V2_CONTROLLER"); a channel without HEARTBEAT_ gets
/// "PARAMS_" in front of it whole.
[[nodiscard]] std::string ParamsChannelFor(const std::string& heartbeat_channel);

/// The params_t of `config` (its EffectiveValues() at the time of the call) for `process`.
[[nodiscard]] params_t MakeParamsMessage(const std::string& process, const ProcessArgs& args,
                                         const ConfigNode& config);

/// The word for a param_t source: "default", "file", "override" ("unknown" for any other value).
[[nodiscard]] const char* ParamSourceName(int8_t source);

/// A params_t for people: a header line (process, host, pid, run id), the command line, then
/// every value as "key: value" under the file it came from, "# default" or "# override" after
/// the values that the file did not set.
[[nodiscard]] std::string FormatParams(const params_t& msg);

class ConfigPublisher {
 public:
  /// Subscribes to REQUEST_PARAMS and publishes the configuration once. `config` is shared, not
  /// copied: values read after this are in later messages.
  ConfigPublisher(lcm::LCM& lcm, const Clock& clock, std::string process, std::string channel,
                  ProcessArgs args, const ConfigNode& config);
  ConfigPublisher(const ConfigPublisher&) = delete;
  ConfigPublisher& operator=(const ConfigPublisher&) = delete;

  /// Publishes the configuration now.
  void Publish();

  [[nodiscard]] const std::string& channel() const { return channel_; }
  /// Messages published (the first one included) and malformed requests dropped.
  [[nodiscard]] int64_t published() const { return seq_; }
  [[nodiscard]] int64_t malformed_requests() const { return malformed_requests_; }

 private:
  lcm::LCM& lcm_;
  const Clock& clock_;
  std::string process_;
  std::string channel_;
  ProcessArgs args_;
  ConfigNode config_;
  int64_t epoch_;
  int64_t seq_{0};
  int64_t malformed_requests_{0};
  GuardedSubscriptions subscriptions_;
};

}  // namespace kestrel
