// USB discovery on a fake sysfs tree built in a temporary directory (real layout: devices under
// /sys/devices, symlinked from /sys/bus/usb/devices, CDC-ACM ttys under the interface), the
// VID:PID table, hot-plug de-duplication, the sysfs watch, and the kestrel-devices executable.
#include "drivers/usb/usb_sysfs.h"

#include <gtest/gtest.h>
#include <stdlib.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>
#include <thread>

#include "common/config.h"
#include "drivers/usb/devices_config.h"
#include "drivers/usb/usb_discovery.h"

namespace kestrel {
namespace {

namespace fs = std::filesystem;

void WriteFile(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

// A fake sysfs root, removed at the end of the test.
class FakeSysfs : public ::testing::Test {
 protected:
  void SetUp() override {
    char pattern[] = "/tmp/kestrel_usb_sysfs_XXXXXX";
    ASSERT_NE(mkdtemp(pattern), nullptr);
    root_ = pattern;
    fs::create_directories(root_ / "bus/usb/devices");
    // Root hub of bus 1 (not a sensor).
    AddDevice("usb1", "pci0000:00/0000:00:14.0/usb1", "1d6b", "0002", 1, 1, "0000:00:14.0");
    // Hokuyo on 1-1, CDC-ACM with the current tty layout, serial readable.
    const fs::path hokuyo =
        AddDevice("1-1", "pci0000:00/0000:00:14.0/usb1/1-1", "15d1", "0000", 1, 5, "H1234567");
    fs::create_directories(hokuyo / "1-1:1.0/tty/ttyACM0");
    fs::create_directories(hokuyo / "1-1:1.1");
    Link("1-1:1.0", hokuyo / "1-1:1.0");  // interfaces are listed too, without idVendor
    // Xtion on 2-3 (PID 0601), no serial attribute, no tty.
    AddDevice("2-3", "pci0000:00/0000:00:1d.0/usb2/2-3", "1d27", "0601", 2, 7, "");
    // A second Hokuyo behind a hub, old tty layout "tty:ttyACM1".
    const fs::path hokuyo2 = AddDevice("1-2.4", "pci0000:00/0000:00:14.0/usb1/1-2/1-2.4", "15D1",
                                       "0000", 1, 12, "H7654321");
    fs::create_directories(hokuyo2 / "1-2.4:1.0/tty:ttyACM1");
    // A mouse (not a sensor) and a device with a malformed id file (skipped).
    AddDevice("1-3", "pci0000:00/0000:00:14.0/usb1/1-3", "046d", "c52b", 1, 3, "");
    AddDevice("1-4", "pci0000:00/0000:00:14.0/usb1/1-4", "zzzz", "0000", 1, 4, "");
  }
  void TearDown() override { fs::remove_all(root_); }

  fs::path AddDevice(const std::string& name, const std::string& devpath, const std::string& vid,
                     const std::string& pid, int bus, int address, const std::string& serial) {
    const fs::path dir = root_ / "devices" / devpath;
    WriteFile(dir / "idVendor", vid + "\n");
    WriteFile(dir / "idProduct", pid + "\n");
    WriteFile(dir / "busnum", std::to_string(bus) + "\n");
    WriteFile(dir / "devnum", std::to_string(address) + "\n");
    if (!serial.empty()) WriteFile(dir / "serial", serial + "\n");
    Link(name, dir);
    return dir;
  }
  void Link(const std::string& name, const fs::path& target) {
    fs::create_directory_symlink(target, root_ / "bus/usb/devices" / name);
  }

  fs::path root_;
};

TEST_F(FakeSysfs, ScansDevicesSortedByBusAndAddress) {
  const std::vector<SysfsUsbDevice> devices = ScanSysfsUsbDevices(root_.string());
  ASSERT_EQ(devices.size(), 5u);  // usb1, 1-3, 1-1, 1-2.4, 2-3 (1-4 malformed, 1-1:1.0 interface)
  EXPECT_EQ(devices[0].name, "usb1");
  EXPECT_EQ(devices[1].name, "1-3");
  EXPECT_EQ(devices[2].name, "1-1");
  EXPECT_EQ(devices[2].vendor_id, 0x15d1);
  EXPECT_EQ(devices[2].product_id, 0x0000);
  EXPECT_EQ(devices[2].bus, 1);
  EXPECT_EQ(devices[2].address, 5);
  EXPECT_EQ(devices[2].serial, "H1234567");
  EXPECT_EQ(devices[2].ttys, std::vector<std::string>{"/dev/ttyACM0"});
  EXPECT_EQ(devices[3].name, "1-2.4");
  EXPECT_EQ(devices[3].ttys, std::vector<std::string>{"/dev/ttyACM1"});
  EXPECT_EQ(devices[4].name, "2-3");
  EXPECT_EQ(devices[4].serial, "");
  EXPECT_TRUE(devices[4].ttys.empty());
}

TEST_F(FakeSysfs, SensorsAreTheHokuyosAndTheXtionWithTheirTtys) {
  const std::vector<UsbSensor> sensors = SensorsFromSysfs(ScanSysfsUsbDevices(root_.string()));
  ASSERT_EQ(sensors.size(), 3u);
  EXPECT_EQ(sensors[0].Describe(),
            "hokuyo 15d1:0000 bus 1 address 5 serial H1234567 tty /dev/ttyACM0 sysfs 1-1");
  EXPECT_EQ(sensors[1].Describe(),
            "hokuyo 15d1:0000 bus 1 address 12 serial H7654321 tty /dev/ttyACM1 sysfs 1-2.4");
  EXPECT_EQ(sensors[2].Describe(), "xtion 1d27:0601 bus 2 address 7 serial (unreadable) sysfs 2-3");
  const auto found = FindSysfsDevice(root_.string(), 2, 7);
  ASSERT_TRUE(found.has_value());
  EXPECT_EQ(found->name, "2-3");
  EXPECT_FALSE(FindSysfsDevice(root_.string(), 2, 8).has_value());
}

TEST_F(FakeSysfs, HokuyoTtysAndXtionUri) {
  EXPECT_EQ(FindHokuyoTtys(root_.string()),
            (std::vector<std::string>{"/dev/ttyACM0", "/dev/ttyACM1"}));
  const std::vector<UsbSensor> sensors = SensorsFromSysfs(ScanSysfsUsbDevices(root_.string()));
  ASSERT_EQ(sensors.size(), 3u);
  EXPECT_EQ(OpenNiUri(sensors[2]), "1d27/0601@2/7");
  EXPECT_TRUE(FindHokuyoTtys((root_ / "absent").string()).empty());
}

TEST_F(FakeSysfs, WatchReportsEachArrivalAndDepartureOnce) {
  std::mutex mutex;
  std::vector<std::string> events;
  std::atomic<bool> stop{false};
  std::thread watcher([&] {
    WatchSysfs(
        root_.string(), 10.0, 0.02,
        [&](const UsbEvent& e) {
          std::lock_guard<std::mutex> lock(mutex);
          events.push_back(std::string(e.arrived ? "+" : "-") + e.sensor.sysfs_name);
        },
        &stop);
  });
  auto wait_for = [&](size_t n) {
    for (int i = 0; i < 500; ++i) {
      {
        std::lock_guard<std::mutex> lock(mutex);
        if (events.size() >= n) return true;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
  };
  ASSERT_TRUE(wait_for(3));
  fs::remove(root_ / "bus/usb/devices/2-3");  // unplug the Xtion
  AddDevice("2-4", "pci0000:00/0000:00:1d.0/usb2/2-4", "1d27", "0600", 2, 9, "X1");
  ASSERT_TRUE(wait_for(5));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // room for wrong duplicates
  stop = true;
  watcher.join();
  EXPECT_EQ(events, (std::vector<std::string>{"+1-1", "+1-2.4", "+2-3", "-2-3", "+2-4"}));
}

TEST(UsbIds, MatchesExactlyTheSensorIds) {
  int hokuyo = 0, xtion = 0, other_vendor = 0;
  for (uint32_t pid = 0; pid <= 0xffff; ++pid) {
    const auto p = static_cast<uint16_t>(pid);
    hokuyo += MatchSensor(0x15d1, p) == SensorKind::kHokuyo ? 1 : 0;
    xtion += MatchSensor(0x1d27, p) == SensorKind::kXtion ? 1 : 0;
    other_vendor += MatchSensor(0x1d6b, p).has_value() ? 1 : 0;
  }
  EXPECT_EQ(hokuyo, 1);
  EXPECT_EQ(xtion, 2);
  EXPECT_EQ(other_vendor, 0);
  EXPECT_EQ(MatchSensor(0x1d27, 0x0600), SensorKind::kXtion);
  EXPECT_EQ(MatchSensor(0x1d27, 0x0601), SensorKind::kXtion);
  EXPECT_FALSE(MatchSensor(0x1d27, 0x0609).has_value());
}

TEST(UsbIds, ParsesSysfsNumbers) {
  EXPECT_EQ(ParseHex16("15d1\n"), 0x15d1);
  EXPECT_EQ(ParseHex16("15D1"), 0x15d1);
  EXPECT_EQ(ParseHex16("0000\n"), 0);
  EXPECT_FALSE(ParseHex16("").has_value());
  EXPECT_FALSE(ParseHex16("12345").has_value());
  EXPECT_FALSE(ParseHex16("0x15").has_value());
  EXPECT_EQ(ParseDecimal("12\n"), 12);
  EXPECT_FALSE(ParseDecimal("-1").has_value());
  EXPECT_FALSE(ParseDecimal("1a").has_value());
}

TEST(DevicesConfig, ShippedFileLoadsAndBadValuesAreRejected) {
  const ConfigNode node =
      ConfigNode::LoadFile(std::string(KESTREL_SOURCE_DIR) + "/config/drivers/devices.yaml");
  const DevicesConfig config = LoadDevicesConfig(node);
  node.CheckNoUnknownKeys();
  EXPECT_EQ(config.sysfs_root, "/sys");
  EXPECT_TRUE(config.use_libusb);
  EXPECT_THROW((void)LoadDevicesConfig(ConfigNode::FromString("poll_period_s: 0\n", "t.yaml")),
               ConfigError);
}

TEST(DevicePresence, DropsDoubleArrivalsAndUnknownDepartures) {
  DevicePresence presence;
  EXPECT_TRUE(presence.Arrive(1, 5));
  EXPECT_FALSE(presence.Arrive(1, 5));  // ENUMERATE and the event thread both report it
  EXPECT_TRUE(presence.Arrive(1, 6));
  EXPECT_FALSE(presence.Leave(2, 1));  // never arrived
  EXPECT_TRUE(presence.Leave(1, 5));
  EXPECT_FALSE(presence.Leave(1, 5));
  EXPECT_TRUE(presence.Arrive(1, 5));  // plugged in again
  EXPECT_EQ(presence.size(), 2u);
  EXPECT_EQ(presence.duplicates(), 3);
}

// libusb on this machine (if it starts) must agree with sysfs about which sensors are attached.
TEST(UsbDiscovery, LibusbListAgreesWithSysfs) {
  std::string error;
  std::unique_ptr<UsbDiscovery> usb = UsbDiscovery::Open("/sys", &error);
  if (!usb) {
    EXPECT_NE(error.find("libusb_init failed"), std::string::npos) << error;
    GTEST_SKIP() << error;
  }
  std::vector<std::tuple<int, int>> from_libusb, from_sysfs;
  for (const UsbSensor& s : usb->List()) from_libusb.push_back(s.key());
  for (const UsbSensor& s : SensorsFromSysfs(ScanSysfsUsbDevices("/sys"))) {
    from_sysfs.push_back(s.key());
  }
  EXPECT_EQ(from_libusb, from_sysfs);
}

std::string RunCommand(const std::string& command, int* status) {
  FILE* pipe = popen(command.c_str(), "r");
  std::string out;
  char buffer[512];
  while (pipe != nullptr && fgets(buffer, sizeof(buffer), pipe) != nullptr) out += buffer;
  *status = pipe != nullptr ? pclose(pipe) : -1;
  return out;
}

TEST_F(FakeSysfs, ExecutableListsTheFakeTreeWithoutLibusb) {
  int status = 0;
  const std::string out =
      RunCommand(std::string(KESTREL_DEVICES) +
                     " --list --set use_libusb=false --set sysfs_root=" + root_.string() + " 2>&1",
                 &status);
  EXPECT_EQ(status, 0) << out;
  EXPECT_EQ(out,
            "hokuyo 15d1:0000 bus 1 address 5 serial H1234567 tty /dev/ttyACM0 sysfs 1-1\n"
            "hokuyo 15d1:0000 bus 1 address 12 serial H7654321 tty /dev/ttyACM1 sysfs 1-2.4\n"
            "xtion 1d27:0601 bus 2 address 7 serial (unreadable) sysfs 2-3\n");
  const std::string empty = RunCommand(std::string(KESTREL_DEVICES) +
                                           " --watch 0.2 --set use_libusb=false --set "
                                           "sysfs_root=/nonexistent 2>&1",
                                       &status);
  EXPECT_EQ(status, 0) << empty;
  EXPECT_EQ(empty, "no Hokuyo (15d1:0000) or Xtion (1d27:0600/0601) device attached\n");
  RunCommand(std::string(KESTREL_DEVICES) + " --watch -1 2>&1", &status);
  EXPECT_EQ(WEXITSTATUS(status), 2);
}

// libusb_init failing (injected with LD_PRELOAD): a clean notice, the sysfs answer, exit 0.
TEST_F(FakeSysfs, ExecutableFallsBackToSysfsWhenLibusbInitFails) {
  for (const char* mode : {" --list", " --watch 0.2"}) {
    int status = 0;
    const std::string out =
        RunCommand(std::string("LD_PRELOAD=") + KESTREL_LIBUSB_INIT_FAILS + " " + KESTREL_DEVICES +
                       mode + " --set sysfs_root=" + root_.string() + " 2>&1",
                   &status);
    EXPECT_EQ(status, 0) << out;
    EXPECT_EQ(out.rfind("libusb unavailable (libusb_init failed: LIBUSB_ERROR_OTHER", 0), 0u)
        << out;
    EXPECT_NE(out.find("using sysfs only\n"), std::string::npos) << out;
    EXPECT_NE(out.find("hokuyo 15d1:0000 bus 1 address 5 serial H1234567 tty /dev/ttyACM0"),
              std::string::npos)
        << out;
  }
}

// On the real machine: exit 0, and every line is a sensor, a clean "none" or a libusb notice.
TEST(UsbDiscovery, ExecutableReportsCleanlyOnThisMachine) {
  for (const char* mode : {" --list", " --watch 0.3"}) {
    int status = 0;
    const std::string out = RunCommand(std::string(KESTREL_DEVICES) + mode + " 2>&1", &status);
    EXPECT_EQ(status, 0) << out;
    std::istringstream lines(out);
    std::string line;
    int n = 0;
    while (std::getline(lines, line)) {
      ++n;
      const bool ok = line.rfind("hokuyo ", 0) == 0 || line.rfind("xtion ", 0) == 0 ||
                      line.rfind("arrived ", 0) == 0 || line.rfind("left ", 0) == 0 ||
                      line.rfind("no Hokuyo", 0) == 0 || line.rfind("libusb ", 0) == 0;
      EXPECT_TRUE(ok) << line;
    }
    EXPECT_GE(n, 1);
  }
}

}  // namespace
}  // namespace kestrel
