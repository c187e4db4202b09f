#include "viewer/foxglove/foxglove_server.h"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <map>
#include <set>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "common/log.h"
#include "viewer/bridge/viewer_server.h"
#include "viewer/bridge/websocket_server.h"
#include "viewer/foxglove/foxglove_bridge.h"

namespace kestrel::foxglove {
namespace {
using Handle = WsHandle;
using nlohmann::json;

/// Message Data (spec "Binary messages"): opcode 0x01, u32 subscription id, u64 time, payload.
std::string MessageData(uint32_t subscription_id, uint64_t time_ns, const std::string& payload) {
  std::string frame(13 + payload.size(), '\0');
  frame[0] = 0x01;
  for (int i = 0; i < 4; ++i) frame[1 + i] = static_cast<char>((subscription_id >> (8 * i)) & 0xff);
  for (int i = 0; i < 8; ++i) frame[5 + i] = static_cast<char>((time_ns >> (8 * i)) & 0xff);
  std::memcpy(frame.data() + 13, payload.data(), payload.size());
  return frame;
}
}  // namespace

struct FoxgloveServer::Impl {
  struct Channel {
    uint32_t id{0};
    std::string topic;
    std::string schema_name;
    std::string latest_json;
    uint64_t latest_time_ns{0};
    bool has_latest{false};
    std::function<Snapshot()> snapshot;
  };
  struct Client {
    std::map<uint32_t, uint32_t> subscriptions;  ///< subscription id -> channel id
    std::set<uint32_t> behind;                   ///< channels with a skipped message
  };

  Options options;
  WsServer server;
  std::vector<Channel> channels;  ///< index = channel id
  std::map<std::string, uint32_t> channel_of_topic;
  std::map<Handle, Client, std::owner_less<Handle>> clients;
  Counters counters;
  bool stopped{false};
  std::string session_id;

  static json Advertised(const Channel& c) {
    return {{"id", c.id},
            {"topic", c.topic},
            {"encoding", "json"},
            {"schemaName", c.schema_name},
            {"schema", SchemaOf(c.schema_name)},
            {"schemaEncoding", "jsonschema"}};
  }

  bool SendText(const Handle& hdl, const std::string& text) {
    websocketpp::lib::error_code ec;
    server.send(hdl, text, websocketpp::frame::opcode::text, ec);
    return !ec;
  }
  bool SendBinary(const Handle& hdl, const std::string& bytes) {
    websocketpp::lib::error_code ec;
    server.send(hdl, bytes, websocketpp::frame::opcode::binary, ec);
    return !ec;
  }
  void Status(const Handle& hdl, int level, const std::string& message) {
    SendText(hdl, json{{"op", "status"}, {"level", level}, {"message", message}}.dump());
  }

  bool OnValidate(const Handle& hdl) {
    websocketpp::lib::error_code ec;
    const WsServer::connection_ptr con = server.get_con_from_hdl(hdl, ec);
    if (ec) return false;
    const std::vector<std::string>& asked = con->get_requested_subprotocols();
    const asio::ip::tcp::endpoint local = server.get_local_endpoint(ec);
    const std::string origin = con->get_request_header("Origin");
    std::string why;
    auto status = websocketpp::http::status_code::bad_request;
    if (std::find(asked.begin(), asked.end(), kSubprotocol) == asked.end()) {
      why = std::string("the client did not ask for the ") + kSubprotocol + " subprotocol";
    } else if (!WebSocketOriginAllowed(origin, ec ? -1 : local.port(), options.allowed_origins)) {
      why = "a page from origin '" + origin +
            "' may not connect (foxglove.allowed_origins lists the origins allowed besides the "
            "endpoint's own; https://app.foxglove.dev is Foxglove's web app)";
      status = websocketpp::http::status_code::forbidden;
    } else if (static_cast<int>(clients.size()) >= options.max_clients) {
      why = "too many clients (" + std::to_string(options.max_clients) + ")";
      status = websocketpp::http::status_code::service_unavailable;
    }
    if (!why.empty()) {
      ++counters.refused;
      Log(LogLevel::kWarning, "foxglove server: refused a connection: " + why);
      con->set_status(status);
      return false;
    }
    con->select_subprotocol(kSubprotocol, ec);
    return !ec;
  }

