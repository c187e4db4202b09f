#pragma once
/// @file
/// What every Kestrel process main shares: the command line (--config, --set, --lcm-url, --help,
/// and the process's own options, all parsed by CLI11), loading the YAML configuration with
/// overrides, and turning a configuration error into a one-line message (file, key, value, range)
/// and exit code 2 before anything starts. An unknown option, a missing value or a value that is
/// not of the option's type is such an error: nothing runs on a mistyped command line.
///
/// A main is one screen:
/// @code
///   int main(int argc, char** argv) {
///     std::string save_path;
///     return kestrel::RunProcess(
///         "kestrel-mapper", argc, argv, kUsage,
///         [&](CLI::App& app) { app.add_option("--save", save_path); },   // the process's own
///         [&](const kestrel::ProcessArgs& args, kestrel::ConfigNode& config) {
///       const MapperConfig mapper_config = LoadMapperConfig(config);   // throws ConfigError
///       config.CheckNoUnknownKeys();
///       lcm::LCM lcm(args.lcm_url);
///       ...
///       return loop.Run();
///     });
///   }
/// @endcode

#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/config.h"

namespace CLI {
class App;
}  // namespace CLI

namespace kestrel {

struct ProcessArgs {
  std::string config_path;                ///< --config FILE (empty: defaults only)
  std::vector<std::string> overrides;     ///< --set key.path=value, in order
  std::string lcm_url;                    ///< --lcm-url URL ("" = LCM_DEFAULT_URL or LCM's default)
  std::string sim_clock_channel;          ///< --sim-clock CHANNEL: run on the simulator's time
  std::vector<std::string> command_line;  ///< argv as given, argv[0] first (for params_t)
};

/// Declares a process's own options and positional arguments on the CLI11 parser, bound to the
/// caller's variables (add_option, add_flag; checks such as CLI::PositiveNumber).
using OptionDeclarer = std::function<void(CLI::App&)>;

/// Why a command line was refused (CLI11's words: the argument not expected, the option that
/// could not be converted and its value, the value missing).
class CommandLineError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Parses argv[1..argc) with the common options and those `declare` adds; the variables bound
/// in `declare` hold their values afterwards. Returns false on -h/--help (the
/// caller prints the usage). @throws CommandLineError on anything CLI11 refuses.
[[nodiscard]] bool ParseCommandLine(int argc, const char* const* argv,
                                    const OptionDeclarer& declare, ProcessArgs* args);

/// Parses the command line; prints `usage` and the common options and exits 0 on --help; prints
/// the refusal and a pointer to --help and exits 2 on a malformed command line.
[[nodiscard]] ProcessArgs ParseProcessArgs(int argc, char** argv, const std::string& usage,
                                           const OptionDeclarer& declare);

/// Loads args.config_path (or an empty document) and applies the overrides.
/// @throws ConfigError
[[nodiscard]] ConfigNode LoadProcessConfig(const ProcessArgs& args);

/// Seconds since this process was started (exec), from /proc/self/stat's start time (10 ms
/// resolution) and CLOCK_BOOTTIME; NaN where /proc cannot be read. For start-up timing logs.
[[nodiscard]] double SecondsSinceProcessStart();

/// Parses the arguments, loads the configuration, sets the log name, installs the SIGINT/SIGTERM
/// handlers and runs `body`. A ConfigError (or any exception escaping `body`) is printed as one
/// line and turns into exit code 2 (configuration) or 1 (anything else).
int RunProcess(const std::string& name, int argc, char** argv, const std::string& usage,
               const OptionDeclarer& declare,
               const std::function<int(const ProcessArgs&, ConfigNode&)>& body);

/// RunProcess for a process with no options of its own: any other argument is refused.
int RunProcess(const std::string& name, int argc, char** argv, const std::string& usage,
               const std::function<int(const ProcessArgs&, ConfigNode&)>& body);

}  // namespace kestrel
