#pragma once
/// @file
/// Calibrating the mapper's sensor models from a recorded run (docs/algorithms.md §3.7): the
/// log's scans, paired with its poses as kestrel-mapper pairs them (the measured pose and the
/// configured extrinsics: the errors of both end up in the fit), each ray cast against the
/// world's surfaces for its true range, and SensorCalibrator's fit per sensor.

#include <string>
#include <vector>

#include "tools/fidelity/sensor_calibration.h"

namespace kestrel {

struct CalibrationRunConfig {
  std::string root{"."};
  std::string log_path;
  std::string world_file;
  std::string mapper_file{"config/mapper.yaml"};
  std::vector<std::string> overrides;
  int every{4};  ///< use every n-th scan of each sensor (>= 1)
};

/// One sensor's fit, with the values the mapper had.
struct SensorCalibrationResult {
  std::string name;
  double z_min_m{0.0}, z_max_m{0.0};
  double configured_sigma_m{0.0}, configured_p_rand{0.0}, configured_p_miss{0.0};
  SensorCalibration fit;
  int64_t rays_left_map{0};  ///< returns from outside the map (not fitted)
};

/// @throws ConfigError, std::runtime_error (unreadable log; a sensor without returns to fit).
[[nodiscard]] std::vector<SensorCalibrationResult> CalibrateFromLog(
    const CalibrationRunConfig& config);

}  // namespace kestrel
