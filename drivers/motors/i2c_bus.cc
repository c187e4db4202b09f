#include "drivers/motors/i2c_bus.h"

#include <fcntl.h>
#include <linux/i2c-dev.h>
#include <linux/i2c.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace kestrel {

namespace {
constexpr uint8_t kMagic[4] = {'K', 'I', '2', 'C'};
constexpr uint8_t kReplyOk = 0;
constexpr uint8_t kReplyNack = 1;
constexpr size_t kMaxDatagram = 4096;

std::string Errno(const std::string& what) { return what + ": " + std::strerror(errno); }

sockaddr_un UnixAddress(const std::string& path) {
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  if (path.size() >= sizeof(address.sun_path)) {
    throw std::runtime_error("socket path too long (" + std::to_string(path.size()) +
                             " bytes): " + path);
  }
  std::memcpy(address.sun_path, path.c_str(), path.size() + 1);
  return address;
}

bool HasMagic(const std::vector<uint8_t>& d) {
  return d.size() >= 4 && std::memcmp(d.data(), kMagic, 4) == 0;
}
}  // namespace

std::vector<uint8_t> EncodeI2cRequest(const std::vector<I2cMessage>& messages) {
  std::vector<uint8_t> out(kMagic, kMagic + 4);
  out.push_back(static_cast<uint8_t>(messages.size()));
  for (const I2cMessage& m : messages) {
    out.push_back(m.address);
    out.push_back(m.read ? 1 : 0);
    out.push_back(static_cast<uint8_t>(m.data.size()));
    if (!m.read) out.insert(out.end(), m.data.begin(), m.data.end());
  }
  return out;
}

bool DecodeI2cRequest(const std::vector<uint8_t>& d, std::vector<I2cMessage>* messages) {
  messages->clear();
  if (!HasMagic(d) || d.size() < 5) return false;
  size_t at = 5;
  for (int i = 0; i < d[4]; ++i) {
    if (at + 3 > d.size()) return false;
    I2cMessage m;
    m.address = d[at];
    if (m.address > 0x7f || d[at + 1] > 1) return false;
    m.read = d[at + 1] == 1;
    const size_t length = d[at + 2];
    at += 3;
    if (m.read) {
      m.data.assign(length, 0);
    } else {
      if (at + length > d.size()) return false;
      m.data.assign(d.begin() + static_cast<std::ptrdiff_t>(at),
                    d.begin() + static_cast<std::ptrdiff_t>(at + length));
      at += length;
    }
    messages->push_back(std::move(m));
  }
  return at == d.size();
}

// --- i2c-dev ---

LinuxI2cBus::LinuxI2cBus(std::string device) : device_(std::move(device)) {
  fd_ = ::open(device_.c_str(), O_RDWR | O_CLOEXEC);
  if (fd_ < 0) throw std::runtime_error(Errno("cannot open I2C bus " + device_));
}

LinuxI2cBus::~LinuxI2cBus() {
  if (fd_ >= 0) ::close(fd_);
}

bool LinuxI2cBus::Transfer(std::vector<I2cMessage>* messages, std::string* error) {
  std::vector<i2c_msg> raw(messages->size());
  for (size_t i = 0; i < messages->size(); ++i) {
    I2cMessage& m = (*messages)[i];
    raw[i].addr = m.address;
    raw[i].flags = m.read ? I2C_M_RD : 0;
    raw[i].len = static_cast<uint16_t>(m.data.size());
    raw[i].buf = m.data.data();
  }
  i2c_rdwr_ioctl_data transfer{};
  transfer.msgs = raw.data();
  transfer.nmsgs = static_cast<uint32_t>(raw.size());
  if (::ioctl(fd_, I2C_RDWR, &transfer) < 0) {
    *error = Errno(device_ + ": I2C_RDWR");
    return false;
  }
  return true;
}

// --- Unix-domain socket ---

SocketI2cBus::SocketI2cBus(std::string path, int timeout_ms)
    : path_(std::move(path)), timeout_ms_(timeout_ms) {
  const sockaddr_un address = UnixAddress(path_);
  fd_ = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw std::runtime_error(Errno("socket for " + path_));
  if (::connect(fd_, reinterpret_cast<const sockaddr*>(&address), sizeof(address)) != 0) {
    const std::string message = Errno("cannot connect to the I2C socket " + path_);
    ::close(fd_);
    fd_ = -1;
    throw std::runtime_error(message);
  }
}

SocketI2cBus::~SocketI2cBus() {
  if (fd_ >= 0) ::close(fd_);
}

