#pragma once
/// @file
/// kestrel-vicon-emitter: sends the Vicon Tracker UDP object stream (vicon_packet.h) to a loopback
/// address only, from the simulator's truth (SIM_TRUTH, sim_truth_t) or from a synthetic circle,
/// so kestrel-vicon runs unchanged in simulated flights and tests.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/heartbeat.h"
#include "common/lcm_decode.h"
#include "common/log.h"
#include "common/node_loop.h"
#include "common/se3.h"
#include "drivers/vicon/vicon_config.h"
#include "drivers/vicon/vicon_packet.h"
#include "kestrel/sim_truth_t.hpp"

namespace kestrel {

/// A UDP sender that refuses any destination outside 127.0.0.0/8.
class LoopbackUdpSender {
 public:
  /// @throws std::invalid_argument unless `address` is a loopback IPv4 address and port is in
  /// [1, 65535]; std::runtime_error if the socket cannot be created.
  LoopbackUdpSender(const std::string& address, int port);
  LoopbackUdpSender(const LoopbackUdpSender&) = delete;
  LoopbackUdpSender& operator=(const LoopbackUdpSender&) = delete;
  /// Closes the socket.
  ~LoopbackUdpSender();

  /// Sends one datagram. Returns false (with *error) if the kernel refused it.
  bool Send(const uint8_t* data, size_t size, std::string* error);

 private:
  int fd_{-1};
};

/// The wire form of body pose X_WB: translation in mm, Euler XYZ (R = Rx Ry Rz) in rad.
[[nodiscard]] ViconObject ViconObjectFromPose(const std::string& name, const Pose3& X_WB);

/// The synthetic trajectory at time t_s (s since start): position on the circle of radius_m about
/// center_m at angle angular_rate_radps * t_s (counter-clockwise from +x), body x along the
/// direction of travel (yaw = angle + pi/2, or - pi/2 when the rate is negative), then rolled by
/// roll_rad about body x: R_WB = Rz(yaw) Rx(roll).
[[nodiscard]] Pose3 SyntheticCirclePose(const ViconEmitterConfig& config, double t_s);

class ViconEmitterNode {
 public:
  /// Opens the loopback sender; subscribes to config.truth_channel when source is "sim_truth".
  /// @throws std::invalid_argument on a bad config (e.g. a non-loopback destination).
  ViconEmitterNode(lcm::LCM& lcm, const ViconEmitterConfig& config, const Clock& clock);
  ViconEmitterNode(const ViconEmitterNode&) = delete;
  ViconEmitterNode& operator=(const ViconEmitterNode&) = delete;

  /// Adds the synthetic frame timer (source "synthetic") and the 1 Hz heartbeat to `loop`.
  void AddTimers(NodeLoop& loop);
  /// Sends one synthetic frame for the clock's current time (the timer calls this).
  void SendSyntheticFrame();
  /// Sends one frame for X_WB with the next frame number. Returns false if sending failed.
  bool SendPose(const Pose3& X_WB);

  /// Datagrams sent so far.
  [[nodiscard]] int64_t frames_sent() const { return frames_sent_; }
  /// sim_truth_t messages rejected (malformed bytes, non-finite or non-unit pose).
  [[nodiscard]] int64_t truth_rejected() const { return truth_rejected_; }

 private:
  void OnTruth(const sim_truth_t& truth);

  const ViconEmitterConfig config_;
  const Clock& clock_;
  LoopbackUdpSender sender_;
  Heartbeat heartbeat_;
  DropCounter drops_;
  GuardedSubscriptions subscriptions_;
  uint32_t next_frame_number_;
  int64_t start_utime_{-1};
  int64_t next_truth_utime_{-1};
  int64_t frames_sent_{0};
  int64_t send_errors_{0};
  int64_t truth_rejected_{0};
};

}  // namespace kestrel
