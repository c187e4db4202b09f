// Closed-loop tests in one process: GeometricController -> Mixer -> RigidBodySimulator (RK4,
// first-order motor lag), the paper-sized vehicle (config defaults = config/vehicle/paper.yaml).
// The figures are printed (and recorded as test properties) for the closing note.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>

#include "control/geometric_controller.h"
#include "control/mixer.h"
#include "control/rigid_body.h"
#include "exploration/dijkstra.h"
#include "exploration/grid_map_2d.h"
#include "exploration/trajectory_planner.h"

namespace kestrel {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kControlDt_s = 0.0025;  // 400 Hz, within the vehicle's 200-500 Hz

// The paper's elliptical helix (docs/algorithms.md §11.8): x_d = (0.4 t, 0.4 sin(pi t),
// 0.6 cos(pi t) + z0), b1d = (cos(pi t), sin(pi t), 0), i.e. yaw = pi t; derivatives in closed
// form.
FlatOutput Helix(double t, double z0) {
  const double w = kPi;
  const double s = std::sin(w * t);
  const double c = std::cos(w * t);
  FlatOutput d;
  d.position_m = Eigen::Vector3d(0.4 * t, 0.4 * s, 0.6 * c + z0);
  d.velocity_mps = Eigen::Vector3d(0.4, 0.4 * w * c, -0.6 * w * s);
  d.acceleration_mps2 = Eigen::Vector3d(0.0, -0.4 * w * w * s, -0.6 * w * w * c);
  d.jerk_mps3 = Eigen::Vector3d(0.0, -0.4 * w * w * w * c, 0.6 * w * w * w * s);
  d.snap_mps4 = Eigen::Vector3d(0.0, 0.4 * w * w * w * w * s, 0.6 * w * w * w * w * c);
  d.yaw_rad = w * t;
  d.yaw_rate_radps = w;
  d.yaw_acceleration_radps2 = 0.0;
  return d;
}

struct Loop {
  VehicleConfig vehicle;
  GeometricControllerConfig gains = GeometricControllerConfig::FromVehicle(vehicle);
  double inverted_collective_floor_N = 0.0;  // a collective floor while b3 . e3 < 0 (0: none)

