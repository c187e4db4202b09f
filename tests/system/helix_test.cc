// The paper's elliptical helix (docs/algorithms.md §11.8) flown by kestrel-controller's node in
// closed loop with the SIMULATOR's dynamics and sensors (kestrel-sim's node, lockstep, memq://):
// motion capture with its noise, latency and dropouts, IMU with noise and bias, motor lag
// tau = 0.02 s, the paper-sized vehicle. RMS position error after a 2 s transient.
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "common/config.h"
#include "common/trajectory_message.h"
#include "control/controller_node.h"
#include "kestrel/command_t.hpp"
#include "sim/sim_node.h"
#include "tests/system/flight_sim_config.h"

namespace kestrel {
namespace {

/// x_d = (x0 + 0.4 t, y0 + 0.4 sin(pi t), z0 + 0.6 cos(pi t)), yaw = pi t (b1d = (cos, sin, 0)),
/// as 0.1 s polynomial pieces from degree-11 Taylor expansions (error < 1e-12 m).
PiecewisePolynomialTrajectory Helix(double start_s, const Eigen::Vector3d& base,
                                    double duration_s) {
  std::vector<PolynomialSegment> segments;
  const double w = M_PI;
  for (double t0 = 0; t0 < duration_s - 1e-9; t0 += 0.1) {
    PolynomialSegment seg;
    seg.duration_s = 0.1;
    std::vector<double> sx, cz;
    double fact = 1.0;
    for (int k = 0; k <= 11; ++k) {
      if (k > 0) fact *= k;
      // d^k/dt^k sin(w t) = w^k sin(w t + k pi/2); likewise cos.
      sx.push_back(0.4 * std::pow(w, k) * std::sin(w * t0 + k * M_PI / 2) / fact);
      cz.push_back(0.6 * std::pow(w, k) * std::cos(w * t0 + k * M_PI / 2) / fact);
    }
    sx[0] += base.y();
    cz[0] += base.z();
    seg.coefficients[0] = {base.x() + 0.4 * t0, 0.4};
    seg.coefficients[1] = sx;
    seg.coefficients[2] = cz;
    seg.coefficients[3] = {w * t0, w};
    segments.push_back(seg);
  }
  return *PiecewisePolynomialTrajectory::Create(start_s, segments, nullptr);
}

double FlyHelix(bool sensor_noise, double* max_error_m) {
  ConfigNode sim_cfg = testing::FlightSimConfig();
  if (!sensor_noise) {  // no noise, no bias, no latency: the law and the motor lag alone
    for (const char* o :
         {"mocap.position_sigma_m=0", "mocap.orientation_sigma_rad=0", "mocap.latency_s=0",
          "imu.gyro_noise_sigma_radps=0", "imu.accel_noise_sigma_mps2=0",
          "imu.gyro_bias_sigma_radps=0", "imu.accel_bias_sigma_mps2=0",
          "imu.gyro_bias_walk_radps_sqrt_s=0", "imu.accel_bias_walk_mps2_sqrt_s=0"}) {
      sim_cfg.ApplyOverride(o);
    }
  }
  const SimConfig sim_config = LoadSimConfig(sim_cfg, KESTREL_SOURCE_DIR);
  ControllerConfig controller_config;
  controller_config.flight.vehicle = sim_config.vehicle;
  // The world's geofence (WorldGeofence), 0.5 m more headroom for the helix's top.
  const Geofence fence = WorldGeofence(sim_config.world);
  controller_config.flight.safety.geofence_min_m = fence.min_m;
  controller_config.flight.safety.geofence_max_m = fence.max_m + Eigen::Vector3d(0, 0, 0.5);
  lcm::LCM lcm("memq://");
  SimClock clock(1700000000000000);
  SimNode sim(lcm, sim_config, clock);
  ControllerNode controller(lcm, controller_config, clock);
  const int64_t period = SecondsToUtime(1.0 / controller_config.rate_hz);
  int64_t next_tick = clock.NowUtime();
  auto step = [&] {
    sim.Step();
    while (lcm.handleTimeout(0) > 0) {
    }
    while (clock.NowUtime() >= next_tick) {
      controller.Tick(next_tick);
      next_tick += period;
    }
    while (lcm.handleTimeout(0) > 0) {
    }
  };
  // Take off to 1.6 m above the start (as kestrel-cmd does), hover.
  command_t takeoff{};
  takeoff.utime = clock.NowUtime();
  takeoff.seq = 1;
  takeoff.source = "test";
  takeoff.command = command_t::COMMAND_TAKEOFF;
  takeoff.height_m = 1.6;  // the helix spans hover - 1.2 m .. hover
  for (int i = 0; i < 500; ++i) step();
  lcm.publish("COMMAND", &takeoff);
  for (int i = 0; i < 8000; ++i) step();
  const Eigen::Vector3d hover = sim.simulator().vehicle().state().p_W;
  // The helix starts 0.5 s ahead, at the hover point (z0 = hover z - 0.6 so z_d(0) = hover z).
  const double t_start = UtimeToSeconds(clock.NowUtime()) + 0.5;
  const Eigen::Vector3d base = hover - Eigen::Vector3d(0, 0, 0.6);
  const PiecewisePolynomialTrajectory helix = Helix(t_start, base, 10.0);
  const trajectory_t msg = ToMessage(helix, clock.NowUtime(), 1, 1);
  lcm.publish("TRAJECTORY", &msg);
  double sum2 = 0;
  int n = 0;
  *max_error_m = 0;
  while (UtimeToSeconds(clock.NowUtime()) < t_start + 10.0) {
    step();
    const double t = UtimeToSeconds(clock.NowUtime());
    if (t < t_start + 2.0) continue;
    const double e = (sim.simulator().vehicle().state().p_W - helix.Evaluate(t).position_m).norm();
    sum2 += e * e;
    *max_error_m = std::max(*max_error_m, e);
    ++n;
  }
  EXPECT_EQ(sim.simulator().vehicle().collision_count(), 0);
  EXPECT_GT(n, 1000);
  return std::sqrt(sum2 / n);
}

// Without sensor noise, bias or latency; motor lag 0.02 s, not compensated by the controller.
TEST(Helix, TracksInTheSimulatorWithoutMocapNoiseWithin2cm) {
  double max_e = 0;
  const double rms = FlyHelix(false, &max_e);
  std::printf("helix in the simulator, no sensor noise: RMS %.1f mm, max %.1f mm\n", rms * 1e3,
              max_e * 1e3);
  EXPECT_LT(rms, 0.02);
}

// With the simulator's motion-capture noise, latency and dropouts and IMU noise.
TEST(Helix, TracksInTheSimulatorWithSensorNoiseWithin5cm) {
  double max_e = 0;
  const double rms = FlyHelix(true, &max_e);
  std::printf("helix in the simulator, with sensor noise: RMS %.1f mm, max %.1f mm\n", rms * 1e3,
              max_e * 1e3);
  EXPECT_LT(rms, 0.05);
}

}  // namespace
}  // namespace kestrel
