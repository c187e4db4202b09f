#pragma once
/// @file
/// What the viewer page's server (viewer_server.h) and the Foxglove endpoint
/// (viewer/foxglove/foxglove_server.h) share of websocketpp: the server type over standalone asio,
/// its set-up (quiet logs, address reuse, the largest client message), listening on an address,
/// the port bound, polling, and closing every connection. Included by their .cc files only.

#include <websocketpp/config/asio_no_tls.hpp>
#include <websocketpp/server.hpp>

#include <cstddef>
#include <string>
#include <vector>

namespace kestrel {

using WsServer = websocketpp::server<websocketpp::config::asio>;
using WsHandle = websocketpp::connection_hdl;

/// Quiet logs (fatal errors only), asio, address reuse, and the largest message a client may send.
/// `who` names the server in errors. @throws std::runtime_error.
void InitWebSocketServer(WsServer& server, size_t max_message_bytes, const std::string& who);

/// Listens on host:port ("localhost" is 127.0.0.1; port 0: any free port) and accepts.
/// @throws std::runtime_error naming `who`, the address and the reason.
void ListenAndAccept(WsServer& server, const std::string& host, int port, const std::string& who);

/// The port listened on, -1 if none.
[[nodiscard]] int LocalPort(WsServer& server);

/// Runs whatever socket work is ready, without blocking.
void PollWebSocketServer(WsServer& server);

/// Stops listening, closes `clients` with "going away" and `reason`, and lets the closes go out.
void CloseWebSocketServer(WsServer& server, const std::vector<WsHandle>& clients,
                          const std::string& reason);

}  // namespace kestrel
