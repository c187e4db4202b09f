#include "exploration/planner_config.h"

#include <cmath>
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
  }
  return "unknown";
}

void PlannerConfig::Validate() const {
  projection.Validate();
  gain.Validate();
  candidates.Validate();
  trajectory.Validate();
  volumetric.Validate();
  KESTREL_THROW_UNLESS(
      frontier.min_distance_m >= 0.0 && std::isfinite(frontier.min_distance_m),
      "frontier.min_distance_m = " << frontier.min_distance_m << ", accepted [0, inf)");
  KESTREL_THROW_UNLESS(
      frontier.view_min_range_m >= 0.0 && frontier.view_max_range_m > frontier.view_min_range_m &&
          std::isfinite(frontier.view_max_range_m),
      "frontier.view_min_range_m = " << frontier.view_min_range_m
                                     << ", view_max_range_m = " << frontier.view_max_range_m
                                     << ", accepted 0 <= min < max < inf");
  KESTREL_THROW_UNLESS(frontier.goal_max_range_m > frontier.view_min_range_m &&
                           frontier.goal_max_range_m <= frontier.view_max_range_m,
                       "frontier.goal_max_range_m = "
                           << frontier.goal_max_range_m
                           << ", accepted (view_min_range_m = " << frontier.view_min_range_m
                           << ", view_max_range_m = " << frontier.view_max_range_m << "]");
  KESTREL_THROW_UNLESS(
      frontier.horizontal_fov_deg > 0.0 && frontier.horizontal_fov_deg <= 360.0,
      "frontier.horizontal_fov_deg = " << frontier.horizontal_fov_deg << ", accepted (0, 360]");
  KESTREL_THROW_UNLESS(
      frontier.min_frontier_cells >= 1,
      "frontier.min_frontier_cells = " << frontier.min_frontier_cells << ", accepted >= 1");
  KESTREL_THROW_UNLESS(
      startup_vertical_fov_rad > 0.0 && startup_vertical_fov_rad < M_PI,
      "startup_vertical_fov_rad = " << startup_vertical_fov_rad << ", accepted (0, pi)");
}

void VolumetricConfig::Validate() const {
  KESTREL_THROW_UNLESS(std::isfinite(band_below_m) && band_below_m > 0.0,
                       "volumetric.band_below_m = " << band_below_m << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(std::isfinite(band_above_m) && band_above_m > 0.0,
                       "volumetric.band_above_m = " << band_above_m << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(std::isfinite(margin_m) && margin_m >= 0.0,
                       "volumetric.margin_m = " << margin_m << ", accepted [0, inf)");
  KESTREL_THROW_UNLESS(
      std::isfinite(passage_margin_m) && passage_margin_m >= 0.0,
      "volumetric.passage_margin_m = " << passage_margin_m << ", accepted [0, inf)");
  KESTREL_THROW_UNLESS(
      std::isfinite(candidate_spacing_m) && candidate_spacing_m > 0.0,
      "volumetric.candidate_spacing_m = " << candidate_spacing_m << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(std::isfinite(end_gain_nats) && end_gain_nats > 0.0,
                       "volumetric.end_gain_nats = " << end_gain_nats << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(
      std::isfinite(local_horizon_m) && local_horizon_m >= 0.0,
      "volumetric.local_horizon_m = " << local_horizon_m << ", accepted [0, inf) (0: off)");
  KESTREL_THROW_UNLESS(
      std::isfinite(peer_view_radius_m) && peer_view_radius_m > 0.0,
      "volumetric.peer_view_radius_m = " << peer_view_radius_m << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(std::isfinite(preferred_clearance_m) && preferred_clearance_m >= 0.0,
                       "volumetric.preferred_clearance_m = " << preferred_clearance_m
                                                             << ", accepted [0, inf) (0: off)");
  KESTREL_THROW_UNLESS(
      std::isfinite(clearance_weight) && clearance_weight >= 0.0,
      "volumetric.clearance_weight = " << clearance_weight << ", accepted [0, inf) (0: off)");
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
