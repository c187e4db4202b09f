// The Foxglove endpoint over real loopback sockets, driven by a client written here from the
// protocol's specification (foxglove.websocket.v1): the handshake selects the subprotocol, the
// server sends Server Info and Advertise, a subscription receives Message Data frames (opcode,
// subscription id, time, payload) with the newest message first, unsubscribing stops them, a new
// topic is advertised to a connected client, and bad requests get a Status.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "kestrel/pose_t.hpp"
#include "viewer/foxglove/foxglove_bridge.h"
#include "viewer/foxglove/foxglove_node.h"
#include "viewer/foxglove/foxglove_server.h"

namespace kestrel::foxglove {
namespace {

using nlohmann::json;

/// One WebSocket frame as received (RFC 6455, section 5.2: server frames are not masked).
struct Frame {
  int opcode{0};
  std::string payload;
};

class FoxgloveServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    FoxgloveServer::Options options;
    options.port = 0;
    server_ = std::make_unique<FoxgloveServer>(options);
    ASSERT_GT(server_->port(), 0);
    port_ = server_->port();
    poll_ = [this] { server_->Poll(); };
  }
  void TearDown() override {
    if (fd_ >= 0) close(fd_);
  }

  int Connect() {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    EXPECT_GE(fd, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<uint16_t>(port_));
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
    return fd;
  }
  void SendAll(const std::string& bytes) {
    ASSERT_EQ(send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL),
              static_cast<ssize_t>(bytes.size()));
  }
  // Polls the server and reads until `done` or the time-out.
  bool Pump(const std::function<bool()>& done, double timeout_s = 5.0) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    char buffer[65536];
    while (std::chrono::steady_clock::now() < end) {
      poll_();
      const ssize_t n = recv(fd_, buffer, sizeof buffer, MSG_DONTWAIT);
      if (n > 0) received_.append(buffer, static_cast<size_t>(n));
      if (done()) return true;
      usleep(1000);
    }
    return false;
  }
  std::string Handshake(const std::string& protocol_header) {
    fd_ = Connect();
    SendAll("GET / HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port_) +
            "\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n" + protocol_header +
            "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n");
    EXPECT_TRUE(Pump([&] { return received_.find("\r\n\r\n") != std::string::npos; }));
    const size_t end = received_.find("\r\n\r\n");
    const std::string response = received_.substr(0, end + 4);
    received_.erase(0, end + 4);
    return response;
  }
  // A handshake asking for the subprotocol from a page of `origin` is refused with 403.
  void ExpectForbidden(const std::string& origin) {
    const std::string response =
        Handshake("Sec-WebSocket-Protocol: foxglove.websocket.v1\r\nOrigin: " + origin + "\r\n");
    EXPECT_EQ(response.rfind("HTTP/1.1 403", 0), 0u) << origin << ": " << response;
    close(fd_);
    received_.clear();
  }
  // The next complete frame, waiting for it.
  std::optional<Frame> NextFrame() {
    std::optional<Frame> frame;
    Pump([&] {
      frame = Parse();
      return frame.has_value();
    });
    return frame;
  }
  std::optional<Frame> Parse() {
    if (received_.size() < 2) return std::nullopt;
    const auto byte = [&](size_t i) { return static_cast<uint8_t>(received_[i]); };
    EXPECT_EQ(byte(0) & 0x80, 0x80) << "fragmented frame";
    EXPECT_EQ(byte(1) & 0x80, 0) << "a server frame must not be masked";
    uint64_t length = byte(1) & 0x7f;
    size_t header = 2;
    if (length == 126) {
      if (received_.size() < 4) return std::nullopt;
      length = (uint64_t{byte(2)} << 8) | byte(3);
      header = 4;
    } else if (length == 127) {
      if (received_.size() < 10) return std::nullopt;
      length = 0;
      for (int i = 0; i < 8; ++i) length = (length << 8) | byte(2 + static_cast<size_t>(i));
      header = 10;
    }
    if (received_.size() < header + length) return std::nullopt;
    Frame f{byte(0) & 0x0f, received_.substr(header, length)};
    received_.erase(0, header + length);
    return f;
  }
  // A masked client frame (RFC 6455, section 5.3).
  void SendFrame(int opcode, const std::string& payload) {
    std::string frame(1, static_cast<char>(0x80 | opcode));
    const unsigned char mask[4] = {0x12, 0x34, 0x56, 0x78};
    if (payload.size() < 126) {
      frame += static_cast<char>(0x80 | payload.size());
    } else {
      frame += static_cast<char>(0x80 | 126);
      frame += static_cast<char>((payload.size() >> 8) & 0xff);
      frame += static_cast<char>(payload.size() & 0xff);
    }
    frame.append(reinterpret_cast<const char*>(mask), 4);
    for (size_t i = 0; i < payload.size(); ++i) {
      frame += static_cast<char>(payload[i] ^ static_cast<char>(mask[i % 4]));
    }
    SendAll(frame);
  }
  json NextJson() {
    const std::optional<Frame> f = NextFrame();
    EXPECT_TRUE(f.has_value());
    if (!f) return json();
    EXPECT_EQ(f->opcode, 1) << "expected a text frame";
    return json::parse(f->payload);
  }
  // Opens a Foxglove session; returns the advertised channels by topic.
  std::map<std::string, json> Open() {
    const std::string response =
        Handshake("Sec-WebSocket-Protocol: " + std::string(kSubprotocol) + "\r\n");
    EXPECT_EQ(response.rfind("HTTP/1.1 101", 0), 0u) << response;
    EXPECT_NE(response.find("Sec-WebSocket-Protocol: foxglove.websocket.v1"), std::string::npos)
        << response;
    const json info = NextJson();
    EXPECT_EQ(info["op"], "serverInfo");
    EXPECT_EQ(info["name"], "kestrel-viewer");
    EXPECT_TRUE(info["capabilities"].is_array());
    std::map<std::string, json> channels;
    const json advertise = NextJson();
    EXPECT_EQ(advertise["op"], "advertise");
    for (const json& c : advertise["channels"]) channels[c["topic"]] = c;
    return channels;
  }
  static void ExpectMessageData(const Frame& f, uint32_t subscription, uint64_t time_ns,
                                const std::string& payload) {
    ASSERT_EQ(f.opcode, 2) << "expected a binary frame";
    ASSERT_GE(f.payload.size(), 13u);
    EXPECT_EQ(static_cast<uint8_t>(f.payload[0]), 0x01);
    uint32_t id = 0;
    uint64_t time = 0;
    for (int i = 3; i >= 0; --i) id = (id << 8) | static_cast<uint8_t>(f.payload[1 + i]);
    for (int i = 7; i >= 0; --i) time = (time << 8) | static_cast<uint8_t>(f.payload[5 + i]);
    EXPECT_EQ(id, subscription);
    EXPECT_EQ(time, time_ns);
    EXPECT_EQ(f.payload.substr(13), payload);
  }

  std::unique_ptr<FoxgloveServer> server_;
  int port_{-1};
  std::function<void()> poll_;  ///< the server's socket work (and, for a node, LCM's)
  int fd_{-1};
  std::string received_;
};

