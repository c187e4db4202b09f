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
#include "mapping/range_bands.h"
#include "sim/ground_truth.h"
#include "sim/ray_reach.h"
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

namespace {

// Every message in publication order, as lcm-logger would record it (stamped with the
// simulated time), so the run can be replayed into fresh processes.
struct LogWriter {
  lcm::LogFile* file{nullptr};
  const SimClock* clock{nullptr};
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
};

// Fault injection: relays one of the simulator's channels, dropping a seeded fraction of its
// messages, or every message during the motion-capture outage.
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
    const bool drop =
        (drop_fraction > 0 && std::uniform_real_distribution<double>(0, 1)(*rng) < drop_fraction) ||
        (now >= outage_begin && now < outage_end);
    if (drop) {
      ++*dropped;
      return;
    }
    lcm->publish(to, rbuf->data, rbuf->data_size);
  }
};

// One mission: its configuration, its nodes over one memq:// LCM, the lockstep loop and the
// figures of MissionResult. Run() builds the world and the nodes in a fixed order (their
// publisher epochs come from the seed, docs/design.md §7.5), runs the lockstep, then sums up.
class Mission {
 public:
  explicit Mission(const MissionConfig& mc) : mc_(mc) {}

  MissionResult Run() {
    SeedPublisherEpochs(static_cast<uint64_t>(mc_.seed));
    mission_epoch_ = NewPublisherEpoch();  // the take-off command's
    LoadSimulator();
    LoadNodeConfigurations();
    StartNodes();
    StartLog();
    WatchExplorer();
    StartQualityAndFaults();
    StartLockstep();
    while (Step()) {
    }
    Summarise();
    WriteFiles();
    r_.wall_time_s = SecondsSince(wall_start_);
    return std::move(r_);
  }

 private:
  static double SecondsSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  // The first vehicle's nodes (replaced when killed and respawned: no references kept).
  ExplorerNode& explorer() { return *explorers_.front(); }
  ControllerNode* controller() { return controllers_.front().get(); }
  void Drain() {
    while (lcm_.handleTimeout(0) > 0) {
    }
  }

  // --- Building the world and the nodes.

  // The simulator's configuration: the world and seed, the vehicles (V1_, V2_, ... at clear
  // places around the world's start), the sensors relayed when faults are injected.
  void LoadSimulator() {
    std::vector<std::string> overrides = mc_.sim_overrides;
    faults_ = mc_.sensor_drop_fraction > 0 || mc_.mocap_outage_s > 0;
    if (faults_) {  // the simulator publishes on SIM_*; a relay drops what the fault asks
      overrides.push_back("channels.depth=SIM_DEPTH_XTION");
      overrides.push_back("channels.scan=SIM_SCAN_HOKUYO");
      overrides.push_back("channels.pose=SIM_POSE_VICON");
    }
    overrides.push_back("world_file=" + PathUnderRoot(mc_.root, mc_.world_file));
    overrides.push_back("seed=" + std::to_string(mc_.seed));
    sim_cfg_ = Load(mc_.root, mc_.sim_file, overrides);
    sim_config_ = LoadSimConfig(sim_cfg_, mc_.root);
    KESTREL_THROW_UNLESS(mc_.vehicles == 1 || !faults_,
                         "the fault injection applies to one vehicle only (--vehicles 1)");
    if (mc_.vehicles != 1) {
      offsets_ = VehicleStartOffsets(sim_config_.world, mc_.vehicles, mc_.vehicle_spacing_m,
                                     sim_config_.vehicle.diameter_m,
                                     sim_config_.world.exploration_height_m);
      prefixes_.clear();
      std::ostringstream list;
      list << "vehicles=[";
      for (int k = 0; k < mc_.vehicles; ++k) {
        prefixes_.push_back("V" + std::to_string(k + 1) + "_");
        const Eigen::Vector3d& o = offsets_[static_cast<size_t>(k)];
        list << (k > 0 ? ", " : "") << "{prefix: " << prefixes_.back() << ", start_offset_m: ["
             << o.x() << ", " << o.y() << ", " << o.z() << "]}";
      }
      list << "]";
      sim_cfg_.ApplyOverride(list.str());
      sim_config_ = LoadSimConfig(sim_cfg_, mc_.root);
    }
    sim_cfg_.CheckNoUnknownKeys();
  }

