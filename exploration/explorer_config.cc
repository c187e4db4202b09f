#include "exploration/explorer_config.h"

#include <stdexcept>

#include "common/check.h"
#include "common/config.h"
#include "common/identity.h"
#include "common/vehicle_prefixes.h"
#include "exploration/planner_config_io.h"
#include "mapping/mapping_config.h"

namespace kestrel {

const ParamTable<ExplorerConfig>& ExplorerParams() {
  using C = ExplorerConfig;
  static const ParamTable<C> table{{
      {"startup_yaw_rate_radps", &C::startup_yaw_rate_radps, Range::Positive()},
      {"height_tolerance_m", &C::height_tolerance_m, Range::Positive()},
      {"startup_while_climbing", &C::startup_while_climbing},
      {"startup_min_rise_m", &C::startup_min_rise_m, Range::Positive()},
      {"replan_period_s", &C::replan_period_s, Range::Positive()},
      {"replan_min_remaining_s", &C::replan_min_remaining_s, Range::NonNegative()},
      {"end_stall_window_s", &C::end_stall_window_s, Range::NonNegative()},
      {"end_stall_min_growth", &C::end_stall_min_growth, Range{0.0, 1.0, true, false}},
      {"end_stall_in_volumetric", &C::end_stall_in_volumetric},
      {"safety_check_period_s", &C::safety_check_period_s, Range::Positive()},
      {"retry_period_s", &C::retry_period_s, Range::Positive()},
      {"nonstop", &C::nonstop},
      {"replan_lookahead_s", &C::replan_lookahead_s, Range::Positive()},
      {"max_home_attempts", &C::max_home_attempts, Range::Closed(1, 1000)},
      {"flown_path_spacing_m", &C::flown_path_spacing_m, Range::Positive()},
      {"max_failed_plans", &C::max_failed_plans, Range::Closed(1, 1000)},
      {"max_end_deferrals", &C::max_end_deferrals, Range::Closed(0, 1000)},
      {"return_home", &C::return_home},
      {"land_at_end", &C::land_at_end},
      {"min_separation_m", &C::min_separation_m, Range::Positive()},
      {"min_vertical_separation_m", &C::min_vertical_separation_m, Range::Positive()},
      {"max_yield_s", &C::max_yield_s, Range::Positive()},
      {"controller_hold_replan_s", &C::controller_hold_replan_s, Range::Positive()},
      {"unlearned_looks", &C::unlearned_looks, Range::Closed(0, 254)},
      {"unlearned_min_entropy_drop_nats", &C::unlearned_min_entropy_drop_nats,
       Range::NonNegative()},
      {"unlearned_azimuth_bins", &C::unlearned_azimuth_bins, Range::Closed(1, 36000)},
      {"unlearned_rows", &C::unlearned_rows, Range::Closed(1, 1000)},
  }};
  return table;
}

const ParamTable<ExplorerNodeConfig>& ExplorerNodeParams() {
  using C = ExplorerNodeConfig;
  static const ParamTable<C> table{{
      {"max_status_candidates", &C::max_status_candidates, Range::Closed(1, 100000)},
      {"map2d_period_s", &C::map2d_period_s, Range::NonNegative()},
  }};
  return table;
}

void ExplorerConfig::Validate() const {
  planner.Validate();
  map.Validate();
  KESTREL_THROW_UNLESS(p_init > 0 && p_init < 1, "map.p_init = " << p_init << " must be in (0, 1)");
  CheckParams("explorer", ExplorerParams(), *this);
  KESTREL_THROW_UNLESS(unlearned_looks != 1,
                       "explorer.unlearned_looks = 1: a look only sets the reference; accepted 0 "
                       "(off) or [2, 254]");
  for (size_t i = 0; i < peers.size(); ++i) {
    for (size_t j = 0; j < i; ++j) {
      KESTREL_THROW_UNLESS(peers[i] != peers[j], "explorer.peers[" << j << "] and [" << i
                                                                   << "] share the prefix '"
                                                                   << peers[i] << "'");
    }
  }
}

void ExplorerNodeConfig::Validate() const {
  explorer.Validate();
  CheckParams("explorer", ExplorerNodeParams(), *this);
  for (size_t i = 0; i < explorer.peers.size(); ++i) {
    KESTREL_THROW_UNLESS(explorer.peers[i] != vehicle_prefix,
                         "explorer.peers[" << i << "].prefix = '" << explorer.peers[i]
                                           << "' is this vehicle's own prefix");
  }
  KESTREL_THROW_UNLESS(run_id.empty() || CheckRunId(run_id).empty(),
                       "explorer.run_id = '" << run_id << "': " << CheckRunId(run_id));
}

ExplorerNodeConfig LoadExplorerNodeConfig(const ConfigNode& node) {
  ExplorerNodeConfig c;
  ExplorerConfig& x = c.explorer;
  // The planner reads its own keys; the map and explorer sections are ours.
  if (node.Has("map")) {
    const ConfigNode m = node.Child("map");  // the mapper's keys (config/mapper.yaml)
    ReadMapLimits(m, &x.map);
    m.Read("p_init", &x.p_init, Range::Open(0.0, 1.0));
  }
  if (node.Has("explorer")) {
    const ConfigNode e = node.Child("explorer");
    e.Read("map_channel", &c.map_channel);
    e.Read("delta_channel", &c.delta_channel);
    e.Read("pose_channel", &c.pose_channel);
    e.Read("controller_channel", &c.controller_channel);
    e.Read("trajectory_channel", &c.trajectory_channel);
    e.Read("status_channel", &c.status_channel);
    e.Read("command_channel", &c.command_channel);
    e.Read("map2d_prefix", &c.map2d_prefix);
    e.Read("heartbeat_channel", &c.heartbeat_channel);
    ReadParams(e, ExplorerParams(), &x);
    ReadParams(e, ExplorerNodeParams(), &c);
    std::string profile =
        x.startup_yaw_profile == StartupYawProfile::kRamped ? "ramped" : "smoothstep";
    e.Read("startup_yaw_profile", &profile, {"smoothstep", "ramped"});
    x.startup_yaw_profile =
        profile == "ramped" ? StartupYawProfile::kRamped : StartupYawProfile::kSmoothstep;
    e.Read("vehicle_prefix", &c.vehicle_prefix);
    ReadVehiclePrefixes(e, "peers", &x.peers);
    e.Read("state_path", &c.state_path);
    e.Read("run_id", &c.run_id);
  }
  // Last: the planner's reader also checks that no key of the file is left unread.
  x.planner = LoadPlannerConfig(node);
  try {
    c.Validate();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(node.file() + ": " + e.what());
  }
  return c;
}

bool StallRuleApplies(ExplorationMode mode, const ExplorerConfig& config) {
  if (config.end_stall_window_s <= 0.0) return false;
  return !IsVolumetric(mode) || config.end_stall_in_volumetric;
}

}  // namespace kestrel
