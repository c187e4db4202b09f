#include "viewer/bridge/viewer_server.h"

#ifndef ASIO_STANDALONE
#define ASIO_STANDALONE
#endif

#include <cctype>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>

#include "common/log.h"
#include "viewer/bridge/websocket_server.h"

namespace kestrel {

ClientAction DecideClientAction(bool needs_snapshot, int64_t unsent_bytes,
                                int64_t max_unsent_bytes) {
  if (unsent_bytes > max_unsent_bytes) return ClientAction::kSkip;
  return needs_snapshot ? ClientAction::kSendSnapshot : ClientAction::kSendUpdate;
}

std::string ContentTypeOf(const std::string& path) {
  const auto ends_with = [&](const std::string& suffix) {
    return path.size() >= suffix.size() &&
           path.compare(path.size() - suffix.size(), suffix.size(), suffix) == 0;
  };
  if (ends_with(".html")) return "text/html; charset=utf-8";
  if (ends_with(".js") || ends_with(".mjs")) return "text/javascript; charset=utf-8";
  if (ends_with(".css")) return "text/css; charset=utf-8";
  if (ends_with(".json")) return "application/json";
  if (ends_with(".png")) return "image/png";
  if (ends_with(".svg")) return "image/svg+xml";
  return "application/octet-stream";
}

std::string ResolveWebPath(const std::string& web_root, const std::string& target) {
  std::string path = target.substr(0, target.find_first_of("?#"));
  if (path.empty() || path[0] != '/') return "";
  if (path == "/") path = "/index.html";
  if (path.find("..") != std::string::npos || path.find("//") != std::string::npos) return "";
  for (const char c : path) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '.' || c == '_' || c == '-' || c == '/';
    if (!ok) return "";
  }
  return web_root + path;
}

namespace {
std::string Lowercase(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}
}  // namespace

bool WebSocketOriginAllowed(const std::string& origin, int port,
                            const std::vector<std::string>& allowed_origins) {
  if (origin.empty()) return true;  // not a browser: the Origin rule guards pages, not programs
  const std::string o = Lowercase(origin);
  const std::string suffix = ":" + std::to_string(port);
  if (port > 0 && (o == "http://127.0.0.1" + suffix || o == "http://localhost" + suffix ||
                   o == "http://[::1]" + suffix)) {
    return true;
  }
  for (const std::string& allowed : allowed_origins) {
    if (o == Lowercase(allowed)) return true;
  }
  return false;
}

std::string CheckAllowedOrigin(const std::string& origin) {
  const std::string o = Lowercase(origin);
  if (o == "null" || o == "*") {
    return "'" + origin + "' would admit every local file or every page; name one origin";
  }
  const size_t scheme_end = o.find("://");
  const std::string scheme = scheme_end == std::string::npos ? "" : o.substr(0, scheme_end);
  if (scheme != "http" && scheme != "https") {
    return "'" + origin + "' is not an origin: it must start with http:// or https://";
  }
  std::string rest = o.substr(scheme_end + 3);
  std::string host = rest;
  std::string port;
  if (!rest.empty() && rest[0] == '[') {  // an IPv6 address
    const size_t close = rest.find(']');
    if (close == std::string::npos) return "'" + origin + "': an IPv6 host without its ']'";
    host = rest.substr(0, close + 1);
    const std::string after = rest.substr(close + 1);
    if (!after.empty() && after[0] != ':') {
      return "'" + origin + "': only ':PORT' may follow the host (no path, no '/')";
    }
    port = after.empty() ? "" : after.substr(1);
    if (!after.empty() && port.empty()) return "'" + origin + "': ':' without a port";
    for (const char c : host.substr(1, host.size() - 2)) {
      if (!std::isxdigit(static_cast<unsigned char>(c)) && c != ':' && c != '.') {
        return "'" + origin + "': '" + std::string(1, c) + "' in an IPv6 address";
      }
    }
  } else {
    const size_t colon = rest.find(':');
    host = rest.substr(0, colon);
    if (colon != std::string::npos) {
      port = rest.substr(colon + 1);
      if (port.empty()) return "'" + origin + "': ':' without a port";
    }
    for (const char c : host) {
      if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '-') {
        return "'" + origin + "': '" + std::string(1, c) +
               "' in the host (an origin is scheme://host[:port], no path, no '/' at the end)";
      }
    }
  }
  if (host.empty() || host == "[]") return "'" + origin + "': no host";
  if (!port.empty()) {
    for (const char c : port) {
      if (!std::isdigit(static_cast<unsigned char>(c))) {
        return "'" + origin + "': port '" + port + "' is not a number (no path, no '/' after it)";
      }
    }
    if (port.size() > 5 || std::stoi(port) < 1 || std::stoi(port) > 65535) {
      return "'" + origin + "': port " + port + " outside [1, 65535]";
    }
  }
  return "";
}

namespace {
using Handle = WsHandle;

bool ReadWholeFile(const std::string& path, std::string* out) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  std::ostringstream buffer;
  buffer << in.rdbuf();
  *out = buffer.str();
  return static_cast<bool>(in) || in.eof();
}
}  // namespace

struct ViewerServer::Impl {
  struct Client {
    bool needs_snapshot{true};
  };

  Options options;
  WsServer server;
  std::map<Handle, Client, std::owner_less<Handle>> clients;
  Counters counters;
  bool stopped{false};

