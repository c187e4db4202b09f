// kestrel-devices: lists the attached Hokuyo and Xtion sensors (--list) or watches them come and
// go (--watch SECONDS), through libusb-1.0, or sysfs alone where libusb cannot start.
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "common/command_line.h"
#include "common/config.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "drivers/usb/devices_config.h"
#include "drivers/usb/usb_discovery.h"

namespace {

const char kUsage[] =
    "kestrel-devices: lists Kestrel's USB sensors (Hokuyo 15d1:0000, Xtion 1d27:0600/0601).\n"
    "Usage: kestrel-devices [--list] [--watch SECONDS] [--config config/drivers/devices.yaml]\n"
    "                       [--set use_libusb=false] [--set sysfs_root=/sys]\n"
    "  --list           print the attached sensors, one per line (default)\n"
    "  --watch SECONDS  print 'arrived ...' / 'left ...' lines for SECONDS (present ones first)\n";

const char kNone[] = "no Hokuyo (15d1:0000) or Xtion (1d27:0600/0601) device attached\n";

}  // namespace

int main(int argc, char** argv) {
  bool list = false;
  double watch_s = 0.0;
  return kestrel::RunProcess(
      "kestrel-devices", argc, argv, kUsage,
      [&](CLI::App& app) {
        app.add_flag("--list", list);
        app.add_option("--watch", watch_s)->check(kestrel::cli::Within(1e-3, 86400.0));
      },
      [&](const kestrel::ProcessArgs&, kestrel::ConfigNode& config_node) {
        const bool watch = watch_s > 0.0;
        if (list && watch) throw kestrel::ConfigError("--list and --watch exclude each other");
        const kestrel::DevicesConfig config = kestrel::LoadDevicesConfig(config_node);
        config_node.CheckNoUnknownKeys();

        std::unique_ptr<kestrel::UsbDiscovery> usb;
        if (config.use_libusb) {
          std::string error;
          usb = kestrel::UsbDiscovery::Open(config.sysfs_root, &error);
          if (!usb) std::printf("libusb unavailable (%s); using sysfs only\n", error.c_str());
        }
        std::mutex print_mutex;
        int events = 0;
        auto print_event = [&](const kestrel::UsbEvent& e) {
          std::lock_guard<std::mutex> lock(print_mutex);
          ++events;
          std::printf("%s %s\n", e.arrived ? "arrived" : "left", e.sensor.Describe().c_str());
          std::fflush(stdout);
        };

        if (!watch) {
          const std::vector<kestrel::UsbSensor> sensors =
              usb ? usb->List()
                  : kestrel::SensorsFromSysfs(kestrel::ScanSysfsUsbDevices(config.sysfs_root));
          for (const auto& s : sensors) std::printf("%s\n", s.Describe().c_str());
          if (sensors.empty()) std::fputs(kNone, stdout);
          return 0;
        }
        std::string error;
        if (usb && usb->StartWatch(print_event, &error)) {
          const auto end =
              std::chrono::steady_clock::now() + std::chrono::duration<double>(watch_s);
          while (std::chrono::steady_clock::now() < end && !kestrel::NodeLoop::signal_received()) {
            std::this_thread::sleep_for(std::chrono::milliseconds(50));
          }
          usb->StopWatch();
        } else {
          if (usb) std::printf("libusb hot-plug unavailable (%s); watching sysfs\n", error.c_str());
          std::atomic<bool> stop{false};
          kestrel::WatchSysfs(
              config.sysfs_root, watch_s, config.poll_period_s,
              [&](const kestrel::UsbEvent& e) {
                print_event(e);
                if (kestrel::NodeLoop::signal_received()) stop = true;
              },
              &stop);
        }
        if (events == 0) std::fputs(kNone, stdout);
        return 0;
      });
}
