// libFuzzer target: what a browser or any local program sends kestrel-viewer over TCP
// (docs/design.md §7.7): the HTTP request, the WebSocket handshake and then WebSocket frames,
// parsed by websocketpp (the viewer's server library) with the viewer's limit on message size and
// the viewer's own handlers for the HTTP target (ResolveWebPath, ContentTypeOf) and the Origin rule
// (WebSocketOriginAllowed). websocketpp's iostream transport stands in for asio, so the bytes
// reach the same HTTP parser and hybi13 frame processor without a socket. The first input byte
// sets the size of the pieces the rest arrives in. Properties, beyond no crash and no sanitizer
// report: no exception escapes the server (one would stop kestrel-viewer); a resolved path lies
// under the web root with no "..", "//" or other character outside [A-Za-z0-9._/-]; an allowed
// Origin is empty or the server's own; no message over the limit reaches the handler.
#include <cctype>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>

#include <websocketpp/config/core.hpp>
#include <websocketpp/server.hpp>

#include "viewer/bridge/viewer_server.h"

namespace {

using Server = websocketpp::server<websocketpp::config::core>;
constexpr int kPort = 8740;
const std::string kWebRoot = "/srv/kestrel/web";

void Require(bool condition) {
  if (!condition) std::abort();
}

void CheckResolved(const std::string& target) {
  const std::string path = kestrel::ResolveWebPath(kWebRoot, target);
  if (path.empty()) return;
  Require(path.rfind(kWebRoot + "/", 0) == 0);
  const std::string rest = path.substr(kWebRoot.size());
  Require(rest.find("..") == std::string::npos && rest.find("//") == std::string::npos);
  for (const char c : rest) {
    Require(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-' ||
            c == '/');
  }
  (void)kestrel::ContentTypeOf(path);
}

void CheckOrigin(const std::string& origin) {
  if (!kestrel::WebSocketOriginAllowed(origin, kPort)) return;
  std::string o = origin;
  for (char& c : o) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const std::string port = ":" + std::to_string(kPort);
  Require(o.empty() || o == "http://127.0.0.1" + port || o == "http://localhost" + port ||
          o == "http://[::1]" + port);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const size_t piece = 1 + data[0] % 128;
  const char* bytes = reinterpret_cast<const char*>(data + 1);
  const size_t length = size - 1;

  // The pure rules on the raw input too, so they see what no HTTP parser would pass on.
  CheckResolved(std::string(bytes, length));
  CheckOrigin(std::string(bytes, length));

  try {
    Server server;
    server.clear_access_channels(websocketpp::log::alevel::all);
    server.clear_error_channels(websocketpp::log::elevel::all);
    server.set_max_message_size(kestrel::kViewerMaxMessageBytes);
    std::ostringstream out;
    server.register_ostream(&out);
    server.set_http_handler([&](websocketpp::connection_hdl hdl) {
      const Server::connection_ptr con = server.get_con_from_hdl(hdl);
      CheckResolved(con->get_resource());
      con->set_status(websocketpp::http::status_code::not_found);
      con->set_body("not found");
    });
    server.set_validate_handler([&](websocketpp::connection_hdl hdl) {
      const Server::connection_ptr con = server.get_con_from_hdl(hdl);
      const std::string origin = con->get_request_header("Origin");
      CheckOrigin(origin);
      CheckResolved(con->get_resource());
      return kestrel::WebSocketOriginAllowed(origin, kPort);
    });
    server.set_message_handler([](websocketpp::connection_hdl, const Server::message_ptr& msg) {
      Require(msg->get_payload().size() <= kestrel::kViewerMaxMessageBytes);
    });
    const Server::connection_ptr con = server.get_connection();
    con->start();
    for (size_t pos = 0; pos < length; pos += piece) {
      const size_t n = std::min(piece, length - pos);
      size_t used = 0;
      while (used < n) {
        const size_t k = con->read_some(bytes + pos + used, n - used);
        if (k == 0) break;
        used += k;
      }
      if (used < n) break;  // the connection stopped reading (closed or failed)
    }
    con->eof();
  } catch (...) {
    std::abort();  // an exception here would escape the viewer's poll loop
  }
  return 0;
}