  // The mapper's, the explorer's and the controller's files, with what the world and the
  // simulated vehicle set in every one of them: one world, its limits everywhere.
  void LoadNodeConfigurations() {
    const World& world = sim_config_.world;
    mapper_cfg_ = Load(mc_.root, mc_.mapper_file, mc_.mapper_overrides);
    mapper_config_ = LoadMapperConfig(mapper_cfg_);
    mapper_cfg_.CheckNoUnknownKeys();
    mapper_config_.limits.min_m = world.map_min_m;
    mapper_config_.limits.max_m = world.map_max_m;
    mapper_config_.checkpoint_path.clear();
    mapper_config_.vehicle_prefixes = prefixes_;
    // memq:// has no receive buffer to protect (docs/design.md §7.6): snapshots go out whole at
    // their instant, as before pacing, unless snapshot_bytes_per_s is set on the command line.
    if (std::none_of(mc_.mapper_overrides.begin(), mc_.mapper_overrides.end(),
                     [](const auto& o) { return o.rfind("snapshot_bytes_per_s=", 0) == 0; })) {
      mapper_config_.snapshot_bytes_per_s = 0;
    }
    mapper_config_.sensors[0].X_BS = sim_config_.vehicle.X_BS_xtion;
    if (mapper_config_.sensors.size() > 1) {
      mapper_config_.sensors[1].X_BS = sim_config_.vehicle.X_BS_hokuyo;
    }

    explorer_cfg_ = Load(mc_.root, mc_.explorer_file, mc_.explorer_overrides);
    explorer_config_ = LoadExplorerNodeConfig(explorer_cfg_);
    explorer_cfg_.CheckNoUnknownKeys();
    ExplorerConfig& e = explorer_config_.explorer;
    e.map = mapper_config_.limits;
    e.p_init = mapper_config_.occupancy.p_init;
    e.planner.projection.height_m = world.exploration_height_m;
    e.planner.projection.p_init = mapper_config_.occupancy.p_init;
    // The vehicle that flies is the simulator's: its diameter sets k_C and the disc checked.
    e.planner.projection.vehicle_diameter_m = sim_config_.vehicle.diameter_m;
    e.planner.trajectory.vehicle_radius_m = 0.5 * sim_config_.vehicle.diameter_m;
    // The gain predicts the mapper's update (docs/algorithms.md §6): its range bands too, per
    // sensor of the same name, over the angle the mapper's window spans with the simulated
    // sensors (whole rows of the camera, whole beams of the LIDAR: range_bands.h).
    const DepthCameraConfig& camera = sim_config_.depth;
    const PlanarLidarConfig& lidar = sim_config_.lidar;
    const double camera_fy =
        0.5 * camera.height_px / std::tan(0.5 * camera.vfov_deg * M_PI / 180.0);  // sim/sensors
    for (VolumetricSensor& v : e.planner.volumetric.gain.sensors) {
      for (const auto& m : mapper_config_.sensors) {
        if (m.name != v.name) continue;
        const double delta = m.model.direction_uncertainty_rad;
        const bool planar = m.kind == "scan";
        v.model.direction_uncertainty_rad =
            BandWindowAngle(delta, planar ? 1.0 / lidar.angle_step_rad : camera_fy);
        v.model.band_surface_max_m = m.model.band_surface_max_m;
      }
    }

    controller_cfg_ = ConfigNode::FromString("{}", "(defaults)");
    if (!mc_.controller_file.empty()) {
      controller_cfg_ = ConfigNode::LoadFile(PathUnderRoot(mc_.root, mc_.controller_file));
      controller_config_ = LoadControllerConfig(controller_cfg_, sim_config_.vehicle);
    }
    controller_config_.flight.vehicle = sim_config_.vehicle;
    const Geofence fence = WorldGeofence(world);  // as the sheets' (scripts/world-env)
    controller_config_.flight.safety.geofence_min_m = fence.min_m;
    controller_config_.flight.safety.geofence_max_m = fence.max_m;
  }

  // The nodes in one process: the simulator, a controller per vehicle, the mapper, an explorer
  // per vehicle (in this order: their epochs); with process kills, their state files in a
  // folder of the run and one run id (docs/design.md §2.5).
  void StartNodes() {
    KESTREL_THROW_UNLESS(lcm_.good(), "memq:// LCM unavailable");
    sim_ = std::make_unique<SimNode>(lcm_, sim_config_, clock_);
    const bool kills = mc_.controller_kill_at_s >= 0 || mc_.explorer_kill_at_s >= 0;
    KESTREL_THROW_UNLESS(!kills || mc_.vehicles == 1, "process kills apply to one vehicle only");
    state_dir_ = mc_.state_dir;
    if (kills && state_dir_.empty()) {
      char dir[] = "/tmp/kestrel-mission-XXXXXX";
      KESTREL_THROW_UNLESS(mkdtemp(dir) != nullptr, "cannot make a state folder under /tmp");
      state_dir_ = dir;
      remove_state_dir_ = true;
    }
    if (kills) {
      controller_config_.state_path = state_dir_ + "/controller.state";
      controller_config_.run_id = "mission-" + std::to_string(mc_.seed);
      explorer_config_.state_path = state_dir_ + "/explorer.state";
      explorer_config_.run_id = controller_config_.run_id;
    }
    for (const std::string& p : prefixes_) {
      ControllerConfig c = controller_config_;
      for (std::string* channel :
           {&c.pose_channel, &c.imu_channel, &c.trajectory_channel, &c.command_channel,
            &c.motor_channel, &c.status_channel, &c.heartbeat_channel}) {
        *channel = p + *channel;
      }
      controller_configs_.push_back(c);
      controllers_.push_back(std::make_unique<ControllerNode>(lcm_, c, clock_));
    }
    mapper_ = std::make_unique<MapperNode>(lcm_, mapper_config_, clock_);
    for (const std::string& p : prefixes_) {
      ExplorerNodeConfig e = explorer_config_;
      e.vehicle_prefix = p;
      for (const std::string& q : prefixes_) {
        if (q != p) e.explorer.peers.push_back(q);
      }
      explorer_configs_.push_back(e);
      explorers_.push_back(std::make_unique<ExplorerNode>(lcm_, e, clock_));
    }
  }