  void OnOpen(const Handle& hdl) {
    ++counters.connections;
    clients[hdl] = Client{};
    SendText(hdl, json{{"op", "serverInfo"},
                       {"name", options.name},
                       {"capabilities", json::array()},
                       {"metadata", json::object()},
                       {"sessionId", session_id}}
                      .dump());
    json advertised = json::array();
    for (const Channel& c : channels) advertised.push_back(Advertised(c));
    if (!advertised.empty()) {
      SendText(hdl, json{{"op", "advertise"}, {"channels", advertised}}.dump());
    }
  }

  void OnMessage(const Handle& hdl, const WsServer::message_ptr& msg) {
    const auto it = clients.find(hdl);
    if (it == clients.end()) return;
    Client& client = it->second;
    if (msg->get_opcode() != websocketpp::frame::opcode::text) {
      ++counters.bad_requests;
      Status(hdl, 1, "binary client messages (client publishing, services) are not supported");
      return;
    }
    const json request = json::parse(msg->get_payload(), nullptr, /*allow_exceptions=*/false);
    const std::string op =
        request.is_object() && request.contains("op") && request["op"].is_string()
            ? request["op"].get<std::string>()
            : "";
    if (op == "subscribe" && request.contains("subscriptions") &&
        request["subscriptions"].is_array()) {
      for (const json& s : request["subscriptions"]) {
        if (!s.is_object() || !s.contains("id") || !s.contains("channelId") ||
            !s["id"].is_number_unsigned() || !s["channelId"].is_number_unsigned()) {
          ++counters.bad_requests;
          Status(hdl, 1, "subscribe: every subscription needs a numeric id and channelId");
          continue;
        }
        const auto id = s["id"].get<uint32_t>();
        const auto channel_id = s["channelId"].get<uint32_t>();
        if (channel_id >= channels.size() || client.subscriptions.count(id) != 0) {
          ++counters.bad_requests;
          Status(hdl, 1,
                 "subscribe: subscription " + std::to_string(id) +
                     (channel_id >= channels.size() ? " names no advertised channel"
                                                    : " is already in use"));
          continue;
        }
        client.subscriptions[id] = channel_id;
        SendLatest(hdl, id, channels[channel_id]);
      }
      return;
    }
    if (op == "unsubscribe" && request.contains("subscriptionIds") &&
        request["subscriptionIds"].is_array()) {
      for (const json& id : request["subscriptionIds"]) {
        if (id.is_number_unsigned()) client.subscriptions.erase(id.get<uint32_t>());
      }
      return;
    }
    ++counters.bad_requests;
    Status(hdl, 1,
           "ignored a client message" + (op.empty() ? "" : " '" + op + "'") +
               ": this server supports subscribe and unsubscribe");
  }

  // The newest message of a channel (its snapshot for /map) to one subscription.
  void SendLatest(const Handle& hdl, uint32_t subscription_id, const Channel& c) {
    if (c.snapshot) {
      const Snapshot snapshot = c.snapshot();
      if (!snapshot.second.empty()) {
        SendBinary(hdl, MessageData(subscription_id, snapshot.first, snapshot.second));
        ++counters.messages_sent;
      }
      return;
    }
    if (!c.has_latest) return;
    SendBinary(hdl, MessageData(subscription_id, c.latest_time_ns, c.latest_json));
    ++counters.messages_sent;
  }

