#pragma once
/// @file
/// kestrel-vicon's node: a UDP socket bound to config.bind_address:config.port, the ViconBridge
/// core, pose_t on each object's channel (POSE_VICON by default) and a heartbeat with the drop
/// counters on HEARTBEAT_VICON.
///
/// Threading: ReceiveOnce() may run on a receive thread (StartReceiveThread) while the NodeLoop
/// runs the time-out and heartbeat timers on the main thread; one mutex serialises the bridge, the
/// heartbeat and every publish. Datagrams are stamped with the kernel's arrival time
/// (SO_TIMESTAMPNS) when the clock is the host clock, else with clock.NowUtime() after recvmsg.

#include <atomic>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/heartbeat.h"
#include "common/log.h"
#include "common/node_loop.h"
#include "drivers/vicon/vicon_bridge.h"
#include "drivers/vicon/vicon_config.h"

namespace kestrel {

class ViconNode {
 public:
  /// Opens and binds the UDP socket.
  /// @throws std::invalid_argument on a bad config, std::runtime_error if the socket cannot be
  /// bound (message names the address, port and errno text).
  ViconNode(lcm::LCM& lcm, const ViconConfig& config, const Clock& clock);
  ViconNode(const ViconNode&) = delete;
  ViconNode& operator=(const ViconNode&) = delete;
  /// Stops the receive thread and closes the socket.
  ~ViconNode();

  /// Waits up to timeout_ms for datagrams, then handles every queued one (at most 256).
  /// Returns the number handled, or -1 on a socket error (logged).
  int ReceiveOnce(int timeout_ms);
  /// Applies the time-out at the clock's time and publishes the invalid poses.
  void CheckTimeouts();
  /// Publishes one heartbeat: STATE_OK when every object is valid, DEGRADED otherwise.
  void PublishHeartbeat();
  /// Adds the time-out check (config.check_period_s) and heartbeat timers to `loop`.
  void AddTimers(NodeLoop& loop);
  /// Runs ReceiveOnce(50) on a thread until StopReceiveThread() or destruction.
  void StartReceiveThread();
  /// Stops and joins the receive thread (no-op when not running).
  void StopReceiveThread();

  /// The bound UDP port (the chosen one when config.port is 0).
  [[nodiscard]] int bound_port() const { return bound_port_; }
  /// A copy of the bridge counters (thread-safe).
  [[nodiscard]] ViconBridgeStats stats() const;
  /// The publisher epoch stamped on every pose (common/identity.h).
  [[nodiscard]] int64_t epoch() const { return epoch_; }

 private:
  // Stamps the epoch on each pose and publishes it.
  void Publish(std::vector<ViconPoseOutput>* outputs);

  lcm::LCM& lcm_;
  const ViconConfig config_;
  const Clock& clock_;
  int fd_{-1};
  int bound_port_{0};
  bool kernel_timestamps_{false};  // SO_TIMESTAMPNS on (host clock only)
  mutable std::mutex mutex_;
  ViconBridge bridge_;
  Heartbeat heartbeat_;
  DropCounter drops_;
  int64_t epoch_;
  std::vector<uint8_t> buffer_;
  std::vector<ViconPoseOutput> outputs_;
  std::atomic<bool> stop_thread_{false};
  std::thread thread_;
};

}  // namespace kestrel
