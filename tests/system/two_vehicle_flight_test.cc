// Two vehicles in one simulation, each flown by its own controller node on its own channels
// (V1_*, V2_*), lockstep over memq:// LCM with the simulator's sensor noise and latency
// (docs/design.md §7.10): both take off and hold at their own places, one lands while the other
// keeps holding, and they never touch.
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/config.h"
#include "control/controller_node.h"
#include "kestrel/command_t.hpp"
#include "sim/sim_node.h"
#include "tests/system/flight_sim_config.h"

namespace kestrel {
namespace {

constexpr int kVehicles = 2;

class TwoVehicles {
 public:
  TwoVehicles() {
    ConfigNode sim_cfg = testing::FlightSimConfig();
    sim_cfg.ApplyOverride(
        "vehicles=[{prefix: V1_, start_offset_m: [0, 0, 0]}, {prefix: V2_, start_offset_m: "
        "[1.5, 0, 0]}]");
    sim_config_ = LoadSimConfig(sim_cfg, KESTREL_SOURCE_DIR);
    sim_ = std::make_unique<SimNode>(lcm_, sim_config_, clock_);
    for (int k = 0; k < kVehicles; ++k) {
      const std::string p = sim_config_.vehicles[static_cast<size_t>(k)].prefix;
      ControllerConfig c;
      c.flight.vehicle = sim_config_.vehicle;
      const Geofence fence = WorldGeofence(sim_config_.world);
      c.flight.safety.geofence_min_m = fence.min_m;
      c.flight.safety.geofence_max_m = fence.max_m;
      c.pose_channel = p + c.pose_channel;
      c.imu_channel = p + c.imu_channel;
      c.trajectory_channel = p + c.trajectory_channel;
      c.command_channel = p + c.command_channel;
      c.motor_channel = p + c.motor_channel;
      c.status_channel = p + c.status_channel;
      c.heartbeat_channel = p + c.heartbeat_channel;
      controllers_.push_back(std::make_unique<ControllerNode>(lcm_, c, clock_));
      period_us_ = SecondsToUtime(1.0 / c.rate_hz);
      prefixes_.push_back(p);
    }
    next_tick_us_ = clock_.NowUtime();
  }

  void Step() {
    sim_->Step();
    Drain();
    while (clock_.NowUtime() >= next_tick_us_) {
      for (auto& c : controllers_) c->Tick(next_tick_us_);
      next_tick_us_ += period_us_;
    }
    Drain();
    for (int k = 0; k < kVehicles; ++k) {
      const Eigen::Vector3d p = truth(k).p_W;
      for (int j = 0; j < k; ++j) {
        min_separation_m_ = std::min(min_separation_m_, (p - truth(j).p_W).norm());
      }
    }
  }
  void StepFor(double s) {
    const int64_t end = clock_.NowUtime() + SecondsToUtime(s);
    while (clock_.NowUtime() < end) Step();
  }
  void Command(int k, int8_t command, double height_m) {
    command_t msg{};
    msg.utime = clock_.NowUtime();
    msg.seq = ++command_seq_;
    msg.epoch = 77;
    msg.source = "two_vehicle_flight_test";
    msg.command = command;
    msg.height_m = height_m;
    lcm_.publish(prefixes_[static_cast<size_t>(k)] + "COMMAND", &msg);
  }
  [[nodiscard]] FlightMode mode(int k) const {
    return controllers_[static_cast<size_t>(k)]->flight().supervisor().mode();
  }
  [[nodiscard]] const QuadrotorState& truth(int k) const {
    return sim_->simulator().vehicle(static_cast<size_t>(k)).state();
  }
  [[nodiscard]] const Simulator& sim() const { return sim_->simulator(); }
  [[nodiscard]] double min_separation_m() const { return min_separation_m_; }

 private:
  void Drain() {
    while (lcm_.handleTimeout(0) > 0) {
    }
  }

  lcm::LCM lcm_{"memq://"};
  SimClock clock_{1'000'000};
  SimConfig sim_config_;
  std::unique_ptr<SimNode> sim_;
  std::vector<std::unique_ptr<ControllerNode>> controllers_;
  std::vector<std::string> prefixes_;
  int64_t period_us_{0};
  int64_t next_tick_us_{0};
  int64_t command_seq_{0};
  double min_separation_m_{1e9};
};

TEST(TwoVehicles, EachFliesOnItsOwnControllerAndChannels) {
  TwoVehicles f;
  const Eigen::Vector3d start0 = f.truth(0).p_W;
  const Eigen::Vector3d start1 = f.truth(1).p_W;
  EXPECT_NEAR((start1 - start0).x(), 1.5, 1e-9);
  f.StepFor(0.5);
  f.Command(0, command_t::COMMAND_TAKEOFF, 1.0);
  f.Command(1, command_t::COMMAND_TAKEOFF, 0.6);
  f.StepFor(8.0);
  ASSERT_EQ(f.mode(0), FlightMode::kHold);
  ASSERT_EQ(f.mode(1), FlightMode::kHold);
  for (int k = 0; k < 2; ++k) {
    const Eigen::Vector3d start = k == 0 ? start0 : start1;
    const double height = k == 0 ? 1.0 : 0.6;
    const Eigen::Vector3d p = f.truth(k).p_W;
    std::printf(
        "vehicle %d holds at (%.3f, %.3f, %.3f), %.3f m from its start column, height "
        "%.3f m\n",
        k + 1, p.x(), p.y(), p.z(), (p - start).head<2>().norm(), p.z() - start.z());
    EXPECT_LT((p - start).head<2>().norm(), 0.1) << "vehicle " << k + 1 << " holds its column";
    EXPECT_NEAR(p.z() - start.z(), height, 0.1) << "vehicle " << k + 1 << " at its own height";
  }
  // The second lands; the first keeps holding.
  f.Command(1, command_t::COMMAND_LAND, 0.0);
  f.StepFor(8.0);
  EXPECT_LT(f.truth(1).p_W.z() - start1.z(), 0.05) << "vehicle 2 landed";
  EXPECT_EQ(f.mode(0), FlightMode::kHold);
  EXPECT_NEAR(f.truth(0).p_W.z() - start0.z(), 1.0, 0.1) << "vehicle 1 still holds";
  EXPECT_EQ(f.sim().inter_vehicle_collision_count(), 0);
  EXPECT_EQ(f.sim().vehicle(0).collision_count(), 0);
  EXPECT_EQ(f.sim().vehicle(1).collision_count(), 0);
  std::printf("minimum separation %.3f m\n", f.min_separation_m());
  EXPECT_GT(f.min_separation_m(), 1.3);
}

}  // namespace
}  // namespace kestrel
