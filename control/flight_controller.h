#pragma once
/// @file
/// The controller process's logic without I/O: state estimator (IMU + motion capture), safety
/// supervisor (modes, time-outs, geofence), geometric controller and mixer, wired together. The
/// LCM node (control/controller_node.h) decodes messages into these calls and publishes Step()'s
/// output; closed-loop tests drive it directly with the rigid-body model. Pure: time comes with
/// every call. Frames as in control/vehicle_state.h.

#include <Eigen/Core>
#include <string>

#include "common/trajectory.h"
#include "common/vehicle_config.h"
#include "control/geometric_controller.h"
#include "control/mixer.h"
#include "control/safety.h"
#include "control/state_estimator.h"

namespace kestrel {

/// Everything the flight controller needs. `controller` mass, inertia and thrust range are taken
/// from `vehicle` (overwritten by the constructor).
struct FlightControllerConfig {
  VehicleConfig vehicle;                 ///< the vehicle (mixer, mass, inertia)
  GeometricControllerConfig controller;  ///< gains of the law
  StateEstimatorConfig estimator;        ///< observer gains and history
  SafetyConfig safety;                   ///< time-outs, take-off/landing, geofence

  /// Validates every part; throws std::invalid_argument naming the field.
  void Validate() const;
};

/// One step's result: the motor command and what led to it.
struct FlightOutput {
  double time_s{0.0};                                       ///< s
  bool armed{false};                                        ///< false: motors stop
  Eigen::Vector4d rotor_thrust_N{Eigen::Vector4d::Zero()};  ///< after saturation, N
  double thrust_N{0.0};                                     ///< achieved f, N
  Eigen::Vector3d moment_Nm{Eigen::Vector3d::Zero()};       ///< achieved M, B, N m
  SafetyDecision decision;                                  ///< mode, set point, reason
  bool has_state{false};                                    ///< the estimator is initialised
  VehicleState state;                                       ///< the estimate used
  bool control_ok{false};  ///< the law produced an output (else a level-hover fallback)
  ControlOutput control;   ///< the law's output and errors (valid if control_ok)
  double pose_age_s{0.0};  ///< time since the newest valid pose, s (inf if none)
};

/// Estimator + supervisor + law + mixer. Not thread-safe.
class FlightController {
 public:
  /// @throws std::invalid_argument if config.Validate() throws.
  explicit FlightController(const FlightControllerConfig& config);

  /// Feeds one IMU sample (see StateEstimator::AddImu).
  bool AddImu(const ImuSample& sample) { return estimator_.AddImu(sample); }
  /// Feeds one valid motion-capture pose (see StateEstimator::AddPose).
  bool AddPose(const PoseMeasurement& pose) { return estimator_.AddPose(pose); }
  /// An operator command (see SafetySupervisor::HandleCommand).
  bool HandleCommand(FlightCommand command, double time_s, double takeoff_height_m = 0.0);
  /// A new trajectory (see SafetySupervisor::AcceptTrajectory).
  bool AcceptTrajectory(const PiecewisePolynomialTrajectory& trajectory, double time_s,
                        std::string* reason) {
    return supervisor_.AcceptTrajectory(trajectory, time_s, reason);
  }

  /// Takes a flying vehicle over after a controller restart from the current estimate (see
  /// SafetySupervisor::Takeover); false with *reason until the estimator has a fresh pose.
  bool Takeover(double time_s, double ground_z_m, bool landing, std::string* reason);

  /// Computes the motor command for time_s (s, non-decreasing across calls).
  [[nodiscard]] FlightOutput Step(double time_s);

  [[nodiscard]] const StateEstimator& estimator() const { return estimator_; }
  [[nodiscard]] const SafetySupervisor& supervisor() const { return supervisor_; }
  [[nodiscard]] const Mixer& mixer() const { return mixer_; }

 private:
  FlightControllerConfig config_;
  StateEstimator estimator_;
  SafetySupervisor supervisor_;
  GeometricController law_;
  Mixer mixer_;
  double last_step_time_s_;
};

}  // namespace kestrel
