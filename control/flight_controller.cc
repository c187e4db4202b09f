#include "control/flight_controller.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace kestrel {

namespace {

GeometricControllerConfig LawConfig(const FlightControllerConfig& config) {
  GeometricControllerConfig law = config.controller;
  const GeometricControllerConfig from_vehicle =
      GeometricControllerConfig::FromVehicle(config.vehicle);
  law.mass_kg = from_vehicle.mass_kg;
  law.inertia_kgm2 = from_vehicle.inertia_kgm2;
  law.min_thrust_N = from_vehicle.min_thrust_N;
  law.max_thrust_N = from_vehicle.max_thrust_N;
  return law;
}

}  // namespace

void FlightControllerConfig::Validate() const {
  vehicle.Validate();
  GeometricControllerConfig law = controller;
  law.mass_kg = vehicle.mass_kg;
  law.inertia_kgm2 = vehicle.inertia_kgm2;
  law.min_thrust_N = 4.0 * vehicle.min_rotor_thrust_N;
  law.max_thrust_N = 4.0 * vehicle.max_rotor_thrust_N;
  law.Validate();
  estimator.Validate();
  safety.Validate();
}

FlightController::FlightController(const FlightControllerConfig& config)
    : config_(config),
      estimator_(config.estimator),
      supervisor_(config.safety),
      law_(LawConfig(config)),
      mixer_(config.vehicle),
      last_step_time_s_(-std::numeric_limits<double>::infinity()) {
  config_.Validate();
}

bool FlightController::HandleCommand(FlightCommand command, double time_s,
                                     double takeoff_height_m) {
  const VehicleState state = estimator_.initialized() ? estimator_.state() : VehicleState{};
  return supervisor_.HandleCommand(command, time_s, estimator_.initialized() ? &state : nullptr,
                                   estimator_.last_pose_time_s(), takeoff_height_m);
}

bool FlightController::Takeover(double time_s, double ground_z_m, bool landing,
                                std::string* reason) {
  if (!estimator_.initialized()) {
    if (reason != nullptr) *reason = "takeover waits: the estimator has no pose yet";
    return false;
  }
  return supervisor_.Takeover(time_s, estimator_.state(), estimator_.last_pose_time_s(), ground_z_m,
                              landing, reason);
}

FlightOutput FlightController::Step(double time_s) {
  FlightOutput out;
  out.time_s = time_s;
  out.has_state = estimator_.initialized();
  if (out.has_state) out.state = estimator_.state();
  out.pose_age_s = time_s - estimator_.last_pose_time_s();
  out.decision = supervisor_.Update(time_s, out.has_state ? &out.state : nullptr,
                                    estimator_.last_pose_time_s());
  double dt_s = time_s - last_step_time_s_;
  if (!std::isfinite(dt_s) || dt_s < 0.0) dt_s = 0.0;
  dt_s = std::min(dt_s, law_.config().max_dt_s);
  last_step_time_s_ = time_s;

  if (!out.decision.motors_enabled || !out.has_state) {
    law_.ResetIntegrals();
    out.armed = false;
    return out;  // rotor thrusts zero: motors stop
  }
  if (out.decision.reset_integrals) law_.ResetIntegrals();
  double f = 0.0;
  Eigen::Vector3d M = Eigen::Vector3d::Zero();
  out.control_ok = law_.Compute(out.state, out.decision.setpoint, dt_s, &out.control);
  if (out.control_ok) {
    f = out.control.thrust_N;
    M = out.control.moment_Nm;
  } else {
    // The law cannot act (e.g. free fall commanded): weight and rate damping only.
    f = config_.vehicle.mass_kg * kGravity_mps2;
    M = -law_.config().k_W_Nms_per_rad * out.state.angular_velocity_radps;
  }
  const MixerOutput mixed = mixer_.Mix(f, M);
  out.armed = true;
  out.rotor_thrust_N = mixed.rotor_thrust_N;
  out.thrust_N = mixed.thrust_N;
  out.moment_Nm = mixed.moment_Nm;
  return out;
}

}  // namespace kestrel
