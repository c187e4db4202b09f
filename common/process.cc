#include "common/process.h"

#include <cstdio>
#include <cstdlib>
#include <exception>

#include "common/log.h"
#include "common/node_loop.h"

namespace kestrel {

ProcessArgs ParseProcessArgs(int argc, char** argv, const std::string& usage) {
  ProcessArgs args;
  const std::string common_help =
      "\nCommon options:\n"
      "  --config FILE        YAML configuration (keys are checked; unknown keys are errors)\n"
      "  --set KEY.PATH=VALUE override one configuration value (repeatable)\n"
      "  --lcm-url URL        LCM provider, e.g. udpm://239.255.76.67:7667?ttl=0\n"
      "  --sim-clock CHANNEL  follow the simulator's time (sim_truth_t on CHANNEL, e.g. "
      "SIM_TRUTH)\n"
      "  -h, --help           this text\n";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&](const std::string& flag) -> std::string {
      const std::string prefix = flag + "=";
      if (a.rfind(prefix, 0) == 0) return a.substr(prefix.size());
      if (i + 1 >= argc) {
        std::fprintf(stderr, "%s: %s needs a value\n%s%s", argv[0], flag.c_str(), usage.c_str(),
                     common_help.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "-h" || a == "--help") {
      std::printf("%s%s", usage.c_str(), common_help.c_str());
      std::exit(0);
    } else if (a == "--config" || a.rfind("--config=", 0) == 0) {
      args.config_path = value("--config");
    } else if (a == "--set" || a.rfind("--set=", 0) == 0) {
      args.overrides.push_back(value("--set"));
    } else if (a == "--lcm-url" || a.rfind("--lcm-url=", 0) == 0) {
      args.lcm_url = value("--lcm-url");
    } else if (a == "--sim-clock" || a.rfind("--sim-clock=", 0) == 0) {
      args.sim_clock_channel = value("--sim-clock");
    } else {
      args.positional.push_back(a);  // process-specific flags and arguments: the body's to check
    }
  }
  return args;
}

ConfigNode LoadProcessConfig(const ProcessArgs& args) {
  ConfigNode config = args.config_path.empty() ? ConfigNode::FromString("{}", "(defaults)")
                                               : ConfigNode::LoadFile(args.config_path);
  for (const auto& o : args.overrides) config.ApplyOverride(o);
  return config;
}

int RunProcess(const std::string& name, int argc, char** argv, const std::string& usage,
               const std::function<int(const ProcessArgs&, ConfigNode&)>& body) {
  SetLogProcessName(name);
  const ProcessArgs args = ParseProcessArgs(argc, argv, usage);
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
