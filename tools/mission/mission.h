#pragma once
/// @file
/// The whole system in one process, deterministic: kestrel-sim's SimNode, the
/// controller, the mapper and the explorer over memq:// with the simulator's clock, in lockstep.
/// The same seed gives the same messages and the same map, bit for bit. Used by the CI
/// regression (tests/system/mission_test.cc), scripts/regress and scripts/demo's summary.

#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "exploration/planner.h"
#include "exploration/unlearned_cells.h"
#include "mapping/map_quality.h"
#include "sim/world.h"
#include "tools/map_score/map_claims.h"

namespace kestrel {

struct MissionConfig {
  std::string root{"."};  ///< repository root (relative config paths start here)
  std::string sim_file{"config/sim/sim.yaml"};
  std::string world_file{"config/worlds/lasr.yaml"};
  std::string mapper_file{"config/mapper.yaml"};
  std::string explorer_file{"config/exploration/explorer.yaml"};
  std::string controller_file;             ///< "" = defaults
  std::vector<std::string> sim_overrides;  ///< --set style, applied to the sim file
  std::vector<std::string> mapper_overrides;
  std::vector<std::string> explorer_overrides;
  int64_t seed{1};
  double max_time_s{400.0};      ///< simulated seconds before giving up
  double takeoff_at_s{0.5};      ///< the take-off command (as kestrel-cmd sends it), s after start
  double quality_period_s{5.0};  ///< known fraction / entropy sampling period, s
  bool compute_quality{true};    ///< ground truth and observable cells (section 10)
  std::string log_path;          ///< every message, as an LCM log (lcm-logplayer replays it)
  /// The tool's command line, recorded with each node's configuration (params_t on
  /// PARAMS_SIM, PARAMS_CONTROLLER, PARAMS_MAPPER, PARAMS_EXPLORER) at the start of the log.
  std::vector<std::string> command_line;
  std::string csv_path;        ///< time series (t, entropy, known fraction, ...) if set
  std::string plans_csv_path;  ///< one row per plan (stage times, positions) if set
  std::string map_path;        ///< final map file (Kestrel map) if set
  /// The cells the simulator's rays reached and when (sim/ray_reach.h), written here if set
  /// (kestrel-fidelity and kestrel-map-score read it); needs compute_quality.
  std::string reach_path;
  std::string octomap_path;  ///< final map exported for OctoMap tools (.bt or .ot) if set
  std::string ply_path;      ///< occupied cells as a PLY point cloud if set
  bool verbose{false};       ///< every plan, collision and sample on stderr (debugging)
  /// > 0: one progress line on stderr at most this often (simulated s, at the quality samples):
  /// time, explorer state, known fraction, map entropy, path, collisions.
  double progress_period_s{0.0};
  // Faults, injected between the simulator and the other nodes.
  double sensor_drop_fraction{0.0};  ///< drop this fraction of depth images and scans (seeded)
  double mocap_outage_at_s{-1.0};    ///< motion capture lost from this time (s after start)...
  double mocap_outage_s{0.0};        ///< ...for this long (poses not delivered)
  /// Process kills (docs/design.md §2.5), first vehicle only: the controller node destroyed at
  /// this time (s after start; < 0: never), no motor commands for controller_down_s (the
  /// runner's respawn gap), then a new controller node with the same state file and run id.
  double controller_kill_at_s{-1.0};
  double controller_down_s{1.0};  ///< s
  /// The same for the explorer node (its state file kept; the map comes from the mapper).
  double explorer_kill_at_s{-1.0};
  double explorer_down_s{2.0};  ///< s
  /// The explorer is killed at the first moment after explorer_kill_at_s, while it explores (or
  /// 60 s later whatever it does), when the trajectory the controller flies ends within this, s
  /// (so that the controller's hold is seen while it is down; infinite: at explorer_kill_at_s).
  double explorer_kill_max_left_s{std::numeric_limits<double>::infinity()};
  /// Only while the explorer returns home (RETURNING), whenever that is.
  bool explorer_kill_returning{false};
  /// Folder of the controller's and the explorer's state files when a kill is asked ("": a new
  /// folder under /tmp, removed at the end).
  std::string state_dir;
  /// Several vehicles (docs/exploration.md, "Several vehicles"), 1 to 4: vehicle k has the
  /// channel prefix V<k+1>_, its own controller and explorer; one mapper fuses them all. With 1,
  /// the run is the one-vehicle run (no prefixes).
  int vehicles{1};
  /// Each further vehicle starts this far from the others (and from the world's start), at the
  /// first of a fixed list of offsets whose vehicle disc is clear of obstacles up to above the
  /// flight height (VehicleStartOffsets), m.
  double vehicle_spacing_m{1.5};
  /// > 0: stop the run once the known fraction reaches this (time and path to 95% need no more).
  double stop_at_known{0.0};
  /// Asked after every simulated step: true ends the run there (kestrel-mission: SIGINT or
  /// SIGTERM arrived); the figures and files are then those of the flight so far. Empty: never.
  std::function<bool()> stop_requested;
};

/// Start offsets (x, y, 0) from the world's start for `vehicles` vehicles of `diameter_m`: the
/// first is 0; each further one the first of the offsets spacing_m x (0, 1), (0, -1), (1, 0),
/// (-1, 0), (1, 1), (-1, 1), (1, -1), (-1, -1), then twice those, that is at least spacing_m from
/// the ones before, inside the map, and whose disc (radius diameter_m / 2 + 0.2 m) is free of
/// obstacles from 5 cm above the start's floor to 0.3 m above height_m. @throws
/// std::invalid_argument if no such place is found.
[[nodiscard]] std::vector<Eigen::Vector3d> VehicleStartOffsets(const World& world, int vehicles,
                                                               double spacing_m, double diameter_m,
                                                               double height_m);

/// One vehicle's part of a mission.
struct MissionVehicle {
  std::string prefix;  ///< its channel prefix ("" with one vehicle)
  Eigen::Vector3d start_offset_m{Eigen::Vector3d::Zero()};
  double path_length_m{0};  ///< flown distance (true state)
  double path_to_95_m{-1};  ///< flown when the map first reached 95% known (-1: never)
  int collisions{0};        ///< with obstacles and the floor
  std::string end_rule;     ///< Explorer::end_rule
  std::string landing;      ///< Explorer::landing
  int64_t yields{0};        ///< plans refused by the separation check
  int plans{0};
  bool landed{false};
};

/// One row of the time series.
struct MissionSample {
  double time_s{0};
  double entropy_nats{0};
  double known_fraction{0};
  double accuracy{0};
  Eigen::Vector3d position_m{Eigen::Vector3d::Zero()};
  int explorer_state{0};
};

struct MissionResult {
  double sim_time_s{0};           ///< simulated time at the end
  double wall_time_s{0};          ///< wall time of the run
  double exploration_time_s{-1};  ///< take-off to the explorer's land command (-1: never)
  bool landed{false};             ///< the controller ended in IDLE after the land command
  int collisions{0};              ///< collision episodes (obstacles and floor crashes)
  std::string last_collision;     ///< obstacle of the latest collision ("floor": a crash)
  double path_length_m{0};        ///< flown distance (true state)
  int plans{0};
  double planning_wall_s{0};  ///< total wall time of all plans
  int64_t scans_applied{0};
  size_t mapper_queue_max{0};  ///< most scans waiting in the mapper's queue at once
  bool mapper_applied_every_message{false};
  uint64_t map_hash{0};
  double final_entropy_nats{0};
  MapQuality quality;  ///< at the end (section 10), if computed
  /// Cells the final map claims free without grounds (tools/map_score/map_claims.h), with the
  /// freed-early figures from the quality samples, if quality is computed.
  MapClaims claims;
  double time_to_95_s{-1};  ///< first sample with known fraction >= 0.95 (-1: never)
  std::vector<MissionSample> samples;
  std::string end_reason;
  bool interrupted{false};  ///< config.stop_requested ended the run before its end
  std::string end_rule;     ///< what ended exploration (Explorer::end_rule)
  /// Cells the explorer stopped chasing because looking at them taught nothing
  /// (Explorer::unlearned), their entropy in the final map, nats, and where the largest lie.
  size_t unlearned_cells{0};
  double unlearned_entropy_nats{0.0};
  std::vector<UnlearnedRegion> unlearned_regions;
  std::string landing;          ///< "returned home (...)" or "landed elsewhere: ..."
  double plan_median_s{0};      ///< median wall time of an exploration replan
  double plan_max_s{0};         ///< slowest exploration replan
  double plan_cpu_median_s{0};  ///< median CPU time of the planning thread per replan
  double plan_cpu_max_s{0};     ///< largest CPU time of a replan
  /// Median of each planner stage over the exploration replans (PlanTimings), s.
  PlanTimings plan_stage_median_s;
  double plan_positions_bounded_median{0};  ///< volumetric: positions bounded per replan
  double plan_positions_gained_median{0};   ///< volumetric: positions evaluated exactly
  double plan_ray_memo_fraction{0};         ///< volumetric: rays whose I_ray came from a memo
  /// Largest |z - h| of the true vehicle while exploring or flying home, m (h: the exploration
  /// height): trajectories stay in the plane their checks assume.
  double max_height_error_m{0};
  int64_t sensor_messages_dropped{0};  ///< by the fault injection
  int64_t poses_dropped{0};            ///< by the motion-capture outage
  bool tracked_after_outage{false};    ///< the controller was in TRACK after the outage
  /// The explorer's first plan after the start-up turn chose a goal (a trajectory was sent).
  bool first_plan_chose_goal{false};
  /// Simulated time of that first exploration plan, s from the start (-1: none).
  double first_plan_time_s{-1};
  /// The vehicle's (x, y) left the collision cell (docs/algorithms.md §7.1, edge alpha_C from the
  /// map's lower corner) that holds the take-off point, at some time of the flight.
  bool left_start_collision_cell{false};
  /// An EXPLORATION_STATUS message said DONE (what processes watching the explorer rely on).
  bool done_status_published{false};
  /// Every vehicle, in order (one with one vehicle).
  std::vector<MissionVehicle> vehicles;
  double path_to_95_m{-1};  ///< all vehicles' flown distance when the map reached 95% known
  /// Smallest horizontal distance between two vehicles' true centres over the run while their
  /// heights differ by less than the explorers' min_vertical_separation_m (the separation the
  /// explorers keep), m (infinite with one vehicle, or if never).
  double min_separation_m{std::numeric_limits<double>::infinity()};
  /// Smallest 3D distance between two vehicles' true centres (one flying over a landed one
  /// included), m (infinite with one vehicle).
  double min_distance_3d_m{std::numeric_limits<double>::infinity()};
  double vertical_separation_m{0.0};  ///< the explorers' min_vertical_separation_m, m
  int inter_vehicle_contacts{0};      ///< contacts between vehicles (the simulator's count)
  /// Farthest the first vehicle went outside the controller's geofence over the run, m (<= 0:
  /// never outside).
  double max_geofence_excursion_m{-1e9};
  // The controller kill (controller_kill_at_s).
  double controller_time_to_hold_s{-1};  ///< kill -> the new controller in HOLD, s (-1: never)
  double controller_height_lost_m{0};    ///< height at the kill - lowest height in the 3 s after
  std::string controller_takeover;       ///< the new controller's takeover status
  /// Respawn -> the new controller accepts a trajectory (the explorer replanned), s (-1: never).
  double controller_track_after_s{-1};
  // The explorer kill (explorer_kill_at_s).
  /// The trajectory flown at the kill ended this long after it, s (< 0: before it).
  double explorer_kill_trajectory_left_s{0};
  bool explorer_down_held{false};              ///< the controller reached HOLD while it was down
  bool explorer_down_flight_kept{true};        ///< ...and was in TRACK or HOLD all the while
  double explorer_down_hold_max_speed_mps{0};  ///< largest true speed in that HOLD, m/s
  /// Restart -> the controller tracks a trajectory of the new explorer, s (-1: never).
  double explorer_first_trajectory_s{-1};
  std::string explorer_resume;                 ///< the new explorer's resume status
  bool explorer_startup_after_restart{false};  ///< the new explorer flew a start-up turn
  double explorer_killed_at_s{-1};             ///< when it was killed, s after start (-1: never)
  /// Far-start trajectories the (last) controller refused, and the explorer's replans after the
  /// controller held without flying its trajectory.
  int64_t far_start_refusals{0};
  int64_t explorer_controller_holds{0};
};

/// Runs a mission. @throws ConfigError / std::invalid_argument on bad configuration.
MissionResult RunMission(const MissionConfig& config);

/// Writes the time series as CSV.
void WriteMissionCsv(const std::string& path, const MissionResult& result);

/// A short human-readable summary.
std::string MissionSummary(const MissionResult& result);

}  // namespace kestrel
