#pragma once
/// @file
/// Reading a PlannerConfig from YAML (config/exploration/explorer.yaml is the reference file,
/// every key documented there). Absent keys keep their defaults; unknown keys, values out of range
/// and inconsistent fields are ConfigErrors naming the file, the key and the accepted range.
/// Angles are typed in degrees in YAML (`_deg`) and stored in radians. trajectory.vehicle_radius_m
/// defaults to half of projection.vehicle_diameter_m when absent.

#include <string>

#include "exploration/planner.h"

namespace kestrel {

class ConfigNode;

/// Reads the planner's configuration from a YAML node, then validates it.
/// @throws ConfigError naming the file, the key, the value and the accepted range.
[[nodiscard]] PlannerConfig LoadPlannerConfig(const ConfigNode& node);

/// LoadPlannerConfig(ConfigNode::LoadFile(path)). @throws ConfigError.
/// (A file of planner keys only: config/exploration/explorer.yaml also has the explorer node's
/// sections, so it loads with LoadExplorerNodeConfig, exploration/explorer_config.h.)
[[nodiscard]] PlannerConfig LoadPlannerConfigFile(const std::string& path);

}  // namespace kestrel