  Channel& ChannelFor(const std::string& topic, const std::string& schema_name) {
    const auto found = channel_of_topic.find(topic);
    if (found != channel_of_topic.end()) return channels[found->second];
    Channel c;
    c.id = static_cast<uint32_t>(channels.size());
    c.topic = topic;
    c.schema_name = schema_name;
    channels.push_back(c);
    channel_of_topic[topic] = c.id;
    const std::string advertise =
        json{{"op", "advertise"}, {"channels", json::array({Advertised(channels.back())})}}.dump();
    for (const auto& [hdl, client] : clients) SendText(hdl, advertise);
    return channels.back();
  }
};

FoxgloveServer::FoxgloveServer(const Options& options) : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  s.options = options;
  s.session_id = std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(
                                    std::chrono::system_clock::now().time_since_epoch())
                                    .count());
  InitWebSocketServer(s.server, kViewerMaxMessageBytes, "foxglove server");
  s.server.set_validate_handler([this](const Handle& h) { return impl_->OnValidate(h); });
  s.server.set_open_handler([this](const Handle& h) { impl_->OnOpen(h); });
  s.server.set_close_handler([this](const Handle& h) { impl_->clients.erase(h); });
  s.server.set_fail_handler([this](const Handle& h) { impl_->clients.erase(h); });
  s.server.set_message_handler(
      [this](const Handle& h, const WsServer::message_ptr& m) { impl_->OnMessage(h, m); });
  ListenAndAccept(s.server, options.host, options.port, "foxglove server");
}

FoxgloveServer::~FoxgloveServer() {
  try {
    Stop();
  } catch (const std::exception& e) {  // a destructor must not throw: say it and go on
    Log(LogLevel::kWarning, std::string("foxglove server: stopping: ") + e.what());
  }
}

int FoxgloveServer::port() const { return LocalPort(impl_->server); }

void FoxgloveServer::Poll() { PollWebSocketServer(impl_->server); }

void FoxgloveServer::Advertise(const std::string& topic, const std::string& schema_name) {
  (void)impl_->ChannelFor(topic, schema_name);
}

bool FoxgloveServer::HasSubscribers(const std::string& topic) const {
  const auto found = impl_->channel_of_topic.find(topic);
  if (found == impl_->channel_of_topic.end()) return false;
  for (const auto& [hdl, client] : impl_->clients) {
    for (const auto& [subscription_id, channel_id] : client.subscriptions) {
      if (channel_id == found->second) return true;
    }
  }
  return false;
}

void FoxgloveServer::SetSnapshotSource(const std::string& topic,
                                       std::function<Snapshot()> snapshot) {
  const auto found = impl_->channel_of_topic.find(topic);
  if (found == impl_->channel_of_topic.end()) {
    throw std::invalid_argument("foxglove server: no channel " + topic + " to give a snapshot");
  }
  impl_->channels[found->second].snapshot = std::move(snapshot);
}

void FoxgloveServer::Publish(const std::string& topic, const std::string& schema_name,
                             uint64_t time_ns, const std::string& json_text) {
  Impl& s = *impl_;
  Impl::Channel& channel = s.ChannelFor(topic, schema_name);
  channel.latest_json = json_text;
  channel.latest_time_ns = time_ns;
  channel.has_latest = true;
  for (auto& [hdl, client] : s.clients) {
    websocketpp::lib::error_code ec;
    const WsServer::connection_ptr con = s.server.get_con_from_hdl(hdl, ec);
    if (ec || con->get_state() != websocketpp::session::state::open) continue;
    for (const auto& [subscription_id, channel_id] : client.subscriptions) {
      if (channel_id != channel.id) continue;
      if (static_cast<int64_t>(con->get_buffered_amount()) > s.options.max_client_buffer_bytes) {
        ++s.counters.messages_skipped;
        client.behind.insert(channel.id);
        continue;
      }
      if (client.behind.erase(channel.id) != 0 && channel.snapshot) {
        s.SendLatest(hdl, subscription_id, channel);  // the whole map makes good what was skipped
        continue;
      }
      if (s.SendBinary(hdl, MessageData(subscription_id, time_ns, json_text))) {
        ++s.counters.messages_sent;
      }
    }
  }
}

int FoxgloveServer::clients() const { return static_cast<int>(impl_->clients.size()); }

const FoxgloveServer::Counters& FoxgloveServer::counters() const { return impl_->counters; }

void FoxgloveServer::Stop() {
  Impl& s = *impl_;
  if (s.stopped) return;
  s.stopped = true;
  std::vector<Handle> handles;
  for (const auto& [hdl, client] : s.clients) handles.push_back(hdl);
  CloseWebSocketServer(s.server, handles, "kestrel-viewer stopping");
  s.clients.clear();
}

}  // namespace kestrel::foxglove