bool SocketI2cBus::Transfer(std::vector<I2cMessage>* messages, std::string* error) {
  const std::vector<uint8_t> request = EncodeI2cRequest(*messages);
  if (::send(fd_, request.data(), request.size(), MSG_NOSIGNAL) !=
      static_cast<ssize_t>(request.size())) {
    *error = Errno(name() + ": send");
    return false;
  }
  pollfd readable{fd_, POLLIN, 0};
  const int ready = ::poll(&readable, 1, timeout_ms_);
  if (ready <= 0) {
    *error = ready == 0 ? name() + ": no reply within " + std::to_string(timeout_ms_) + " ms"
                        : Errno(name() + ": poll");
    return false;
  }
  std::vector<uint8_t> reply(kMaxDatagram);
  const ssize_t n = ::recv(fd_, reply.data(), reply.size(), 0);
  if (n <= 0) {
    *error = n == 0 ? name() + ": the device side hung up" : Errno(name() + ": recv");
    return false;
  }
  reply.resize(static_cast<size_t>(n));
  if (!HasMagic(reply) || reply.size() < 6) {
    *error = name() + ": malformed reply (" + std::to_string(n) + " bytes)";
    return false;
  }
  if (reply[4] == kReplyNack) {
    *error = name() + ": NACK from address 0x" +
             [&] {
               char hex[8];
               const size_t index = reply[5];
               std::snprintf(hex, sizeof(hex), "%02x",
                             index < messages->size() ? (*messages)[index].address : 0);
               return std::string(hex);
             }() +
             " (message " + std::to_string(reply[5]) + ")";
    return false;
  }
  size_t at = 6;
  for (I2cMessage& m : *messages) {
    if (!m.read) continue;
    if (at + m.data.size() > reply.size()) {
      *error = name() + ": reply shorter than the reads asked";
      return false;
    }
    std::memcpy(m.data.data(), reply.data() + at, m.data.size());
    at += m.data.size();
  }
  if (at != reply.size()) {
    *error = name() + ": reply longer than the reads asked";
    return false;
  }
  return true;
}

std::unique_ptr<I2cBus> OpenI2cBus(const std::string& spec) {
  if (spec.rfind("unix:", 0) == 0) return std::make_unique<SocketI2cBus>(spec.substr(5));
  if (spec.rfind("/dev/", 0) == 0) return std::make_unique<LinuxI2cBus>(spec);
  throw std::invalid_argument("bus '" + spec + "': use /dev/i2c-N or unix:PATH");
}

// --- the devices' side ---

I2cSocketServer::I2cSocketServer(std::string path, Device device)
    : path_(std::move(path)), device_(std::move(device)) {
  const sockaddr_un address = UnixAddress(path_);
  ::unlink(path_.c_str());
  listen_fd_ = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
  if (listen_fd_ < 0) throw std::runtime_error(Errno("socket for " + path_));
  if (::bind(listen_fd_, reinterpret_cast<const sockaddr*>(&address), sizeof(address)) != 0 ||
      ::listen(listen_fd_, 4) != 0) {
    const std::string message = Errno("cannot listen on " + path_);
    ::close(listen_fd_);
    throw std::runtime_error(message);
  }
}

I2cSocketServer::~I2cSocketServer() {
  if (client_fd_ >= 0) ::close(client_fd_);
  if (listen_fd_ >= 0) ::close(listen_fd_);
  ::unlink(path_.c_str());
}

int I2cSocketServer::Poll(int timeout_ms) {
  pollfd fds[2] = {{listen_fd_, POLLIN, 0}, {client_fd_, POLLIN, 0}};
  const int ready = ::poll(fds, client_fd_ >= 0 ? 2 : 1, timeout_ms);
  if (ready <= 0) return 0;
  if ((fds[0].revents & POLLIN) != 0) {
    const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
    if (fd >= 0) {
      if (client_fd_ >= 0) ::close(client_fd_);  // the newest driver is the one alive
      client_fd_ = fd;
    }
    return 0;
  }
  if (client_fd_ < 0 || (fds[1].revents & (POLLIN | POLLHUP | POLLERR)) == 0) return 0;
  std::vector<uint8_t> request(kMaxDatagram);
  const ssize_t n = ::recv(client_fd_, request.data(), request.size(), 0);
  if (n <= 0) {
    ::close(client_fd_);
    client_fd_ = -1;
    return 0;
  }
  request.resize(static_cast<size_t>(n));
  std::vector<I2cMessage> messages;
  std::vector<uint8_t> reply(kMagic, kMagic + 4);
  if (!DecodeI2cRequest(request, &messages)) {
    ++malformed_;
    reply.push_back(kReplyNack);
    reply.push_back(0xff);
  } else {
    uint8_t status = kReplyOk, failed = 0;
    std::vector<uint8_t> reads;
    for (size_t i = 0; i < messages.size(); ++i) {
      if (!device_(messages[i])) {
        status = kReplyNack;
        failed = static_cast<uint8_t>(i);
        break;
      }
      if (messages[i].read)
        reads.insert(reads.end(), messages[i].data.begin(), messages[i].data.end());
    }
    reply.push_back(status);
    reply.push_back(failed);
    if (status == kReplyOk) reply.insert(reply.end(), reads.begin(), reads.end());
  }
  ::send(client_fd_, reply.data(), reply.size(), MSG_NOSIGNAL);
  return 1;
}

}  // namespace kestrel
