#include "sim/quadrotor.h"

#include <cmath>

#include <gtest/gtest.h>

namespace kestrel {
namespace {

World OpenWorld(bool floor) {
  World w;
  w.name = "open";
  w.map_min_m = Eigen::Vector3d(-50, -50, -50);
  w.map_max_m = Eigen::Vector3d(50, 50, 50);
  w.exploration_height_m = 1.0;
  if (floor) w.planes.push_back(WorldPlane{"floor", Eigen::Vector3d::UnitZ(), 0.0});
  return w;
}

Pose3 At(const Eigen::Vector3d& p, double yaw = 0.0) { return Pose3{p, QuaternionFromYaw(yaw)}; }

// Thrust equal to weight, shared equally, holds altitude and attitude exactly.
TEST(Quadrotor, HoverThrustHoldsAltitude) {
  const VehicleConfig vehicle;
  const World w = OpenWorld(true);
  Quadrotor quad(vehicle, QuadrotorConfig{}, w, nullptr);
  const Eigen::Vector4d hover = Eigen::Vector4d::Constant(vehicle.mass_kg * kGravity_mps2 / 4);
  quad.Reset(At({1, 2, 1.5}, 0.3), hover);
  for (int k = 0; k < 500; ++k) quad.Step(hover, 0.01);
  EXPECT_NEAR((quad.state().p_W - Eigen::Vector3d(1, 2, 1.5)).norm(), 0.0, 1e-9);
  EXPECT_LT(quad.state().v_W.norm(), 1e-9);
  EXPECT_LT(quad.state().w_B.norm(), 1e-9);
  EXPECT_NEAR(YawOf(quad.state().q_WB), 0.3, 1e-9);
  EXPECT_LT(quad.acceleration_W().norm(), 1e-9);
  EXPECT_FALSE(quad.on_ground());
}

// Both shipped vehicles (paper-sized and small) hover on weight / 4 per rotor and spin about
// z under a pure yaw moment at M_z / J_zz.
TEST(Quadrotor, ShippedVehiclesHoverAndYaw) {
  for (const char* file : {"paper.yaml", "small.yaml"}) {
    SCOPED_TRACE(file);
    VehicleConfig vehicle =
        LoadVehicleConfigFile(std::string(KESTREL_SOURCE_DIR) + "/config/vehicle/" + file);
    vehicle.motor_time_constant_s = 0.0;
    const World w = OpenWorld(false);
    Quadrotor quad(vehicle, QuadrotorConfig{}, w, nullptr);
    const double weight = vehicle.mass_kg * kGravity_mps2;
    quad.Reset(At({0, 0, 5}), Eigen::Vector4d::Constant(weight / 4));
    for (int k = 0; k < 100; ++k) quad.Step(Eigen::Vector4d::Constant(weight / 4), 0.01);
    EXPECT_NEAR(quad.state().p_W.z(), 5.0, 1e-9);
    const Eigen::Vector4d thrust =
        quad.geometry().mixer_inverse * Eigen::Vector4d(weight, 0, 0, 0.01);
    for (int k = 0; k < 10; ++k) quad.Step(thrust, 0.01);
    EXPECT_NEAR(quad.state().w_B.z(), 0.01 / vehicle.inertia_kgm2.z() * 0.1, 1e-9);
    EXPECT_NEAR(quad.state().p_W.z(), 5.0, 1e-9);
  }
}

// No thrust: falls as the closed-form solution of m zdd = -m g - c zd (linear body drag c).
TEST(Quadrotor, FreeFallMatchesClosedForm) {
  const VehicleConfig vehicle;
  const World w = OpenWorld(false);
  Quadrotor quad(vehicle, QuadrotorConfig{}, w, nullptr);
  quad.Reset(At({0, 0, 30}));
  const double m = vehicle.mass_kg, c = vehicle.linear_drag_Ns_per_m.z(), g = kGravity_mps2;
  for (int k = 1; k <= 150; ++k) {
    quad.Step(Eigen::Vector4d::Zero(), 0.01);
    const double t = 0.01 * k;
    const double z = 30.0 - (m * g / c) * (t - (m / c) * (1.0 - std::exp(-c * t / m)));
    const double vz = -(m * g / c) * (1.0 - std::exp(-c * t / m));
    ASSERT_NEAR(quad.state().p_W.z(), z, 1e-9) << t;
    ASSERT_NEAR(quad.state().v_W.z(), vz, 1e-9) << t;
  }
  EXPECT_NEAR(quad.acceleration_W().z(), -g - c / m * quad.state().v_W.z(), 1e-9);
  EXPECT_NEAR(quad.state().p_W.head<2>().norm(), 0.0, 1e-12);
}

// A pure moment (thrusts from the common mixer's inverse for [m g, M]) spins the vehicle about
// that body axis only, with w = J^-1 M t; the sim's per-rotor moments agree with the mixer.
TEST(Quadrotor, PureTorqueSpinsAboutTheRightAxis) {
  VehicleConfig vehicle;
  vehicle.motor_time_constant_s = 0.0;
  const World w = OpenWorld(false);
  for (int axis = 0; axis < 3; ++axis) {
    SCOPED_TRACE(axis);
    Quadrotor quad(vehicle, QuadrotorConfig{}, w, nullptr);
    quad.Reset(At({0, 0, 10}));
    Eigen::Vector4d wrench(vehicle.mass_kg * kGravity_mps2, 0, 0, 0);
    wrench[1 + axis] = 0.05;
    const Eigen::Vector4d thrust = quad.geometry().mixer_inverse * wrench;
    ASSERT_GT(thrust.minCoeff(), 0.0);
    const double t = 0.3;
    for (int k = 0; k < 30; ++k) quad.Step(thrust, t / 30);
    const double expected_rate = 0.05 / vehicle.inertia_kgm2[axis] * t;
    const Eigen::Vector3d w_B = quad.state().w_B;
    EXPECT_NEAR(w_B[axis], expected_rate, 1e-9 * expected_rate);
    EXPECT_NEAR(w_B[(axis + 1) % 3], 0.0, 1e-12);
    EXPECT_NEAR(w_B[(axis + 2) % 3], 0.0, 1e-12);
    // Rotation angle 1/2 (M/J) t^2 about the same axis.
    const Eigen::AngleAxisd turned(quad.state().q_WB);
    EXPECT_NEAR(turned.angle(), 0.5 * 0.05 / vehicle.inertia_kgm2[axis] * t * t, 1e-9);
    EXPECT_NEAR(std::abs(turned.axis()[axis]), 1.0, 1e-9);
  }
}

// docs/design.md §4 numbering (X layout): rotor 1 is front-right and spins clockwise, so extra
// thrust on it rolls left-side-up (w_x < 0), pitches nose-up (w_y < 0) and yaws counter-clockwise
// (w_z > 0: the drag reaction of a clockwise rotor).
TEST(Quadrotor, RotorOneFollowsTheFrameConvention) {
  VehicleConfig vehicle;
  vehicle.motor_time_constant_s = 0.0;
  const World w = OpenWorld(false);
  Quadrotor quad(vehicle, QuadrotorConfig{}, w, nullptr);
  quad.Reset(At({0, 0, 10}));
  Eigen::Vector4d thrust = Eigen::Vector4d::Constant(vehicle.mass_kg * kGravity_mps2 / 4);
  thrust[0] += 1.0;
  quad.Step(thrust, 0.05);
  EXPECT_LT(quad.state().w_B.x(), 0.0);
  EXPECT_LT(quad.state().w_B.y(), 0.0);
  EXPECT_GT(quad.state().w_B.z(), 0.0);
  EXPECT_GT(quad.geometry().position_B_m(0, 0), 0.0);
  EXPECT_LT(quad.geometry().position_B_m(1, 0), 0.0);
}

// A thrust step reaches 1 - 1/e of the step after one motor time constant (first-order lag).
TEST(Quadrotor, MotorLagHasTheConfiguredTimeConstant) {
  for (double tau : {0.02, 0.05}) {
    VehicleConfig vehicle;
    vehicle.motor_time_constant_s = tau;
    const World w = OpenWorld(false);
    Quadrotor quad(vehicle, QuadrotorConfig{}, w, nullptr);
    const double t0 = vehicle.mass_kg * kGravity_mps2 / 4;
    quad.Reset(At({0, 0, 10}), Eigen::Vector4d::Constant(t0));
    const Eigen::Vector4d command = Eigen::Vector4d::Constant(t0 + 2.0);
    for (int n = 1; n <= 3; ++n) {
      quad.Step(command, tau);
      for (int i = 0; i < 4; ++i) {
        EXPECT_NEAR(quad.state().thrust_N[i], t0 + 2.0 * (1.0 - std::exp(-n)), 1e-8) << tau;
      }
    }
  }
}

// On the floor without enough thrust the vehicle rests (no collision, zero acceleration);
// enough thrust lifts it; a fall onto the floor faster than the crash speed is a collision.
TEST(Quadrotor, RestsOnTheFloorTakesOffAndCrashes) {
  const VehicleConfig vehicle;
  const World w = OpenWorld(true);
  Quadrotor quad(vehicle, QuadrotorConfig{}, w, nullptr);
  quad.Reset(At({0, 0, 0}, 1.0));
  for (int k = 0; k < 100; ++k) quad.Step(Eigen::Vector4d::Constant(5.0), 0.01);
  EXPECT_TRUE(quad.on_ground());
  EXPECT_LT(quad.state().p_W.norm(), 1e-12);
  EXPECT_EQ(quad.acceleration_W(), Eigen::Vector3d::Zero());
  EXPECT_EQ(quad.collision_count(), 0);
  const Eigen::Vector4d climb = Eigen::Vector4d::Constant(vehicle.mass_kg * kGravity_mps2 / 4 + 2);
  for (int k = 0; k < 100; ++k) quad.Step(climb, 0.01);
  EXPECT_FALSE(quad.on_ground());
  EXPECT_GT(quad.state().p_W.z(), 0.1);
  quad.Reset(At({0, 0, 2.0}));
  for (int k = 0; k < 200; ++k) quad.Step(Eigen::Vector4d::Zero(), 0.01);
  EXPECT_TRUE(quad.on_ground());
  EXPECT_EQ(quad.collision_count(), 1);
  EXPECT_EQ(quad.last_collision(), "floor");
}

// Flying into a wall is one collision (counted once per episode) naming the wall.
TEST(Quadrotor, ContactWithAnObstacleIsACollision) {
  const VehicleConfig vehicle;
  World w = OpenWorld(true);
  w.boxes.push_back(WorldBox{"wall", {2.0, 0, 1}, {0.05, 3, 1}, Eigen::Quaterniond::Identity()});
  const BulletWorld bullet(w, 0.5 * vehicle.diameter_m, 0.15);
  Quadrotor quad(vehicle, QuadrotorConfig{}, w, &bullet);
  QuadrotorState s;
  s.p_W = Eigen::Vector3d(0, 0, 1);
  s.v_W = Eigen::Vector3d(1.0, 0, 0);
  s.thrust_N.setConstant(vehicle.mass_kg * kGravity_mps2 / 4);
  quad.SetState(s);
  double first_contact_x = 0.0;
  for (int k = 0; k < 200 && quad.collision_count() == 0; ++k) {
    quad.Step(s.thrust_N, 0.01);
    first_contact_x = quad.state().p_W.x();
  }
  EXPECT_EQ(quad.collision_count(), 1);
  EXPECT_EQ(quad.last_collision(), "wall");
  // The disc touches the wall face at x = 1.95 when its centre is one radius away.
  EXPECT_NEAR(first_contact_x, 1.95 - 0.5 * vehicle.diameter_m, 0.02);
  for (int k = 0; k < 20; ++k) quad.Step(s.thrust_N, 0.01);
  EXPECT_TRUE(quad.in_collision());
  EXPECT_EQ(quad.collision_count(), 1);
}

// Kinematic mode puts the vehicle on the trajectory: position, velocity, thrust axis along
// a + g e3, heading yaw, body rate from the yaw rate.
TEST(Quadrotor, KinematicModeFollowsTheTrajectory) {
  const VehicleConfig vehicle;
  const World w = OpenWorld(true);
  Quadrotor quad(vehicle, QuadrotorConfig{}, w, nullptr);
  PolynomialSegment seg;
  seg.duration_s = 4.0;
  seg.coefficients[0] = {1.0, 0.0, 0.5};  // x = 1 + 0.5 t^2: a_x = 1
  seg.coefficients[1] = {2.0, 0.3};       // y = 2 + 0.3 t
  seg.coefficients[2] = {1.0};            // z = 1
  seg.coefficients[3] = {0.1, 0.5};       // yaw = 0.1 + 0.5 t
  std::string error;
  const auto trajectory = PiecewisePolynomialTrajectory::Create(0.0, {seg}, &error);
  ASSERT_TRUE(trajectory.has_value()) << error;
  const double t = 1.5;
  quad.FollowTrajectory(*trajectory, t);
  EXPECT_TRUE(quad.state().p_W.isApprox(Eigen::Vector3d(1 + 0.5 * t * t, 2 + 0.3 * t, 1), 1e-12));
  EXPECT_TRUE(quad.state().v_W.isApprox(Eigen::Vector3d(t, 0.3, 0), 1e-12));
  const Eigen::Vector3d b3 = quad.state().q_WB * Eigen::Vector3d::UnitZ();
  EXPECT_TRUE(b3.isApprox(Eigen::Vector3d(1, 0, kGravity_mps2).normalized(), 1e-12));
  const Eigen::Vector3d b1 = quad.state().q_WB * Eigen::Vector3d::UnitX();
  // b1 lies in the plane of the heading and b3: its azimuth is the yaw up to the 0.1 rad tilt.
  EXPECT_NEAR(std::atan2(b1.y(), b1.x()), 0.1 + 0.5 * t, 0.02);
  // Constant acceleration: the thrust axis is fixed, so the body turns about b3 only, at about
  // the yaw rate (0.5 rad/s; exactly so for a level vehicle).
  const Eigen::Vector3d w_W = quad.state().q_WB * quad.state().w_B;
  EXPECT_NEAR(w_W.norm(), 0.5, 0.01);
  EXPECT_NEAR(w_W.normalized().dot(b3), 1.0, 1e-6);
  // Level flight at constant yaw rate: w_B = (0, 0, 0.5) exactly (to the central difference).
  PolynomialSegment level;
  level.duration_s = 4.0;
  level.coefficients = {std::vector<double>{0.0, 0.2}, std::vector<double>{1.0},
                        std::vector<double>{1.0}, std::vector<double>{0.0, 0.5}};
  const auto spin = PiecewisePolynomialTrajectory::Create(0.0, {level}, &error);
  ASSERT_TRUE(spin.has_value()) << error;
  quad.FollowTrajectory(*spin, 2.0);
  EXPECT_TRUE(quad.state().w_B.isApprox(Eigen::Vector3d(0, 0, 0.5), 1e-8))
      << quad.state().w_B.transpose();
  EXPECT_NEAR(YawOf(quad.state().q_WB), 1.0, 1e-12);
}

}  // namespace
}  // namespace kestrel
