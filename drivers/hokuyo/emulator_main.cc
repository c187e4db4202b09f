// kestrel-hokuyo-emulator: serves SCIP 2.0 on a pseudo-terminal and prints the tty path to use,
// so kestrel-hokuyo (or any SCIP client) can be run without the sensor.
#include <chrono>
#include <cstdio>
#include <thread>

#include "common/node_loop.h"
#include "common/process.h"
#include "drivers/hokuyo/emulator.h"

namespace {
constexpr char kUsage[] =
    "kestrel-hokuyo-emulator [--config FILE] [--set key=value]...\n"
    "Emulates a Hokuyo LIDAR (SCIP 2.0) on a pseudo-terminal and prints its path.\n"
    "Keys: model (URG-04LX | UTM-30LX), clock_offset_ms, clock_drift_ppm,\n"
    "      link_path (stable symlink to the tty), start_streaming, start_in_time_adjust_mode.\n";
}  // namespace

int main(int argc, char** argv) {
  return kestrel::RunProcess(
      "kestrel-hokuyo-emulator", argc, argv, kUsage,
      [](const kestrel::ProcessArgs&, kestrel::ConfigNode& config) {
        kestrel::HokuyoEmulatorOptions options;
        std::string model = "URG-04LX";
        config.Read("model", &model, std::vector<std::string>{"URG-04LX", "UTM-30LX"});
        options.model = *kestrel::FindHokuyoModel(model);
        config.Read("clock_offset_ms", &options.clock_offset_ms,
                    kestrel::Range::Closed(0, 16777215));
        config.Read("clock_drift_ppm", &options.clock_drift_ppm, kestrel::Range::Closed(-1e4, 1e4));
        config.Read("link_path", &options.link_path);
        config.Read("start_streaming", &options.start_streaming);
        config.Read("start_in_time_adjust_mode", &options.start_in_time_adjust_mode);
        config.CheckNoUnknownKeys();
        kestrel::HokuyoEmulator emulator(options);
        std::printf("%s\n", emulator.device_path().c_str());
        std::fflush(stdout);
        while (!kestrel::NodeLoop::signal_received()) {
          std::this_thread::sleep_for(std::chrono::milliseconds(50));
        }
        return 0;
      });
}