  // The log (mc.log_path): every message, and first what each node runs with
  // (docs/design.md §6). The values the mission sets from the world and the vehicle after loading
  // (map limits, height, diameter) are not among them; the world and the vehicle files are, with
  // the simulator's.
  void StartLog() {
    if (mc_.log_path.empty()) return;
    log_ = std::make_unique<lcm::LogFile>(mc_.log_path, "w");
    KESTREL_THROW_UNLESS(log_->good(), "cannot write the log " << mc_.log_path);
    writer_.file = log_.get();
    writer_.clock = &clock_;
    lcm_.subscribe(".*", &LogWriter::Handle, &writer_);
    struct NodeConfig {
      const char* name;
      const ConfigNode* node;
      std::string file;
    };
    const NodeConfig configs[] = {
        {"SIM", &sim_cfg_, PathUnderRoot(mc_.root, mc_.sim_file)},
        {"CONTROLLER", &controller_cfg_, PathUnderRoot(mc_.root, mc_.controller_file)},
        {"MAPPER", &mapper_cfg_, PathUnderRoot(mc_.root, mc_.mapper_file)},
        {"EXPLORER", &explorer_cfg_, PathUnderRoot(mc_.root, mc_.explorer_file)}};
    for (const auto& [name, node, file] : configs) {
      ProcessArgs args;
      args.config_path = file;
      args.command_line = mc_.command_line;
      params_t params = MakeParamsMessage("kestrel-mission", args, *node);
      params.utime = clock_.NowUtime();
      params.epoch = mission_epoch_;
      lcm_.publish(std::string("PARAMS_") + name, &params);
    }
  }

  // The first explorer's status: its first exploration plan and its DONE; with mc.verbose every
  // plan and the collision map around the vehicle at each plan.
  void WatchExplorer() {
    const int64_t t0_utime = clock_.NowUtime();
    const std::string status = prefixes_.front() + explorer_config_.status_channel;
    watch_.Add<exploration_status_t>(
        status,
        [this, t0_utime](const std::string&, const exploration_status_t& m) {
          const ExplorerState state = static_cast<ExplorerState>(m.state);
          if (state == ExplorerState::kDone) r_.done_status_published = true;
          if (first_plan_seen_ || state == ExplorerState::kStartup ||
              state == ExplorerState::kWaiting) {
            return;
          }
          first_plan_seen_ = true;
          r_.first_plan_chose_goal = m.chosen_index >= 0;
          r_.first_plan_time_s = UtimeToSeconds(clock_.NowUtime() - t0_utime);
        },
        nullptr);
    if (!mc_.verbose) return;
    watch_.Add<exploration_status_t>(
        status,
        [](const std::string&, const exploration_status_t& m) {
          std::fprintf(stderr,
                       "  plan %lld state %d: %s (best gain %.1f nats, %d candidates, goal %.2f "
                       "%.2f yaw %.2f)\n",
                       static_cast<long long>(m.seq), m.state, m.reason.c_str(),
                       m.best_unweighted_gain_nats, m.num_candidates, m.goal_position_m[0],
                       m.goal_position_m[1], m.goal_yaw_rad);
        },
        nullptr);
    watch_.Add<grid_map_t>(
        prefixes_.front() + explorer_config_.map2d_prefix + "COLLISION",
        [this](const std::string&, const grid_map_t& m) { PrintCollisionMap(m); }, nullptr);
  }

  // The collision map around the vehicle: '.' traversable, '#' occupied (P > 0.5), '?'
  // neither, 'V' the vehicle's cell.
  void PrintCollisionMap(const grid_map_t& m) const {
    const int vx = static_cast<int>(std::floor((position_.x() - m.origin_m[0]) / m.resolution_m));
    const int vy = static_cast<int>(std::floor((position_.y() - m.origin_m[1]) / m.resolution_m));
    const double free = explorer_config_.explorer.planner.projection.collision_threshold;
    for (int y = std::min(m.height - 1, vy + 5); y >= std::max(0, vy - 5); --y) {
      std::string row = "    ";
      for (int x = std::max(0, vx - 8); x <= std::min(m.width - 1, vx + 8); ++x) {
        const float p = m.values[static_cast<size_t>(y * m.width + x)];
        row += (x == vx && y == vy) ? 'V' : p <= free ? '.' : p > 0.5 ? '#' : '?';
      }
      std::fprintf(stderr, "%s\n", row.c_str());
    }
  }

  // Ground truth for map quality (docs/algorithms.md §12.2) on the mapper's lattice, where the
  // simulator's rays reached and the map's claims against it (docs/algorithms.md §12.5), and the
  // fault injection's relays: a seeded fraction of depth images and scans dropped, and every pose
  // during the motion-capture outage.
  void StartQualityAndFaults() {
    if (mc_.compute_quality) {
      const GridSpec grid = GridSpecOf(mapper_->geometry());
      scorer_.emplace(
          sim_config_.world, sim_->simulator().caster(), grid,
          mapper_config_.sensors[0].model.z_max_m, sim_config_.depth.vfov_deg * M_PI / 180.0,
          mapper_config_.sensors[0].model.no_return_informs, sim_config_.depth.range_max_m);
      reach_.emplace(grid);
      sim_->mutable_simulator().SetRayReach(&*reach_);
      claims_.emplace(sim_config_.world, grid, scorer_->truth());
    }
    const int64_t start_utime = clock_.NowUtime();
    outage_begin_ =
        mc_.mocap_outage_s > 0 ? start_utime + SecondsToUtime(mc_.mocap_outage_at_s) : -1;
    outage_end_ = outage_begin_ + SecondsToUtime(mc_.mocap_outage_s);
    relays_ = {Relay{&lcm_, &clock_, "DEPTH_XTION", mc_.sensor_drop_fraction, -1, -1, &fault_rng_,
                     &r_.sensor_messages_dropped},
               Relay{&lcm_, &clock_, "SCAN_HOKUYO", mc_.sensor_drop_fraction, -1, -1, &fault_rng_,
                     &r_.sensor_messages_dropped},
               Relay{&lcm_, &clock_, "POSE_VICON", 0.0, outage_begin_, outage_end_, &fault_rng_,
                     &r_.poses_dropped}};
    if (faults_) {
      lcm_.subscribe("SIM_DEPTH_XTION", &Relay::Handle, &relays_[0]);
      lcm_.subscribe("SIM_SCAN_HOKUYO", &Relay::Handle, &relays_[1]);
      lcm_.subscribe("SIM_POSE_VICON", &Relay::Handle, &relays_[2]);
    }
  }

