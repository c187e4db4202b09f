#pragma once
/// @file
/// Configuration of kestrel-mapper (config/mapper.yaml): the map, the sensors it fuses, the pose
/// synchronisation, what it publishes and how often, checkpoints and the overload policy.

#include <string>
#include <vector>

#include "common/config.h"
#include "common/se3.h"
#include "mapping/grid.h"
#include "mapping/occupancy_updater.h"
#include "mapping/pose_history.h"
#include "mapping/sensor_model.h"

namespace kestrel {

/// One range sensor the mapper subscribes to.
struct MapperSensorConfig {
  std::string name{"xtion"};  ///< sensor name; selects the extrinsic X_BS in the vehicle file
  std::string channel{"DEPTH_XTION"};  ///< LCM channel
  std::string kind{"depth"};           ///< "depth" (depth_image_t) or "scan" (planar_scan_t)
  SensorModelConfig model{SensorModelConfig::Xtion()};  ///< forward model (docs/algorithms.md §3.2)
  Pose3 X_BS;  ///< sensor frame in the body frame (from the vehicle file)
};

struct MapperConfig {
  std::string grid{"dense"};   ///< "dense" (the paper's fixed limits) or "growing" (8^3 blocks)
  std::string model{"exact"};  ///< "exact" (docs/algorithms.md §4.1) or "log_odds" (baseline)
  MapLimits limits;            ///< map limits and resolution alpha (growing: lattice origin)
  OccupancyLimits occupancy;   ///< P_init and the clamp P_min
  LogOddsConfig log_odds;      ///< baseline parameters (model = log_odds)
  std::vector<MapperSensorConfig> sensors;  ///< default: the paper's Xtion and Hokuyo
  std::string pose_channel{"POSE_VICON"};   ///< pose_t of the vehicle body
  /// The vehicles whose scans are fused into the one map (docs/design.md §7.10): each one's
  /// prefix goes before every sensor channel and the pose channel, and its scans are paired with
  /// its own poses. One vehicle without a prefix by default.
  std::vector<std::string> vehicle_prefixes{""};
  PoseHistoryConfig pose_history;  ///< interpolation limits (docs/design.md §5.2)

  std::string map_channel{"MAP3D"};          ///< full snapshots, in chunks
  std::string delta_channel{"MAP3D_DELTA"};  ///< changed cells between snapshots
  std::string status_channel{"MAP_STATUS"};  ///< map_status_t
  std::string heartbeat_channel{"HEARTBEAT_MAPPER"};
  double snapshot_period_s{5.0};  ///< full snapshot period, s (0: never)
  double delta_period_s{0.5};     ///< delta period, s (0: never)
  double status_period_s{1.0};    ///< status and heartbeat period, s
  int snapshot_blocks_per_chunk{
      64};  ///< 8^3-cell blocks per map3d_chunk_t at most (64: 128 KiB raw)
  /// Largest encoded map message, bytes (docs/design.md §7.6): a snapshot chunk whose encoding
  /// is larger is split (its blocks halved); a delta is sent as soon as its changed cells fill
  /// this (after the scan that filled it, so one scan can take it past; beyond three times this it
  /// becomes a snapshot). The default keeps chunks and nearly every delta in one LCM datagram
  /// (65 499 bytes with its header and channel).
  int map_message_max_bytes{60000};
  /// Pace of a snapshot's chunks, bytes per second of the node's clock (0: all at once). Deltas
  /// keep going out meanwhile, and chain on from the snapshot (docs/design.md §3.3).
  double snapshot_bytes_per_s{1.0e6};

