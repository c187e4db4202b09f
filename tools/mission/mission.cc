#include "tools/mission/mission.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <memory>
#include <optional>
#include <random>
#include <sstream>

#include <unistd.h>

#include <lcm/lcm-cpp.hpp>

#include "common/check.h"
#include "common/clock.h"
#include "common/config.h"
#include "common/config_publisher.h"
#include "common/identity.h"
#include "common/log.h"
#include "control/controller_node.h"
#include "exploration/explorer_node.h"
#include "exploration/explorer_state.h"
#include "kestrel/command_t.hpp"
#include "kestrel/exploration_status_t.hpp"
#include "kestrel/grid_map_t.hpp"
#include "mapping/mapper_node.h"
#include "sim/ground_truth.h"
#include "sim/sim_node.h"
#include "tools/map_score/map_scorer.h"

namespace kestrel {

namespace {

ConfigNode Load(const std::string& root, const std::string& file,
                const std::vector<std::string>& overrides) {
  ConfigNode node = ConfigNode::LoadFile(PathUnderRoot(root, file));
  for (const auto& o : overrides) node.ApplyOverride(o);
  return node;
}

std::string Fixed3(double v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.3f", v);
  return text;
}

// The upper median (the element at size / 2 once sorted) of v, 0 if v is empty.
double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto middle = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), middle, v.end());
  return *middle;
}

// Whether a vehicle disc of radius_m at xy is clear of obstacles between z_low_m and z_high_m
// (points every 5 cm in the disc, every 10 cm in height).
bool DiscClear(const World& world, const Eigen::Vector2d& xy, double radius_m, double z_low_m,
               double z_high_m) {
  const int n = static_cast<int>(std::ceil(radius_m / 0.05));
  for (double z = z_low_m; z <= z_high_m + 1e-9; z += 0.1) {
    for (int i = -n; i <= n; ++i) {
      for (int j = -n; j <= n; ++j) {
        const Eigen::Vector2d d(0.05 * i, 0.05 * j);
        if (d.norm() > radius_m) continue;
        if (IsInsideObstacle(world, Eigen::Vector3d(xy.x() + d.x(), xy.y() + d.y(), z)))
          return false;
      }
    }
  }
  return true;
}

}  // namespace

std::vector<Eigen::Vector3d> VehicleStartOffsets(const World& world, int vehicles, double spacing_m,
                                                 double diameter_m, double height_m) {
  KESTREL_THROW_UNLESS(vehicles >= 1 && vehicles <= 4,
                       "vehicles = " << vehicles << ": accepted 1 to 4");
  KESTREL_THROW_UNLESS(spacing_m > diameter_m,
                       "vehicle spacing " << spacing_m << " m must exceed the vehicle diameter "
                                          << diameter_m << " m");
  std::vector<Eigen::Vector3d> offsets{Eigen::Vector3d::Zero()};
  const Eigen::Vector2d start = world.start_X_WB.p.head<2>();
  const double radius = 0.5 * diameter_m + 0.2;
  const double z_low = world.start_X_WB.p.z() + 0.05;
  const double z_high = height_m + 0.3;
  const Eigen::Vector2d directions[] = {{0, 1}, {0, -1}, {1, 0},  {-1, 0},
                                        {1, 1}, {-1, 1}, {1, -1}, {-1, -1}};
  for (int scale = 1; scale <= 2 && static_cast<int>(offsets.size()) < vehicles; ++scale) {
    for (const Eigen::Vector2d& d : directions) {
      if (static_cast<int>(offsets.size()) == vehicles) break;
      const Eigen::Vector2d offset = scale * spacing_m * d;
      const Eigen::Vector2d xy = start + offset;
      bool ok = (xy.array() - radius > world.map_min_m.head<2>().array()).all() &&
                (xy.array() + radius < world.map_max_m.head<2>().array()).all();
      for (const Eigen::Vector3d& o : offsets) {
        ok = ok && (o.head<2>() - offset).norm() >= spacing_m - 1e-9;
      }
      if (ok && DiscClear(world, xy, radius, z_low, z_high)) {
        offsets.emplace_back(offset.x(), offset.y(), 0.0);
      }
    }
  }
  KESTREL_THROW_UNLESS(static_cast<int>(offsets.size()) == vehicles,
                       "no clear start for vehicle " << offsets.size() + 1 << " within "
                                                     << 2 * spacing_m << " m of the start in "
                                                     << world.name);
  return offsets;
}