const std::string kTf = R"({"timestamp":{"sec":1,"nsec":0},"parent_frame_id":"world"})";

TEST_F(FoxgloveServerTest, AdvertisesSubscribesAndSendsMessageData) {
  server_->Publish("/tf", "foxglove.FrameTransform", 1000000000ULL, kTf);
  std::map<std::string, json> channels = Open();
  ASSERT_EQ(channels.count("/tf"), 1u);
  const json& tf = channels["/tf"];
  EXPECT_EQ(tf["encoding"], "json");
  EXPECT_EQ(tf["schemaName"], "foxglove.FrameTransform");
  EXPECT_EQ(tf["schemaEncoding"], "jsonschema");
  EXPECT_EQ(json::parse(tf["schema"].get<std::string>())["title"], "foxglove.FrameTransform");

  SendFrame(
      1,
      json{{"op", "subscribe"}, {"subscriptions", {{{"id", 7}, {"channelId", tf["id"]}}}}}.dump());
  std::optional<Frame> f = NextFrame();  // the newest message at once
  ASSERT_TRUE(f.has_value());
  ExpectMessageData(*f, 7, 1000000000ULL, kTf);
  server_->Publish("/tf", "foxglove.FrameTransform", 2500000000ULL, kTf + " ");
  f = NextFrame();
  ASSERT_TRUE(f.has_value());
  ExpectMessageData(*f, 7, 2500000000ULL, kTf + " ");

  // A topic first published now is advertised to the connected client.
  server_->Publish("/candidates", "foxglove.SceneUpdate", 3000000000ULL, R"({"entities":[]})");
  const json advertise = NextJson();
  EXPECT_EQ(advertise["op"], "advertise");
  ASSERT_EQ(advertise["channels"].size(), 1u);
  EXPECT_EQ(advertise["channels"][0]["topic"], "/candidates");
  EXPECT_EQ(json::parse(advertise["channels"][0]["schema"].get<std::string>())["title"],
            "foxglove.SceneUpdate");

  // After unsubscribing nothing more arrives on /tf; a bad request gets a Status.
  SendFrame(1, json{{"op", "unsubscribe"}, {"subscriptionIds", {7}}}.dump());
  Pump([] { return false; }, 0.3);  // let the server read it (returns after the time-out)
  server_->Publish("/tf", "foxglove.FrameTransform", 4000000000ULL, kTf);
  SendFrame(1, R"({"op":"getParameters","parameterNames":[]})");
  const json status = NextJson();
  EXPECT_EQ(status["op"], "status");
  EXPECT_EQ(status["level"], 1);
  EXPECT_NE(status["message"].get<std::string>().find("getParameters"), std::string::npos);
  EXPECT_EQ(server_->counters().bad_requests, 1);
  EXPECT_EQ(server_->counters().messages_sent, 2);
}