  [[nodiscard]] MapQuality Quality() const {
    return scorer_->Score([&](const CellIndex& c) { return mapper_->ProbabilityAt(c); },
                          mapper_config_.occupancy.p_init);
  }

  // The cells the map holds known free now (tools/map_score/map_claims.h).
  [[nodiscard]] std::vector<uint8_t> KnownFree() const {
    return KnownFreeBelow(
        scorer_->Probabilities([&](const CellIndex& c) { return mapper_->ProbabilityAt(c); }),
        mapper_config_.occupancy.p_init);
  }

  // --- The lockstep loop.

  void StartLockstep() {
    const World& world = sim_config_.world;
    t0_ = clock_.NowUtime();
    control_period_us_ = SecondsToUtime(1.0 / controller_config_.rate_hz);
    next_control_ = next_explore_ = next_sample_ = t0_;
    // The collision cell of the take-off point (docs/algorithms.md §7.1: edge alpha_C from the
    // map's corner).
    const double alpha = mapper_config_.limits.resolution_m;
    alpha_c_ = CollisionFactor(explorer_config_.explorer.planner.projection, alpha) * alpha;
    start_cell_ =
        ((world.start_X_WB.p.head<2>() - world.map_min_m.head<2>()) / alpha_c_).array().floor();
    position_ = position_at_last_step_ = world.start_X_WB.p;
    r_.vehicles.resize(prefixes_.size());
    for (size_t k = 0; k < prefixes_.size(); ++k) {
      r_.vehicles[k].prefix = prefixes_[k];
      r_.vehicles[k].start_offset_m = offsets_[k];
      last_positions_.push_back(sim_->simulator().vehicle(k).state().p_W);
    }
  }

  // One simulator step and everything due at it; false when the run ends.
  bool Step() {
    sim_->Step();
    Drain();
    const int64_t now = clock_.NowUtime();
    const double t = UtimeToSeconds(now - t0_);
    SendTakeoff(t, now);
    KillAndRespawnController(t, now);
    KillAndRespawnExplorer(t, now);
    const Eigen::Vector3d truth = sim_->simulator().vehicle().state().p_W;
    const ControllerConfig& cc = controller_configs_[0];
    r_.max_geofence_excursion_m =
        std::max({r_.max_geofence_excursion_m, (cc.flight.safety.geofence_min_m - truth).maxCoeff(),
                  (truth - cc.flight.safety.geofence_max_m).maxCoeff()});
    StepNodes(now);
    Measure(t, now);
    if (now >= next_sample_) Sample(t);
    return !Finished(t, now);
  }

  // The take-off command (as kestrel-cmd sends it) to every vehicle at mc.takeoff_at_s.
  void SendTakeoff(double t, int64_t now) {
    if (takeoff_utime_ >= 0 || t < mc_.takeoff_at_s) return;
    const World& world = sim_config_.world;
    command_t cmd{};
    cmd.utime = now;
    cmd.seq = 1;
    cmd.epoch = mission_epoch_;
    cmd.source = "mission";
    cmd.command = command_t::COMMAND_TAKEOFF;
    cmd.height_m = world.exploration_height_m - world.start_X_WB.p.z();
    for (const std::string& p : prefixes_) {
      lcm_.publish(p + controller_config_.command_channel, &cmd);
    }
    takeoff_utime_ = now;
    Drain();
  }

  // The controller kill (first vehicle): destroyed, nothing for the gap, then built again; what
  // the vehicle lost meanwhile and how the new controller took over.
  void KillAndRespawnController(double t, int64_t now) {
    const Eigen::Vector3d truth = sim_->simulator().vehicle().state().p_W;
    if (mc_.controller_kill_at_s >= 0 && controller_killed_at_ < 0 &&
        t >= mc_.controller_kill_at_s) {
      controllers_.front().reset();
      controller_killed_at_ = t;
      controller_z_kill_ = controller_z_min_ = truth.z();
    }
    if (controller_killed_at_ < 0) return;
    const double respawn_at = controller_killed_at_ + mc_.controller_down_s;
    if (!controller() && t >= respawn_at) {
      controllers_.front() = std::make_unique<ControllerNode>(lcm_, controller_configs_[0], clock_);
      next_control_ = now;
      r_.controller_takeover = controller()->takeover_status();
    }
    if (t > respawn_at + 3.0) return;
    controller_z_min_ = std::min(controller_z_min_, truth.z());
    r_.controller_height_lost_m = controller_z_kill_ - controller_z_min_;
    if (!controller()) return;
    r_.controller_takeover = controller()->takeover_status();
    if (r_.controller_track_after_s < 0 && controller()->trajectory_seq() >= 0) {
      r_.controller_track_after_s = t - respawn_at;
    }
    if (r_.controller_time_to_hold_s < 0 &&
        controller()->flight().supervisor().mode() == FlightMode::kHold) {
      r_.controller_time_to_hold_s = t - controller_killed_at_;
    }
  }

