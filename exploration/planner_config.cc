#include "exploration/planner_config.h"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "common/check.h"

namespace kestrel {

const char* ModeName(ExplorationMode mode) {
  switch (mode) {
    case ExplorationMode::kCombined:
      return "combined";
    case ExplorationMode::kTwoMap:
      return "two_map";
    case ExplorationMode::kFrontier:
      return "frontier";
    case ExplorationMode::kVolumetric:
      return "volumetric";
    case ExplorationMode::kVolumetricTour:
      return "volumetric_tour";
  }
  return "unknown";
}

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
// Finite numbers above 0, or at least 0.
const Range kPositive{0.0, kInf, false, false};
const Range kNonNegative{0.0, kInf, true, false};
}  // namespace

const ParamTable<FrontierConfig>& FrontierParams() {
  using C = FrontierConfig;
  static const ParamTable<C> table{{
      {"min_distance_m", &C::min_distance_m, kNonNegative},
      {"fine_traversability", &C::fine_traversability},
      {"view_min_range_m", &C::view_min_range_m, kNonNegative},
      {"view_max_range_m", &C::view_max_range_m, kPositive},
      {"goal_max_range_m", &C::goal_max_range_m, kPositive},
      {"horizontal_fov_deg", &C::horizontal_fov_deg, Range{0.0, 360.0, false, true}},
      {"min_frontier_cells", &C::min_frontier_cells, Range::Closed(1, 1000000)},
  }};
  return table;
}

const ParamTable<VolumetricConfig>& VolumetricParams() {
  using C = VolumetricConfig;
  static const ParamTable<C> table{{
      {"band_below_m", &C::band_below_m, kPositive},
      {"band_above_m", &C::band_above_m, kPositive},
      {"margin_m", &C::margin_m, kNonNegative},
      {"passage_margin_m", &C::passage_margin_m, kNonNegative},
      {"preferred_clearance_m", &C::preferred_clearance_m, kNonNegative},
      {"clearance_weight", &C::clearance_weight, kNonNegative},
      {"candidate_spacing_m", &C::candidate_spacing_m, kPositive},
      {"end_gain_nats", &C::end_gain_nats, kPositive},
      {"local_horizon_m", &C::local_horizon_m, kNonNegative},
      {"skip_viewed_poses", &C::skip_viewed_poses},
      {"skip_flown_poses", &C::skip_flown_poses},
      {"peer_view_radius_m", &C::peer_view_radius_m, kPositive},
      {"tour_site_m", &C::tour_site_m, kPositive},
      {"tour_max_sites", &C::tour_max_sites, Range::Closed(1, 1000)},
      {"tour_coarsen", &C::tour_coarsen, Range::Closed(1, 64)},
      {"tour_prize_weight", &C::tour_prize_weight, kNonNegative},
  }};
  return table;
}

void PlannerConfig::Validate() const {
  projection.Validate();
  gain.Validate();
  candidates.Validate();
  trajectory.Validate();
  volumetric.Validate();
  CheckParams("frontier", FrontierParams(), frontier);
  // The ranges that depend on each other.
  KESTREL_THROW_UNLESS(
      frontier.view_max_range_m > frontier.view_min_range_m,
      "frontier.view_min_range_m = " << frontier.view_min_range_m << ", view_max_range_m = "
                                     << frontier.view_max_range_m << ", accepted min < max");
  KESTREL_THROW_UNLESS(frontier.goal_max_range_m > frontier.view_min_range_m &&
                           frontier.goal_max_range_m <= frontier.view_max_range_m,
                       "frontier.goal_max_range_m = "
                           << frontier.goal_max_range_m
                           << ", accepted (view_min_range_m = " << frontier.view_min_range_m
                           << ", view_max_range_m = " << frontier.view_max_range_m << "]");
  KESTREL_THROW_UNLESS(
      startup_vertical_fov_rad > 0.0 && startup_vertical_fov_rad < M_PI,
      "startup_vertical_fov_rad = " << startup_vertical_fov_rad << ", accepted (0, pi)");
}

void VolumetricConfig::Validate() const {
  CheckParams("volumetric", VolumetricParams(), *this);
  gain.Validate();
}

TraversabilityConfig FineTraversabilityConfig(const PlannerConfig& config) {
  TraversabilityConfig t;
  t.height_m = config.projection.height_m;
  t.band_below_m = config.volumetric.band_below_m;
  t.band_above_m = config.volumetric.band_above_m;
  t.vehicle_radius_m = config.trajectory.vehicle_radius_m;
  t.margin_m = config.volumetric.margin_m;
  t.passage_margin_m = config.volumetric.passage_margin_m;
  t.free_threshold = config.projection.collision_threshold;
  t.p_init = config.projection.p_init;
  t.preferred_extra_m = config.volumetric.preferred_clearance_m;
  t.clearance_weight = config.volumetric.clearance_weight;
  return t;
}

}  // namespace kestrel
