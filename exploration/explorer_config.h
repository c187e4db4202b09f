#pragma once
/// @file
/// Configuration of the explorer (config/exploration/explorer.yaml): ExplorerConfig, what the
/// pure Explorer (exploration/explorer.h) decides with, and ExplorerNodeConfig, that plus the
/// node's wiring (channels, prefixes, state file, publishing rates), as mapping/mapper_config.h
/// and control/controller_node.h do. The scalar keys of the `explorer:` section are one table
/// (common/param_table.h): the loader and Validate take each key's range from it, the defaults
/// are the members below, and tests/exploration/explorer_config_test.cc checks that the
/// reference YAML file states the same defaults and describes every key.

#include <string>
#include <vector>

#include "common/param_table.h"
#include "exploration/planner.h"
#include "exploration/startup_turn.h"
#include "mapping/grid.h"

namespace kestrel {

class ConfigNode;

/// What the explorer decides with (units in the names; the `explorer:` keys of the YAML file).
struct ExplorerConfig {
  PlannerConfig planner;  ///< config/exploration/explorer.yaml (planning)
  MapLimits map;          ///< the mapper's lattice (limits, resolution)
  double p_init{0.1};     ///< the mapper's P_init

  /// Several vehicles (docs/exploration.md, "Several vehicles"): the other vehicles, by their
  /// channel prefixes. The explorer reads each one's pose and trajectory, discounts the candidates
  /// in view of its goal (VolumetricConfig::peer_view_radius_m) and publishes no trajectory that
  /// comes nearer to it than min_separation_m (a vehicle yields: it keeps or stops its flight and
  /// plans again). Empty for one vehicle.
  std::vector<std::string> peers;
  /// Smallest horizontal distance to another vehicle a published trajectory may plan, m
  /// (> 0; docs/exploration.md, "Several vehicles"). Where two vehicles are already nearer, a
  /// trajectory may not bring them nearer still.
  double min_separation_m{1.2};
  /// Two vehicles whose heights differ by this much are clear of each other whatever their
  /// horizontal distance (one flies over a landed one), m (> 0).
  double min_vertical_separation_m{0.6};
  /// Yielding to another vehicle is not a failed plan for this long in a row, s (> 0); after it,
  /// each refused plan counts as a failure (max_failed_plans, max_home_attempts).
  double max_yield_s{60.0};

  double startup_yaw_rate_radps{0.8};  ///< peak yaw rate of the start-up full circle, rad/s
  double height_tolerance_m{0.25};     ///< hovering within this of h counts as "at height", m
  /// true: the start-up turn overlaps the climb (docs/exploration.md, "Start-up: the turn while
  /// climbing"): it starts once the controller is in TAKEOFF and the vehicle is
  /// startup_min_rise_m above the lowest height seen while waiting. false (default): the turn
  /// starts in HOLD within height_tolerance_m of h, after the climb; the overlap saves little
  /// time and, seen from below h, can leave the band around the take-off unseen, so that the gain
  /// rule ends exploration early (measured in docs/exploration.md, same section).
  bool startup_while_climbing{false};
  double startup_min_rise_m{0.3};  ///< see startup_while_climbing, m (> 0)
  /// How the heading turns (exploration/startup_turn.h): smoothstep (one degree-7 smoothstep of
  /// the heading) or ramped (ramps of the rate and a cruise at the peak: an earlier first plan,
  /// but not an earlier 95% known; docs/exploration.md, "Start-up: the turn while climbing").
  StartupYawProfile startup_yaw_profile{StartupYawProfile::kSmoothstep};
  double replan_period_s{1.0};  ///< replan at least this often while flying, s...
  /// ...unless the trajectory ends within this, s: a replan near the goal (often while the
  /// vehicle turns to the goal's heading in the goal's cell, which is no candidate) would pick
  /// another goal before this one is reached, again and again.
  double replan_min_remaining_s{0.0};
  /// Progress stall (Kestrel's addition; 0 disables): exploration also ends when the number of
  /// known 3D cells (P < P_init / 2 or P > 0.5, docs/algorithms.md §12.2's rule on the
  /// explorer's own map) grew by less than end_stall_min_growth of itself over this window, s.
  /// The gain-based tests alone may never end in a cluttered world: cells no sensor can see keep
  /// a little predicted gain that the vehicle chases round the rooms.
  double end_stall_window_s{120.0};
  double end_stall_min_growth{0.005};  ///< see end_stall_window_s, fraction in [0, 1)
  /// Whether the progress-stall rule also ends the volumetric mode. Off: its own end rule does
  /// (docs/exploration.md, "Ending and the flight home": a reached pose keeps no gain, so the
  /// poses it can chase are finite); in a large world the stall rule ended it while whole rooms
  /// were left (docs/STATUS.md has the figures).
  bool end_stall_in_volumetric{false};
  double safety_check_period_s{0.5};  ///< how often the remaining path is re-checked, s
  /// Non-stop flight (docs/exploration.md, "Non-stop flight"): a replan while a trajectory is
  /// flown starts from the state the trajectory predicts replan_lookahead_s ahead, and the
  /// published trajectory is the flown one up to then, spliced to the new one (continuous in
  /// position, velocity and acceleration): the vehicle never stops to replan.
  bool nonstop{true};
  double replan_lookahead_s{1.0};     ///< s (> 0; longer than the slowest replan)
  int max_home_attempts{5};           ///< failed plans home before landing where the vehicle is
  double flown_path_spacing_m{0.25};  ///< the flown corridor keeps a point every this many m
  double retry_period_s{1.0};         ///< wait after a failed plan, s
  int max_failed_plans{5};            ///< consecutive failures before returning home
  /// An end rule that holds while the take-off point is unreachable (fine modes) is deferred this
  /// many times in a row, retry_period_s apart, the vehicle stopped (docs/exploration.md, "Ending
  /// and the flight home"): map noise closed a way the vehicle flew, and the verdict covers only
  /// part of the building. 0: never deferred.
  int max_end_deferrals{5};
  bool return_home{true};  ///< fly back to the take-off point at the end
  bool land_at_end{true};  ///< then send a land command
  /// Unlearned cells (docs/exploration.md, "Unlearned cells"; exploration/unlearned_cells.h), the
  /// volumetric mode only: at each exploration replan the cells in the sensors' view from the
  /// vehicle's pose are looked at, and a cell whose entropy has not dropped by
  /// unlearned_min_entropy_drop_nats over this many looks in a row is read as certain by the
  /// gain from then on (it is reported, not chased). 0: off (the gain reads the map as it is).
  int unlearned_looks{0};
  double unlearned_min_entropy_drop_nats{0.05};  ///< see unlearned_looks, nats (>= 0)
  /// The view of a look: azimuths every 2 pi / unlearned_azimuth_bins inside each sensor's field
  /// of view, unlearned_rows elevations over a camera's vertical one.
  int unlearned_azimuth_bins{360};
  int unlearned_rows{24};  ///< see unlearned_azimuth_bins

