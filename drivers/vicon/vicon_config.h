#pragma once
/// @file
/// Configuration of kestrel-vicon (the bridge) and kestrel-vicon-emitter
/// (config/drivers/vicon.yaml, config/drivers/vicon_emitter.yaml). Plain structs, defaults at the
/// members, units in the names.

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "drivers/vicon/vicon_packet.h"

namespace kestrel {

class ConfigNode;

/// One tracked object published by the bridge.
struct ViconObjectConfig {
  std::string name{"kestrel"};        ///< Vicon object name as streamed (1..23 bytes)
  std::string channel{"POSE_VICON"};  ///< LCM channel of its pose_t
  std::string child_frame_id;         ///< pose_t.child_frame_id ("" = the Vicon name)
};

/// kestrel-vicon: UDP object stream in, pose_t out.
struct ViconConfig {
  /// Local address to receive on: "0.0.0.0" (any interface) or a dotted IPv4 address.
  std::string bind_address{"0.0.0.0"};
  int port{51001};  ///< UDP port Tracker sends to; 0 = any free port (tests), [0, 65535]
  std::vector<ViconObjectConfig> objects{ViconObjectConfig{}};  ///< objects to publish, >= 1
  std::string frame_id{"world"};  ///< pose_t.frame_id (Vicon's world, assumed z up = W)
  /// Transport + processing latency subtracted from the receive time, s, [0, 1].
  double latency_s{0.0};
  /// An object not seen for this long is published invalid, s, (0, 10].
  double timeout_s{0.1};
  /// While an object is invalid, its invalid pose_t is repeated at this period, s, (0, 10].
  double invalid_repeat_period_s{0.1};
  /// Period of the time-out check, s, (0, 1].
  double check_period_s{0.01};
  /// A forward frame-number jump larger than this is a stream restart, not drops, >= 1.
  int64_t max_frame_gap{1000};
  /// A backward frame-number step of at most this many frames is a late (reordered) datagram and
  /// is dropped; a larger one is a Tracker restart and resets the frame counter, >= 0.
  int64_t reorder_window_frames{100};
  /// Euler order of the rotation: "xyz_intrinsic" (R = Rx Ry Rz, Vicon's EulerXYZ) or
  /// "xyz_extrinsic" (R = Rz Ry Rx).
  std::string euler_order{"xyz_intrinsic"};
  /// Accept zero bytes after the last item (Tracker's fixed-size send buffer).
  bool allow_zero_padding{true};
  /// Treat an object whose six values are exactly 0 as occluded (not seen in this frame).
  bool zero_pose_is_occluded{true};
  std::string heartbeat_channel{"HEARTBEAT_VICON"};  ///< heartbeat_t channel
  double heartbeat_period_s{1.0};                    ///< heartbeat period, s, (0, 1]

  /// Throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
  /// The parsed euler_order (call after Validate).
  [[nodiscard]] ViconEulerOrder euler_order_enum() const;
};

/// Reads a ViconConfig from a YAML node (absent keys keep their defaults) and validates it.
/// @throws ConfigError naming the file, key, value and range.
[[nodiscard]] ViconConfig LoadViconConfig(const ConfigNode& node);

/// kestrel-vicon-emitter: sends the object stream on loopback only.
struct ViconEmitterConfig {
  /// Destination address; must be a loopback address (127.0.0.0/8): nothing leaves the machine.
  std::string destination_address{"127.0.0.1"};
  int port{51001};  ///< destination UDP port, [1, 65535]
  /// "sim_truth": re-send the simulator's truth (SIM_TRUTH); "synthetic": a circle trajectory.
  std::string source{"synthetic"};
  std::string truth_channel{"SIM_TRUTH"};  ///< sim_truth_t channel (source sim_truth)
  std::string object_name{"kestrel"};      ///< Vicon object name sent, 1..23 bytes
  double rate_hz{100.0};                   ///< frames per second, (0, 1000]
  int64_t first_frame_number{1};           ///< frame number of the first datagram, [0, 2^32 - 1]
  /// Synthetic trajectory: a horizontal circle of this radius (m) around `center_m`, at
  /// `angular_rate_radps`, the body yawing with the tangent and rolling by `roll_rad`.
  double radius_m{1.0};
  Eigen::Vector3d center_m{0.0, 0.0, 1.0};                   ///< circle centre in W, m
  double angular_rate_radps{0.5};                            ///< rad/s along the circle
  double roll_rad{0.1};                                      ///< constant roll (about body x), rad
  std::string heartbeat_channel{"HEARTBEAT_VICON_EMITTER"};  ///< heartbeat_t channel

  /// Throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// Reads a ViconEmitterConfig from YAML and validates it. @throws ConfigError
[[nodiscard]] ViconEmitterConfig LoadViconEmitterConfig(const ConfigNode& node);

/// True when `address` is a dotted IPv4 address in 127.0.0.0/8.
[[nodiscard]] bool IsLoopbackAddress(const std::string& address);

}  // namespace kestrel