MissionResult RunMission(const MissionConfig& mc) {
  const auto wall_start = std::chrono::steady_clock::now();
  // The nodes' publisher epochs from the seed, so that the same seed gives the same messages
  // (docs/design.md §7.5); the nodes are built in a fixed order below.
  SeedPublisherEpochs(static_cast<uint64_t>(mc.seed));
  const int64_t mission_epoch = NewPublisherEpoch();  // the take-off command's
  // --- Configuration: one world, its limits everywhere.
  std::vector<std::string> sim_overrides = mc.sim_overrides;
  const bool faults = mc.sensor_drop_fraction > 0 || mc.mocap_outage_s > 0;
  if (faults) {  // the simulator publishes on SIM_*; a relay drops what the fault asks
    sim_overrides.push_back("channels.depth=SIM_DEPTH_XTION");
    sim_overrides.push_back("channels.scan=SIM_SCAN_HOKUYO");
    sim_overrides.push_back("channels.pose=SIM_POSE_VICON");
  }
  sim_overrides.push_back("world_file=" + PathUnderRoot(mc.root, mc.world_file));
  sim_overrides.push_back("seed=" + std::to_string(mc.seed));
  ConfigNode sim_node_cfg = Load(mc.root, mc.sim_file, sim_overrides);
  SimConfig sim_config = LoadSimConfig(sim_node_cfg, mc.root);
  KESTREL_THROW_UNLESS(mc.vehicles == 1 || !faults,
                       "the fault injection applies to one vehicle only (--vehicles 1)");
  std::vector<std::string> prefixes{""};
  std::vector<Eigen::Vector3d> offsets{Eigen::Vector3d::Zero()};
  if (mc.vehicles != 1) {
    // Several vehicles: V1_, V2_, ... at clear places around the world's start.
    offsets =
        VehicleStartOffsets(sim_config.world, mc.vehicles, mc.vehicle_spacing_m,
                            sim_config.vehicle.diameter_m, sim_config.world.exploration_height_m);
    prefixes.clear();
    std::ostringstream list;
    list << "vehicles=[";
    for (int k = 0; k < mc.vehicles; ++k) {
      prefixes.push_back("V" + std::to_string(k + 1) + "_");
      const Eigen::Vector3d& o = offsets[static_cast<size_t>(k)];
      list << (k > 0 ? ", " : "") << "{prefix: " << prefixes.back() << ", start_offset_m: ["
           << o.x() << ", " << o.y() << ", " << o.z() << "]}";
    }
    list << "]";
    sim_node_cfg.ApplyOverride(list.str());
    sim_config = LoadSimConfig(sim_node_cfg, mc.root);
  }
  sim_node_cfg.CheckNoUnknownKeys();
  const size_t num_vehicles = prefixes.size();
  const World& world = sim_config.world;

  ConfigNode mapper_cfg = Load(mc.root, mc.mapper_file, mc.mapper_overrides);
  MapperConfig mapper_config = LoadMapperConfig(mapper_cfg);
  mapper_cfg.CheckNoUnknownKeys();
  mapper_config.limits.min_m = world.map_min_m;
  mapper_config.limits.max_m = world.map_max_m;
  mapper_config.checkpoint_path.clear();
  mapper_config.vehicle_prefixes = prefixes;
  // memq:// has no receive buffer to protect (docs/design.md §7.6): snapshots go out whole at
  // their instant, as before pacing, unless snapshot_bytes_per_s is set on the command line.
  if (std::none_of(mc.mapper_overrides.begin(), mc.mapper_overrides.end(),
                   [](const std::string& o) { return o.rfind("snapshot_bytes_per_s=", 0) == 0; })) {
    mapper_config.snapshot_bytes_per_s = 0;
  }
  mapper_config.sensors[0].X_BS = sim_config.vehicle.X_BS_xtion;
  if (mapper_config.sensors.size() > 1)
    mapper_config.sensors[1].X_BS = sim_config.vehicle.X_BS_hokuyo;

  ConfigNode explorer_cfg = Load(mc.root, mc.explorer_file, mc.explorer_overrides);
  ExplorerNodeConfig explorer_config = LoadExplorerNodeConfig(explorer_cfg);
  explorer_cfg.CheckNoUnknownKeys();
  explorer_config.explorer.map = mapper_config.limits;
  explorer_config.explorer.p_init = mapper_config.occupancy.p_init;
  explorer_config.explorer.planner.projection.height_m = world.exploration_height_m;
  explorer_config.explorer.planner.projection.p_init = mapper_config.occupancy.p_init;
  // The vehicle that flies is the simulator's: its diameter sets k_C and the disc checked.
  explorer_config.explorer.planner.projection.vehicle_diameter_m = sim_config.vehicle.diameter_m;
  explorer_config.explorer.planner.trajectory.vehicle_radius_m =
      0.5 * sim_config.vehicle.diameter_m;

  ControllerConfig controller_config;
  ConfigNode controller_cfg = ConfigNode::FromString("{}", "(defaults)");
  if (!mc.controller_file.empty()) {
    controller_cfg = ConfigNode::LoadFile(PathUnderRoot(mc.root, mc.controller_file));
    controller_config = LoadControllerConfig(controller_cfg, sim_config.vehicle);
  }
  controller_config.flight.vehicle = sim_config.vehicle;
  const Geofence fence = WorldGeofence(world);  // as the sheets' (scripts/world-env)
  controller_config.flight.safety.geofence_min_m = fence.min_m;
  controller_config.flight.safety.geofence_max_m = fence.max_m;

  int64_t r_sensor_dropped_ = 0;
  int64_t r_poses_dropped_ = 0;
  // --- The nodes, in one process: a controller and an explorer per vehicle, one mapper.
  lcm::LCM lcm("memq://");
  KESTREL_THROW_UNLESS(lcm.good(), "memq:// LCM unavailable");
  SimClock clock(1700000000000000);  // a fixed, plausible epoch: stamps are the same every run
  SimNode sim(lcm, sim_config, clock);
  // Process kills: the state files (docs/design.md §2.5) in a folder of the run, one run id.
  const bool kills = mc.controller_kill_at_s >= 0 || mc.explorer_kill_at_s >= 0;
  KESTREL_THROW_UNLESS(!kills || mc.vehicles == 1, "process kills apply to one vehicle only");
  std::string state_dir = mc.state_dir;
  bool remove_state_dir = false;
  if (kills && state_dir.empty()) {
    char dir[] = "/tmp/kestrel-mission-XXXXXX";
    KESTREL_THROW_UNLESS(mkdtemp(dir) != nullptr, "cannot make a state folder under /tmp");
    state_dir = dir;
    remove_state_dir = true;
  }
  if (kills) {
    controller_config.state_path = state_dir + "/controller.state";
    controller_config.run_id = "mission-" + std::to_string(mc.seed);
    explorer_config.state_path = state_dir + "/explorer.state";
    explorer_config.run_id = controller_config.run_id;
  }
  std::vector<ControllerConfig> controller_configs;
  std::vector<ExplorerNodeConfig> explorer_configs;
  std::vector<std::unique_ptr<ControllerNode>> controllers;
  for (const std::string& p : prefixes) {
    ControllerConfig c = controller_config;
    for (std::string* channel :
         {&c.pose_channel, &c.imu_channel, &c.trajectory_channel, &c.command_channel,
          &c.motor_channel, &c.status_channel, &c.heartbeat_channel}) {
      *channel = p + *channel;
    }
    controller_configs.push_back(c);
    controllers.push_back(std::make_unique<ControllerNode>(lcm, c, clock));
  }
  MapperNode mapper(lcm, mapper_config, clock);
  std::vector<std::unique_ptr<ExplorerNode>> explorers;
  for (const std::string& p : prefixes) {
    ExplorerNodeConfig e = explorer_config;
    e.vehicle_prefix = p;
    for (const std::string& q : prefixes) {
      if (q != p) e.explorer.peers.push_back(q);
    }
    explorer_configs.push_back(e);
    explorers.push_back(std::make_unique<ExplorerNode>(lcm, e, clock));
  }
  // The first vehicle's nodes (replaced when killed and respawned: no references kept).
  const auto explorer = [&]() -> ExplorerNode& { return *explorers.front(); };

  // Every message in publication order, as lcm-logger would record it (stamped with the
  // simulated time), so the run can be replayed into fresh processes.
  std::unique_ptr<lcm::LogFile> log;
  struct LogWriter {
    lcm::LogFile* file;
    const SimClock* clock;
    int64_t events{0};
    void Handle(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
      lcm::LogEvent ev;
      ev.eventnum = events++;
      ev.timestamp = clock->NowUtime();
      ev.channel = channel;
      ev.datalen = static_cast<int32_t>(rbuf->data_size);
      ev.data = rbuf->data;
      file->writeEvent(&ev);
    }
  } writer{nullptr, &clock};
  if (!mc.log_path.empty()) {
    log = std::make_unique<lcm::LogFile>(mc.log_path, "w");
    KESTREL_THROW_UNLESS(log->good(), "cannot write the log " << mc.log_path);
    writer.file = log.get();
    lcm.subscribe(".*", &LogWriter::Handle, &writer);
    // What each node runs with, first in the log (docs/design.md §6). The values the mission
    // sets from the world and the vehicle after loading (map limits, height, diameter) are not
    // among them; the world and the vehicle files are, with the simulator's.
    struct NodeConfig {
      const char* name;
      const ConfigNode* node;
      std::string file;
    };
    const NodeConfig configs[] = {
        {"SIM", &sim_node_cfg, PathUnderRoot(mc.root, mc.sim_file)},
        {"CONTROLLER", &controller_cfg, PathUnderRoot(mc.root, mc.controller_file)},
        {"MAPPER", &mapper_cfg, PathUnderRoot(mc.root, mc.mapper_file)},
        {"EXPLORER", &explorer_cfg, PathUnderRoot(mc.root, mc.explorer_file)}};
    for (const auto& [name, node, file] : configs) {
      ProcessArgs args;
      args.config_path = file;
      args.command_line = mc.command_line;
      params_t params = MakeParamsMessage("kestrel-mission", args, *node);
      params.utime = clock.NowUtime();
      params.epoch = mission_epoch;
      lcm.publish(std::string("PARAMS_") + name, &params);
    }
  }
  MissionResult r;
  const int64_t t0_utime = clock.NowUtime();
  GuardedSubscriptions watch(lcm);
  bool first_plan_seen = false;
  watch.Add<exploration_status_t>(
      prefixes.front() + explorer_config.status_channel,
      [&](const std::string&, const exploration_status_t& m) {
        if (m.state == exploration_status_t::STATE_DONE) r.done_status_published = true;
        if (first_plan_seen || m.state == exploration_status_t::STATE_STARTUP ||
            m.state == exploration_status_t::STATE_WAITING) {
          return;
        }
        first_plan_seen = true;
        r.first_plan_chose_goal = m.chosen_index >= 0;
        r.first_plan_time_s = UtimeToSeconds(clock.NowUtime() - t0_utime);
      },
      nullptr);
  if (mc.verbose) {
    watch.Add<exploration_status_t>(
        prefixes.front() + explorer_config.status_channel,
        [&](const std::string&, const exploration_status_t& m) {
          std::fprintf(stderr,
                       "  plan %lld state %d: %s (best gain %.1f nats, %d candidates, goal %.2f "
                       "%.2f yaw %.2f)\n",
                       static_cast<long long>(m.seq), m.state, m.reason.c_str(),
                       m.best_unweighted_gain_nats, m.num_candidates, m.goal_position_m[0],
                       m.goal_position_m[1], m.goal_yaw_rad);
        },
        nullptr);
  }

  Eigen::Vector3d vehicle_position = world.start_X_WB.p;
  if (mc.verbose) {
    // The collision map around the vehicle at each plan: '.' traversable, '#' occupied (P > 0.5),
    // '?' neither, 'V' the vehicle's cell.
    watch.Add<grid_map_t>(
        prefixes.front() + explorer_config.map2d_prefix + "COLLISION",
        [&](const std::string&, const grid_map_t& m) {
          const int vx =
              static_cast<int>(std::floor((vehicle_position.x() - m.origin_m[0]) / m.resolution_m));
          const int vy =
              static_cast<int>(std::floor((vehicle_position.y() - m.origin_m[1]) / m.resolution_m));
          for (int y = std::min(m.height - 1, vy + 5); y >= std::max(0, vy - 5); --y) {
            std::string row = "    ";
            for (int x = std::max(0, vx - 8); x <= std::min(m.width - 1, vx + 8); ++x) {
              const float p = m.values[static_cast<size_t>(y * m.width + x)];
              row += (x == vx && y == vy)                                                   ? 'V'
                     : p <= explorer_config.explorer.planner.projection.collision_threshold ? '.'
                     : p > 0.5                                                              ? '#'
                                                                                            : '?';
            }
            std::fprintf(stderr, "%s\n", row.c_str());
          }
        },
        nullptr);
  }

  // --- Ground truth for map quality (section 10), on the mapper's lattice.
  const GridGeometry& geometry = mapper.geometry();
  const GridSpec grid = GridSpecOf(geometry);
  std::optional<MapScorer> scorer;
  if (mc.compute_quality) {
    scorer.emplace(world, sim.simulator().caster(), grid, mapper_config.sensors[0].model.z_max_m,
                   sim_config.depth.vfov_deg * M_PI / 180.0);
  }
  auto quality = [&]() {
    return scorer->Score([&](const CellIndex& c) { return mapper.ProbabilityAt(c); },
                         mapper_config.occupancy.p_init);
  };

  // --- Fault injection: relay the simulator's sensors, dropping a seeded fraction of depth
  // images and scans, and every pose during the motion-capture outage.
  struct Relay {
    lcm::LCM* lcm;
    const SimClock* clock;
    std::string to;
    double drop_fraction;
    int64_t outage_begin, outage_end;  // utime, pose relay only
    std::mt19937_64* rng;
    int64_t* dropped;
    void Handle(const lcm::ReceiveBuffer* rbuf, const std::string&) {
      const int64_t now = clock->NowUtime();
      const bool drop = (drop_fraction > 0 &&
                         std::uniform_real_distribution<double>(0, 1)(*rng) < drop_fraction) ||
                        (now >= outage_begin && now < outage_end);
      if (drop) {
        ++*dropped;
        return;
      }
      lcm->publish(to, rbuf->data, rbuf->data_size);
    }
  };
  std::mt19937_64 fault_rng(static_cast<uint64_t>(mc.seed) * 7 + 3);
  const int64_t start_utime = clock.NowUtime();
  const int64_t outage_begin =
      mc.mocap_outage_s > 0 ? start_utime + SecondsToUtime(mc.mocap_outage_at_s) : -1;
  const int64_t outage_end = outage_begin + SecondsToUtime(mc.mocap_outage_s);
  Relay depth_relay{&lcm, &clock, "DEPTH_XTION", mc.sensor_drop_fraction,
                    -1,   -1,     &fault_rng,    &r_sensor_dropped_};
  Relay scan_relay{&lcm, &clock, "SCAN_HOKUYO", mc.sensor_drop_fraction,
                   -1,   -1,     &fault_rng,    &r_sensor_dropped_};
  Relay pose_relay{&lcm,         &clock,     "POSE_VICON", 0.0,
                   outage_begin, outage_end, &fault_rng,   &r_poses_dropped_};
  if (faults) {
    lcm.subscribe("SIM_DEPTH_XTION", &Relay::Handle, &depth_relay);
    lcm.subscribe("SIM_SCAN_HOKUYO", &Relay::Handle, &scan_relay);
    lcm.subscribe("SIM_POSE_VICON", &Relay::Handle, &pose_relay);
  }

  // --- Lockstep.
  const int64_t t0 = clock.NowUtime();
  const int64_t control_period_us = SecondsToUtime(1.0 / controller_config.rate_hz);
  int64_t next_control = t0;
  int64_t next_explore = t0;
  int64_t next_sample = t0;
  double next_progress_s = 0.0;
  bool takeoff_sent = false;
  int64_t takeoff_utime = -1, land_utime = -1;
  int reported_collisions = 0;
  // The collision cell of the take-off point (section 7: edge alpha_C from the map's corner).
  const double alpha_c = CollisionFactor(explorer_config.explorer.planner.projection,
                                         mapper_config.limits.resolution_m) *
                         mapper_config.limits.resolution_m;
  const Eigen::Vector2d start_cell =
      ((world.start_X_WB.p.head<2>() - world.map_min_m.head<2>()) / alpha_c).array().floor();
  Eigen::Vector3d last_position = world.start_X_WB.p;
  r.vehicles.resize(num_vehicles);
  std::vector<Eigen::Vector3d> last_positions;
  for (size_t k = 0; k < num_vehicles; ++k) {
    r.vehicles[k].prefix = prefixes[k];
    r.vehicles[k].start_offset_m = offsets[k];
    last_positions.push_back(sim.simulator().vehicle(k).state().p_W);
  }
  auto all_explorers = [&](ExplorerState state) {
    return std::all_of(explorers.begin(), explorers.end(),
                       [state](const auto& e) { return e && e->state() == state; });
  };
  double controller_killed_at = -1, controller_z_kill = 0, controller_z_min = 0;
  double explorer_killed_at = -1, explorer_restarted_at = -1;
  auto drain = [&] {
    while (lcm.handleTimeout(0) > 0) {
    }
  };
  while (true) {
    sim.Step();
    drain();
    const int64_t now = clock.NowUtime();
    const double t = UtimeToSeconds(now - t0);
    if (!takeoff_sent && t >= mc.takeoff_at_s) {
      command_t cmd{};
      cmd.utime = now;
      cmd.seq = 1;
      cmd.epoch = mission_epoch;
      cmd.source = "mission";
      cmd.command = command_t::COMMAND_TAKEOFF;
      cmd.height_m = world.exploration_height_m - world.start_X_WB.p.z();
      for (const std::string& p : prefixes)
        lcm.publish(p + controller_config.command_channel, &cmd);
      takeoff_sent = true;
      takeoff_utime = now;
      drain();
    }
    // Process kills (first vehicle): destroyed, nothing for the gap, then built again.
    const Eigen::Vector3d truth_p = sim.simulator().vehicle().state().p_W;
    if (mc.controller_kill_at_s >= 0 && controller_killed_at < 0 && t >= mc.controller_kill_at_s) {
      controllers.front().reset();
      controller_killed_at = t;
      controller_z_kill = controller_z_min = truth_p.z();
    }
    if (controller_killed_at >= 0 && !controllers.front() &&
        t >= controller_killed_at + mc.controller_down_s) {
      controllers.front() = std::make_unique<ControllerNode>(lcm, controller_configs[0], clock);
      next_control = now;
      r.controller_takeover = controllers.front()->takeover_status();
    }
    if (controller_killed_at >= 0 && t <= controller_killed_at + mc.controller_down_s + 3.0) {
      controller_z_min = std::min(controller_z_min, truth_p.z());
      r.controller_height_lost_m = controller_z_kill - controller_z_min;
      if (controllers.front()) {
        r.controller_takeover = controllers.front()->takeover_status();
        if (r.controller_track_after_s < 0 && controllers.front()->trajectory_seq() >= 0) {
          r.controller_track_after_s = t - controller_killed_at - mc.controller_down_s;
        }
        if (r.controller_time_to_hold_s < 0 &&
            controllers.front()->flight().supervisor().mode() == FlightMode::kHold) {
          r.controller_time_to_hold_s = t - controller_killed_at;
        }
      }
    }
    if (mc.explorer_kill_at_s >= 0 && explorer_killed_at < 0 && t >= mc.explorer_kill_at_s) {
      const ControllerNode* c = controllers.front().get();
      const double left_s = c != nullptr && c->trajectory_seq() >= 0
                                ? c->trajectory_end_s() - UtimeToSeconds(now)
                                : std::numeric_limits<double>::infinity();
      const bool exploring = explorer().state() == ExplorerState::kExploring;
      if (left_s <= mc.explorer_kill_max_left_s && (exploring || t >= mc.explorer_kill_at_s + 60)) {
        r.explorer_kill_trajectory_left_s = left_s;
        explorers.front().reset();
        explorer_killed_at = t;
        r.explorer_killed_at_s = t;
      }
    }
    if (explorer_killed_at >= 0 && !explorers.front()) {
      const ControllerNode* c = controllers.front().get();
      const FlightMode m = c != nullptr ? c->flight().supervisor().mode() : FlightMode::kIdle;
      if (m != FlightMode::kTrack && m != FlightMode::kHold) r.explorer_down_flight_kept = false;
      if (m == FlightMode::kHold) {
        r.explorer_down_held = true;
        r.explorer_down_hold_max_speed_mps = std::max(r.explorer_down_hold_max_speed_mps,
                                                      sim.simulator().vehicle().state().v_W.norm());
      }
      if (t >= explorer_killed_at + mc.explorer_down_s) {
        explorers.front() = std::make_unique<ExplorerNode>(lcm, explorer_configs[0], clock);
        explorer_restarted_at = t;
        next_explore = now;
      }
    }
    if (explorer_restarted_at >= 0 && r.explorer_first_trajectory_s < 0 && controllers.front() &&
        controllers.front()->trajectory_epoch() == explorer().epoch()) {
      r.explorer_first_trajectory_s = t - explorer_restarted_at;
    }
    if (explorer_restarted_at >= 0) {
      r.explorer_resume = explorer().resume_status();
      if (explorer().state() == ExplorerState::kStartup) {
        r.explorer_startup_after_restart = true;
      }
    }
    {
      const ControllerConfig& cc = controller_configs[0];
      r.max_geofence_excursion_m = std::max(
          {r.max_geofence_excursion_m, (cc.flight.safety.geofence_min_m - truth_p).maxCoeff(),
           (truth_p - cc.flight.safety.geofence_max_m).maxCoeff()});
    }
    while (now >= next_control) {
      for (auto& c : controllers) {
        if (c) c->Tick(next_control);
      }
      next_control += control_period_us;
    }
    drain();
    r.mapper_queue_max = std::max(r.mapper_queue_max, mapper.queue_depth());
    mapper.ProcessPending();
    mapper.PublishDue();
    drain();
    if (now >= next_explore) {
      // In vehicle order, each one's messages delivered before the next plans (deterministic).
      for (auto& e : explorers) {
        if (!e) continue;  // killed
        e->Step();
        drain();
      }
      next_explore += 50000;
    }
    if (outage_begin >= 0 && now > outage_end + SecondsToUtime(1.0) && controllers.front() &&
        controllers.front()->flight().supervisor().mode() == FlightMode::kTrack) {
      r.tracked_after_outage = true;
    }
    const Eigen::Vector3d p = sim.simulator().vehicle().state().p_W;
    vehicle_position = p;
    if (mc.verbose && sim.simulator().vehicle().collision_count() != reported_collisions) {
      reported_collisions = sim.simulator().vehicle().collision_count();
      const auto& state = sim.simulator().vehicle().state();
      const double tilt_deg =
          std::acos(std::clamp((state.q_WB * Eigen::Vector3d::UnitZ()).z(), -1.0, 1.0)) * 180.0 /
          M_PI;
      std::fprintf(stderr,
                   "COLLISION at t %.2f s with %s, vehicle at %.2f %.2f %.2f, velocity %.2f %.2f "
                   "%.2f m/s, tilt %.1f deg\n",
                   t, sim.simulator().vehicle().last_collision().c_str(), p.x(), p.y(), p.z(),
                   state.v_W.x(), state.v_W.y(), state.v_W.z(), tilt_deg);
    }
    if (!r.left_start_collision_cell) {
      const Eigen::Vector2d cell_now =
          ((p.head<2>() - world.map_min_m.head<2>()) / alpha_c).array().floor();
      r.left_start_collision_cell = cell_now != start_cell;
    }
    if (explorers.front() && (explorer().state() == ExplorerState::kExploring ||
                              explorer().state() == ExplorerState::kReturning)) {
      r.max_height_error_m =
          std::max(r.max_height_error_m,
                   std::abs(p.z() - explorer_config.explorer.planner.projection.height_m));
    }
    r.path_length_m += (p - last_position).norm();
    last_position = p;
    for (size_t k = 1; k < num_vehicles; ++k) {
      const Eigen::Vector3d q = sim.simulator().vehicle(k).state().p_W;
      r.path_length_m += (q - last_positions[k]).norm();
      r.vehicles[k].path_length_m += (q - last_positions[k]).norm();
      last_positions[k] = q;
      for (size_t j = 0; j < k; ++j) {
        const Eigen::Vector3d d = q - sim.simulator().vehicle(j).state().p_W;
        r.min_distance_3d_m = std::min(r.min_distance_3d_m, d.norm());
        if (std::abs(d.z()) < explorer_config.explorer.min_vertical_separation_m) {
          r.min_separation_m = std::min(r.min_separation_m, d.head<2>().norm());
        }
      }
    }
    r.vehicles[0].path_length_m += (p - last_positions[0]).norm();
    last_positions[0] = p;
    if (land_utime < 0 && all_explorers(ExplorerState::kDone)) {
      land_utime = now;
      r.exploration_time_s = UtimeToSeconds(now - takeoff_utime);
    }
    if (now >= next_sample) {
      next_sample += SecondsToUtime(mc.quality_period_s);
      MissionSample s;
      s.time_s = t;
      s.entropy_nats = mapper.entropy_nats();
      s.position_m = p;
      s.explorer_state = explorers.front() ? static_cast<int>(explorer().state()) : -1;
      if (mc.compute_quality) {
        const MapQuality q = quality();
        s.known_fraction = q.known_fraction;
        s.accuracy = q.accuracy;
        if (r.time_to_95_s < 0 && q.known_fraction >= 0.95) {
          r.time_to_95_s = t;
          r.path_to_95_m = r.path_length_m;
          for (MissionVehicle& v : r.vehicles) v.path_to_95_m = v.path_length_m;
        }
      }
      r.samples.push_back(s);
      if (mc.progress_period_s > 0.0 && t >= next_progress_s) {
        next_progress_s = t + mc.progress_period_s - 0.5 * mc.quality_period_s;
        std::fprintf(stderr,
                     "progress: %6.1f s simulated, %-9s known %s, entropy %.0f nats, path %.0f m, "
                     "collisions %d\n",
                     t, ExplorerStateName(s.explorer_state).c_str(),
                     mc.compute_quality ? Fixed3(s.known_fraction).c_str() : "-", s.entropy_nats,
                     r.path_length_m, sim.simulator().vehicle().collision_count());
      }
      if (mc.verbose) {
        std::fprintf(
            stderr,
            "t %6.1f s  state %d  pos %5.2f %5.2f %4.2f  H %.0f  known %.3f  collisions %d\n", t,
            s.explorer_state, p.x(), p.y(), p.z(), s.entropy_nats, s.known_fraction,
            sim.simulator().vehicle().collision_count());
      }
    }
    if (land_utime >= 0 && std::all_of(controllers.begin(), controllers.end(), [](const auto& c) {
          return c && c->flight().supervisor().mode() == FlightMode::kIdle;
        })) {
      r.landed = true;
      r.end_reason = "exploration ended by the " + explorer().explorer().end_rule() + "; " +
                     explorer().explorer().landing() + "; landed";
      if (num_vehicles > 1) r.end_reason = "every vehicle landed (" + r.end_reason + ")";
      break;
    }
    if (mc.stop_at_known > 0 && !r.samples.empty() &&
        r.samples.back().known_fraction >= mc.stop_at_known) {
      r.end_reason = "known fraction " + Fixed3(r.samples.back().known_fraction) + " reached";
      break;
    }
    if (t >= mc.max_time_s) {
      r.end_reason = "time limit " + std::to_string(mc.max_time_s) + " s";
      break;
    }
  }
  r.sim_time_s = UtimeToSeconds(clock.NowUtime() - t0);
  // A run that ended while a node was down: built again so that the figures below can be read.
  if (!explorers.front()) {
    explorers.front() = std::make_unique<ExplorerNode>(lcm, explorer_configs[0], clock);
  }
  if (remove_state_dir) {
    for (const char* f :
         {"/controller.state", "/explorer.state", "/controller.state.tmp", "/explorer.state.tmp"}) {
      std::remove((state_dir + f).c_str());
    }
    rmdir(state_dir.c_str());
  }
  r.sensor_messages_dropped = r_sensor_dropped_;
  r.poses_dropped = r_poses_dropped_;
  r.collisions = 0;
  for (size_t k = 0; k < num_vehicles; ++k) {
    MissionVehicle& v = r.vehicles[k];
    v.collisions = sim.simulator().vehicle(k).collision_count();
    r.collisions += v.collisions;
    if (v.collisions > 0) r.last_collision = sim.simulator().vehicle(k).last_collision();
    v.end_rule = explorers[k]->explorer().end_rule();
    v.landing = explorers[k]->explorer().landing();
    v.yields = explorers[k]->explorer().count(ExplorerEvent::kYielded);
    v.plans = static_cast<int>(explorers[k]->explorer().plans());
    v.landed = r.landed;
  }
  r.inter_vehicle_contacts = sim.simulator().inter_vehicle_collision_count();
  if (controllers.front()) {
    r.far_start_refusals = controllers.front()->drops().count("refused trajectory (far start)");
  }
  r.explorer_controller_holds = explorer().explorer().count(ExplorerEvent::kControllerHolds);
  r.vertical_separation_m = explorer_config.explorer.min_vertical_separation_m;
  r.plans = 0;
  for (const auto& e : explorers) r.plans += static_cast<int>(e->explorer().plans());
  r.planning_wall_s = explorer().explorer().total_planning_s();
  r.end_rule = explorer().explorer().end_rule();
  r.landing = explorer().explorer().landing();
  if (!explorer().explorer().plan_times_s().empty()) {
    std::vector<double> times = explorer().explorer().plan_times_s();
    std::sort(times.begin(), times.end());
    r.plan_median_s = times[times.size() / 2];
    r.plan_max_s = times.back();
    std::vector<double> cpu = explorer().explorer().plan_cpu_times_s();
    std::sort(cpu.begin(), cpu.end());
    r.plan_cpu_median_s = cpu[cpu.size() / 2];
    r.plan_cpu_max_s = cpu.back();
    auto stage_median = [&](double PlanTimings::*stage) {
      std::vector<double> v;
      for (const PlanTimings& t : explorer().explorer().plan_timings()) v.push_back(t.*stage);
      return Median(std::move(v));
    };
    r.plan_stage_median_s.projection_s = stage_median(&PlanTimings::projection_s);
    r.plan_stage_median_s.dijkstra_s = stage_median(&PlanTimings::dijkstra_s);
    r.plan_stage_median_s.gain_s = stage_median(&PlanTimings::gain_s);
    r.plan_stage_median_s.trajectory_s = stage_median(&PlanTimings::trajectory_s);
    r.plan_stage_median_s.total_s = stage_median(&PlanTimings::total_s);
    std::vector<double> bounded, gained;
    long rays = 0, hits = 0;
    for (const VolumetricGainStats& g : explorer().explorer().plan_gain_stats()) {
      bounded.push_back(static_cast<double>(g.poses_bounded));
      gained.push_back(static_cast<double>(g.poses_gained));
      rays += g.rays;
      hits += g.rays_memo_hits;
    }
    r.plan_positions_bounded_median = Median(std::move(bounded));
    r.plan_positions_gained_median = Median(std::move(gained));
    r.plan_ray_memo_fraction = rays > 0 ? static_cast<double>(hits) / static_cast<double>(rays) : 0;
  }
  r.scans_applied = mapper.scans_applied();
  r.mapper_applied_every_message = mapper.applied_every_message();
  r.map_hash = mapper.map_hash();
  r.final_entropy_nats = mapper.entropy_nats();
  if (mc.compute_quality) r.quality = quality();
  if (!mc.map_path.empty()) mapper.SaveMapFile(mc.map_path);
  if (!mc.octomap_path.empty()) mapper.ExportOctoMapFile(mc.octomap_path);
  if (!mc.ply_path.empty()) mapper.ExportPlyFile(mc.ply_path);
  if (!mc.csv_path.empty()) WriteMissionCsv(mc.csv_path, r);
  if (!mc.plans_csv_path.empty()) {
    std::ofstream out(mc.plans_csv_path);
    out << "plan,total_ms,projection_ms,distance_field_ms,gain_ms,trajectory_ms,positions,"
           "positions_bounded,positions_evaluated,cpu_ms\n";
    const std::vector<PlanTimings>& t = explorer().explorer().plan_timings();
    const std::vector<VolumetricGainStats>& g = explorer().explorer().plan_gain_stats();
    const std::vector<double>& cpu = explorer().explorer().plan_cpu_times_s();
    for (size_t i = 0; i < t.size() && i < g.size(); ++i) {
      out << i << "," << 1e3 * t[i].total_s << "," << 1e3 * t[i].projection_s << ","
          << 1e3 * t[i].dijkstra_s << "," << 1e3 * t[i].gain_s << "," << 1e3 * t[i].trajectory_s
          << "," << g[i].positions << "," << g[i].poses_bounded << "," << g[i].poses_gained << ","
          << (i < cpu.size() ? 1e3 * cpu[i] : -1.0) << "\n";
    }
  }
  r.wall_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return r;
}

