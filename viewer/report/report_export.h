#pragma once
/// @file
/// kestrel-report's data step: reads a recorded run (an LCM log), rebuilds the mapper's
/// 3D map from its MAP3D snapshots and MAP3D_DELTA messages (MapReplica), and writes plain CSV
/// files that kestrel_report.py draws as the paper's figures (Figs. 1-3, 5-7):
///
///  - meta.csv         key,value: lattice, p_init, times, message counts, world;
///  - timeseries.csv   one row per MAP_STATUS (or per map update when the log has none): map
///                     entropy H (eq. (6), as the mapper reported it and recomputed from the
///                     replica), known fraction and accuracy against the world's ground truth
///                     (docs/algorithms.md §12.2, the logic of kestrel-map-score) and the known
///                     fraction of the whole lattice;
///  - vehicles.csv     one row per vehicle of the run (docs/design.md §7.10): its prefix, its
///                     trajectory file, path length, plans and the last EXPLORATION_STATUS
///                     (state, reason: the end rule and the landing once it landed);
///  - trajectory.csv   the first vehicle's flown path (POSE_VICON, valid poses, one per
///                     trajectory period); trajectory_<prefix>.csv the other vehicles';
///  - plans.csv, candidates.csv   every EXPLORATION_STATUS of the first vehicle and its candidate
///                     poses;
///  - map2d_index.csv, map2d_<k>_<name>.csv   the first vehicle's newest MAP2D_* grids at each
///                     requested time;
///  - occupied.csv     cell centres of the final map with P > occupied_threshold, and their P;
///  - truth.csv        cell centres of the world voxelised on the map lattice (with a world);
///  - config_processes.csv, config.csv   the configuration of the run (docs/design.md §6): one
///                     row per process life (channel, process, host, pid, epoch, run id, config
///                     file, command line) and one per value it ran with (key, value, file,
///                     source), from the newest params_t of each life on PARAMS_*.
///
/// The vehicles: those named in ReportExportConfig::vehicle_prefixes, or else every prefix P
/// (letters, digits, '_', possibly empty) for which the log holds a channel P + POSE_VICON, in
/// natural order ("" first, V2_ before V10_); a log with no such channel: one vehicle, no prefix.
/// A vehicle's channels are its prefix before pose_channel, exploration_channel and map2d_prefix;
/// the map channels are shared. A one-vehicle run (no prefix) is exported as it always was.
///
/// Times are seconds since the first MAP_STATUS (the demo's convention; the first map update when
/// the log has no MAP_STATUS), from the messages' own utime (the simulator's clock in a simulated
/// run), not the logger's receive time. The file names do not depend on the input.

#include <cstdint>
#include <string>
#include <vector>

namespace kestrel {

/// What to export and from where.
struct ReportExportConfig {
  std::string log_path;    ///< LCM log of the run (lcm-logger or kestrel-mission --log)
  std::string world_path;  ///< world YAML for ground truth ("" = none: no truth, no known fraction)
  std::string out_dir;     ///< directory for the CSV files (created if missing)
  /// Times (s since the first MAP_STATUS) at which to keep the 2D maps; empty = half way and end.
  std::vector<double> map2d_times_s;
  double occupied_threshold{0.5};   ///< cells with P above this go to occupied.csv, in (0, 1)
  double trajectory_period_s{0.1};  ///< one trajectory row per this much time, s, >= 0
  double sensor_range_m{4.0};       ///< observable-cell sweep range, m (kestrel-map-score default)
  double vertical_fov_rad{45.0 * 3.14159265358979323846 / 180.0};  ///< sweep vertical FOV, rad
  std::string map_channel{"MAP3D"};                                ///< map3d_chunk_t snapshots
  std::string delta_channel{"MAP3D_DELTA"};                        ///< map3d_delta_t
  std::string status_channel{"MAP_STATUS"};                        ///< map_status_t (entropy)
  std::string pose_channel{"POSE_VICON"};                          ///< pose_t (trajectory)
  std::string exploration_channel{"EXPLORATION_STATUS"};           ///< exploration_status_t
  std::string map2d_prefix{"MAP2D_"};    ///< grid_map_t channels: + COLLISION, COMBINED, ENTROPY
  std::string params_prefix{"PARAMS_"};  ///< params_t channels: + the process (MAPPER, SIM, ...)
  /// The vehicles' channel prefixes (docs/design.md §7.10); empty: found in the log (see above).
  std::vector<std::string> vehicle_prefixes;

  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// One vehicle of the run, as written to vehicles.csv.
struct ReportVehicle {
  std::string prefix;           ///< its channel prefix ("" for a one-vehicle run)
  std::string trajectory_file;  ///< trajectory.csv (the first vehicle) or trajectory_<prefix>.csv
  int64_t poses{0};             ///< its POSE_VICON messages
  int64_t valid_poses{0};       ///< of which valid, with a usable orientation
  /// Length of its trajectory file's path: the sum of the distances between the consecutive
  /// valid poses kept, one per trajectory_period_s, m.
  double path_length_m{0};
  int64_t plans{0};          ///< its EXPLORATION_STATUS messages
  int final_state{-1};       ///< state of its last EXPLORATION_STATUS (-1: none)
  std::string final_reason;  ///< reason of its last EXPLORATION_STATUS
  double final_time_s{0};    ///< time of its last EXPLORATION_STATUS, s
  bool land_sent{false};     ///< an EXPLORATION_STATUS said DONE (home or a landing place)
};

/// What was exported (also written to meta.csv).
struct ReportExportSummary {
  int64_t events{0};            ///< log events read
  int64_t malformed{0};         ///< events on Kestrel channels that failed the guarded decode
  int64_t snapshots_chunks{0};  ///< MAP3D chunks applied
  int64_t deltas_applied{0};    ///< MAP3D_DELTA messages applied
  int64_t map_rejects{0};       ///< chunks or deltas the replica refused (lost messages)
  int64_t status_messages{0};   ///< MAP_STATUS messages
  int64_t poses{0};             ///< POSE_VICON messages, every vehicle's
  int64_t plans{0};             ///< EXPLORATION_STATUS messages of the first vehicle (plans.csv)
  int64_t map2d_messages{0};    ///< MAP2D_* messages
  int64_t params_messages{0};   ///< PARAMS_* messages
  size_t configurations{0};     ///< config_processes.csv rows: process lives that told theirs
  size_t samples{0};            ///< timeseries.csv rows
  size_t occupied_cells{0};     ///< occupied.csv rows
  size_t truth_cells{0};        ///< truth.csv rows (0 without a world)
  double duration_s{0};         ///< time of the last clock message since the time origin, s
  bool truncated{false};        ///< the log ended inside an event (the events before it are used)
  std::vector<std::string> warnings;    ///< missing channels, truncation, rejects (also on stderr)
  std::vector<ReportVehicle> vehicles;  ///< every vehicle, in vehicles.csv's order
};

/// The vehicles' prefixes found in a log's channel names: every P (letters, digits, '_',
/// possibly empty) with a channel P + `pose_channel`, in natural order ("" first, then by the
/// numbers in them: V2_ before V10_); {""} when there is none.
[[nodiscard]] std::vector<std::string> VehiclePrefixesOf(const std::vector<std::string>& channels,
                                                         const std::string& pose_channel);

/// Reads the log and writes the files listed in the file comment into config.out_dir.
/// @throws std::invalid_argument on bad configuration; std::runtime_error when the log cannot be
///   read, holds no complete MAP3D snapshot, or its map is unbounded (growing), or a file cannot
///   be written.
ReportExportSummary ExportReportData(const ReportExportConfig& config);

}  // namespace kestrel