  // Runs for duration_s from `initial`, calling observe(t, state, output) after every control
  // step (t = time of the state). Returns false if the controller ever failed.
  bool Run(const VehicleState& initial, double duration_s,
           const std::function<FlatOutput(double)>& desired,
           const std::function<void(double, const VehicleState&, const ControlOutput&)>& observe) {
    GeometricController controller(gains);
    const Mixer mixer(vehicle);
    RigidBodySimulator sim(vehicle);
    const Eigen::Vector4d hover = Eigen::Vector4d::Constant(vehicle.mass_kg * kGravity_mps2 / 4.0);
    sim.SetState(initial, hover);
    const int steps = static_cast<int>(std::lround(duration_s / kControlDt_s));
    for (int k = 0; k < steps; ++k) {
      const double t = k * kControlDt_s;
      const VehicleState state = sim.state();
      ControlOutput out;
      if (!controller.Compute(state, desired(t), k == 0 ? 0.0 : kControlDt_s, &out)) return false;
      observe(t, state, out);
      const double f = state.R_WB(2, 2) < 0.0 ? std::max(out.thrust_N, inverted_collective_floor_N)
                                              : out.thrust_N;
      const MixerOutput mixed = mixer.Mix(f, out.moment_Nm);
      sim.Step(mixed.rotor_thrust_N, kControlDt_s);
    }
    return true;
  }
};

struct HelixFigures {
  double rms_m = 0.0;
  double max_m = 0.0;
};

HelixFigures FlyHelix(Loop* loop) {
  const double z0 = 1.0;
  VehicleState initial;  // at the helix start, at rest, level, heading along x
  initial.position_m = Helix(0.0, z0).position_m;
  double sum_sq = 0.0;
  int n = 0;
  HelixFigures figures;
  const bool ok = loop->Run(
      initial, 10.0, [z0](double t) { return Helix(t, z0); },
      [&](double t, const VehicleState&, const ControlOutput& out) {
        if (t < 2.0) return;  // after the 2 s transient
        const double e = out.e_x_m.norm();
        sum_sq += e * e;
        ++n;
        figures.max_m = std::max(figures.max_m, e);
      });
  EXPECT_TRUE(ok);
  figures.rms_m = std::sqrt(sum_sq / n);
  return figures;
}

// The paper's helix with the paper-sized vehicle and its 0.02 s motor lag, no sensor noise, the
// controller NOT compensating the lag: position RMS below 2 cm after a 2 s transient.
TEST(ClosedLoop, PaperHelixTracksWithinTwoCentimetres) {
  Loop loop;
  ASSERT_EQ(loop.vehicle.motor_time_constant_s, 0.02);
  ASSERT_EQ(loop.gains.thrust_lag_compensation_s, 0.0);
  const HelixFigures figures = FlyHelix(&loop);
  std::printf(
      "helix (tau 0.02 s, no lag compensation, large_angle e_R): RMS %.2f mm, max %.2f mm after 2 "
      "s\n",
      figures.rms_m * 1e3, figures.max_m * 1e3);
  RecordProperty("helix_rms_mm", std::to_string(figures.rms_m * 1e3));
  EXPECT_LT(figures.rms_m, 0.02);
}

// The same with CDC 2010's attitude error (the default is the large-angle one): both must stay
// under 2 cm.
TEST(ClosedLoop, PaperHelixWithCdc2010ErrorTracksWithinTwoCentimetres) {
  Loop loop;
  loop.gains.attitude_error = AttitudeErrorForm::kCdc2010;
  const HelixFigures figures = FlyHelix(&loop);
  std::printf("helix (tau 0.02 s, no lag compensation, cdc2010 e_R): RMS %.2f mm, max %.2f mm\n",
              figures.rms_m * 1e3, figures.max_m * 1e3);
  RecordProperty("helix_cdc2010_rms_mm", std::to_string(figures.rms_m * 1e3));
  EXPECT_LT(figures.rms_m, 0.02);
}

// The same with the thrust-lag compensation on (f + tau fdot): reported for comparison.
TEST(ClosedLoop, PaperHelixWithThrustLagCompensation) {
  Loop loop;
  loop.gains.thrust_lag_compensation_s = loop.vehicle.motor_time_constant_s;
  const HelixFigures figures = FlyHelix(&loop);
  std::printf("helix (tau 0.02 s, thrust lag compensated): RMS %.2f mm, max %.2f mm after 2 s\n",
              figures.rms_m * 1e3, figures.max_m * 1e3);
  RecordProperty("helix_compensated_rms_mm", std::to_string(figures.rms_m * 1e3));
  EXPECT_LT(figures.rms_m, 0.02);
}

// From 1 m away, tilted 40 deg and rotating, the vehicle settles on a hover set point: the
// feedback terms in W_d, Wdot_d keep hover stable.
TEST(ClosedLoop, SettlesOnHoverFromLargeOffset) {
  Loop loop;
  VehicleState initial;
  initial.position_m = Eigen::Vector3d(1.0, -0.5, 4.5);
  initial.velocity_mps = Eigen::Vector3d(-0.5, 0.5, 1.0);
  initial.R_WB = Eigen::AngleAxisd(40.0 * kPi / 180.0, Eigen::Vector3d(1, 1, 0).normalized())
                     .toRotationMatrix();
  initial.angular_velocity_radps = Eigen::Vector3d(1.0, -0.5, 0.5);
  const Eigen::Vector3d target(0.0, 0.0, 5.0);
  VehicleState last;
  ASSERT_TRUE(loop.Run(
      initial, 8.0, [&](double) { return FlatOutput::Hover(target, 1.0); },
      [&](double, const VehicleState& s, const ControlOutput&) { last = s; }));
  // (The position integral's slow mode, about c1 k_i / (k_x + k_i) = 0.03 1/s, leaves a few mm.)
  EXPECT_LT((last.position_m - target).norm(), 0.015);
  EXPECT_LT(last.velocity_mps.norm(), 0.01);
  EXPECT_LT(last.angular_velocity_radps.norm(), 0.01);
}

struct FlipFigures {
  double time_to_upright_s = -1.0;  // first time the tilt is below 10 deg
  double altitude_lost_m = 0.0;     // start height - lowest height
  double tilt_at_end_deg = 180.0;
  double max_tilt_after_upright_deg = 0.0;  // a second roll-over would show here
};

// Upside down (178 deg from the hover attitude, about the axis (1, 0.3, 0)) at rest at 20 m (the
// model has no ground), holding that point: the mixer keeps the flipping moments while the law
// asks for negative thrust, and the vehicle rights itself.
FlipFigures FlyFlip(Loop* loop) {
  const Eigen::Vector3d target(0.0, 0.0, 20.0);
  VehicleState initial;
  initial.position_m = target;
  initial.R_WB = Eigen::AngleAxisd(178.0 * kPi / 180.0, Eigen::Vector3d(1, 0.3, 0).normalized())
                     .toRotationMatrix();
  FlipFigures figures;
  double min_z = target.z();
  EXPECT_TRUE(loop->Run(
      initial, 14.0, [&](double) { return FlatOutput::Hover(target, 0.0); },
      [&](double t, const VehicleState& s, const ControlOutput&) {
        const double tilt_deg = std::acos(std::clamp(s.R_WB(2, 2), -1.0, 1.0)) * 180.0 / kPi;
        if (figures.time_to_upright_s < 0.0 && tilt_deg < 10.0) figures.time_to_upright_s = t;
        if (figures.time_to_upright_s >= 0.0) {
          figures.max_tilt_after_upright_deg =
              std::max(figures.max_tilt_after_upright_deg, tilt_deg);
        }
        min_z = std::min(min_z, s.position_m.z());
        figures.tilt_at_end_deg = tilt_deg;
      }));
  figures.altitude_lost_m = target.z() - min_z;
  std::printf(
      "upside-down 178 deg, %s e_R (controller's model): upright (tilt < 10 deg) after "
      "%.3f s, altitude lost %.3f m, largest tilt after that %.1f deg\n",
      ToString(loop->gains.attitude_error), figures.time_to_upright_s, figures.altitude_lost_m,
      figures.max_tilt_after_upright_deg);
  return figures;
}

// The large-angle attitude error (the default) starts the flip at full moment: upright within
// 0.8 s losing under 3.5 m (bounds stated for the paper-sized vehicle; CDC 2010's error takes
// 1.79 s and loses 19.5 m, see the next test, so these bounds fail with it), and it does not
// roll over again while it climbs back (the bounds on A_z, the tilt, W_d and Wdot_d: without
// them the tilt went back to 116 deg); the tilt limit is 57 deg.
TEST(ClosedLoop, RecoversFromUpsideDownWithLargeAngleError) {
  Loop loop;
  ASSERT_EQ(loop.gains.attitude_error, AttitudeErrorForm::kLargeAngle);
  const FlipFigures figures = FlyFlip(&loop);
  RecordProperty("flip_time_s", std::to_string(figures.time_to_upright_s));
  RecordProperty("flip_altitude_lost_m", std::to_string(figures.altitude_lost_m));
  EXPECT_GT(figures.time_to_upright_s, 0.0);
  EXPECT_LT(figures.time_to_upright_s, 0.8);
  EXPECT_LT(figures.altitude_lost_m, 3.5);
  EXPECT_LT(figures.max_tilt_after_upright_deg, 60.0);
  EXPECT_LT(figures.tilt_at_end_deg, 1.0);
}

// CDC 2010's e_R = sin(angle) is small near 180 deg, so the law starts the flip slowly while the
// vehicle falls with its rotors near idle: it still rights itself, later and lower, and after
// climbing back 13 m too high it settles only after about 11 s.
TEST(ClosedLoop, RecoversFromUpsideDownWithCdc2010Error) {
  Loop loop;
  loop.gains.attitude_error = AttitudeErrorForm::kCdc2010;
  const FlipFigures figures = FlyFlip(&loop);
  RecordProperty("flip_cdc2010_time_s", std::to_string(figures.time_to_upright_s));
  RecordProperty("flip_cdc2010_altitude_lost_m", std::to_string(figures.altitude_lost_m));
  EXPECT_GT(figures.time_to_upright_s, 0.0);
  EXPECT_LT(figures.time_to_upright_s, 2.5);
  EXPECT_LT(figures.altitude_lost_m, 25.0);
  EXPECT_LT(figures.tilt_at_end_deg, 1.0);
}

// The thrust bound while inverted: the mixer gives only the collective the flipping moments need
// (f = A . R e3 < 0 upside down). A collective floor while b3 . e3 < 0 (half the weight here)
// only pushes the vehicle towards the ground: more altitude lost, with either attitude error.
TEST(ClosedLoop, CollectiveWhileInvertedOnlyAddsToTheFall) {
  for (const AttitudeErrorForm form :
       {AttitudeErrorForm::kLargeAngle, AttitudeErrorForm::kCdc2010}) {
    Loop plain;
    plain.gains.attitude_error = form;
    Loop floored = plain;
    floored.inverted_collective_floor_N = 0.5 * floored.vehicle.mass_kg * kGravity_mps2;
    const FlipFigures a = FlyFlip(&plain);
    const FlipFigures b = FlyFlip(&floored);
    std::printf(
        "  (with a collective floor of m g / 2 while inverted: %.2f m lost instead of %.2f)\n",
        b.altitude_lost_m, a.altitude_lost_m);
    EXPECT_GT(b.altitude_lost_m, a.altitude_lost_m + 0.2) << ToString(form);
  }
}

// The planner's non-stop limits (docs/exploration.md, section "Non-stop flight"): a PlanTrajectory
// result over an L-shaped 8 m corridor (0.8 m cells, one cell wide: 4 m east, then 4 m north,
// turning the heading by 90 deg on the way) at 1 m/s, 1 m/s^2 and 1 rad/s, flown by the
// controller on its rigid-body model from a hover at the start, plus 2 s of hover at the end.
// Measured: max position error 3.7 mm, RMS 2.6 mm (no sensor noise); bound 1 cm.
TEST(ClosedLoop, TracksANonStopPlannedTrajectory) {
  const int w = 6, h = 6;
  GridMap2D c = GridMap2D::Filled({0.0, 0.0}, 0.8, 1.0, w, h, 0.0);
  std::vector<bool> traversable(static_cast<size_t>(w * h), false);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const bool free = y == 0 || x == 5;
      traversable[static_cast<size_t>(c.IndexOf(x, y))] = free;
      c.at(x, y) = free ? 0.0 : 0.9;
    }
  }
  const DistanceField field = ComputeDistanceField(w, h, traversable, {0, 0}, 0.8);
  TrajectoryConfig config;
  config.max_speed_mps = 1.0;
  config.max_acceleration_mps2 = 1.0;
  config.max_yaw_rate_radps = 1.0;
  config.vehicle_radius_m = 0.25;
  TrajectoryStart start;
  start.position_m = Eigen::Vector3d(0.4, 0.4, 1.0);
  const TrajectoryPlan plan =
      PlanTrajectory(c, traversable, field, c.IndexOf(5, 5), start, kPi / 2, 1.0, config);
  ASSERT_TRUE(plan.trajectory.has_value()) << plan.error;
  ASSERT_EQ(plan.stop_waypoints, 0);
  const PiecewisePolynomialTrajectory& trajectory = *plan.trajectory;
  Loop loop;
  VehicleState initial;
  initial.position_m = start.position_m;
  double sum_sq = 0.0, max_m = 0.0, max_speed = 0.0;
  int n = 0;
  ASSERT_TRUE(loop.Run(
      initial, trajectory.duration_s() + 2.0,
      [&](double t) { return trajectory.Evaluate(trajectory.start_time_s() + t); },
      [&](double, const VehicleState& s, const ControlOutput& out) {
        const double e = out.e_x_m.norm();
        sum_sq += e * e;
        ++n;
        max_m = std::max(max_m, e);
        max_speed = std::max(max_speed, s.velocity_mps.norm());
      }));
  const double rms_m = std::sqrt(sum_sq / n);
  std::printf(
      "non-stop L (8 m, %.2f s, 1 m/s, 1 m/s^2): position error max %.2f mm, RMS %.2f mm, "
      "vehicle's top speed %.3f m/s\n",
      trajectory.duration_s(), max_m * 1e3, rms_m * 1e3, max_speed);
  RecordProperty("nonstop_l_max_mm", std::to_string(max_m * 1e3));
  RecordProperty("nonstop_l_rms_mm", std::to_string(rms_m * 1e3));
  EXPECT_LT(max_m, 0.01);
}

}  // namespace
}  // namespace kestrel
