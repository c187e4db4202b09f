#pragma once
/// @file
/// A Foxglove WebSocket server (subprotocol foxglove.websocket.v1, the protocol of
/// github.com/foxglove/ws-protocol, docs/spec.md): Foxglove connects to ws://127.0.0.1:PORT and
/// sees Kestrel's topics (foxglove_bridge.h). websocketpp over standalone asio, one thread,
/// polled, like the viewer page's server.
///
/// What it speaks: on connection, Server Info (no optional capabilities) and one Advertise of
/// every channel known; a channel first published later is advertised to every client then.
/// Subscribe / Unsubscribe (JSON) from the client; Message Data (binary: opcode 0x01, u32
/// subscription id, u64 receive time in ns, the JSON payload) for every message on a subscribed
/// channel, and on subscription the newest message of that channel at once. Anything else a
/// client sends is answered with a Status (level 1) naming what was ignored. A client whose
/// unsent bytes exceed max_client_buffer_bytes skips messages (counted) until it drains; a map
/// update it skipped is made good by the whole map at its next message on /map.
///
/// Like the page's server it accepts handshakes only without an Origin, from its own origin or
/// from an origin in allowed_origins (WebSocketOriginAllowed): Foxglove's desktop app sends none;
/// Foxglove's web app sends https://app.foxglove.dev, which is refused (403) unless listed; any
/// other page in the user's browser cannot read the vehicle's state. A handshake without the
/// subprotocol is refused (400).

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace kestrel::foxglove {

inline constexpr const char* kSubprotocol = "foxglove.websocket.v1";

class FoxgloveServer {
 public:
  struct Options {
    std::string host{"127.0.0.1"};  ///< listen address
    int port{8765};                 ///< 0: any free port (see port())
    std::string name{"kestrel-viewer"};
    int64_t max_client_buffer_bytes{16 << 20};
    int max_clients{8};
    /// Origins whose pages may connect besides the endpoint's own loopback origin
    /// (WebSocketOriginAllowed), e.g. https://app.foxglove.dev.
    std::vector<std::string> allowed_origins;
  };
  struct Counters {
    int64_t connections{0};
    int64_t refused{0};           ///< no subprotocol, a foreign Origin, or too many clients
    int64_t messages_sent{0};     ///< Message Data frames
    int64_t messages_skipped{0};  ///< not sent: the client was behind
    int64_t bad_requests{0};      ///< client messages that were not a known JSON op
  };

  /// Binds and listens. @throws std::runtime_error if it cannot.
  explicit FoxgloveServer(const Options& options);
  ~FoxgloveServer();
  FoxgloveServer(const FoxgloveServer&) = delete;
  FoxgloveServer& operator=(const FoxgloveServer&) = delete;

  [[nodiscard]] int port() const;
  /// Runs whatever socket work is ready, without blocking.
  void Poll();
  /// Sends a message on `topic` (advertised now if new, with `schema_name` and its JSON Schema)
  /// to every client subscribed to it; a client that subscribes later gets this newest message
  /// first (or the topic's snapshot, SetSnapshotSource).
  void Publish(const std::string& topic, const std::string& schema_name, uint64_t time_ns,
               const std::string& json);
  /// Advertises `topic` before its first message (so a client can subscribe to it at once).
  void Advertise(const std::string& topic, const std::string& schema_name);
  /// Whether any client subscribes to `topic` now.
  [[nodiscard]] bool HasSubscribers(const std::string& topic) const;
  /// For /map: what a client that subscribes (or fell behind) gets instead of the newest update:
  /// its time (ns) and JSON ("" for nothing yet). @throws std::invalid_argument for a topic not
  /// advertised.
  using Snapshot = std::pair<uint64_t, std::string>;
  void SetSnapshotSource(const std::string& topic, std::function<Snapshot()> snapshot);

  [[nodiscard]] int clients() const;
  [[nodiscard]] const Counters& counters() const;
  /// Closes every connection and stops listening (also done by the destructor).
  void Stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kestrel::foxglove
