#include "drivers/vicon/vicon_emitter.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "common/check.h"

namespace kestrel {

LoopbackUdpSender::LoopbackUdpSender(const std::string& address, int port) {
  KESTREL_THROW_UNLESS(IsLoopbackAddress(address),
                       "destination '" << address << "' is not a loopback address (127.0.0.0/8)");
  KESTREL_THROW_UNLESS(port >= 1 && port <= 65535, "port " << port << ", accepted [1, 65535]");
  fd_ = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw std::runtime_error(std::string("emitter: socket: ") + std::strerror(errno));
  sockaddr_in destination{};
  destination.sin_family = AF_INET;
  destination.sin_port = htons(static_cast<uint16_t>(port));
  inet_pton(AF_INET, address.c_str(), &destination.sin_addr);
  // connect() fixes the destination: every send goes to this loopback address and no other.
  if (connect(fd_, reinterpret_cast<const sockaddr*>(&destination), sizeof(destination)) != 0) {
    const std::string error = std::strerror(errno);
    close(fd_);
    throw std::runtime_error("emitter: connect " + address + ":" + std::to_string(port) + ": " +
                             error);
  }
}

LoopbackUdpSender::~LoopbackUdpSender() {
  if (fd_ >= 0) close(fd_);
}

bool LoopbackUdpSender::Send(const uint8_t* data, size_t size, std::string* error) {
  const ssize_t n = send(fd_, data, size, 0);
  if (n == static_cast<ssize_t>(size)) return true;
  // ECONNREFUSED: nobody listens yet (ICMP port unreachable on loopback); not fatal.
  if (error != nullptr) *error = n < 0 ? std::strerror(errno) : "short send";
  return false;
}

ViconObject ViconObjectFromPose(const std::string& name, const Pose3& X_WB) {
  ViconObject object;
  object.name = name;
  object.translation_mm = X_WB.p * 1000.0;  // m -> mm
  object.rotation_rad = ViconEulerXyzFromQuaternion(X_WB.q);
  return object;
}

Pose3 SyntheticCirclePose(const ViconEmitterConfig& config, double t_s) {
  const double angle = config.angular_rate_radps * t_s;
  Pose3 X_WB;
  X_WB.p =
      config.center_m + config.radius_m * Eigen::Vector3d(std::cos(angle), std::sin(angle), 0.0);
  const double half_pi = 1.57079632679489661923;
  const double yaw = angle + (config.angular_rate_radps >= 0.0 ? half_pi : -half_pi);
  X_WB.q = Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())) *
           Eigen::Quaterniond(Eigen::AngleAxisd(config.roll_rad, Eigen::Vector3d::UnitX()));
  return X_WB;
}

ViconEmitterNode::ViconEmitterNode(lcm::LCM& lcm, const ViconEmitterConfig& config,
                                   const Clock& clock)
    : config_((config.Validate(), config)),
      clock_(clock),
      sender_(config.destination_address, config.port),
      heartbeat_(lcm, clock, "kestrel-vicon-emitter", config.heartbeat_channel),
      drops_(clock),
      subscriptions_(lcm),
      next_frame_number_(static_cast<uint32_t>(config.first_frame_number)) {
  if (config_.source == "sim_truth") {
    subscriptions_.Add<sim_truth_t>(
        config_.truth_channel,
        [this](const std::string&, const sim_truth_t& truth) { OnTruth(truth); },
        [this](const std::string& channel, const std::string& reason) {
          ++truth_rejected_;
          drops_.Count("malformed " + channel, reason);
        });
  }
  heartbeat_.SetState(heartbeat_t::STATE_OK);
}

bool ViconEmitterNode::SendPose(const Pose3& X_WB) {
  ViconFrame frame;
  frame.frame_number = next_frame_number_++;
  frame.objects.push_back(ViconObjectFromPose(config_.object_name, X_WB));
  const std::vector<uint8_t> bytes = EncodeViconDatagram(frame);
  std::string error;
  if (!sender_.Send(bytes.data(), bytes.size(), &error)) {
    ++send_errors_;
    drops_.Count("send", error);
    return false;
  }
  ++frames_sent_;
  return true;
}

void ViconEmitterNode::SendSyntheticFrame() {
  const int64_t now = clock_.NowUtime();
  if (start_utime_ < 0) start_utime_ = now;
  SendPose(SyntheticCirclePose(config_, UtimeToSeconds(now - start_utime_)));
}

void ViconEmitterNode::OnTruth(const sim_truth_t& truth) {
  // Down-sample the truth stream to rate_hz on its own time stamps.
  if (next_truth_utime_ >= 0 && truth.utime < next_truth_utime_) return;
  Pose3 X_WB;
  X_WB.p = Eigen::Vector3d(truth.position_m[0], truth.position_m[1], truth.position_m[2]);
  if (!X_WB.p.allFinite() || !QuaternionFromWxyz(truth.orientation_wxyz, &X_WB.q)) {
    ++truth_rejected_;
    drops_.Count("bad sim_truth", "non-finite position or non-unit orientation");
    return;
  }
  const int64_t period_us = SecondsToUtime(1.0 / config_.rate_hz);
  next_truth_utime_ = (next_truth_utime_ < 0 ? truth.utime : next_truth_utime_) + period_us;
  if (next_truth_utime_ <= truth.utime) next_truth_utime_ = truth.utime + period_us;
  SendPose(X_WB);
}

void ViconEmitterNode::AddTimers(NodeLoop& loop) {
  if (config_.source == "synthetic") {
    loop.AddTimer("vicon_emit", SecondsToUtime(1.0 / config_.rate_hz),
                  [this](int64_t) { SendSyntheticFrame(); });
  }
  loop.AddTimer("vicon_emitter_heartbeat", SecondsToUtime(1.0), [this](int64_t) {
    heartbeat_.SetValue("frames_sent", static_cast<double>(frames_sent_));
    heartbeat_.SetValue("send_errors", static_cast<double>(send_errors_));
    heartbeat_.SetValue("truth_rejected", static_cast<double>(truth_rejected_));
    heartbeat_.Publish();
  });
}

}  // namespace kestrel