  // The explorer kill (first vehicle), while it explores and its trajectory ends within
  // mc.explorer_kill_max_left_s: what the controller did while it was down, and how the new one
  // resumed.
  void KillAndRespawnExplorer(double t, int64_t now) {
    if (mc_.explorer_kill_at_s >= 0 && explorer_killed_at_ < 0 && t >= mc_.explorer_kill_at_s) {
      const ControllerNode* c = controller();
      const double left_s = c != nullptr && c->trajectory_seq() >= 0
                                ? c->trajectory_end_s() - UtimeToSeconds(now)
                                : std::numeric_limits<double>::infinity();
      const ExplorerState state = explorer().state();
      const bool when = mc_.explorer_kill_returning ? state == ExplorerState::kReturning
                                                    : state == ExplorerState::kExploring ||
                                                          t >= mc_.explorer_kill_at_s + 60;
      if (left_s <= mc_.explorer_kill_max_left_s && when) {
        r_.explorer_kill_trajectory_left_s = left_s;
        explorers_.front().reset();
        explorer_killed_at_ = t;
        r_.explorer_killed_at_s = t;
      }
    }
    if (explorer_killed_at_ >= 0 && !explorers_.front()) {
      const ControllerNode* c = controller();
      const FlightMode m = c != nullptr ? c->flight().supervisor().mode() : FlightMode::kIdle;
      if (m != FlightMode::kTrack && m != FlightMode::kHold) r_.explorer_down_flight_kept = false;
      if (m == FlightMode::kHold) {
        r_.explorer_down_held = true;
        r_.explorer_down_hold_max_speed_mps = std::max(
            r_.explorer_down_hold_max_speed_mps, sim_->simulator().vehicle().state().v_W.norm());
      }
      if (t >= explorer_killed_at_ + mc_.explorer_down_s) {
        explorers_.front() = std::make_unique<ExplorerNode>(lcm_, explorer_configs_[0], clock_);
        explorer_restarted_at_ = t;
        next_explore_ = now;
      }
    }
    if (explorer_restarted_at_ < 0) return;
    if (r_.explorer_first_trajectory_s < 0 && controller() &&
        controller()->trajectory_epoch() == explorer().epoch()) {
      r_.explorer_first_trajectory_s = t - explorer_restarted_at_;
    }
    r_.explorer_resume = explorer().resume_status();
    if (explorer().state() == ExplorerState::kStartup) r_.explorer_startup_after_restart = true;
  }

  // The controllers at their rate, the mapper, and the explorers every 50 ms (in vehicle order,
  // each one's messages delivered before the next plans: deterministic).
  void StepNodes(int64_t now) {
    while (now >= next_control_) {
      for (auto& c : controllers_) {
        if (c) c->Tick(next_control_);
      }
      next_control_ += control_period_us_;
    }
    Drain();
    r_.mapper_queue_max = std::max(r_.mapper_queue_max, mapper_->queue_depth());
    mapper_->ProcessPending();
    mapper_->PublishDue();
    Drain();
    if (now < next_explore_) return;
    for (auto& e : explorers_) {
      if (!e) continue;  // killed
      e->Step();
      Drain();
    }
    next_explore_ += 50000;
  }

  // The flight's figures at every step: tracking after the outage, collisions, the start cell
  // left, the height error, path lengths, separations, the land command.
  void Measure(double t, int64_t now) {
    if (outage_begin_ >= 0 && now > outage_end_ + SecondsToUtime(1.0) && controller() &&
        controller()->flight().supervisor().mode() == FlightMode::kTrack) {
      r_.tracked_after_outage = true;
    }
    const Eigen::Vector3d p = sim_->simulator().vehicle().state().p_W;
    position_ = p;
    if (mc_.verbose && sim_->simulator().vehicle().collision_count() != reported_collisions_) {
      reported_collisions_ = sim_->simulator().vehicle().collision_count();
      PrintCollision(t);
    }
    if (!r_.left_start_collision_cell) {
      const Eigen::Vector2d cell_now =
          ((p.head<2>() - sim_config_.world.map_min_m.head<2>()) / alpha_c_).array().floor();
      r_.left_start_collision_cell = cell_now != start_cell_;
    }
    if (explorers_.front() && (explorer().state() == ExplorerState::kExploring ||
                               explorer().state() == ExplorerState::kReturning)) {
      r_.max_height_error_m =
          std::max(r_.max_height_error_m,
                   std::abs(p.z() - explorer_config_.explorer.planner.projection.height_m));
    }
    r_.path_length_m += (p - position_at_last_step_).norm();
    position_at_last_step_ = p;
    MeasureVehicles();
    r_.vehicles[0].path_length_m += (p - last_positions_[0]).norm();
    last_positions_[0] = p;
    const bool all_done = std::all_of(explorers_.begin(), explorers_.end(), [](const auto& e) {
      return e && e->state() == ExplorerState::kDone;
    });
    if (land_utime_ < 0 && all_done) {
      land_utime_ = now;
      r_.exploration_time_s = UtimeToSeconds(now - takeoff_utime_);
    }
  }

