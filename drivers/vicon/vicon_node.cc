#include "drivers/vicon/vicon_node.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <stdexcept>

#include "common/identity.h"

namespace kestrel {
namespace {

// Any UDP payload fits, so an over-long datagram is seen whole and rejected by its length.
constexpr size_t kReceiveBufferBytes = 65536;
constexpr int kMaxDatagramsPerCall = 256;

}  // namespace

ViconNode::ViconNode(lcm::LCM& lcm, const ViconConfig& config, const Clock& clock)
    : lcm_(lcm),
      config_(config),
      clock_(clock),
      bridge_(config),
      heartbeat_(lcm, clock, "kestrel-vicon", config.heartbeat_channel),
      drops_(clock),
      epoch_(NewPublisherEpoch()),
      buffer_(kReceiveBufferBytes) {
  fd_ = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (fd_ < 0) throw std::runtime_error(std::string("vicon: socket: ") + std::strerror(errno));
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(config_.port));
  if (inet_pton(AF_INET, config_.bind_address.c_str(), &address.sin_addr) != 1 ||
      bind(fd_, reinterpret_cast<const sockaddr*>(&address), sizeof(address)) != 0) {
    const std::string error = std::strerror(errno);
    close(fd_);
    throw std::runtime_error("vicon: cannot bind UDP " + config_.bind_address + ":" +
                             std::to_string(config_.port) + ": " + error);
  }
  socklen_t length = sizeof(address);
  getsockname(fd_, reinterpret_cast<sockaddr*>(&address), &length);
  bound_port_ = ntohs(address.sin_port);
  // With the host clock, stamp each datagram with the kernel's arrival time (CLOCK_REALTIME, the
  // WallClock's base), so a late receive thread does not add to the latency.
  if (!clock_.is_simulated()) {
    const int on = 1;
    kernel_timestamps_ = setsockopt(fd_, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof(on)) == 0;
  }
  heartbeat_.SetState(heartbeat_t::STATE_STARTING);
  Log(LogLevel::kInfo, "vicon: listening on UDP " + config_.bind_address + ":" +
                           std::to_string(bound_port_) + " for " +
                           std::to_string(config_.objects.size()) + " object(s)");
}

ViconNode::~ViconNode() {
  StopReceiveThread();
  if (fd_ >= 0) close(fd_);
}

int ViconNode::ReceiveOnce(int timeout_ms) {
  pollfd pfd{fd_, POLLIN, 0};
  const int ready = poll(&pfd, 1, timeout_ms);
  if (ready < 0) {
    if (errno == EINTR) return 0;
    Log(LogLevel::kError, std::string("vicon: poll: ") + std::strerror(errno));
    return -1;
  }
  if (ready == 0) return 0;
  int handled = 0;
  while (handled < kMaxDatagramsPerCall) {
    iovec iov{buffer_.data(), buffer_.size()};
    alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timespec))];
    msghdr message{};
    message.msg_iov = &iov;
    message.msg_iovlen = 1;
    message.msg_control = control;
    message.msg_controllen = sizeof(control);
    const ssize_t n = recvmsg(fd_, &message, MSG_DONTWAIT);
    if (n < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) break;
      Log(LogLevel::kError, std::string("vicon: recv: ") + std::strerror(errno));
      return -1;
    }
    int64_t receive_utime = clock_.NowUtime();
    for (cmsghdr* c = CMSG_FIRSTHDR(&message); kernel_timestamps_ && c != nullptr;
         c = CMSG_NXTHDR(&message, c)) {
      if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS) {
        timespec t{};
        std::memcpy(&t, CMSG_DATA(c), sizeof(t));
        const int64_t kernel_utime = int64_t{t.tv_sec} * 1000000 + t.tv_nsec / 1000;
        // Never later than now (the clock is non-decreasing), never absurdly early.
        if (kernel_utime <= receive_utime && receive_utime - kernel_utime < 1000000) {
          receive_utime = kernel_utime;
        }
      }
    }
    std::lock_guard<std::mutex> lock(mutex_);
    outputs_.clear();
    std::string reason;
    const ViconPacketError error = bridge_.HandleDatagram(buffer_.data(), static_cast<size_t>(n),
                                                          receive_utime, &outputs_, &reason);
    if (error != ViconPacketError::kNone) {
      drops_.Count(std::string("malformed vicon datagram ") + ViconPacketErrorName(error), reason);
      heartbeat_.SetLastError(reason);
    }
    Publish(&outputs_);
    ++handled;
  }
  return handled;
}

