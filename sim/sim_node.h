#pragma once
/// @file
/// kestrel-sim's node: the Simulator (sim/simulator.h) on LCM. Publishes what the hardware
/// drivers publish (POSE_VICON pose_t as the motion-capture bridge does, without velocities;
/// IMU imu_t; DEPTH_XTION depth_image_t raw 16-bit; SCAN_HOKUYO planar_scan_t) plus SIM_TRUTH
/// (sim_truth_t) and a 1 Hz heartbeat; reads MOTOR_COMMAND (dynamic mode) or TRAJECTORY
/// (kinematic mode) through the guarded decoder. With several vehicles, each one's channels carry
/// its prefix (V2_POSE_VICON, V2_MOTOR_COMMAND, V2_SIM_TRUTH, ...); the heartbeat is the
/// simulator's, one for all. With sensor_device_prefix set, depth images and scans go out on the
/// device channels (e.g. DEV_DEPTH_XTION) for kestrel-sim-standin to relay (docs/design.md §7.11).
/// Lockstep: Step() advances one physics step,
/// sets the SimClock to the new time and publishes; nodes sharing the lcm and clock in one
/// process then handle the messages (lcm.handleTimeout(0)) before the next Step().

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/heartbeat.h"
#include "common/lcm_decode.h"
#include "kestrel/motor_command_t.hpp"
#include "kestrel/trajectory_t.hpp"
#include "sim/simulator.h"

namespace kestrel {

/// kestrel-sim's LCM node (see the file comment). Not thread-safe; neither copyable nor movable.
/// SIM_TRUTH's real_time_factor and the heartbeat depend on the wall clock; every other field
/// of every message is deterministic for a seed, but for the publisher epoch, which is drawn at
/// construction (deterministic after SeedPublisherEpochs, common/identity.h).
class SimNode {
 public:
  /// Builds the simulator at the clock's current time and subscribes. The lcm and clock must
  /// outlive the node. @throws std::invalid_argument if config.Validate() throws.
  SimNode(lcm::LCM& lcm, const SimConfig& config, SimClock& clock);
  SimNode(const SimNode&) = delete;
  SimNode& operator=(const SimNode&) = delete;

  /// One lockstep step: advance physics, set the clock, publish everything due.
  void Step();

  /// The simulation core (state, sensors, latest frames).
  [[nodiscard]] const Simulator& simulator() const { return *simulator_; }
  /// The simulation core, mutable (e.g. SetVehicleState before the first Step).
  [[nodiscard]] Simulator& mutable_simulator() { return *simulator_; }
  /// Messages refused (malformed, wrong motor count, bad trajectory), since start.
  [[nodiscard]] int64_t rejected_messages() const { return rejected_; }
  /// The same by reason: "malformed" (refused by the guarded decoder), "refused" (decoded but
  /// unusable); in the heartbeat as dropped.<reason>.
  [[nodiscard]] const DropCounter& drops() const { return drops_; }
  /// Simulated seconds per wall second since the last heartbeat (0 before the first).
  [[nodiscard]] double real_time_factor() const { return real_time_factor_; }
  /// The publisher epoch stamped on every message but the heartbeat (common/identity.h).
  [[nodiscard]] int64_t epoch() const { return epoch_; }

 private:
  /// Per vehicle: its channel names and the sequence numbers of its streams.
  struct VehicleChannels {
    std::string pose, imu, depth, scan, truth, motor, trajectory;
    int64_t pose_seq{0}, imu_seq{0}, depth_seq{0}, scan_seq{0}, truth_seq{0};
  };

  void OnMotorCommand(size_t k, const motor_command_t& msg);
  void OnTrajectory(size_t k, const trajectory_t& msg);
  void Reject(const std::string& kind, const std::string& channel, const std::string& reason);
  void Publish(size_t k);
  void PublishHeartbeat();

  lcm::LCM& lcm_;
  SimClock& clock_;
  std::unique_ptr<Simulator> simulator_;
  GuardedSubscriptions subscriptions_;
  Heartbeat heartbeat_;
  DropCounter drops_;
  int64_t epoch_;
  std::vector<VehicleChannels> channels_;  // by vehicle
  int64_t rejected_{0};
  int64_t next_heartbeat_utime_;
  std::chrono::steady_clock::time_point wall_at_heartbeat_;
  int64_t utime_at_heartbeat_;
  double real_time_factor_{0.0};
};

}  // namespace kestrel
