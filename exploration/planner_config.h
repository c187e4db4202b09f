#pragma once
/// @file
/// What a replan is configured with (config/exploration/explorer.yaml; loaded by
/// exploration/planner_config_io.h): the mode, the paper's projections, gains, candidates and
/// trajectories, the frontier baseline's and the volumetric mode's own parameters.

#include <cmath>

#include "common/param_table.h"

#include "exploration/candidates.h"
#include "exploration/information_gain.h"
#include "exploration/projected_maps.h"
#include "exploration/trajectory_planner.h"
#include "exploration/traversability.h"
#include "exploration/volumetric_gain.h"

namespace kestrel {

/// Which planner and which map predicts the gain.
enum class ExplorationMode {
  kCombined,  ///< B for the gain, C for traversability (the paper's experiment)
  kTwoMap,    ///< E for the gain, C for traversability (the paper's simulation)
  kFrontier,  ///< nearest reachable frontier (Yamauchi 1997), the baseline
  /// 3D expected information gain on the exact map, fine traversability (docs/exploration.md)
  kVolumetric,
  /// The volumetric mode's gains, traversability and end rule, the goal chosen by an open tour
  /// over information sites (docs/exploration.md, "The information tour")
  kVolumetricTour,
};

/// "combined", "two_map", "frontier", "volumetric" or "volumetric_tour" (the names of
/// exploration_status_t.mode).
[[nodiscard]] const char* ModeName(ExplorationMode mode);

/// Whether `mode` plans with the volumetric planner (volumetric or volumetric_tour).
[[nodiscard]] inline bool IsVolumetric(ExplorationMode mode) {
  return mode == ExplorationMode::kVolumetric || mode == ExplorationMode::kVolumetricTour;
}

/// Parameters of the frontier baseline.
struct FrontierConfig {
  /// A frontier cell nearer than this (d_cell, m) is not a goal, so the vehicle does not stay in
  /// place; default 0: any cell but the vehicle's own (d_cell > 0).
  double min_distance_m{0.0};
  /// true: frontiers on the fine traversability of the volumetric mode (the fair baseline, same
  /// search and trajectories); false: on the paper's collision map C.
  bool fine_traversability{true};
  // Fine frontiers only (exploration/frontiers.h): what a goal must see.
  double view_min_range_m{0.7};  ///< frontier cells nearer than this are not seen, m
  double view_max_range_m{4.0};  ///< frontier cells farther than this are not seen, m
  /// A goal sees some frontier cell at most this far (view_min_range_m < this <= view_max_range_m),
  /// m: a reached goal covers cells to view_max_range_m, so the next goal on the same stretch of
  /// frontier lies at least the difference farther on (no crawl along it one cell at a time).
  double goal_max_range_m{2.5};
  double horizontal_fov_deg{58.0};  ///< the camera's horizontal field of view, deg
  int min_frontier_cells{1};        ///< a goal sees at least this many frontier cells (>= 1)
};

/// Parameters of the volumetric mode (docs/exploration.md) beyond those it shares: the height,
/// C_thresh and P_init come from `projection`, the vehicle radius from `trajectory`, the bump and
/// switch margin from `candidates`.
struct VolumetricConfig {
  /// Vehicle band below h checked for traversability, m (> 0): the body's half height (0.075 m),
  /// the dip of its rim at 10 deg of tilt (0.44 sin 10 deg = 0.076 m) and one map cell for the
  /// top of a thin or pointed object that the map resolves only below its tip (docs/exploration.md,
  /// "Traversability").
  double band_below_m{0.25};
  double band_above_m{0.15};  ///< vehicle band above h, m (> 0)
  double margin_m{0.10};      ///< clearance beyond the vehicle radius, m (>= 0)
  /// Clearance beyond the vehicle radius, to the blocked cells' surfaces, at a passage point (a
  /// point on a gap's middle line, at any angle), m (>= 0; docs/exploration.md,
  /// "Traversability"; exploration/traversability.h, step 3b).
  double passage_margin_m{0.0125};
  /// Paths prefer this much clearance beyond radius + margin where the space allows, m (>= 0;
  /// 0: off): Dijkstra's steps weigh 1 + clearance_weight s^2, s the shortfall's fraction of this
  /// (docs/exploration.md, "Traversability"; exploration/traversability.h, step 4).
  double preferred_clearance_m{0.30};
  double clearance_weight{2.0};      ///< the step weight at the required clearance, minus 1 (>= 0)
  double candidate_spacing_m{0.75};  ///< candidate positions every this many m (>= one cell)
  /// The paper's end rule, working: exploration ends when the best UNWEIGHTED 3D gain of every
  /// reachable candidate pose is below this, nats (> 0).
  double end_gain_nats{4.0};
  /// Local first (docs/exploration.md, "Choosing the next pose"), m (0 = off): the goal is the
  /// best gain x bump with the bump's d_max (eq. 17) at most this, among the poses worth
  /// end_gain_nats, so that a large building does not flatten the bump (d_max grows with the
  /// farthest reachable cell) and the flight does not wander among poses the end rule already
  /// calls explored; only when no pose within it is worth end_gain_nats is the choice made over
  /// every pose with the paper's d_max.
  double local_horizon_m{0.0};
  /// A candidate pose (position within candidate_spacing_m / 2, heading within half a step) that
  /// the vehicle has reached as a goal (PlannerInput::reached_goals) while facing the goal's
  /// heading (within half a step, PlannerInput::reached_views) keeps no gain, in the choice and
  /// in the end rule: a gain the model still predicts after the flight looked from there is one
  /// the sensor does not collect (docs/exploration.md, "Ending and the flight home").
  bool skip_viewed_poses{true};
  /// Likewise for every pose the vehicle has flown through (PlannerInput::flown_views: position
  /// within candidate_spacing_m / 2, its heading in the candidate heading's half-step window):
  /// the camera looked from there on the way, not only at goals.
  bool skip_flown_poses{true};
  /// Several vehicles (docs/exploration.md, "Several vehicles"): a candidate position within this
  /// of another vehicle's goal (PlannerInput::peer_goals), in sight of it over the band, has its
  /// objective discounted by 1 - d / peer_view_radius_m for each such goal (Burgard et al. 2005's
  /// linear visibility discount; at most to 0), m (> 0). The end rule ignores the discount.
  double peer_view_radius_m{3.0};
  /// Mode volumetric_tour (docs/exploration.md, "The information tour"): the edge of the square
  /// tiles that group candidate poses into information sites, m (> 0).
  double tour_site_m{4.0};
  /// The sites the tour orders, at most (the largest gains; >= 1).
  int tour_max_sites{20};
  /// The site-to-site travel times on a grid coarser by this factor (1: the fine cells; >= 1).
  int tour_coarsen{4};
  /// Prize-collecting tour, nats per second of travel (0: off, every site is visited): the tour
  /// minimises this x travel time - the sites' best gains collected, so a site whose gain does not
  /// pay for its detour waits (>= 0). When it leaves every site out, the plain tour decides.
  double tour_prize_weight{0.0};
  VolumetricGainConfig gain;  ///< sensors' 3D rays (gain.sensors' vertical keys), azimuth bins

  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// Everything a replan needs to know, validated as a whole.
struct PlannerConfig {
  ExplorationMode mode{ExplorationMode::kVolumetric};  ///< planner and gain map
  ProjectionConfig projection;                         ///< eqs. (11)-(16)
  GainConfig gain;                                     ///< eq. (10) sensors, rays, weighting
  CandidateConfig candidates;                          ///< lattice, headings, bump, end test
  TrajectoryConfig trajectory;                         ///< limits, order, disc radius
  FrontierConfig frontier;                             ///< baseline only
  VolumetricConfig volumetric;                         ///< volumetric mode (and fine frontiers)
  /// Vertical field of view of the camera for the start-up radius of section 8, rad (Xtion 45 deg).
  double startup_vertical_fov_rad{45.0 * M_PI / 180.0};

  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// The scalar keys of the `frontier:` section, with their ranges (common/param_table.h): the
/// loader (planner_config_io.h) and Validate take each key's range from here.
[[nodiscard]] const ParamTable<FrontierConfig>& FrontierParams();
/// The scalar keys of the `volumetric:` section (but gain.azimuth_bins), with their ranges.
[[nodiscard]] const ParamTable<VolumetricConfig>& VolumetricParams();

/// The fine traversability parameters of `config` (volumetric keys, height, C_thresh, P_init,
/// vehicle radius).
[[nodiscard]] TraversabilityConfig FineTraversabilityConfig(const PlannerConfig& config);

}  // namespace kestrel
