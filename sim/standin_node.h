#pragma once
/// @file
/// kestrel-sim-standin's node: stands in for one sensor driver (kestrel-xtion or kestrel-hokuyo)
/// in a simulation whose simulator publishes its depth images or scans on a device channel
/// (sensor_device_prefix, sim/simulator.h), so that the "driver" is a process of its own that can
/// be killed and restarted (docs/design.md §7.11). It reads the device channel through the
/// guarded decoder and republishes each frame on the driver channel unchanged but for `seq` (its
/// own counter, from 0 at every start, counting the frames it relays, as the real drivers do)
/// and `epoch` (its own publisher epoch). An optional seeded loss (drop_fraction) stands for a
/// flaky USB or serial link; every frame not relayed is counted by reason ("link_loss",
/// "malformed") and reported in the heartbeat as dropped.<reason>, beside device_frames and
/// relayed.

#include <cstdint>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/config.h"
#include "common/heartbeat.h"
#include "common/lcm_decode.h"
#include "common/log.h"
#include "common/node_loop.h"
#include "sim/sim_random.h"

namespace kestrel {

/// One stand-in's configuration (config/sim/standin.yaml; loaded by LoadStandinConfig).
struct StandinConfig {
  std::string sensor{"depth"};  ///< "depth" (depth_image_t) or "scan" (planar_scan_t)
  std::string device_channel{"DEV_DEPTH_XTION"};             ///< in: what the device delivers
  std::string channel{"DEPTH_XTION"};                        ///< out: the driver channel
  std::string heartbeat_channel{"HEARTBEAT_STANDIN_DEPTH"};  ///< heartbeat out
  double heartbeat_period_s{1.0};                            ///< heartbeat period, s, (0, 10]
  double drop_fraction{0.0};  ///< probability that a frame is lost on the link, [0, 1]
  int64_t seed{1};            ///< seed of the loss draws (the same losses at every start)

  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// Reads `sensor` and the chosen sensor's section (depth: or scan:, each with device_channel,
/// channel, heartbeat_channel), heartbeat_period_s, drop_fraction and seed; absent keys keep
/// their defaults (those of the chosen sensor). @throws ConfigError naming the key.
[[nodiscard]] StandinConfig LoadStandinConfig(const ConfigNode& root);

/// The stand-in's LCM node (see the file comment). Not thread-safe; not copyable.
class StandinNode {
 public:
  /// Subscribes to the device channel. The lcm and clock must outlive the node.
  /// @throws std::invalid_argument if config.Validate() throws.
  StandinNode(lcm::LCM& lcm, const StandinConfig& config, const Clock& clock);
  StandinNode(const StandinNode&) = delete;
  StandinNode& operator=(const StandinNode&) = delete;

  /// Publishes one heartbeat now (state OK once a frame was relayed, STARTING before).
  void PublishHeartbeat();
  /// Adds the heartbeat timer and the final heartbeat (STOPPING) to `loop`.
  void AddTimers(NodeLoop& loop);

  /// Well-formed frames received on the device channel.
  [[nodiscard]] int64_t device_frames() const { return device_frames_; }
  /// Frames republished on the driver channel.
  [[nodiscard]] int64_t relayed() const { return relayed_; }
  /// Frames not relayed, by reason ("link_loss", "malformed").
  [[nodiscard]] const DropCounter& drops() const { return drops_; }
  /// The publisher epoch stamped on every relayed frame (common/identity.h).
  [[nodiscard]] int64_t epoch() const { return epoch_; }

 private:
  template <typename Message>
  void Relay(const Message& frame);

  lcm::LCM& lcm_;
  const StandinConfig config_;
  GuardedSubscriptions subscriptions_;
  Heartbeat heartbeat_;
  DropCounter drops_;
  SimRandom rng_;
  int64_t epoch_;
  int64_t seq_{0};
  int64_t device_frames_{0};
  int64_t relayed_{0};
};

}  // namespace kestrel
