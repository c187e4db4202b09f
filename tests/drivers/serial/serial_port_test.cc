// SerialPort on a real pseudo-terminal (openpty): raw settings, both directions, time-outs,
// the exclusive lock, flush, and a hang-up of the master side reported as a disconnection.
#include "drivers/serial/serial_port.h"

#include <poll.h>
#include <pty.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <string>

#include <gtest/gtest.h>

namespace kestrel {
namespace {

class SerialPortTest : public ::testing::Test {
 protected:
  void SetUp() override {
    int slave = -1;
    char name[256] = {};
    ASSERT_EQ(openpty(&master_, &slave, name, nullptr, nullptr), 0);
    path_ = name;
    ::close(slave);  // the port under test opens the slave by path
  }
  void TearDown() override {
    if (master_ >= 0) ::close(master_);
  }
  std::string ReadMaster(size_t n) {
    std::string out;
    while (out.size() < n) {
      pollfd p{master_, POLLIN, 0};
      if (::poll(&p, 1, 2000) <= 0) break;
      char buf[256];
      const ssize_t r = ::read(master_, buf, sizeof(buf));
      if (r <= 0) break;
      out.append(buf, static_cast<size_t>(r));
    }
    return out;
  }
  int master_{-1};
  std::string path_;
};

TEST_F(SerialPortTest, ConfiguresRaw8N1) {
  SerialPort port(path_);
  termios tio{};
  ASSERT_EQ(tcgetattr(port.fd(), &tio), 0);
  EXPECT_EQ(tio.c_lflag & (ECHO | ICANON | ISIG | IEXTEN), 0u);
  EXPECT_EQ(tio.c_iflag & (ICRNL | IXON | IXOFF | INLCR | IGNCR), 0u);
  EXPECT_EQ(tio.c_oflag & OPOST, 0u);
  EXPECT_EQ(tio.c_cflag & CSIZE, static_cast<tcflag_t>(CS8));
  EXPECT_EQ(tio.c_cflag & (PARENB | CSTOPB | CRTSCTS), 0u);
  EXPECT_EQ(tio.c_cflag & (CLOCAL | CREAD), static_cast<tcflag_t>(CLOCAL | CREAD));
  EXPECT_EQ(cfgetospeed(&tio), static_cast<speed_t>(B115200));
}

// Bytes pass unchanged both ways: CR, LF and 8-bit bytes are not translated (raw mode).
TEST_F(SerialPortTest, MovesBytesUnchangedBothWays) {
  SerialPort port(path_);
  const std::string to_device("VV\r\n\x01\xff\n", 7);
  ASSERT_EQ(port.Write(to_device, 1000).status, IoStatus::kOk);
  EXPECT_EQ(ReadMaster(to_device.size()), to_device);
  const std::string from_device("VV\n00P\n\r\x80\n\n", 11);
  ASSERT_EQ(::write(master_, from_device.data(), from_device.size()),
            static_cast<ssize_t>(from_device.size()));
  std::string got;
  while (got.size() < from_device.size()) {
    const IoResult r = port.Read(&got, 4096, 2000);
    ASSERT_EQ(r.status, IoStatus::kOk) << ToString(r.status);
  }
  EXPECT_EQ(got, from_device);
}

// A read with nothing to read returns kTimeout, not before the time-out elapsed.
TEST_F(SerialPortTest, ReadTimesOut) {
  SerialPort port(path_);
  std::string got;
  const auto t0 = std::chrono::steady_clock::now();
  const IoResult r = port.Read(&got, 100, 50);
  const auto elapsed = std::chrono::steady_clock::now() - t0;
  EXPECT_EQ(r.status, IoStatus::kTimeout);
  EXPECT_TRUE(got.empty());
  EXPECT_GE(elapsed, std::chrono::milliseconds(45));
}

TEST_F(SerialPortTest, SecondOpenIsRefusedWhileLocked) {
  SerialPort port(path_);
  try {
    SerialPort second(path_);
    FAIL() << "second open succeeded";
  } catch (const SerialError& e) {
    EXPECT_NE(std::string(e.what()).find(path_), std::string::npos) << e.what();
  }
}

TEST_F(SerialPortTest, ReleasesLockOnClose) {
  { SerialPort port(path_); }
  EXPECT_NO_THROW(SerialPort again(path_));
}

TEST_F(SerialPortTest, FlushDiscardsPendingInput) {
  SerialPort port(path_);
  ASSERT_EQ(::write(master_, "stale", 5), 5);
  pollfd p{port.fd(), POLLIN, 0};
  ASSERT_EQ(::poll(&p, 1, 2000), 1);
  port.Flush();
  std::string got;
  EXPECT_EQ(port.Read(&got, 100, 50).status, IoStatus::kTimeout);
  EXPECT_TRUE(got.empty());
}

// Closing the master is what an unplugged USB device looks like: a hang-up.
TEST_F(SerialPortTest, ReportsHangUpAsDisconnected) {
  SerialPort port(path_);
  ::close(master_);
  master_ = -1;
  std::string got;
  const IoResult r = port.Read(&got, 100, 1000);
  EXPECT_EQ(r.status, IoStatus::kDisconnected) << ToString(r.status);
  EXPECT_NE(port.Write("QT\n", 100).status, IoStatus::kOk);
}

TEST(SerialPort, RejectsMissingDeviceAndNonTerminal) {
  EXPECT_THROW(SerialPort("/nonexistent/ttyACM9"), SerialError);
  EXPECT_THROW(SerialPort("/dev/null"), SerialError);
  int master = -1;
  int slave = -1;
  char name[256] = {};
  ASSERT_EQ(openpty(&master, &slave, name, nullptr, nullptr), 0);
  SerialOptions options;
  options.baud = 12345;
  EXPECT_THROW(SerialPort(name, options), SerialError);
  ::close(slave);
  ::close(master);
}

}  // namespace
}  // namespace kestrel