  std::string checkpoint_path;      ///< map file to resume from and save to ("" = none)
  double checkpoint_period_s{5.0};  ///< checkpoint period, s (and at exit)
  /// The run this mapper maps (docs/design.md §3.5), written into its checkpoints; "" = a fresh
  /// id made at start (NewRunId), so that no earlier checkpoint is resumed unless resume = any.
  /// The sheets pass $KESTREL_RUN_ID, which kestrel-procman gives every command it starts.
  std::string run_id;
  /// Which checkpoint to resume: "same_run" (only one written under run_id; another run's is
  /// moved aside) or "any" (whichever run wrote it).
  std::string resume{"same_run"};

  int max_queue{60};          ///< scans held at most; beyond, the oldest is dropped (counted)
  double max_backlog_s{0.5};  ///< backlog beyond which rays are decimated (status shows it)
  /// Every decision on a queued scan (applied: which rays, which pose; skipped: why) goes out on
  /// this channel (map_decisions_t), so that a replay rebuilds the live map whatever the load
  /// (docs/design.md §3.6).
  std::string decisions_channel{"MAP_DECISIONS"};
  /// An LCM log file the decisions are also appended to, each message flushed as it is written,
  /// so that none is lost to the network or to the logger stopping first ("" = none). The sheets
  /// set $KESTREL_RUN/mapper-decisions.lcmlog.
  std::string decisions_log;
  /// Scan order (docs/design.md §3.6, §7.10): a scan is applied only once every configured
  /// stream (vehicle, sensor) has delivered one with a stamp at least as new, or the newest input
  /// is this much newer than the scan (message time, s; 0: no wait, arrival order; a sensor that
  /// never sends delays the map by this much). So sensors relayed by separate driver processes, and
  /// mappers that receive the same scans with different delays (one per vehicle, across a network),
  /// apply them in one order, (stamp, vehicle, sensor), and hold the same map bit for bit. Below
  /// max_backlog_s, so that the wait alone never decimates.
  double order_wait_s{0.3};

  /// The run's LCM log (lcm-logger's file; "" = none). A mapper that resumed its checkpoint reads
  /// it before its live input and applies what it missed while it was down (docs/design.md §3.6):
  /// the map is then the one a mapper that never stopped would hold.
  std::string catch_up_log;
  /// How long catching up may wait for the log to reach the live input (the logger flushes every
  /// 100 ms) before it goes on without (logged), s.
  double catch_up_wait_s{5.0};

  /// Cast the rays of each scan on a second thread ahead of the in-order updates
  /// (ScanIntegrator::SetWorkerThread): the same map bit for bit. Each kind
  /// of scan goes through the thread only while that is faster (WorkerChoice). Off unless
  /// configured: on a 2-vCPU machine the thread's gain comes and goes in spells, down to below one
  /// thread's rays/s (each ray's data crosses the cores, and what that costs depends on where the
  /// host places the vCPUs; docs/STATUS.md, "Mapping"), and it takes up to twice the CPU.
  /// config/mapper.yaml turns it on; the sim sheet turns it off (the simulator and the other
  /// processes share the two cores).
  bool traversal_thread{false};

  /// The kernels that cast eight rays at a time, evaluate their forward models and store their
  /// posteriors (ScanIntegrator::Options::instruction_set): "" for the widest the CPU runs
  /// (AVX-512 vector registers where the CPU has them: faster than the scalar kernels,
  /// bench/mapping; docs/STATUS.md, "Mapping"), "scalar" or "avx512". The same map bit for bit
  /// with each.
  std::string instruction_set;

  /// @throws ConfigError-like std::invalid_argument naming the field, value and range.
  void Validate() const;
};

/// The paper's two sensors with the vehicle file's extrinsics.
[[nodiscard]] std::vector<MapperSensorConfig> DefaultMapperSensors();

/// Reads a MapperConfig from YAML (keys as in config/mapper.yaml). The extrinsics come from the
/// vehicle file named by `vehicle_config` (relative paths are relative to the mapper file's
/// folder, then to the working directory). @throws ConfigError
[[nodiscard]] MapperConfig LoadMapperConfig(const ConfigNode& node);

}  // namespace kestrel
