#pragma once
/// @file
/// The viewer's HTTP + WebSocket server (websocketpp over standalone asio, one thread, polled):
/// serves the page's files from a folder and pushes ViewerFrames to every connected page.
///
/// Pacing: each page is either up to date (it gets every update) or behind. A page whose unsent
/// bytes exceed max_client_buffer_bytes gets no updates (counted as coalesced) and is behind; a
/// page that is new or behind gets one full snapshot at the first broadcast where its unsent
/// bytes are below the limit. So a slow page sees coalesced state, never an unbounded queue. A
/// page that disconnects, even in the middle of a send, is forgotten; no error escapes.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "viewer/bridge/viewer_scene.h"

namespace kestrel {

/// The largest WebSocket message a page may send (pages send nothing of interest); a longer one
/// closes the connection (websocketpp's message_too_big).
inline constexpr size_t kViewerMaxMessageBytes = size_t{64} * 1024;

/// What a page that may still be sent to should get now, from its state (pure, see file comment).
enum class ClientAction { kSendUpdate, kSendSnapshot, kSkip };
[[nodiscard]] ClientAction DecideClientAction(bool needs_snapshot, int64_t unsent_bytes,
                                              int64_t max_unsent_bytes);

/// Whether a WebSocket handshake may open, from its Origin header (pure): by default a page may
/// connect only if this server served it. The server listens on loopback only
/// (config/viewer.yaml), so its pages' origin is http://127.0.0.1:PORT, http://localhost:PORT or
/// http://[::1]:PORT (compared without regard to case). No Origin (a program, not a browser) is
/// allowed. Any other page in the user's browser is refused, a file ("null") and a name that DNS
/// rebinds to 127.0.0.1 included, since the browser would otherwise let it read the vehicle's
/// state; except the origins in `allowed_origins` (config `allowed_origins`,
/// `foxglove.allowed_origins`; e.g. https://app.foxglove.dev, Foxglove's web app), each compared
/// whole without regard to case: the user trusts every page of such an origin with the state.
[[nodiscard]] bool WebSocketOriginAllowed(const std::string& origin, int port,
                                          const std::vector<std::string>& allowed_origins = {});

/// Why `origin` cannot be an entry of an allowed_origins list ("" if it can): an origin as a
/// browser sends it, scheme "http" or "https", "://", a host of letters, digits, '.', '-' (or an
/// IPv6 address in brackets) and an optional ":PORT" (1 to 65535), nothing after (no path, no
/// '/' at the end); "null" and "*" are refused: they would admit any file or any page.
[[nodiscard]] std::string CheckAllowedOrigin(const std::string& origin);

/// The content type of a served file, from its extension ("application/octet-stream" if unknown).
[[nodiscard]] std::string ContentTypeOf(const std::string& path);
/// The file under `web_root` for an HTTP request target ("/" is index.html; a query is ignored),
/// or "" if the target is not a plain relative path (no "..", only [A-Za-z0-9._/-]).
[[nodiscard]] std::string ResolveWebPath(const std::string& web_root, const std::string& target);

class ViewerServer {
 public:
  struct Options {
    std::string host{"127.0.0.1"};  ///< listen address
    int port{8740};                 ///< 0: any free port (see port())
    std::string web_root;           ///< folder served over HTTP
    int64_t max_client_buffer_bytes{8 << 20};
    int max_clients{16};
    /// Origins whose pages may open the WebSocket besides this server's own
    /// (WebSocketOriginAllowed).
    std::vector<std::string> allowed_origins;
  };
  /// Counters since start.
  struct Counters {
    int64_t connections{0};        ///< WebSocket connections accepted
    int64_t refused{0};            ///< connections refused (max_clients)
    int64_t refused_origin{0};     ///< handshakes refused: a foreign Origin
    int64_t snapshots_sent{0};     ///< full snapshots sent
    int64_t updates_sent{0};       ///< update batches sent (to any page)
    int64_t updates_coalesced{0};  ///< update batches a page behind did not get
    int64_t send_errors{0};        ///< sends that failed (page gone)
    int64_t http_requests{0};
    int64_t http_not_found{0};
  };

  /// Binds and listens. @throws std::runtime_error if it cannot.
  explicit ViewerServer(const Options& options);
  ~ViewerServer();
  ViewerServer(const ViewerServer&) = delete;
  ViewerServer& operator=(const ViewerServer&) = delete;

  /// The port listened on.
  [[nodiscard]] int port() const;
  /// Runs whatever socket work is ready (accepts, requests, writes), without blocking.
  void Poll();
  /// Sends `update` to the pages that are up to date and snapshot() to the new or caught-up ones
  /// (see the file comment). snapshot() is called at most once.
  void Broadcast(const std::vector<ViewerFrame>& update,
                 const std::function<std::vector<ViewerFrame>()>& snapshot);
  /// Pages connected now.
  [[nodiscard]] int clients() const;
  [[nodiscard]] const Counters& counters() const;
  /// Stops listening and closes every connection (also done by the destructor).
  void Stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kestrel
