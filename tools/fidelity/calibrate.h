#pragma once
/// @file
/// Calibrating the mapper's sensors from a recorded run (docs/algorithms.md §3.7): the log's
/// scans, paired with its poses as kestrel-mapper pairs them (the measured pose and the
/// configured mount and stamp offset: the errors of both end up in the fit), each ray cast against
/// the world's surfaces for its true range. Optionally first each sensor's mount correction and
/// stamp offset (MountCalibrator), then SensorCalibrator's sigma, p_rand and p_miss with them.

#include <string>
#include <vector>

#include "sim/simulator.h"
#include "tools/fidelity/mount_calibration.h"
#include "tools/fidelity/sensor_calibration.h"

namespace kestrel {

struct CalibrationRunConfig {
  std::string root{"."};
  std::string log_path;
  std::string world_file;
  std::string mapper_file{"config/mapper.yaml"};
  std::vector<std::string> overrides;
  int every{4};  ///< use every n-th scan of each sensor for the sensor models (>= 1)
  /// Fit each sensor's mount correction and stamp offset first (from every scan, at most
  /// mount_options.rays_per_scan returns of each), and the sensor models with the fitted values.
  bool mount{false};
  MountCalibrationOptions mount_options;
};

/// One sensor's fit, with the values the mapper had.
struct SensorCalibrationResult {
  std::string name;
  double z_min_m{0.0}, z_max_m{0.0};
  double configured_sigma_m{0.0}, configured_p_rand{0.0}, configured_p_miss{0.0};
  SensorCalibration fit;
  int64_t rays_left_map{0};  ///< returns from outside the map (not fitted)
  /// config.mount: the configured correction and offset (the fit's start), and the fit (when
  /// mount.ok is false, mount.why says why and the sensor models were fitted without it).
  MountCorrection configured_mount;
  MountFit mount;
  /// The parameters the fit must determine for this kind of sensor: all seven for a depth
  /// camera; for a planar LIDAR its translation and rotation within its scan plane and its clock.
  std::array<bool, kMountParameters> mount_required{};
};

/// @throws ConfigError, std::runtime_error (unreadable log; a sensor without returns to fit; a
/// mount calibration of a log that fuses several vehicles).
[[nodiscard]] std::vector<SensorCalibrationResult> CalibrateFromLog(
    const CalibrationRunConfig& config);

/// The mapper overrides (sensors.<sensor>.mount_correction_m, mount_correction_rad,
/// stamp_offset_s) that make kestrel-mapper use `c`, rounded to 0.01 mm, 1 urad and 0.01 ms.
[[nodiscard]] std::vector<std::string> MountOverrides(size_t sensor, const MountCorrection& c);

/// What the simulator does to vehicle 0's mounts and clocks (docs/design.md §7.13), in the
/// calibration's terms: C = X_BS^-1 * the true mount (drawn from config.seed), and each sensor's
/// stamp offset less the motion capture's residual latency (the pairing sees only their
/// difference). @throws std::invalid_argument if the config does not validate.
struct SimulatedMountTruth {
  MountCorrection depth, lidar;
};
[[nodiscard]] SimulatedMountTruth SimulatedMountTruthOf(const SimConfig& config);

}  // namespace kestrel