void ViconNode::CheckTimeouts() {
  std::lock_guard<std::mutex> lock(mutex_);
  outputs_.clear();
  bridge_.CheckTimeouts(clock_.NowUtime(), &outputs_);
  Publish(&outputs_);
}

void ViconNode::Publish(std::vector<ViconPoseOutput>* outputs) {
  for (ViconPoseOutput& output : *outputs) {
    output.pose.epoch = epoch_;
    lcm_.publish(output.channel, &output.pose);
  }
}

void ViconNode::PublishHeartbeat() {
  std::lock_guard<std::mutex> lock(mutex_);
  const ViconBridgeStats& s = bridge_.stats();
  const int valid = bridge_.num_valid();
  if (s.datagrams == 0) {
    heartbeat_.SetState(heartbeat_t::STATE_STARTING);
  } else {
    heartbeat_.SetState(valid == static_cast<int>(bridge_.num_objects())
                            ? int8_t{heartbeat_t::STATE_OK}
                            : int8_t{heartbeat_t::STATE_DEGRADED});
  }
  heartbeat_.SetValue("datagrams", static_cast<double>(s.datagrams));
  heartbeat_.SetValue("malformed", static_cast<double>(s.malformed));
  heartbeat_.SetValue("frames_dropped", static_cast<double>(s.frames_dropped));
  heartbeat_.SetValue("frames_repeated", static_cast<double>(s.frames_repeated));
  heartbeat_.SetValue("frames_late", static_cast<double>(s.frames_late));
  heartbeat_.SetValue("stream_restarts", static_cast<double>(s.stream_restarts));
  heartbeat_.SetValue("occluded", static_cast<double>(s.occluded));
  heartbeat_.SetValue("unconfigured_objects", static_cast<double>(s.unconfigured_objects));
  heartbeat_.SetValue("timeouts", static_cast<double>(s.timeouts));
  heartbeat_.SetValue("objects_valid", static_cast<double>(valid));
  heartbeat_.SetValue("poses_published", static_cast<double>(s.poses_published));
  heartbeat_.Publish();
}

void ViconNode::AddTimers(NodeLoop& loop) {
  loop.AddTimer("vicon_timeouts", SecondsToUtime(config_.check_period_s),
                [this](int64_t) { CheckTimeouts(); });
  loop.AddTimer("vicon_heartbeat", SecondsToUtime(config_.heartbeat_period_s),
                [this](int64_t) { PublishHeartbeat(); });
  loop.AddShutdownHook([this] {
    StopReceiveThread();
    std::lock_guard<std::mutex> lock(mutex_);
    heartbeat_.SetState(heartbeat_t::STATE_STOPPING);
    heartbeat_.Publish();
  });
}

void ViconNode::StartReceiveThread() {
  if (thread_.joinable()) return;
  stop_thread_ = false;
  thread_ = std::thread([this] {
    while (!stop_thread_) {
      // A socket error is logged once per call; back off instead of spinning on it.
      if (ReceiveOnce(50) < 0) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  });
}

void ViconNode::StopReceiveThread() {
  stop_thread_ = true;
  if (thread_.joinable()) thread_.join();
}

ViconBridgeStats ViconNode::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return bridge_.stats();
}

}  // namespace kestrel
