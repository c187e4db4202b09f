#include "control/rigid_body.h"

#include <gtest/gtest.h>

#include <cmath>

namespace kestrel {
namespace {

VehicleConfig NoDragVehicle(double tau_s) {
  VehicleConfig vehicle;
  vehicle.linear_drag_Ns_per_m.setZero();
  vehicle.motor_time_constant_s = tau_s;
  return vehicle;
}

// With the rotors off the body falls as a point mass: x(t) = x0 + v0 t - g t^2 / 2.
TEST(RigidBodySimulator, FreeFallIsBallistic) {
  RigidBodySimulator sim(NoDragVehicle(0.0));
  VehicleState s;
  s.position_m = Eigen::Vector3d(1, 2, 30);
  s.velocity_mps = Eigen::Vector3d(0.5, -1.0, 2.0);
  sim.SetState(s, Eigen::Vector4d::Zero());
  for (int k = 0; k < 200; ++k) sim.Step(Eigen::Vector4d::Zero(), 0.01);
  const double t = 2.0;
  const Eigen::Vector3d expected =
      s.position_m + s.velocity_mps * t - 0.5 * kGravity_mps2 * t * t * Eigen::Vector3d::UnitZ();
  EXPECT_LT((sim.state().position_m - expected).norm(), 1e-9);
  EXPECT_NEAR(sim.time_s(), 2.0, 1e-12);
  // An accelerometer in free fall reads zero.
  EXPECT_LT(sim.specific_force_B_mps2().norm(), 1e-9);
}

// Equal rotor thrusts m g / 4: the body hovers, and the accelerometer reads +g along z_B.
TEST(RigidBodySimulator, EqualThrustsHover) {
  const VehicleConfig vehicle = NoDragVehicle(0.02);
  RigidBodySimulator sim(vehicle);
  VehicleState s;
  s.position_m = Eigen::Vector3d(0, 0, 1);
  const Eigen::Vector4d hover = Eigen::Vector4d::Constant(vehicle.mass_kg * kGravity_mps2 / 4.0);
  sim.SetState(s, hover);
  for (int k = 0; k < 500; ++k) sim.Step(hover, 0.002);
  EXPECT_LT((sim.state().position_m - s.position_m).norm(), 1e-9);
  EXPECT_LT(sim.state().angular_velocity_radps.norm(), 1e-9);
  EXPECT_LT((sim.specific_force_B_mps2() - Eigen::Vector3d(0, 0, kGravity_mps2)).norm(), 1e-9);
}

// The first-order lag: after a step command, T(t) = T_cmd (1 - exp(-t / tau)).
TEST(RigidBodySimulator, MotorLagIsFirstOrder) {
  RigidBodySimulator sim(NoDragVehicle(0.02));
  VehicleState s;
  s.position_m.z() = 100.0;
  sim.SetState(s, Eigen::Vector4d::Zero());
  const Eigen::Vector4d command(10.0, 10.0, 10.0, 10.0);
  for (int k = 0; k < 10; ++k) sim.Step(command, 0.002);                      // t = 0.02 s = tau
  EXPECT_NEAR(sim.rotor_thrust_N()[0], 10.0 * (1.0 - std::exp(-1.0)), 1e-7);  // RK4 error
}

// Torque-free tumbling of an asymmetric body conserves kinetic energy and the world-frame angular
// momentum R J W.
TEST(RigidBodySimulator, TorqueFreeMotionConservesEnergyAndMomentum) {
  const VehicleConfig vehicle = NoDragVehicle(0.0);
  RigidBodySimulator sim(vehicle, 0.0);
  VehicleState s;
  s.angular_velocity_radps = Eigen::Vector3d(3.0, 0.2, -1.0);  // near the unstable middle axis
  sim.SetState(s, Eigen::Vector4d::Zero());
  const Eigen::Matrix3d J = vehicle.inertia_kgm2.asDiagonal();
  auto energy = [&](const VehicleState& x) {
    return 0.5 * x.angular_velocity_radps.dot(J * x.angular_velocity_radps);
  };
  auto momentum = [&](const VehicleState& x) {
    return Eigen::Vector3d(x.R_WB * J * x.angular_velocity_radps);
  };
  const double e0 = energy(sim.state());
  const Eigen::Vector3d h0 = momentum(sim.state());
  for (int k = 0; k < 1000; ++k) sim.Step(Eigen::Vector4d::Zero(), 0.005);
  EXPECT_NEAR(energy(sim.state()) / e0, 1.0, 1e-6);
  EXPECT_LT((momentum(sim.state()) - h0).norm() / h0.norm(), 1e-6);
}

// A pure yaw moment from the rotors spins the body about z at Mz / Jz (W starting at zero).
TEST(RigidBodySimulator, YawMomentSpinsAboutZ) {
  const VehicleConfig vehicle = NoDragVehicle(0.0);
  RigidBodySimulator sim(vehicle);
  const Eigen::Vector4d T =
      sim.geometry().mixer_inverse * Eigen::Vector4d(vehicle.mass_kg * kGravity_mps2, 0, 0, 0.5);
  VehicleState s;
  s.position_m.z() = 10.0;
  sim.SetState(s, T);
  sim.Step(T, 0.1);
  EXPECT_NEAR(sim.state().angular_velocity_radps.z(), 0.5 / vehicle.inertia_kgm2.z() * 0.1, 1e-9);
  EXPECT_NEAR(sim.state().angular_velocity_radps.head<2>().norm(), 0.0, 1e-9);
  EXPECT_NEAR(sim.state().position_m.z(), 10.0, 1e-9);
}

}  // namespace
}  // namespace kestrel
