#include "viewer/bridge/viewer_node.h"

#include <cmath>

namespace kestrel {
namespace {
ViewerServer::Options ServerOptions(const ViewerConfig& config, const std::string& web_root) {
  ViewerServer::Options o;
  o.host = config.host;
  o.port = config.port;
  o.web_root = web_root;
  o.max_client_buffer_bytes = config.max_client_buffer_bytes;
  o.max_clients = config.max_clients;
  o.allowed_origins = config.allowed_origins;
  return o;
}
// The scene's configuration with the vehicles of the node's (one list, whoever filled it).
ViewerSceneConfig SceneConfigOf(const ViewerConfig& config) {
  ViewerSceneConfig scene = config.scene;
  scene.vehicles = config.vehicle_prefixes;
  return scene;
}
}  // namespace

ViewerNode::ViewerNode(lcm::LCM& lcm, const ViewerConfig& config, const std::string& web_root,
                       const Clock& clock)
    : lcm_(lcm),
      config_(config),
      clock_(clock),
      scene_(SceneConfigOf(config)),
      server_(ServerOptions(config, web_root)),
      subscriptions_(lcm),
      dropped_(clock),
      heartbeat_(lcm, clock, "kestrel-viewer", config.heartbeat_channel) {
  config_.Validate();
  const auto malformed = [this](const std::string& channel, const std::string& reason) {
    dropped_.Count("malformed " + channel, reason);
  };
  subscriptions_.Add<map3d_chunk_t>(
      config_.map_channel,
      [this](const std::string& channel, const map3d_chunk_t& m) {
        ++messages_received_;
        std::string error;
        if (!scene_.OnMapChunk(m, &error)) Refused(channel, error);
      },
      malformed);
  subscriptions_.Add<map3d_delta_t>(
      config_.delta_channel,
      [this](const std::string& channel, const map3d_delta_t& m) {
        ++messages_received_;
        if (!scene_.voxels().has_snapshot()) {
          ++deltas_before_snapshot_;  // started mid-run: normal until the next snapshot
          return;
        }
        std::string error;
        if (!scene_.OnMapDelta(m, &error)) Refused(channel, error);
      },
      malformed);
  subscriptions_.Add<map_status_t>(
      config_.map_status_channel,
      [this](const std::string&, const map_status_t& m) {
        ++messages_received_;
        scene_.OnMapStatus(m);
      },
      malformed);
  // Each vehicle's own channels: its prefix before the configured names (docs/design.md §7.10).
  for (size_t k = 0; k < config_.vehicle_prefixes.size(); ++k) {
    const std::string& prefix = config_.vehicle_prefixes[k];
    subscriptions_.Add<grid_map_t>(
        prefix + config_.map2d_channels,
        [this](const std::string& channel, const grid_map_t& m) {
          ++messages_received_;
          std::string error;
          if (!scene_.OnGridMap(channel, m, &error)) Refused(channel, error);
        },
        malformed);
    subscriptions_.Add<pose_t>(
        prefix + config_.pose_channel,
        [this, k](const std::string&, const pose_t& m) {
          ++messages_received_;
          scene_.OnPose(k, m);
        },
        malformed);
    subscriptions_.Add<trajectory_t>(
        prefix + config_.trajectory_channel,
        [this, k](const std::string& channel, const trajectory_t& m) {
          ++messages_received_;
          std::string error;
          if (!scene_.OnTrajectory(k, m, &error)) Refused(channel, error);
        },
        malformed);
    subscriptions_.Add<exploration_status_t>(
        prefix + config_.exploration_channel,
        [this, k](const std::string&, const exploration_status_t& m) {
          ++messages_received_;
          scene_.OnExploration(k, m);
        },
        malformed);
  }
  heartbeat_.SetState(heartbeat_t::STATE_OK);
}

void ViewerNode::Refused(const std::string& channel, const std::string& reason) {
  dropped_.Count("refused " + channel, reason);
}

void ViewerNode::UpdateCounters() {
  const ViewerServer::Counters& c = server_.counters();
  int64_t malformed = 0, refused = 0;
  for (const auto& [kind, count] : dropped_.counts()) {
    (kind.rfind("malformed", 0) == 0 ? malformed : refused) += count;
  }
  const std::pair<const char*, int64_t> values[] = {
      {"messages_received", messages_received_},
      {"malformed", malformed},
      {"refused", refused},
      {"deltas_before_snapshot", deltas_before_snapshot_},
      {"clients", server_.clients()},
      {"snapshots_sent", c.snapshots_sent},
      {"updates_coalesced", c.updates_coalesced},
      {"send_errors", c.send_errors},
  };
  for (const auto& [name, value] : values) {
    scene_.SetBridgeCounter(name, value);
    heartbeat_.SetValue(name, static_cast<double>(value));
  }
  heartbeat_.SetValue("occupied_cells", static_cast<double>(scene_.voxels().occupied_count()));
  // Degraded while the map copy missed a delta (until the next snapshot); malformed input shows
  // in the counters.
  const bool stale = scene_.voxels().has_snapshot() && !scene_.voxels().current();
  heartbeat_.SetState(stale ? heartbeat_t::STATE_DEGRADED : heartbeat_t::STATE_OK);
  if (!dropped_.last_reason().empty()) heartbeat_.SetLastError(dropped_.last_reason());
}

void ViewerNode::Tick() {
  UpdateCounters();
  const std::vector<ViewerFrame> update = scene_.TakeUpdateFrames();
  server_.Broadcast(update, [this] { return scene_.SnapshotFrames(); });
}

void ViewerNode::PublishDue() {
  const int64_t now = clock_.NowUtime();
  const auto period_us = static_cast<int64_t>(std::llround(1e6 / config_.update_rate_hz));
  if (next_tick_utime_ < 0 || now >= next_tick_utime_) {
    Tick();
    // Catch up by whole periods (no burst after a stall).
    next_tick_utime_ = (next_tick_utime_ < 0 || now - next_tick_utime_ > period_us)
                           ? now + period_us
                           : next_tick_utime_ + period_us;
  }
  if (next_heartbeat_utime_ < 0 || now >= next_heartbeat_utime_) {
    heartbeat_.Publish();
    next_heartbeat_utime_ = now + 1000000;
  }
}

}  // namespace kestrel