  /// While exploring or returning: the controller holding this long after the latest trajectory
  /// was sent without flying it makes the explorer replan from the flown state, s (> 0).
  double controller_hold_replan_s{0.5};

  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// The explorer process: the explorer and its wiring.
struct ExplorerNodeConfig {
  ExplorerConfig explorer;  ///< what it decides with

  std::string map_channel{"MAP3D"};
  std::string delta_channel{"MAP3D_DELTA"};
  std::string pose_channel{"POSE_VICON"};
  std::string controller_channel{"CONTROLLER_STATUS"};
  std::string trajectory_channel{"TRAJECTORY"};
  std::string status_channel{"EXPLORATION_STATUS"};
  std::string command_channel{"COMMAND"};
  std::string map2d_prefix{"MAP2D_"};  ///< + COLLISION, COMBINED, ENTROPY
  std::string heartbeat_channel{"HEARTBEAT_EXPLORER"};
  /// Several vehicles (docs/exploration.md, "Several vehicles"): this vehicle's prefix, put
  /// before the pose, controller, trajectory, status, command, 2D map and heartbeat channels above
  /// ("" for one vehicle; the map channels are shared). The other vehicles are explorer.peers.
  std::string vehicle_prefix;
  int max_status_candidates{512};  ///< candidates listed in EXPLORATION_STATUS (best first)
  /// The 2D maps go out at most this often, s (0: with every plan). The volumetric mode's band is
  /// at the map's resolution (its size per message: docs/STATUS.md); at 1 Hz replans that traffic
  /// crowded the receive buffers of every process on the multicast group.
  double map2d_period_s{5.0};
  /// The explorer's state file ("" = none: a restarted explorer starts WAITING, as on a first
  /// start; docs/design.md §2.5).
  std::string state_path;
  /// The run this explorer belongs to; "" = a fresh id, which resumes nothing. kestrel-explorer
  /// fills it from $KESTREL_RUN_ID when unset.
  std::string run_id;

  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// The scalar keys of the `explorer:` section that ExplorerConfig holds, with their ranges.
[[nodiscard]] const ParamTable<ExplorerConfig>& ExplorerParams();
/// The scalar keys of the `explorer:` section that ExplorerNodeConfig holds, with their ranges.
[[nodiscard]] const ParamTable<ExplorerNodeConfig>& ExplorerNodeParams();

/// Reads an ExplorerNodeConfig: the planner keys of config/exploration/explorer.yaml, its `map:`
/// section (the mapper's lattice and P_init) and its `explorer:` section, then validates it.
/// @throws ConfigError naming the file, the key, the value and the accepted range.
[[nodiscard]] ExplorerNodeConfig LoadExplorerNodeConfig(const ConfigNode& node);

/// Whether the progress-stall rule may end exploration in `mode` (ExplorerConfig::
/// end_stall_window_s, end_stall_in_volumetric).
[[nodiscard]] bool StallRuleApplies(ExplorationMode mode, const ExplorerConfig& config);

}  // namespace kestrel