  // Several vehicles: each one's path, the smallest separation and 3D distance between them.
  void MeasureVehicles() {
    const double vertical_m = explorer_config_.explorer.min_vertical_separation_m;
    for (size_t k = 1; k < prefixes_.size(); ++k) {
      const Eigen::Vector3d q = sim_->simulator().vehicle(k).state().p_W;
      r_.path_length_m += (q - last_positions_[k]).norm();
      r_.vehicles[k].path_length_m += (q - last_positions_[k]).norm();
      last_positions_[k] = q;
      for (size_t j = 0; j < k; ++j) {
        const Eigen::Vector3d d = q - sim_->simulator().vehicle(j).state().p_W;
        r_.min_distance_3d_m = std::min(r_.min_distance_3d_m, d.norm());
        if (std::abs(d.z()) < vertical_m) {
          r_.min_separation_m = std::min(r_.min_separation_m, d.head<2>().norm());
        }
      }
    }
  }

  void PrintCollision(double t) const {
    const auto& vehicle = sim_->simulator().vehicle();
    const auto& state = vehicle.state();
    const double tilt_deg =
        std::acos(std::clamp((state.q_WB * Eigen::Vector3d::UnitZ()).z(), -1.0, 1.0)) * 180.0 /
        M_PI;
    std::fprintf(stderr,
                 "COLLISION at t %.2f s with %s, vehicle at %.2f %.2f %.2f, velocity %.2f %.2f "
                 "%.2f m/s, tilt %.1f deg\n",
                 t, vehicle.last_collision().c_str(), state.p_W.x(), state.p_W.y(), state.p_W.z(),
                 state.v_W.x(), state.v_W.y(), state.v_W.z(), tilt_deg);
  }

  // A time-series sample every mc.quality_period_s: entropy, known fraction, the explorer's
  // state; the time and path to 95% known; the progress and verbose lines.
  void Sample(double t) {
    next_sample_ += SecondsToUtime(mc_.quality_period_s);
    MissionSample s;
    s.time_s = t;
    s.entropy_nats = mapper_->entropy_nats();
    s.position_m = position_;
    s.explorer_state = explorers_.front() ? static_cast<int>(explorer().state()) : -1;
    if (mc_.compute_quality) {
      claims_->Sample(t, KnownFree());
      const MapQuality q = Quality();
      s.known_fraction = q.known_fraction;
      s.accuracy = q.accuracy;
      if (r_.time_to_95_s < 0 && q.known_fraction >= 0.95) {
        r_.time_to_95_s = t;
        r_.path_to_95_m = r_.path_length_m;
        for (MissionVehicle& v : r_.vehicles) v.path_to_95_m = v.path_length_m;
      }
    }
    r_.samples.push_back(s);
    const int collisions = sim_->simulator().vehicle().collision_count();
    if (mc_.progress_period_s > 0.0 && t >= next_progress_s_) {
      next_progress_s_ = t + mc_.progress_period_s - 0.5 * mc_.quality_period_s;
      // The state's name from the explorer's table (exploration/explorer_state.h).
      std::fprintf(stderr,
                   "progress: %6.1f s simulated, %-9s known %s, entropy %.0f nats, path %.0f m, "
                   "collisions %d\n",
                   t, ExplorerStateName(s.explorer_state).c_str(),
                   mc_.compute_quality ? Fixed3(s.known_fraction).c_str() : "-", s.entropy_nats,
                   r_.path_length_m, collisions);
    }
    if (mc_.verbose) {
      std::fprintf(
          stderr, "t %6.1f s  state %d  pos %5.2f %5.2f %4.2f  H %.0f  known %.3f  collisions %d\n",
          t, s.explorer_state, position_.x(), position_.y(), position_.z(), s.entropy_nats,
          s.known_fraction, collisions);
    }
  }

  // The end: every vehicle landed after the land command, the known fraction reached, the time
  // limit, or a stop requested (kestrel-mission: SIGINT or SIGTERM).
  bool Finished(double t, int64_t) {
    if (land_utime_ >= 0 &&
        std::all_of(controllers_.begin(), controllers_.end(), [](const auto& c) {
          return c && c->flight().supervisor().mode() == FlightMode::kIdle;
        })) {
      r_.landed = true;
      r_.end_reason = "exploration ended by the " + explorer().explorer().end_rule() + "; " +
                      explorer().explorer().landing() + "; landed";
      if (prefixes_.size() > 1) r_.end_reason = "every vehicle landed (" + r_.end_reason + ")";
      return true;
    }
    if (mc_.stop_at_known > 0 && !r_.samples.empty() &&
        r_.samples.back().known_fraction >= mc_.stop_at_known) {
      r_.end_reason = "known fraction " + Fixed3(r_.samples.back().known_fraction) + " reached";
      return true;
    }
    if (t >= mc_.max_time_s) {
      r_.end_reason = "time limit " + std::to_string(mc_.max_time_s) + " s";
      return true;
    }
    if (mc_.stop_requested && mc_.stop_requested()) {
      r_.interrupted = true;
      r_.end_reason = "interrupted after " + Fixed3(t) + " s simulated";
      return true;
    }
    return false;
  }