void WriteMissionCsv(const std::string& path, const MissionResult& r) {
  std::ofstream out(path);
  out << "time_s,entropy_nats,known_fraction,accuracy,x_m,y_m,z_m,explorer_state\n";
  for (const MissionSample& s : r.samples) {
    out << s.time_s << "," << s.entropy_nats << "," << s.known_fraction << "," << s.accuracy << ","
        << s.position_m.x() << "," << s.position_m.y() << "," << s.position_m.z() << ","
        << s.explorer_state << "\n";
  }
}

std::string MissionSummary(const MissionResult& r) {
  std::ostringstream s;
  s << "end: " << r.end_reason << "\n"
    << "simulated time: " << r.sim_time_s << " s (wall " << r.wall_time_s << " s, "
    << (r.wall_time_s > 0 ? r.sim_time_s / r.wall_time_s : 0) << "x real time)\n"
    << "exploration time (take-off to land command): " << r.exploration_time_s << " s\n"
    << "landed: " << (r.landed ? "yes" : "no") << "\n"
    << "collisions: " << r.collisions
    << (r.collisions > 0 ? " (last with " + r.last_collision + ")" : std::string()) << "\n"
    << "path length: " << r.path_length_m << " m\n"
    << "largest height error while exploring: " << r.max_height_error_m << " m\n"
    << "ended by: " << (r.end_rule.empty() ? "-" : r.end_rule) << "\n"
    << "landing: " << (r.landing.empty() ? "-" : r.landing) << "\n"
    << "plans: " << r.plans << ", planning wall time " << r.planning_wall_s << " s ("
    << (r.plans > 0 ? 1000.0 * r.planning_wall_s / r.plans : 0) << " ms per plan; replan median "
    << 1000.0 * r.plan_median_s << " ms, max " << 1000.0 * r.plan_max_s << " ms)\n"
    << "replan CPU time (the planning thread's own): median " << 1000.0 * r.plan_cpu_median_s
    << " ms, max " << 1000.0 * r.plan_cpu_max_s << " ms\n"
    << "replan stage medians: projection and traversability "
    << 1000.0 * r.plan_stage_median_s.projection_s << " ms, distance field "
    << 1000.0 * r.plan_stage_median_s.dijkstra_s << " ms, gain "
    << 1000.0 * r.plan_stage_median_s.gain_s << " ms, trajectory "
    << 1000.0 * r.plan_stage_median_s.trajectory_s << " ms\n"
    << "replan gain: median " << r.plan_positions_bounded_median << " positions bounded and "
    << r.plan_positions_gained_median << " evaluated exactly per replan; "
    << 100.0 * r.plan_ray_memo_fraction << "% of rays reused from their memo\n"
    << "scans applied: " << r.scans_applied
    << ", every message applied: " << (r.mapper_applied_every_message ? "yes" : "no")
    << ", mapper queue at most " << r.mapper_queue_max << " scans\n"
    << "map entropy: " << r.final_entropy_nats << " nats, map hash " << std::hex << r.map_hash
    << std::dec << "\n"
    << "known fraction: " << r.quality.known_fraction << " of " << r.quality.observable_cells
    << " observable cells; accuracy " << r.quality.accuracy << "; Brier " << r.quality.brier
    << "; ROC AUC " << r.quality.roc_auc << "\n"
    << "first exploration plan: " << r.first_plan_time_s << " s\n"
    << "time to 95% known: " << r.time_to_95_s << " s\n"
    << "faults: " << r.sensor_messages_dropped << " sensor messages and " << r.poses_dropped
    << " poses dropped; tracking after the outage: " << (r.tracked_after_outage ? "yes" : "no")
    << "\n";
  s << "path length when 95% known: " << r.path_to_95_m << " m (all vehicles)\n";
  if (r.vehicles.size() > 1) {
    s << "vehicles: " << r.vehicles.size() << ", smallest separation " << r.min_separation_m
      << " m (horizontal, heights within " << r.vertical_separation_m
      << " m), smallest 3D distance " << r.min_distance_3d_m << " m, contacts between vehicles "
      << r.inter_vehicle_contacts << "\n";
    for (const MissionVehicle& v : r.vehicles) {
      s << "vehicle " << v.prefix << ": start offset (" << v.start_offset_m.x() << ", "
        << v.start_offset_m.y() << ") m, path " << v.path_length_m << " m (" << v.path_to_95_m
        << " m when 95% known), collisions " << v.collisions << ", plans " << v.plans << ", yields "
        << v.yields << ", ended by: " << (v.end_rule.empty() ? "-" : v.end_rule)
        << ", landing: " << (v.landing.empty() ? "-" : v.landing) << "\n";
    }
  }
  return s.str();
}

}  // namespace kestrel