  void OnHttp(const Handle& hdl) {
    websocketpp::lib::error_code ec;
    const WsServer::connection_ptr con = server.get_con_from_hdl(hdl, ec);
    if (ec) return;
    ++counters.http_requests;
    const std::string path = ResolveWebPath(options.web_root, con->get_resource());
    std::string body;
    if (path.empty() || !ReadWholeFile(path, &body)) {
      ++counters.http_not_found;
      con->set_status(websocketpp::http::status_code::not_found);
      con->append_header("Content-Type", "text/plain; charset=utf-8");
      con->set_body("not found: " + con->get_resource() +
                    (options.web_root.empty() ? "" : "\n(web root " + options.web_root + ")\n"));
      return;
    }
    con->set_status(websocketpp::http::status_code::ok);
    con->append_header("Content-Type", ContentTypeOf(path));
    con->append_header("Cache-Control", "no-store");
    con->set_body(body);
  }

  bool OnValidate(const Handle& hdl) {
    websocketpp::lib::error_code ec;
    const WsServer::connection_ptr con = server.get_con_from_hdl(hdl, ec);
    if (ec) return false;
    const std::string origin = con->get_request_header("Origin");
    const asio::ip::tcp::endpoint local = server.get_local_endpoint(ec);
    const int port = ec ? -1 : local.port();
    if (!WebSocketOriginAllowed(origin, port, options.allowed_origins)) {
      ++counters.refused_origin;
      Log(LogLevel::kWarning, "viewer server: refused a WebSocket from origin '" + origin +
                                  "' (only pages served here, or of an origin listed in "
                                  "allowed_origins, may connect)");
      con->set_status(websocketpp::http::status_code::forbidden);
      return false;
    }
    if (static_cast<int>(clients.size()) >= options.max_clients) {
      ++counters.refused;
      return false;
    }
    return true;
  }

  void OnOpen(const Handle& hdl) {
    ++counters.connections;
    clients[hdl] = Client{};
  }

  void OnGone(const Handle& hdl) { clients.erase(hdl); }

  // Sends one frame; false if the page is gone (it is then forgotten by the close handler).
  bool Send(const Handle& hdl, const ViewerFrame& frame) {
    websocketpp::lib::error_code ec;
    server.send(
        hdl, frame.bytes,
        frame.binary ? websocketpp::frame::opcode::binary : websocketpp::frame::opcode::text, ec);
    if (ec) ++counters.send_errors;
    return !ec;
  }
};

ViewerServer::ViewerServer(const Options& options) : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  s.options = options;
  InitWebSocketServer(s.server, kViewerMaxMessageBytes, "viewer server");
  s.server.set_http_handler([this](const Handle& h) { impl_->OnHttp(h); });
  s.server.set_validate_handler([this](const Handle& h) { return impl_->OnValidate(h); });
  s.server.set_open_handler([this](const Handle& h) { impl_->OnOpen(h); });
  s.server.set_close_handler([this](const Handle& h) { impl_->OnGone(h); });
  s.server.set_fail_handler([this](const Handle& h) { impl_->OnGone(h); });
  s.server.set_message_handler([](const Handle& /*hdl*/, const WsServer::message_ptr& /*msg*/) {});
  ListenAndAccept(s.server, options.host, options.port, "viewer server");
}

ViewerServer::~ViewerServer() {
  try {
    Stop();
  } catch (const std::exception& e) {  // a destructor must not throw: say it and go on
    Log(LogLevel::kWarning, std::string("viewer server: stopping: ") + e.what());
  }
}

int ViewerServer::port() const { return LocalPort(impl_->server); }

void ViewerServer::Poll() { PollWebSocketServer(impl_->server); }

void ViewerServer::Broadcast(const std::vector<ViewerFrame>& update,
                             const std::function<std::vector<ViewerFrame>()>& snapshot) {
  Impl& s = *impl_;
  std::vector<ViewerFrame> snapshot_frames;
  bool have_snapshot = false;
  std::vector<Handle> handles;
  for (const auto& [hdl, client] : s.clients) handles.push_back(hdl);
  for (const Handle& hdl : handles) {
    websocketpp::lib::error_code ec;
    const WsServer::connection_ptr con = s.server.get_con_from_hdl(hdl, ec);
    if (ec || con->get_state() != websocketpp::session::state::open) continue;
    const auto it = s.clients.find(hdl);
    if (it == s.clients.end()) continue;
    Impl::Client& client = it->second;
    switch (DecideClientAction(client.needs_snapshot,
                               static_cast<int64_t>(con->get_buffered_amount()),
                               s.options.max_client_buffer_bytes)) {
      case ClientAction::kSkip:
        if (!update.empty()) ++s.counters.updates_coalesced;
        client.needs_snapshot = true;
        break;
      case ClientAction::kSendSnapshot: {
        if (!have_snapshot) {
          snapshot_frames = snapshot();
          have_snapshot = true;
        }
        bool ok = true;
        for (const ViewerFrame& f : snapshot_frames) ok = ok && s.Send(hdl, f);
        if (ok) {
          client.needs_snapshot = false;
          ++s.counters.snapshots_sent;
        }
        break;
      }
      case ClientAction::kSendUpdate: {
        if (update.empty()) break;
        bool ok = true;
        for (const ViewerFrame& f : update) ok = ok && s.Send(hdl, f);
        if (ok) {
          ++s.counters.updates_sent;
        } else {
          client.needs_snapshot = true;
        }
        break;
      }
    }
  }
}

int ViewerServer::clients() const { return static_cast<int>(impl_->clients.size()); }

const ViewerServer::Counters& ViewerServer::counters() const { return impl_->counters; }

void ViewerServer::Stop() {
  Impl& s = *impl_;
  if (s.stopped) return;
  s.stopped = true;
  std::vector<Handle> handles;
  for (const auto& [hdl, client] : s.clients) handles.push_back(hdl);
  CloseWebSocketServer(s.server, handles, "kestrel-viewer stopping");
  s.clients.clear();
}

}  // namespace kestrel
