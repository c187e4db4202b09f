#pragma once
/// @file
/// What every Kestrel process main shares: the command line (--config, --set, --lcm-url, --help),
/// loading the YAML configuration with overrides, and turning a configuration error into a
/// one-line message (file, key, value, range) and exit code 2 before anything starts.
///
/// A main is one screen:
/// @code
///   int main(int argc, char** argv) {
///     return kestrel::RunProcess("kestrel-mapper", argc, argv, kUsage,
///                                [](const kestrel::ProcessArgs& args, kestrel::ConfigNode& config)
///                                {
///       const MapperConfig mapper_config = LoadMapperConfig(config);   // throws ConfigError
///       config.CheckNoUnknownKeys();
///       lcm::LCM lcm(args.lcm_url);
///       ...
///       return loop.Run();
///     });
///   }
/// @endcode

#include <functional>
#include <string>
#include <vector>

#include "common/config.h"

namespace kestrel {

struct ProcessArgs {
  std::string config_path;              ///< --config FILE (empty: defaults only)
  std::vector<std::string> overrides;   ///< --set key.path=value, in order
  std::string lcm_url;                  ///< --lcm-url URL ("" = LCM_DEFAULT_URL or LCM's default)
  std::string sim_clock_channel;        ///< --sim-clock CHANNEL: run on the simulator's time
  std::vector<std::string> positional;  ///< anything else, in order
};

/// Parses the common flags. Prints `usage` and exits 0 on --help, exits 2 on a malformed flag.
[[nodiscard]] ProcessArgs ParseProcessArgs(int argc, char** argv, const std::string& usage);

/// Loads args.config_path (or an empty document) and applies the overrides.
/// @throws ConfigError
[[nodiscard]] ConfigNode LoadProcessConfig(const ProcessArgs& args);

/// Parses the arguments, loads the configuration, sets the log name, installs the SIGINT/SIGTERM
/// handlers and runs `body`. A ConfigError (or any exception escaping `body`) is printed as one
/// line and turns into exit code 2 (configuration) or 1 (anything else).
int RunProcess(const std::string& name, int argc, char** argv, const std::string& usage,
               const std::function<int(const ProcessArgs&, ConfigNode&)>& body);

}  // namespace kestrel
