#pragma once
/// @file
/// YAML readers (common/config.h) for the mapping library's parameter structs. Each reads the
/// keys it knows (all optional: absent keys keep the struct's defaults), checks each against its
/// range, then runs the struct's Validate(); every error is a ConfigError naming the file, key
/// path, value and accepted range. Unknown keys are left for the caller's CheckNoUnknownKeys().
///
/// Keys (units in the names):
///   sensor model: sigma_m, z_min_m, z_max_m, p_rand, p_miss, cutoff_sigmas, interpolated_gaussian
///   map limits:   min_m [x, y, z], max_m [x, y, z], resolution_m
///   occupancy:    p_init, p_min
///   log-odds:     p_hit, p_miss, p_clamp_min, p_clamp_max, p_unknown
///   pose history: history_s, max_gap_s, max_wait_s

#include "common/config.h"
#include "mapping/grid.h"
#include "mapping/occupancy_updater.h"
#include "mapping/pose_history.h"
#include "mapping/sensor_model.h"

namespace kestrel {

/// Reads a sensor model from `node` on top of *config (e.g. SensorModelConfig::Xtion()).
/// @throws ConfigError on a bad value or a configuration that fails Validate().
void ReadSensorModelConfig(const ConfigNode& node, SensorModelConfig* config);
/// Reads map limits on top of *limits. @throws ConfigError.
void ReadMapLimits(const ConfigNode& node, MapLimits* limits);
/// Reads the occupancy prior and clamp on top of *limits. @throws ConfigError.
void ReadOccupancyLimits(const ConfigNode& node, OccupancyLimits* limits);
/// Reads the log-odds baseline's parameters on top of *config. @throws ConfigError.
void ReadLogOddsConfig(const ConfigNode& node, LogOddsConfig* config);
/// Reads the pose history's parameters on top of *config. @throws ConfigError.
void ReadPoseHistoryConfig(const ConfigNode& node, PoseHistoryConfig* config);

}  // namespace kestrel
