// Simulator benchmarks. Run from anywhere (paths are compiled in):
//   build-sim/bench/sim/sim_bench
// BM_FastRays / BM_BulletRays: the rays of one VGA depth frame (640 x 480, 58 x 45 deg) from the
// start of paper_sim at the exploration height, heading +y; Bullet gets every 16th ray (it is
// slow) and the rate is per ray. BM_DepthFrameVga: a full measured frame (noise, quantisation).
// BM_RealTimeFactor: SimNode over memq:// with a hover-and-yaw motor command loop; counter
// real_time_factor = simulated s / wall s.
#include <chrono>
#include <cmath>
#include <random>

#include <benchmark/benchmark.h>
#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "kestrel/motor_command_t.hpp"
#include "sim/bullet_world.h"
#include "sim/ground_truth.h"
#include "sim/sensors.h"
#include "sim/sim_node.h"
#include "sim/world_ray_caster.h"

namespace kestrel {
namespace {

const std::string kRoot = KESTREL_SOURCE_DIR;

const World& PaperSim() {
  static const World world = LoadWorld(kRoot + "/config/worlds/paper_sim.yaml");
  return world;
}

// Camera pose: start position at the exploration height, looking along +y (the start yaw).
Pose3 CameraPose(const World& w) {
  const VehicleConfig vehicle;
  Pose3 X_WB = w.start_X_WB;
  X_WB.p.z() = w.exploration_height_m;
  return X_WB * vehicle.X_BS_xtion;
}

std::vector<Eigen::Vector3d> VgaRays(const Pose3& X_WS) {
  DepthCameraConfig c = DepthCameraConfig::WithResolution(640, 480);
  const DepthCamera camera(c);
  std::vector<Eigen::Vector3d> dirs;
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      const Eigen::Vector3d d((u - camera.cx_px()) / camera.fx_px(),
                              (v - camera.cy_px()) / camera.fy_px(), 1.0);
      dirs.push_back(X_WS.q * d.normalized());
    }
  }
  return dirs;
}

