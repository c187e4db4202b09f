#pragma once
/// @file
/// kestrel-explorer's node: the wiring around the pure Explorer (exploration/explorer.h, where
/// the state machine and every decision live). It keeps a copy of the mapper's 3D map (MAP3D
/// snapshots and deltas, mapping/map_replica.h; a snapshot whose P_init is not the explorer's
/// map.p_init is refused and counted as "map_prior"), decodes poses, controller status and the
/// other vehicles' poses and trajectories (the guarded path; bad messages counted as drops and
/// dropped), steps the Explorer, and publishes what it returns: TRAJECTORY, EXPLORATION_STATUS,
/// the 2D maps (MAP2D_COLLISION, MAP2D_COMBINED, MAP2D_ENTROPY in two-map mode; at most every
/// map2d_period_s), the land command on COMMAND, and a heartbeat with the drops and, apart, the
/// explorer's events ("event.<kind>": yields, kept replans, deferred ends, ...). Channel names
/// are configuration, each vehicle's behind its prefix.
///
/// Restarts (docs/design.md §2.5): with state_path set, the Explorer's record (state, take-off
/// point, lowest height, end rule) is written there (common/run_state_file.h) at every change of
/// state; a node started with the same run id hands the record back to its Explorer, which
/// resumes once it sees the vehicle airborne.
///
/// Step() does the work; it is cheap when nothing is due, so a lockstep simulation may call it
/// every step.

#include <cstdint>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/heartbeat.h"
#include "common/lcm_decode.h"
#include "common/log.h"
#include "exploration/explorer.h"
#include "exploration/explorer_config.h"
#include "kestrel/pose_t.hpp"
#include "mapping/map_replica.h"

namespace kestrel {

class ExplorerNode {
 public:
  /// Subscribes to the input channels and reads the state file.
  /// @throws std::invalid_argument if the configuration is invalid.
  ExplorerNode(lcm::LCM& lcm, const ExplorerNodeConfig& config, const Clock& clock);
  ExplorerNode(const ExplorerNode&) = delete;
  ExplorerNode& operator=(const ExplorerNode&) = delete;

  /// Steps the Explorer at the clock's time and publishes what it returns.
  void Step();

  /// The decisions: state, plans, end rule, landing, events, planning times.
  [[nodiscard]] const Explorer& explorer() const { return explorer_; }
  [[nodiscard]] ExplorerState state() const { return explorer_.state(); }
  [[nodiscard]] const MapReplica& replica() const { return replica_; }
  /// Messages dropped (malformed, non-finite, not fitting the map, a state file not written).
  [[nodiscard]] const DropCounter& drops() const { return drops_; }
  /// The publisher epoch stamped on every message but the heartbeat (common/identity.h).
  [[nodiscard]] int64_t epoch() const { return epoch_; }
  /// What the start-up found in the state file ("" without one) and, once resumed, how.
  [[nodiscard]] const std::string& resume_status() const;

  /// The explorer's copy of the map now (a view valid until the next map message).
  [[nodiscard]] ExplorerMap Map() const;

 private:
  void SubscribePeers(const std::string& pose_channel, const std::string& trajectory_channel);
  void OnPose(const pose_t& msg);
  void ReadStateFile();
  void WriteStateFile();
  void Heartbeat(double t);
  void Execute(const ExplorerAction& action);
  void PublishStatus(const kestrel::PublishStatus& status);
  void PublishMaps(const PlanResult& result, int64_t seq);
  void PublishLand();
  [[nodiscard]] double now_s() const { return UtimeToSeconds(clock_.NowUtime()); }

  lcm::LCM& lcm_;
  ExplorerNodeConfig config_;  // channels with this vehicle's prefix
  const Clock& clock_;
  MapReplica replica_;
  DropCounter drops_;
  DropCounter events_;  // the Explorer's events (not drops)
  kestrel::Heartbeat heartbeat_;
  GuardedSubscriptions subscriptions_;
  int64_t epoch_;  // drawn after the heartbeat's (the seeded order, docs/design.md §7.5)
  Explorer explorer_;
  int64_t command_seq_{0};
  double last_heartbeat_s_{-1e300};
  double last_map2d_s_{-1e300};
  std::string run_id_;
  std::string file_status_;  // what the state file said at the start
  int saved_state_{-1};      // the state last written to the state file (-1: none)
};

}  // namespace kestrel
