// One mapper fusing two vehicles' scans into one exact map (docs/design.md §7.10): two vehicles
// in one simulation (kinematic, each turning on the spot at its own place in lasr), their sensors
// on V1_* and V2_*, each scan paired with its own vehicle's poses. The fused map holds what
// either vehicle alone sees, agrees with the world, and is the same bit for bit on a second run.
#include <cmath>
#include <cstdio>
#include <deque>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "common/config.h"
#include "mapping/mapper_config.h"
#include "mapping/mapper_node.h"
#include "sim/ground_truth.h"
#include "sim/sim_node.h"

namespace kestrel {
namespace {

const std::string kRoot = KESTREL_SOURCE_DIR;

// A turn on the spot at height h, from yaw 0 to 2 pi in `duration_s`.
PiecewisePolynomialTrajectory Turn(const Eigen::Vector3d& p, double t0_s, double duration_s) {
  const int coeffs = 2;
  const std::vector<double> x{p.x(), 0}, y{p.y(), 0}, z{p.z(), 0}, yaw{0, 2 * M_PI / duration_s};
  std::string error;
  auto t = PiecewisePolynomialTrajectory::CreateFromFlat(t0_s, {duration_s}, coeffs, x, y, z, yaw,
                                                         &error);
  EXPECT_TRUE(t.has_value()) << error;
  return *t;
}

struct Result {
  uint64_t hash{0};
  int64_t known{0};
  double accuracy{0};
  size_t channels{0};
  bool every_message{false};
};

// Two vehicles in lasr, kinematic, V2_ 4 m to the right of V1_.
SimConfig TwoVehicleSimConfig() {
  ConfigNode sim_cfg = ConfigNode::LoadFile(kRoot + "/config/sim/sim_ci.yaml");
  sim_cfg.ApplyOverride("world_file=" + kRoot + "/config/worlds/lasr.yaml");
  sim_cfg.ApplyOverride("mode=kinematic");
  sim_cfg.ApplyOverride("imu.enabled=false");
  sim_cfg.ApplyOverride(
      "vehicles=[{prefix: V1_, start_offset_m: [0, 0, 0]}, {prefix: V2_, start_offset_m: "
      "[0, -4, 0]}]");
  return LoadSimConfig(sim_cfg, kRoot);
}

// The shipped mapper over lasr's limits, fusing the vehicles of `prefixes` (order_wait_s < 0:
// the shipped one).
MapperConfig LasrMapperConfig(const std::vector<std::string>& prefixes, double order_wait_s = -1) {
  ConfigNode mapper_cfg = ConfigNode::LoadFile(kRoot + "/config/mapper.yaml");
  mapper_cfg.ApplyOverride("map.min_m=[0.5,-8.3,-0.15]");
  mapper_cfg.ApplyOverride("map.max_m=[10.3,3.5,1.5]");
  mapper_cfg.ApplyOverride("traversal_thread=false");
  std::string vehicles = "vehicles=[";
  for (const std::string& p : prefixes) vehicles += "{prefix: " + p + "},";
  vehicles.back() = ']';
  mapper_cfg.ApplyOverride(vehicles);
  if (order_wait_s >= 0) mapper_cfg.ApplyOverride("order_wait_s=" + std::to_string(order_wait_s));
  return LoadMapperConfig(mapper_cfg);
}

Result Fly(const std::vector<std::string>& mapped_prefixes) {
  lcm::LCM lcm("memq://");
  SimClock clock(1'000'000);
  const SimConfig sim_config = TwoVehicleSimConfig();
  SimNode sim(lcm, sim_config, clock);

  const MapperConfig mapper_config = LasrMapperConfig(mapped_prefixes);
  MapperNode mapper(lcm, mapper_config, clock);

  const double t0 = UtimeToSeconds(clock.NowUtime());
  for (size_t k = 0; k < 2; ++k) {
    Eigen::Vector3d p = sim_config.world.start_X_WB.p + sim_config.vehicles[k].start_offset_m;
    p.z() = sim_config.world.exploration_height_m;
    sim.mutable_simulator().SetTrajectory(Turn(p, t0, 6.0), k);
  }
  while (UtimeToSeconds(clock.NowUtime()) < t0 + 6.5) {
    sim.Step();
    while (lcm.handleTimeout(0) > 0) {
    }
    mapper.ProcessPending();
  }
  mapper.ApplyRemaining();

  Result r;
  r.hash = mapper.map_hash();
  r.channels = mapper.sequences().size();
  r.every_message = mapper.applied_every_message();
  // Known cells (docs/algorithms.md §12.2: P < P_init / 2 or P > 0.5) against the voxelized
  // world.
  const GridSpec grid = GridSpec::FromLimits(mapper_config.limits.min_m, mapper_config.limits.max_m,
                                             mapper_config.limits.resolution_m);
  const std::vector<uint8_t> truth = VoxelizeWorld(sim_config.world, grid);
  const GridGeometry& g = mapper.geometry();
  int64_t right = 0;
  for (size_t i = 0; i < grid.size(); ++i) {
    const Eigen::Vector3i c = grid.CellOf(i);
    const Eigen::Vector3d centre =
        grid.min_m + (c.cast<double>() + Eigen::Vector3d::Constant(0.5)) * grid.resolution_m;
    const Eigen::Vector3d q = (centre - g.origin_m()) / g.resolution_m();
    const CellIndex cell{static_cast<int32_t>(std::floor(q.x())),
                         static_cast<int32_t>(std::floor(q.y())),
                         static_cast<int32_t>(std::floor(q.z()))};
    const double p = mapper.ProbabilityAt(cell);
    if (p >= 0.5 * mapper_config.occupancy.p_init && p <= 0.5) continue;
    ++r.known;
    if ((p > 0.5) == (truth[i] != 0)) ++right;
  }
  r.accuracy = r.known > 0 ? static_cast<double>(right) / static_cast<double>(r.known) : 0.0;
  return r;
}

// One mapper per vehicle (docs/design.md §7.10): each fuses both vehicles' scans, one receiving
// them at once, the other receiving V2_'s messages `delay_s` late (a slower link). Returns both
// maps' hashes.
std::pair<uint64_t, uint64_t> TwoMappers(double delay_s, double order_wait_s) {
  lcm::LCM near("memq://");
  lcm::LCM far("memq://");
  SimClock clock(1'000'000);
  const SimConfig sim_config = TwoVehicleSimConfig();
  SimNode sim(near, sim_config, clock);
  const MapperConfig mapper_config = LasrMapperConfig({"V1_", "V2_"}, order_wait_s);
  MapperNode prompt(near, mapper_config, clock);
  MapperNode delayed(far, mapper_config, clock);
  // The relay to the far side: V2_'s messages held for delay_s, the rest passed on at once.
  struct Held {
    int64_t release_utime;
    std::string channel;
    std::vector<uint8_t> bytes;
  };
  struct Relay {
    lcm::LCM* far;
    const SimClock* clock;
    int64_t delay_us;
    std::deque<Held> held;
    void Handle(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
      const auto* data = static_cast<const uint8_t*>(rbuf->data);
      if (channel.rfind("V2_", 0) == 0) {
        held.push_back({clock->NowUtime() + delay_us, channel,
                        std::vector<uint8_t>(data, data + rbuf->data_size)});
      } else {
        far->publish(channel, rbuf->data, rbuf->data_size);
      }
    }
    void Release(bool all) {
      while (!held.empty() && (all || held.front().release_utime <= clock->NowUtime())) {
        far->publish(held.front().channel, held.front().bytes.data(),
                     static_cast<unsigned>(held.front().bytes.size()));
        held.pop_front();
      }
    }
  } relay{&far, &clock, SecondsToUtime(delay_s), {}};
  near.subscribe(".*", &Relay::Handle, &relay);
  auto drain = [&] {
    while (near.handleTimeout(0) > 0) {
    }
    while (far.handleTimeout(0) > 0) {
    }
  };
  const double t0 = UtimeToSeconds(clock.NowUtime());
  for (size_t k = 0; k < 2; ++k) {
    Eigen::Vector3d p = sim_config.world.start_X_WB.p + sim_config.vehicles[k].start_offset_m;
    p.z() = sim_config.world.exploration_height_m;
    sim.mutable_simulator().SetTrajectory(Turn(p, t0, 6.0), k);
  }
  while (UtimeToSeconds(clock.NowUtime()) < t0 + 6.5) {
    sim.Step();
    drain();
    relay.Release(false);
    drain();
    prompt.ProcessPending();
    delayed.ProcessPending();
  }
  relay.Release(true);
  // The last scans, once every stream has passed them (the order wait, in message time).
  while (UtimeToSeconds(clock.NowUtime()) < t0 + 7.5) {
    sim.Step();
    drain();
    relay.Release(true);
    drain();
    prompt.ProcessPending();
    delayed.ProcessPending();
  }
  EXPECT_GT(prompt.scans_applied(), 300);
  EXPECT_EQ(prompt.scans_applied(), delayed.scans_applied());
  return {prompt.map_hash(), delayed.map_hash()};
}

TEST(TwoVehicleMapping, OneMapperPerVehicleHoldsTheSameMapWhateverTheDelays) {
  const auto [prompt, delayed] = TwoMappers(0.2, 0.3);
  EXPECT_EQ(prompt, delayed) << "V2_'s scans 0.2 s late must not change the order";
  // Without the order wait, arrival order decides, and the maps differ (exact updates do not
  // commute): the test can tell.
  const auto [prompt0, delayed0] = TwoMappers(0.2, 0.0);
  EXPECT_NE(prompt0, delayed0);
}

TEST(TwoVehicleMapping, OneMapperFusesBothVehiclesExactly) {
  const Result first = Fly({"V1_"});
  const Result second = Fly({"V2_"});
  const Result both = Fly({"V1_", "V2_"});
  std::printf("known cells: V1 alone %lld, V2 alone %lld, fused %lld; accuracy %.4f %.4f %.4f\n",
              static_cast<long long>(first.known), static_cast<long long>(second.known),
              static_cast<long long>(both.known), first.accuracy, second.accuracy, both.accuracy);
  EXPECT_EQ(first.channels, 2U);
  EXPECT_EQ(both.channels, 4U) << "depth and scans of both vehicles";
  EXPECT_TRUE(both.every_message) << "every scan paired and applied";
  EXPECT_GT(both.known, first.known + second.known / 2) << "the second vehicle's view is added";
  EXPECT_GT(both.known, second.known + first.known / 2);
  // Each scan is paired with its own vehicle's poses: the fused map is as right as either alone
  // (scans placed 4 m off would put walls where there are none).
  EXPECT_GT(both.accuracy, 0.97);
  EXPECT_GT(both.accuracy, std::min(first.accuracy, second.accuracy) - 0.01);
  EXPECT_EQ(Fly({"V1_", "V2_"}).hash, both.hash) << "deterministic";
}

}  // namespace
}  // namespace kestrel
