// Controller update cost. Run: build-control/bench/control/control_bench
// The law runs at 200-500 Hz on the vehicle: its budget is 2-5 ms per step.
#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

#include <Eigen/Geometry>

#include "control/flight_controller.h"
#include "control/geometric_controller.h"
#include "control/mixer.h"
#include "control/state_estimator.h"

namespace kestrel {
namespace {

// A point of the paper's helix (docs/algorithms.md §11.8) with a perturbed state.
FlatOutput HelixPoint(double t) {
  const double w = 3.14159265358979323846;
  FlatOutput d;
  d.position_m = {0.4 * t, 0.4 * std::sin(w * t), 0.6 * std::cos(w * t) + 1.0};
  d.velocity_mps = {0.4, 0.4 * w * std::cos(w * t), -0.6 * w * std::sin(w * t)};
  d.acceleration_mps2 = {0.0, -0.4 * w * w * std::sin(w * t), -0.6 * w * w * std::cos(w * t)};
  d.jerk_mps3 = {0.0, -0.4 * w * w * w * std::cos(w * t), 0.6 * w * w * w * std::sin(w * t)};
  d.snap_mps4 = {0.0, 0.4 * w * w * w * w * std::sin(w * t), 0.6 * w * w * w * w * std::cos(w * t)};
  d.yaw_rad = w * t;
  d.yaw_rate_radps = w;
  return d;
}

// Arg: 0 = the large-angle attitude error (default), 1 = CDC 2010's.
AttitudeErrorForm FormOf(const benchmark::State& state) {
  return state.range(0) == 0 ? AttitudeErrorForm::kLargeAngle : AttitudeErrorForm::kCdc2010;
}

void BM_GeometricControllerCompute(benchmark::State& state) {
  GeometricControllerConfig config;
  config.attitude_error = FormOf(state);
  state.SetLabel(ToString(config.attitude_error));
  GeometricController controller{config};
  VehicleState s;
  s.position_m = {0.01, -0.02, 1.61};
  s.velocity_mps = {0.41, 1.2, 0.05};
  s.R_WB = Eigen::AngleAxisd(0.2, Eigen::Vector3d(0.3, 1.0, 0.2).normalized()).toRotationMatrix();
  s.angular_velocity_radps = {0.3, -0.2, 3.1};
  double t = 0.0;
  ControlOutput out;
  for (auto _ : state) {
    const bool ok = controller.Compute(s, HelixPoint(t), 0.0025, &out);
    benchmark::DoNotOptimize(ok);
    benchmark::DoNotOptimize(out);
    t += 0.0025;
  }
}
BENCHMARK(BM_GeometricControllerCompute)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// The attitude error vector alone, over attitudes from 0 to 180 deg (the large-angle form takes
// its quaternion branch within 0.06 deg of 180).
void BM_ComputeAttitudeError(benchmark::State& state) {
  const AttitudeErrorForm form = FormOf(state);
  state.SetLabel(ToString(form));
  std::vector<Eigen::Matrix3d> attitudes;
  for (int k = 0; k <= 180; ++k) {
    attitudes.push_back(Eigen::AngleAxisd(k * 3.14159265358979323846 / 180.0,
                                          Eigen::Vector3d(1, 0.3, 0.2).normalized())
                            .toRotationMatrix());
  }
  const Eigen::Matrix3d R_d = Eigen::AngleAxisd(0.3, Eigen::Vector3d(0, 0, 1)).toRotationMatrix();
  size_t i = 0;
  for (auto _ : state) {
    const Eigen::Vector3d e_R = ComputeAttitudeError(R_d * attitudes[i], R_d, form);
    benchmark::DoNotOptimize(e_R);
    i = i + 1 == attitudes.size() ? 0 : i + 1;
  }
}
BENCHMARK(BM_ComputeAttitudeError)->Arg(0)->Arg(1)->Unit(benchmark::kNanosecond);

void BM_MixerMix(benchmark::State& state) {
  const Mixer mixer{VehicleConfig{}};
  double f = 10.0;
  for (auto _ : state) {
    const MixerOutput out = mixer.Mix(f, Eigen::Vector3d(3.0, -2.0, 0.4));
    benchmark::DoNotOptimize(out);
    f = f > 120.0 ? -20.0 : f + 1.0;  // feasible and saturated cases
  }
}
BENCHMARK(BM_MixerMix)->Unit(benchmark::kMicrosecond);

// One full control step: IMU propagation, (every 4th step) a 20 ms late pose with history replay,
// supervisor, law and mixer, as the node runs it at 400 Hz.
void BM_FlightControllerStep(benchmark::State& state) {
  FlightController flight{FlightControllerConfig{}};
  double t = 0.0;
  (void)flight.AddPose({t, Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity()});
  for (int k = 0; k < 40; ++k) {
    t += 0.0025;
    (void)flight.AddImu({t, Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 0, 9.81)});
  }
  (void)flight.HandleCommand(FlightCommand::kTakeoff, t);
  int k = 0;
  for (auto _ : state) {
    t += 0.0025;
    (void)flight.AddImu({t, Eigen::Vector3d(0.01, 0.0, 0.0), Eigen::Vector3d(0, 0, 9.81)});
    if (++k % 4 == 0) {
      (void)flight.AddPose({t - 0.02, Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity()});
    }
    const FlightOutput out = flight.Step(t);
    benchmark::DoNotOptimize(out);
  }
}
BENCHMARK(BM_FlightControllerStep)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace kestrel

BENCHMARK_MAIN();