  // --- The summary.

  // The figures the nodes hold at the end: per vehicle, the explorers' plans and timings, the
  // mapper's map.
  void Summarise() {
    r_.sim_time_s = UtimeToSeconds(clock_.NowUtime() - t0_);
    // A run that ended while a node was down: built again so that the figures below can be read.
    if (!explorers_.front()) {
      explorers_.front() = std::make_unique<ExplorerNode>(lcm_, explorer_configs_[0], clock_);
    }
    if (remove_state_dir_) {
      for (const char* f : {"/controller.state", "/explorer.state", "/controller.state.tmp",
                            "/explorer.state.tmp"}) {
        std::remove((state_dir_ + f).c_str());
      }
      rmdir(state_dir_.c_str());
    }
    r_.collisions = 0;
    for (size_t k = 0; k < prefixes_.size(); ++k) {
      MissionVehicle& v = r_.vehicles[k];
      const Explorer& e = explorers_[k]->explorer();
      v.collisions = sim_->simulator().vehicle(k).collision_count();
      r_.collisions += v.collisions;
      if (v.collisions > 0) r_.last_collision = sim_->simulator().vehicle(k).last_collision();
      v.end_rule = e.end_rule();
      v.landing = e.landing();
      v.yields = e.count(ExplorerEvent::kYielded);
      v.plans = static_cast<int>(e.plans());
      v.landed = r_.landed;
      r_.plans += v.plans;
    }
    r_.inter_vehicle_contacts = sim_->simulator().inter_vehicle_collision_count();
    if (controller()) {
      r_.far_start_refusals = controller()->drops().count("refused trajectory (far start)");
    }
    const Explorer& e = explorer().explorer();
    r_.explorer_controller_holds = e.count(ExplorerEvent::kControllerHolds);
    r_.vertical_separation_m = explorer_config_.explorer.min_vertical_separation_m;
    r_.planning_wall_s = e.total_planning_s();
    r_.end_rule = e.end_rule();
    r_.landing = e.landing();
    r_.unlearned_cells = e.unlearned().count();
    r_.unlearned_regions =
        e.unlearned().Regions(explorer().Map().view, 3, &r_.unlearned_entropy_nats);
    SummarisePlans(e);
    r_.scans_applied = mapper_->scans_applied();
    r_.mapper_applied_every_message = mapper_->applied_every_message();
    r_.map_hash = mapper_->map_hash();
    r_.final_entropy_nats = mapper_->entropy_nats();
    if (mc_.compute_quality) {
      r_.quality = Quality();
      sim_->mutable_simulator().SetRayReach(nullptr);
      r_.claims = claims_->Claims(KnownFree(), &reach_->first_reach_s());
    }
  }

  // The first explorer's replans: wall and CPU times, stage medians, the volumetric gain's work.
  void SummarisePlans(const Explorer& e) {
    if (e.plan_times_s().empty()) return;
    std::vector<double> times = e.plan_times_s();
    std::sort(times.begin(), times.end());
    r_.plan_median_s = times[times.size() / 2];
    r_.plan_max_s = times.back();
    std::vector<double> cpu = e.plan_cpu_times_s();
    std::sort(cpu.begin(), cpu.end());
    r_.plan_cpu_median_s = cpu[cpu.size() / 2];
    r_.plan_cpu_max_s = cpu.back();
    auto stage_median = [&](double PlanTimings::*stage) {
      std::vector<double> v;
      for (const PlanTimings& t : e.plan_timings()) v.push_back(t.*stage);
      return Median(std::move(v));
    };
    r_.plan_stage_median_s.projection_s = stage_median(&PlanTimings::projection_s);
    r_.plan_stage_median_s.dijkstra_s = stage_median(&PlanTimings::dijkstra_s);
    r_.plan_stage_median_s.gain_s = stage_median(&PlanTimings::gain_s);
    r_.plan_stage_median_s.trajectory_s = stage_median(&PlanTimings::trajectory_s);
    r_.plan_stage_median_s.total_s = stage_median(&PlanTimings::total_s);
    std::vector<double> bounded, gained;
    long rays = 0, hits = 0;
    for (const VolumetricGainStats& g : e.plan_gain_stats()) {
      bounded.push_back(static_cast<double>(g.poses_bounded));
      gained.push_back(static_cast<double>(g.poses_gained));
      rays += g.rays;
      hits += g.rays_memo_hits;
    }
    r_.plan_positions_bounded_median = Median(std::move(bounded));
    r_.plan_positions_gained_median = Median(std::move(gained));
    r_.plan_ray_memo_fraction =
        rays > 0 ? static_cast<double>(hits) / static_cast<double>(rays) : 0;
  }

