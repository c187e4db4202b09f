#include "drivers/serial/serial_port.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/file.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>

namespace kestrel {
namespace {

speed_t BaudConstant(int baud) {
  switch (baud) {
    case 9600:
      return B9600;
    case 19200:
      return B19200;
    case 38400:
      return B38400;
    case 57600:
      return B57600;
    case 115200:
      return B115200;
    case 230400:
      return B230400;
    case 460800:
      return B460800;
    case 500000:
      return B500000;
    case 921600:
      return B921600;
    default:
      return B0;
  }
}

bool IsHangUpErrno(int e) { return e == EIO || e == ENXIO || e == ENODEV || e == EBADF; }

int64_t NowMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

}  // namespace

const char* ToString(IoStatus status) {
  switch (status) {
    case IoStatus::kOk:
      return "ok";
    case IoStatus::kTimeout:
      return "timeout";
    case IoStatus::kDisconnected:
      return "disconnected";
    case IoStatus::kError:
      return "error";
  }
  return "unknown";
}

SerialPort::SerialPort(const std::string& path, const SerialOptions& options) : path_(path) {
  const auto fail = [&](const std::string& what) {
    const int e = errno;
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
    throw SerialError("serial port " + path + ": " + what + ": " + std::strerror(e), e);
  };
  const speed_t speed = BaudConstant(options.baud);
  if (speed == B0) {
    throw SerialError("serial port " + path + ": unsupported baud " + std::to_string(options.baud),
                      EINVAL);
  }
  fd_ = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) fail("open");
  if (!::isatty(fd_)) fail("not a terminal");
  if (options.exclusive) {
    // flock holds across processes (and for root, which TIOCEXCL does not stop).
    if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) fail("locked by another process (flock)");
    if (::ioctl(fd_, TIOCEXCL) != 0) fail("TIOCEXCL");
  }
  termios tio{};
  if (::tcgetattr(fd_, &tio) != 0) fail("tcgetattr");
  // Raw 8N1: no input or output processing, no echo, non-canonical, no flow control.
  tio.c_iflag &= ~static_cast<tcflag_t>(IGNBRK | BRKINT | PARMRK | ISTRIP | INLCR | IGNCR | ICRNL |
                                        IXON | IXOFF | IXANY | INPCK);
  tio.c_oflag &= ~static_cast<tcflag_t>(OPOST);
  tio.c_lflag &= ~static_cast<tcflag_t>(ECHO | ECHONL | ICANON | ISIG | IEXTEN);
  tio.c_cflag &= ~static_cast<tcflag_t>(CSIZE | PARENB | CSTOPB | CRTSCTS);
  tio.c_cflag |= static_cast<tcflag_t>(CS8 | CLOCAL | CREAD);
  tio.c_cc[VMIN] = 0;  // poll() does the waiting
  tio.c_cc[VTIME] = 0;
  if (::cfsetispeed(&tio, speed) != 0 || ::cfsetospeed(&tio, speed) != 0) fail("cfsetspeed");
  if (::tcsetattr(fd_, TCSANOW, &tio) != 0) fail("tcsetattr");
  if (options.flush_on_open) Flush();
}

SerialPort::~SerialPort() {
  if (fd_ < 0) return;
  // TIOCEXCL is a property of the tty, not of this descriptor: clear it so that a later open
  // (this driver reopening after a fault) is not refused while another descriptor stays open.
  ::ioctl(fd_, TIOCNXCL);
  ::close(fd_);
}

void SerialPort::Flush() {
  if (fd_ >= 0) ::tcflush(fd_, TCIOFLUSH);
}

IoResult SerialPort::Write(std::string_view bytes, int timeout_ms) {
  IoResult result;
  const int64_t deadline = NowMs() + timeout_ms;
  while (result.bytes < bytes.size()) {
    const ssize_t n = ::write(fd_, bytes.data() + result.bytes, bytes.size() - result.bytes);
    if (n > 0) {
      result.bytes += static_cast<size_t>(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && errno != EAGAIN) {
      result.error_number = errno;
      result.status = IsHangUpErrno(errno) ? IoStatus::kDisconnected : IoStatus::kError;
      return result;
    }
    const int64_t left = deadline - NowMs();
    if (left <= 0) {
      result.status = IoStatus::kTimeout;
      return result;
    }
    pollfd p{fd_, POLLOUT, 0};
    const int r = ::poll(&p, 1, static_cast<int>(left));
    if (r > 0 && (p.revents & (POLLHUP | POLLERR | POLLNVAL)) != 0) {
      result.status = IoStatus::kDisconnected;
      return result;
    }
  }
  return result;
}

IoResult SerialPort::Read(std::string* out, size_t max_bytes, int timeout_ms) {
  IoResult result;
  pollfd p{fd_, POLLIN, 0};
  int r;
  do {
    r = ::poll(&p, 1, timeout_ms);
  } while (r < 0 && errno == EINTR);
  if (r < 0) {
    result.error_number = errno;
    result.status = IoStatus::kError;
    return result;
  }
  if (r == 0) {
    result.status = IoStatus::kTimeout;
    return result;
  }
  if ((p.revents & POLLIN) == 0 && (p.revents & (POLLHUP | POLLERR | POLLNVAL)) != 0) {
    result.status = IoStatus::kDisconnected;
    return result;
  }
  const size_t old_size = out->size();
  out->resize(old_size + max_bytes);
  ssize_t n;
  do {
    n = ::read(fd_, out->data() + old_size, max_bytes);
  } while (n < 0 && errno == EINTR);
  if (n > 0) {
    out->resize(old_size + static_cast<size_t>(n));
    result.bytes = static_cast<size_t>(n);
    return result;
  }
  out->resize(old_size);
  if (n == 0) {
    result.status = IoStatus::kDisconnected;  // end of file on a tty: hang-up
  } else if (errno == EAGAIN) {
    result.status = IoStatus::kTimeout;
  } else {
    result.error_number = errno;
    result.status = IsHangUpErrno(errno) ? IoStatus::kDisconnected : IoStatus::kError;
  }
  return result;
}

}  // namespace kestrel