void BM_FastRays(benchmark::State& state) {
  const World& w = PaperSim();
  const WorldRayCaster caster(
      w, 0.5,
      state.range(1) == 0 ? WorldRayCaster::Accelerator::kBvh : WorldRayCaster::Accelerator::kGrid);
  state.SetLabel(state.range(1) == 0 ? "bvh" : "grid 0.5 m");
  const Pose3 X_WS = CameraPose(w);
  const std::vector<Eigen::Vector3d> dirs = VgaRays(X_WS);
  std::vector<double> out;
  const int threads = static_cast<int>(state.range(0));
  for (auto _ : state) {
    caster.CastRays(X_WS.p, dirs, 4.0 / std::cos(0.5), &out, threads);
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["rays_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()) * static_cast<double>(dirs.size()),
                         benchmark::Counter::kIsRate);
  size_t hits = 0;
  for (double t : out) hits += std::isfinite(t) ? 1 : 0;
  state.counters["hit_fraction"] = static_cast<double>(hits) / static_cast<double>(out.size());
}
BENCHMARK(BM_FastRays)
    ->Args({1, 0})
    ->Args({2, 0})
    ->Args({1, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// Cost against object count: N random boxes (half rotated) over a 20 m x 20 m floor, rays from
// the centre at random headings and elevations. The BVH keeps the cost far from linear in N.
void BM_FastRaysVsObjectCount(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  std::mt19937_64 g(1);
  auto uniform = [&](double lo, double hi) {
    return lo + (hi - lo) * static_cast<double>(g() >> 11) * 0x1.0p-53;
  };
  World w;
  w.map_min_m = Eigen::Vector3d(-10, -10, -1);
  w.map_max_m = Eigen::Vector3d(10, 10, 3);
  w.planes.push_back(WorldPlane{"floor", Eigen::Vector3d::UnitZ(), 0.0});
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d c(uniform(-10, 10), uniform(-10, 10), uniform(0, 2));
    if (c.head<2>().norm() < 1.0) continue;
    w.boxes.push_back(WorldBox{
        "b", c, Eigen::Vector3d(uniform(0.05, 0.3), uniform(0.05, 0.3), uniform(0.05, 0.5)),
        QuaternionFromYaw(i % 2 == 0 ? 0.0 : uniform(-3, 3))});
  }
  const WorldRayCaster caster(w);
  std::vector<Eigen::Vector3d> dirs(100000);
  for (auto& d : dirs) {
    const double az = uniform(-M_PI, M_PI), el = uniform(-0.4, 0.4);
    d = Eigen::Vector3d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
  }
  std::vector<double> out;
  for (auto _ : state) {
    caster.CastRays(Eigen::Vector3d(0, 0, 1), dirs, 30.0, &out, 1);
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["rays_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()) * static_cast<double>(dirs.size()),
                         benchmark::Counter::kIsRate);
}
BENCHMARK(BM_FastRaysVsObjectCount)
    ->Arg(10)
    ->Arg(100)
    ->Arg(1000)
    ->Arg(10000)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_BulletRays(benchmark::State& state) {
  const World& w = PaperSim();
  const BulletWorld bullet(w, 0.44, 0.15,
                           state.range(0) == 0 ? BulletWorld::BoxShape::kTriangleMesh
                                               : BulletWorld::BoxShape::kConvexBox);
  const Pose3 X_WS = CameraPose(w);
  const std::vector<Eigen::Vector3d> all = VgaRays(X_WS);
  std::vector<Eigen::Vector3d> dirs;
  for (size_t i = 0; i < all.size(); i += 16) dirs.push_back(all[i]);
  double sum = 0.0;
  for (auto _ : state) {
    for (const Eigen::Vector3d& u : dirs) sum += bullet.RayTest(X_WS.p, u, 4.0 / std::cos(0.5));
    benchmark::DoNotOptimize(sum);
  }
  state.counters["rays_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()) * static_cast<double>(dirs.size()),
                         benchmark::Counter::kIsRate);
  state.SetLabel(state.range(0) == 0 ? "boxes as triangle meshes" : "boxes as btBoxShape");
}
BENCHMARK(BM_BulletRays)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_DepthFrameVga(benchmark::State& state) {
  const World& w = PaperSim();
  const WorldRayCaster caster(w);
  DepthCameraConfig c = DepthCameraConfig::WithResolution(640, 480);
  c.num_threads = static_cast<int>(state.range(0));
  const DepthCamera camera(c);
  const Pose3 X_WS = CameraPose(w);
  SimRandom rng(1);
  std::vector<uint16_t> counts;
  for (auto _ : state) {
    camera.Render(caster, X_WS, &rng, &counts);
    benchmark::DoNotOptimize(counts.data());
  }
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["rays_per_s"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * 640.0 * 480.0, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_DepthFrameVga)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

// Ground truth of the shipped worlds on the paper's 0.075 m grid: voxelisation and the
// observable set (default sweep: 0.5 m lattice, 1 deg azimuth, 1.5 deg elevation over +-22.5 deg,
// 4 m range, 2 threads). Arg: 0 paper_sim, 1 lasr, 2 office.
void BM_GroundTruth(benchmark::State& state) {
  const char* names[] = {"paper_sim", "lasr", "office"};
  const World w = LoadWorld(kRoot + "/config/worlds/" + names[state.range(0)] + ".yaml");
  const WorldRayCaster caster(w);
  const GridSpec grid = GridSpec::FromLimits(w.map_min_m, w.map_max_m, 0.075);
  size_t occupied = 0, observable = 0, poses = 0;
  for (auto _ : state) {
    const std::vector<uint8_t> occ = VoxelizeWorld(w, grid);
    const ObservableCells obs = ComputeObservableCells(w, caster, grid, ObservabilityConfig{});
    occupied = observable = 0;
    for (size_t i = 0; i < grid.size(); ++i) {
      occupied += occ[i];
      observable += obs.observable[i];
    }
    poses = obs.sensor_origins.size();
  }
  state.counters["cells"] = static_cast<double>(grid.size());
  state.counters["occupied"] = static_cast<double>(occupied);
  state.counters["observable"] = static_cast<double>(observable);
  state.counters["poses"] = static_cast<double>(poses);
  state.SetLabel(names[state.range(0)]);
}
BENCHMARK(BM_GroundTruth)
    ->DenseRange(0, 2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1);

// Whole simulation: 10 s simulated in paper_sim, the vehicle taking off to 1 m and yawing at
// 0.5 rad/s under a simple altitude loop published on MOTOR_COMMAND every 5 ms; all sensors on.
// Arg 0: depth 80x60 at 15 Hz (CI profile); arg 1: VGA at 30 Hz.
void BM_RealTimeFactor(benchmark::State& state) {
  SimConfig config;
  config.world = PaperSim();
  config.vehicle = VehicleConfig{};
  if (state.range(0) == 0) {
    config.depth = DepthCameraConfig::WithResolution(80, 60);
    config.depth.rate_hz = 15.0;
  } else {
    config.depth = DepthCameraConfig::WithResolution(640, 480);
    config.depth.rate_hz = 30.0;
  }
  config.depth.num_threads = 2;
  const RotorGeometry geometry = ComputeRotorGeometry(config.vehicle);
  double simulated_s = 0.0, wall_s = 0.0;
  int collisions = 0;
  for (auto _ : state) {
    lcm::LCM lcm("memq://");
    SimClock clock(1'000'000'000);
    SimNode node(lcm, config, clock);
    const auto start = std::chrono::steady_clock::now();
    const int64_t t0 = clock.NowUtime();
    for (int k = 0; k < 10000; ++k) {
      if (k % 5 == 0) {
        const QuadrotorState& s = node.simulator().vehicle().state();
        const double m = config.vehicle.mass_kg;
        const double f = m * (kGravity_mps2 + 4.0 * (1.0 - s.p_W.z()) - 3.0 * s.v_W.z());
        const double yaw_moment = 0.05 * (0.5 - s.w_B.z());
        const Eigen::Vector4d thrust =
            geometry.mixer_inverse * Eigen::Vector4d(std::max(0.0, f), 0, 0, yaw_moment);
        motor_command_t cmd;
        cmd.utime = clock.NowUtime();
        cmd.seq = k;
        cmd.epoch = 1;  // one publisher, never restarted
        cmd.armed = true;
        cmd.num_motors = 4;
        cmd.thrust_N.assign(thrust.data(), thrust.data() + 4);
        cmd.total_thrust_N = f;
        cmd.moment_Nm[0] = cmd.moment_Nm[1] = 0.0;
        cmd.moment_Nm[2] = yaw_moment;
        lcm.publish(config.motor_channel, &cmd);
        while (lcm.handleTimeout(0) > 0) {
        }
      }
      node.Step();
    }
    wall_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    simulated_s += UtimeToSeconds(clock.NowUtime() - t0);
    collisions = node.simulator().vehicle().collision_count();
    state.counters["final_z_m"] = node.simulator().vehicle().state().p_W.z();
  }
  state.counters["real_time_factor"] = simulated_s / wall_s;
  state.counters["collisions"] = collisions;
  state.SetLabel(state.range(0) == 0 ? "depth 80x60 @ 15 Hz" : "depth VGA @ 30 Hz");
}
BENCHMARK(BM_RealTimeFactor)
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1);

}  // namespace
}  // namespace kestrel

BENCHMARK_MAIN();
