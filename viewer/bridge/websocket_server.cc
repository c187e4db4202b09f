#include "viewer/bridge/websocket_server.h"

#include <stdexcept>

namespace kestrel {

void InitWebSocketServer(WsServer& server, size_t max_message_bytes, const std::string& who) {
  server.clear_access_channels(websocketpp::log::alevel::all);
  server.clear_error_channels(websocketpp::log::elevel::all);
  server.set_error_channels(websocketpp::log::elevel::fatal);
  websocketpp::lib::error_code ec;
  server.init_asio(ec);
  if (ec) throw std::runtime_error(who + ": " + ec.message());
  server.set_reuse_addr(true);
  server.set_max_message_size(max_message_bytes);
}

void ListenAndAccept(WsServer& server, const std::string& host, int port, const std::string& who) {
  websocketpp::lib::error_code ec;
  const asio::ip::address address =
      asio::ip::make_address(host == "localhost" ? std::string("127.0.0.1") : host, ec);
  if (ec) throw std::runtime_error(who + ": bad host '" + host + "'");
  server.listen(asio::ip::tcp::endpoint(address, static_cast<uint16_t>(port)), ec);
  if (ec) {
    throw std::runtime_error(who + ": cannot listen on " + host + ":" + std::to_string(port) +
                             ": " + ec.message());
  }
  server.start_accept(ec);
  if (ec) throw std::runtime_error(who + ": cannot accept: " + ec.message());
}

int LocalPort(WsServer& server) {
  websocketpp::lib::error_code ec;
  const asio::ip::tcp::endpoint endpoint = server.get_local_endpoint(ec);
  return ec ? -1 : endpoint.port();
}

void PollWebSocketServer(WsServer& server) {
  if (server.stopped()) server.reset();
  server.poll();
}

void CloseWebSocketServer(WsServer& server, const std::vector<WsHandle>& clients,
                          const std::string& reason) {
  websocketpp::lib::error_code ec;
  server.stop_listening(ec);
  for (const WsHandle& hdl : clients) {
    server.close(hdl, websocketpp::close::status::going_away, reason, ec);
  }
  server.poll();
}

}  // namespace kestrel
