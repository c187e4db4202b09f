// LinuxI2cBus on a real i2c-dev adapter: the kernel's i2c-stub (modprobe i2c-stub
// chip_addr=0x29). Skipped, with the reason, where there is none (containers: no modules, no
// /dev/i2c-*); ctest reports the skip (SKIP_REGULAR_EXPRESSION).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <linux/i2c-dev.h>
#include <linux/i2c.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "drivers/motors/blctrl.h"
#include "drivers/motors/i2c_bus.h"

namespace kestrel {
namespace {

// The /dev/i2c-N whose adapter is the SMBus stub, or "".
std::string StubAdapter() {
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/sys/class/i2c-dev", ec)) {
    std::ifstream name(entry.path() / "name");
    std::string line;
    if (std::getline(name, line) && line.find("SMBus stub") != std::string::npos) {
      return "/dev/" + entry.path().filename().string();
    }
  }
  return "";
}

TEST(LinuxI2cBus, WritesASetPointThroughTheKernelsStub) {
  const std::string device = StubAdapter();
  if (device.empty()) {
    GTEST_SKIP() << "no i2c-stub adapter (load it as root: modprobe i2c-dev; modprobe i2c-stub "
                    "chip_addr=0x29); this machine has no kernel modules to load";
  }
  const int fd = ::open(device.c_str(), O_RDWR);
  ASSERT_GE(fd, 0) << device;
  unsigned long functions = 0;
  ASSERT_EQ(::ioctl(fd, I2C_FUNCS, &functions), 0);
  ::close(fd);
  if ((functions & I2C_FUNC_I2C) == 0) {
    GTEST_SKIP() << device << " (i2c-stub) emulates SMBus only, not the plain I2C transfers "
                 << "(I2C_RDWR) a BL-Ctrl set point is";
  }
  LinuxI2cBus bus(device);
  std::vector<I2cMessage> write = {
      {kBlCtrlFirstAddress, false, EncodeBlCtrlSetPoint(BlCtrlVersion::kV1, 200)}};
  std::string error;
  EXPECT_TRUE(bus.Transfer(&write, &error)) << error;
}

TEST(LinuxI2cBus, AMissingAdapterIsAClearError) {
  try {
    LinuxI2cBus bus("/dev/i2c-kestrel-missing");
    FAIL() << "opened a missing adapter";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/dev/i2c-kestrel-missing"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("No such file"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace kestrel