TEST_F(FoxgloveServerTest, ALateSubscriberGetsTheMapSnapshot) {
  server_->Advertise("/map", "foxglove.SceneUpdate");
  EXPECT_FALSE(server_->HasSubscribers("/map"));
  server_->SetSnapshotSource("/map", [] {
    return FoxgloveServer::Snapshot{5, R"({"entities":["whole map"]})"};
  });
  std::map<std::string, json> channels = Open();
  SendFrame(1, json{{"op", "subscribe"},
                    {"subscriptions", {{{"id", 1}, {"channelId", channels["/map"]["id"]}}}}}
                   .dump());
  const std::optional<Frame> f = NextFrame();
  ASSERT_TRUE(f.has_value());
  ExpectMessageData(*f, 1, 5, R"({"entities":["whole map"]})");
  EXPECT_TRUE(server_->HasSubscribers("/map"));
  EXPECT_FALSE(server_->HasSubscribers("/tf"));
  // A subscription to a channel that was never advertised is refused with a Status.
  SendFrame(1, R"({"op":"subscribe","subscriptions":[{"id":2,"channelId":99}]})");
  const json status = NextJson();
  EXPECT_EQ(status["op"], "status");
  EXPECT_NE(status["message"].get<std::string>().find("no advertised channel"), std::string::npos);
}

TEST_F(FoxgloveServerTest, RefusesAHandshakeWithoutTheSubprotocolOrFromAForeignPage) {
  const std::string plain = Handshake("");
  EXPECT_EQ(plain.rfind("HTTP/1.1 400", 0), 0u) << plain;
  close(fd_);
  received_.clear();
  // A foreign page, Foxglove's web app among them while allowed_origins does not list it.
  for (const char* origin : {"http://evil.example", "https://app.foxglove.dev"}) {
    ExpectForbidden(origin);
  }
  EXPECT_EQ(server_->counters().refused, 3);
  EXPECT_EQ(server_->clients(), 0);
}

// allowed_origins = [https://app.foxglove.dev]: Foxglove's web app connects (101, the
// subprotocol, Server Info), written in any case; another page is still refused.
TEST_F(FoxgloveServerTest, AnAllowedOriginConnects) {
  FoxgloveServer::Options options;
  options.port = 0;
  options.allowed_origins = {"https://app.foxglove.dev"};
  server_ = std::make_unique<FoxgloveServer>(options);
  port_ = server_->port();
  const std::string app = Handshake(
      "Sec-WebSocket-Protocol: foxglove.websocket.v1\r\nOrigin: https://App.Foxglove.dev\r\n");
  EXPECT_EQ(app.rfind("HTTP/1.1 101", 0), 0u) << app;
  EXPECT_NE(app.find("Sec-WebSocket-Protocol: foxglove.websocket.v1"), std::string::npos) << app;
  const json info = NextJson();
  EXPECT_EQ(info["op"], "serverInfo");
  close(fd_);
  received_.clear();
  for (const char* origin : {"http://evil.example", "https://app.foxglove.dev.evil.example",
                             "http://app.foxglove.dev"}) {
    ExpectForbidden(origin);
  }
  EXPECT_EQ(server_->counters().connections, 1);
  EXPECT_EQ(server_->counters().refused, 3);
}

// The node: LCM messages (memq://) reach a subscribed client as Foxglove messages, the map's
// blocks at the node's map rate.
TEST_F(FoxgloveServerTest, TheNodeForwardsKestrelChannels) {
  server_.reset();
  lcm::LCM lcm("memq://");
  SimClock clock(1000000);
  FoxgloveNodeConfig config;
  config.server.port = 0;
  FoxgloveNode node(lcm, config, clock);
  port_ = node.port();
  poll_ = [&] {
    while (lcm.handleTimeout(0) > 0) {
    }
    node.Poll();
    node.PublishDue();
  };
  pose_t pose{};
  pose.utime = 2000000;
  pose.valid = true;
  pose.position_m[0] = 1.25;
  pose.orientation_wxyz[0] = 1.0;
  lcm.publish("POSE_VICON", &pose);  // /tf is advertised once the first pose arrived
  poll_();
  std::map<std::string, json> channels = Open();
  ASSERT_EQ(channels.count("/tf"), 1u);
  SendFrame(1, json{{"op", "subscribe"},
                    {"subscriptions", {{{"id", 3}, {"channelId", channels["/tf"]["id"]}}}}}
                   .dump());
  std::optional<Frame> f = NextFrame();
  ASSERT_TRUE(f.has_value());
  ASSERT_EQ(f->opcode, 2);
  EXPECT_EQ(json::parse(f->payload.substr(13))["translation"]["x"], 1.25);
  pose.utime = 3000000;
  pose.position_m[0] = 2.5;
  lcm.publish("POSE_VICON", &pose);
  f = NextFrame();
  ASSERT_TRUE(f.has_value());
  EXPECT_EQ(json::parse(f->payload.substr(13))["translation"]["x"], 2.5);
  // A malformed message is counted, not forwarded.
  const char garbage[] = "garbage";
  lcm.publish("POSE_VICON", garbage, sizeof garbage);
  poll_();
  EXPECT_EQ(node.refused_messages(), 1);
}

}  // namespace
}  // namespace kestrel::foxglove
