#include "common/process.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <exception>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>
#include <CLI/CLI.hpp>

#include "common/lcm_url.h"
#include "common/log.h"
#include "common/node_loop.h"

namespace kestrel {

namespace {
const char* const kCommonHelp =
    "\nCommon options:\n"
    "  --config FILE        YAML configuration (keys are checked; unknown keys are errors)\n"
    "  --set KEY.PATH=VALUE override one configuration value (repeatable)\n"
    "  --lcm-url URL        LCM provider, e.g. udpm://239.255.76.67:7667?ttl=0\n"
    "  --sim-clock CHANNEL  follow the simulator's time (sim_truth_t on CHANNEL, e.g. "
    "SIM_TRUTH)\n"
    "  -h, --help           this text\n";
}  // namespace

bool ParseCommandLine(int argc, const char* const* argv, const OptionDeclarer& declare,
                      ProcessArgs* args) {
  args->command_line.assign(argv, argv + argc);
  CLI::App app;
  app.set_help_flag();  // the process's own usage text is printed instead of CLI11's
  bool help = false;
  app.add_flag("-h,--help", help);
  app.add_option("--config", args->config_path);
  // One value per --set, so a positional argument after it stays positional.
  app.add_option("--set", args->overrides)->allow_extra_args(false);
  app.add_option("--lcm-url", args->lcm_url);
  app.add_option("--sim-clock", args->sim_clock_channel);
  if (declare) declare(app);
  // Extras are collected, not thrown, so that a mistyped option is named first (before, say, a
  // required option that the mistyping left out) and in the order typed.
  app.allow_extras();
  std::vector<std::string> reversed;  // CLI11 takes the arguments last first
  for (int i = argc - 1; i >= 1; --i) reversed.emplace_back(argv[i]);
  std::string refusal;
  try {
    app.parse(reversed);
  } catch (const CLI::ParseError& e) {
    refusal = e.what();
  }
  if (help) return false;
  const std::vector<std::string> extras = app.remaining();
  if (!extras.empty()) {
    const std::string& first = extras.front();
    throw CommandLineError(first.rfind('-', 0) == 0 && first.size() > 1
                               ? "unknown option " + first
                               : "unexpected argument '" + first + "'");
  }
  if (!refusal.empty()) throw CommandLineError(refusal);
  return true;
}

ProcessArgs ParseProcessArgs(int argc, char** argv, const std::string& usage,
                             const OptionDeclarer& declare) {
  ProcessArgs args;
  bool run = false;
  try {
    run = ParseCommandLine(argc, argv, declare, &args);
  } catch (const CommandLineError& e) {
    Log(LogLevel::kError, std::string("command line: ") + e.what() + " (--help lists the options)");
    std::exit(2);
  }
  if (!run) {
    std::printf("%s%s", usage.c_str(), kCommonHelp);
    std::exit(0);
  }
  return args;
}

ConfigNode LoadProcessConfig(const ProcessArgs& args) {
  ConfigNode config = args.config_path.empty() ? ConfigNode::FromString("{}", "(defaults)")
                                               : ConfigNode::LoadFile(args.config_path);
  for (const auto& o : args.overrides) config.ApplyOverride(o);
  return config;
}

double SecondsSinceProcessStart() {
  std::ifstream in("/proc/self/stat");
  std::string stat;
  std::getline(in, stat);
  // Field 22 (starttime, clock ticks after boot) counts from the field after the ")" that ends
  // the command name (which may hold spaces): that is field 3.
  const size_t close = stat.rfind(')');
  if (close == std::string::npos) return std::nan("");
  std::istringstream fields(stat.substr(close + 2));
  std::string field;
  for (int i = 3; i < 22 && fields >> field; ++i) {
  }
  unsigned long long start_ticks = 0;
  if (!(fields >> start_ticks)) return std::nan("");
  timespec now{};
  if (clock_gettime(CLOCK_BOOTTIME, &now) != 0) return std::nan("");
  const double ticks_per_s = static_cast<double>(sysconf(_SC_CLK_TCK));
  return static_cast<double>(now.tv_sec) + 1e-9 * static_cast<double>(now.tv_nsec) -
         static_cast<double>(start_ticks) / ticks_per_s;
}

int RunProcess(const std::string& name, int argc, char** argv, const std::string& usage,
               const std::function<int(const ProcessArgs&, ConfigNode&)>& body) {
  return RunProcess(name, argc, argv, usage, OptionDeclarer(), body);
}

int RunProcess(const std::string& name, int argc, char** argv, const std::string& usage,
               const OptionDeclarer& declare,
               const std::function<int(const ProcessArgs&, ConfigNode&)>& body) {
  SetLogProcessName(name);
  ProcessArgs args = ParseProcessArgs(argc, argv, usage, declare);
  // The receive buffer asked for is what the host grants (docs/design.md §7.6).
  const ReceiveBufferPlan buffer = PlanReceiveBuffer(EffectiveLcmUrl(args.lcm_url), ReadRmemMax());
  if (buffer.resized) {
    Log(LogLevel::kInfo, "LCM: asking recv_buf_size=" + std::to_string(buffer.request_bytes) +
                             ", what net.core.rmem_max allows, for the " +
                             std::to_string(buffer.asked_bytes) + " the URL asked: sockets get " +
                             std::to_string(buffer.granted_bytes) +
                             " bytes (raise net.core.rmem_max for more)");
    args.lcm_url = buffer.url;
  }
  try {
    ConfigNode config = LoadProcessConfig(args);
    NodeLoop::InstallSignalHandlers();
    return body(args, config);
  } catch (const ConfigError& e) {
    Log(LogLevel::kError, std::string("configuration error: ") + e.what());
    return 2;
  } catch (const std::exception& e) {
    Log(LogLevel::kError, std::string("fatal: ") + e.what());
    return 1;
  }
}

}  // namespace kestrel
