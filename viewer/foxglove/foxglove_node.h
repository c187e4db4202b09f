#pragma once
/// @file
/// kestrel-viewer's Foxglove endpoint as a node: Kestrel's channels from LCM through the Bridge
/// (foxglove_bridge.h) to the FoxgloveServer (foxglove_server.h). Malformed or refused messages
/// are counted by channel and logged once per channel; nothing else is dropped.

#include <cstdint>
#include <map>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "viewer/foxglove/foxglove_bridge.h"
#include "viewer/foxglove/foxglove_server.h"

namespace kestrel::foxglove {

struct FoxgloveNodeConfig {
  FoxgloveServer::Options server;
  BridgeConfig bridge;
  double map_rate_hz{1.0};  ///< the map's changed blocks are sent at most this often
};

class FoxgloveNode {
 public:
  /// @throws std::runtime_error if the server cannot listen, std::invalid_argument on a bad
  /// configuration.
  FoxgloveNode(lcm::LCM& lcm, const FoxgloveNodeConfig& config, const Clock& clock);
  ~FoxgloveNode();
  FoxgloveNode(const FoxgloveNode&) = delete;
  FoxgloveNode& operator=(const FoxgloveNode&) = delete;

  /// Socket work (non-blocking).
  void Poll() { server_.Poll(); }
  /// Sends the map's changed blocks when map_rate_hz says so.
  void PublishDue();

  [[nodiscard]] int port() const { return server_.port(); }
  [[nodiscard]] const FoxgloveServer& server() const { return server_; }
  [[nodiscard]] int64_t refused_messages() const { return refused_; }

 private:
  void Handle(const lcm::ReceiveBuffer* rbuf, const std::string& channel);

  lcm::LCM& lcm_;
  FoxgloveNodeConfig config_;
  const Clock& clock_;
  Bridge bridge_;
  FoxgloveServer server_;
  lcm::Subscription* subscription_{nullptr};
  int64_t next_map_utime_{0};
  int64_t refused_{0};
  std::map<std::string, int64_t> refused_by_channel_;
};

}  // namespace kestrel::foxglove
