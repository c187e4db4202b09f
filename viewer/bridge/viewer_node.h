#pragma once
/// @file
/// The bridge node of kestrel-viewer: subscribes to Kestrel's channels (the map's once, and
/// each vehicle's pose, trajectory, exploration and 2D-map channels under its prefix,
/// docs/design.md §7.10), decoded through common/lcm_decode.h (malformed messages are counted
/// by channel, logged rate-limited and dropped), keeps the ViewerScene, serves pages through a
/// ViewerServer, and sends them the scene's changes at update_rate_hz. A 1 Hz heartbeat carries
/// its counters.
///
/// One thread: the process loop (viewer_main.cc) alternates LCM handling, Poll() and Tick().

#include <cstdint>
#include <memory>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/heartbeat.h"
#include "common/lcm_decode.h"
#include "common/log.h"
#include "viewer/bridge/viewer_config.h"
#include "viewer/bridge/viewer_scene.h"
#include "viewer/bridge/viewer_server.h"

namespace kestrel {

class ViewerNode {
 public:
  /// Subscribes and starts listening. @throws std::runtime_error if the port cannot be bound.
  ViewerNode(lcm::LCM& lcm, const ViewerConfig& config, const std::string& web_root,
             const Clock& clock);
  ViewerNode(const ViewerNode&) = delete;
  ViewerNode& operator=(const ViewerNode&) = delete;

  /// Socket work that is ready (no blocking).
  void Poll() { server_.Poll(); }
  /// Sends what is due at the clock's time: page updates at update_rate_hz, the heartbeat at 1 Hz.
  void PublishDue();
  /// Sends the scene's changes now (to every page; new pages get a snapshot).
  void Tick();

  /// The TCP port the page is served on.
  [[nodiscard]] int port() const { return server_.port(); }
  [[nodiscard]] const ViewerScene& scene() const { return scene_; }
  /// Malformed ("malformed <channel>") and refused ("refused <channel>") messages by kind.
  [[nodiscard]] const DropCounter& dropped() const { return dropped_; }
  [[nodiscard]] const ViewerServer& server() const { return server_; }
  /// Messages decoded and handed to the scene (any channel).
  [[nodiscard]] int64_t messages_received() const { return messages_received_; }
  /// MAP3D_DELTA messages ignored because no snapshot had arrived yet (started mid-run).
  [[nodiscard]] int64_t deltas_before_snapshot() const { return deltas_before_snapshot_; }

 private:
  void Refused(const std::string& channel, const std::string& reason);
  void UpdateCounters();

  lcm::LCM& lcm_;
  ViewerConfig config_;
  const Clock& clock_;
  ViewerScene scene_;
  ViewerServer server_;
  GuardedSubscriptions subscriptions_;
  DropCounter dropped_;
  Heartbeat heartbeat_;
  int64_t messages_received_{0};
  int64_t deltas_before_snapshot_{0};
  int64_t next_tick_utime_{-1};
  int64_t next_heartbeat_utime_{-1};
};

}  // namespace kestrel