  // The files asked for: where the rays reached, the map and its exports, the time series, one
  // row per replan.
  void WriteFiles() {
    if (reach_ && !mc_.reach_path.empty()) {
      std::string error;
      if (!WriteRayReachFile(mc_.reach_path, *reach_, &error)) throw std::runtime_error(error);
    }
    if (!mc_.map_path.empty()) mapper_->SaveMapFile(mc_.map_path);
    if (!mc_.octomap_path.empty()) mapper_->ExportOctoMapFile(mc_.octomap_path);
    if (!mc_.ply_path.empty()) mapper_->ExportPlyFile(mc_.ply_path);
    if (!mc_.csv_path.empty()) WriteMissionCsv(mc_.csv_path, r_);
    if (mc_.plans_csv_path.empty()) return;
    const Explorer& e = explorer().explorer();
    std::ofstream out(mc_.plans_csv_path);
    out << "plan,total_ms,projection_ms,distance_field_ms,gain_ms,trajectory_ms,positions,"
           "positions_bounded,positions_evaluated,cpu_ms\n";
    const std::vector<PlanTimings>& t = e.plan_timings();
    const std::vector<VolumetricGainStats>& g = e.plan_gain_stats();
    const std::vector<double>& cpu = e.plan_cpu_times_s();
    for (size_t i = 0; i < t.size() && i < g.size(); ++i) {
      out << i << "," << 1e3 * t[i].total_s << "," << 1e3 * t[i].projection_s << ","
          << 1e3 * t[i].dijkstra_s << "," << 1e3 * t[i].gain_s << "," << 1e3 * t[i].trajectory_s
          << "," << g[i].positions << "," << g[i].poses_bounded << "," << g[i].poses_gained << ","
          << (i < cpu.size() ? 1e3 * cpu[i] : -1.0) << "\n";
    }
  }

  const MissionConfig& mc_;
  const std::chrono::steady_clock::time_point wall_start_{std::chrono::steady_clock::now()};
  int64_t mission_epoch_{0};
  MissionResult r_;
  // Configuration.
  bool faults_{false};
  ConfigNode sim_cfg_ = ConfigNode::FromString("{}", "(none)");
  SimConfig sim_config_;
  std::vector<std::string> prefixes_{""};
  std::vector<Eigen::Vector3d> offsets_{Eigen::Vector3d::Zero()};
  ConfigNode mapper_cfg_ = ConfigNode::FromString("{}", "(none)");
  MapperConfig mapper_config_;
  ConfigNode explorer_cfg_ = ConfigNode::FromString("{}", "(none)");
  ExplorerNodeConfig explorer_config_;
  ConfigNode controller_cfg_ = ConfigNode::FromString("{}", "(none)");
  ControllerConfig controller_config_;
  std::string state_dir_;
  bool remove_state_dir_{false};
  // The nodes, in one process.
  lcm::LCM lcm_{"memq://"};
  SimClock clock_{1700000000000000};  // a fixed, plausible epoch: stamps are the same every run
  std::unique_ptr<SimNode> sim_;
  std::vector<ControllerConfig> controller_configs_;
  std::vector<std::unique_ptr<ControllerNode>> controllers_;
  std::unique_ptr<MapperNode> mapper_;
  std::vector<ExplorerNodeConfig> explorer_configs_;
  std::vector<std::unique_ptr<ExplorerNode>> explorers_;
  // The log, the watchers, the scorer, the fault relays.
  std::unique_ptr<lcm::LogFile> log_;
  LogWriter writer_;
  GuardedSubscriptions watch_{lcm_};
  bool first_plan_seen_{false};
  std::optional<MapScorer> scorer_;
  std::optional<RayReach> reach_;
  std::optional<ClaimTracker> claims_;
  std::mt19937_64 fault_rng_{static_cast<uint64_t>(mc_.seed) * 7 + 3};
  std::vector<Relay> relays_;
  int64_t outage_begin_{-1};
  int64_t outage_end_{-1};
  // The lockstep's clocks and the flight's running figures.
  int64_t t0_{0};
  int64_t control_period_us_{0};
  int64_t next_control_{0};
  int64_t next_explore_{0};
  int64_t next_sample_{0};
  double next_progress_s_{0.0};
  int64_t takeoff_utime_{-1};
  int64_t land_utime_{-1};
  int reported_collisions_{0};
  double alpha_c_{0.0};
  Eigen::Vector2d start_cell_{Eigen::Vector2d::Zero()};
  Eigen::Vector3d position_{Eigen::Vector3d::Zero()};  // the first vehicle, at the last step
  Eigen::Vector3d position_at_last_step_{Eigen::Vector3d::Zero()};
  std::vector<Eigen::Vector3d> last_positions_;
  double controller_killed_at_{-1};
  double controller_z_kill_{0};
  double controller_z_min_{0};
  double explorer_killed_at_{-1};
  double explorer_restarted_at_{-1};
};

}  // namespace

MissionResult RunMission(const MissionConfig& mc) { return Mission(mc).Run(); }

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
    << "unlearned cells (looked at without learning, not chased): " << r.unlearned_cells;
  if (r.unlearned_cells > 0) s << ", " << r.unlearned_entropy_nats << " nats";
  for (const UnlearnedRegion& u : r.unlearned_regions) {
    s << "; " << u.cells << " around (" << u.centroid_m.x() << ", " << u.centroid_m.y() << ", "
      << u.centroid_m.z() << ") m, mean P " << u.mean_probability;
  }
  s << "\n"
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
    << "claims without grounds: " << r.claims.known_free << " cells known free, of which "
    << r.claims.free_in_solid << " half a cell or more inside a solid, " << r.claims.free_outside
    << " outside the building (not connected to the start), " << r.claims.free_unreached
    << " never reached by a ray; " << r.claims.freed_early << " freed before a ray reached them"
    << " (up to " << r.claims.max_lead_s << " s early)\n"
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
