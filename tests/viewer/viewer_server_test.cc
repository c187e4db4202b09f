// The viewer's HTTP + WebSocket server over real loopback sockets: it serves the page's files and
// nothing outside its folder, survives a page that disconnects in the middle of a send, and gives
// a page that stops reading coalesced state (one later snapshot) instead of an unbounded queue.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "viewer/bridge/viewer_server.h"

namespace kestrel {
namespace {

class ViewerServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char dir[] = "/tmp/kestrel-viewer-web-XXXXXX";
    ASSERT_NE(mkdtemp(dir), nullptr);
    web_root_ = dir;
    std::ofstream(web_root_ + "/index.html") << "<!doctype html><p>kestrel</p>\n";
    ViewerServer::Options options;
    options.port = 0;
    options.web_root = web_root_;
    options.max_client_buffer_bytes = 2 << 20;
    server_ = std::make_unique<ViewerServer>(options);
    ASSERT_GT(server_->port(), 0);
  }
  void TearDown() override {
    server_.reset();
    std::remove((web_root_ + "/index.html").c_str());
    rmdir(web_root_.c_str());
  }

  // A client socket connected to the server (non-blocking reads through Pump).
  int Connect(int receive_buffer_bytes = 0) {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    EXPECT_GE(fd, 0);
    if (receive_buffer_bytes > 0) {
      setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &receive_buffer_bytes, sizeof receive_buffer_bytes);
    }
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<uint16_t>(server_->port()));
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
    return fd;
  }
  static void SendAll(int fd, const std::string& text) {
    ASSERT_EQ(send(fd, text.data(), text.size(), MSG_NOSIGNAL), static_cast<ssize_t>(text.size()));
  }
  // Polls the server and reads what the client has until `done(received)` or the time-out; true
  // if done.
  bool Pump(int fd, std::string* received, const std::function<bool(const std::string&)>& done,
            double timeout_s = 5.0) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    char buffer[65536];
    while (std::chrono::steady_clock::now() < end) {
      server_->Poll();
      if (fd >= 0) {
        const ssize_t n = recv(fd, buffer, sizeof buffer, MSG_DONTWAIT);
        if (n > 0) received->append(buffer, static_cast<size_t>(n));
      }
      if (done(*received)) return true;
      usleep(1000);
    }
    return false;
  }
  // The server's answer to a WebSocket handshake with these extra header lines.
  std::string Handshake(int fd, const std::string& extra_headers) {
    SendAll(fd,
            "GET / HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(server_->port()) +
                "\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n" + extra_headers +
                "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n");
    std::string response;
    EXPECT_TRUE(Pump(fd, &response,
                     [](const std::string& r) { return r.find("\r\n\r\n") != std::string::npos; }));
    return response;
  }
  int OpenWebSocket(int receive_buffer_bytes = 0) {
    const int fd = Connect(receive_buffer_bytes);
    const std::string response = Handshake(fd, "");
    EXPECT_EQ(response.rfind("HTTP/1.1 101", 0), 0u) << response;
    return fd;
  }
  std::string HttpGet(const std::string& target) {
    const int fd = Connect();
    SendAll(fd, "GET " + target + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n");
    std::string response;
    (void)Pump(fd, &response, [](const std::string& r) {
      const size_t head = r.find("\r\n\r\n");
      const size_t length = r.find("Content-Length: ");
      if (head == std::string::npos || length == std::string::npos) return false;
      return r.size() >= head + 4 + std::stoul(r.substr(length + 16));
    });
    close(fd);
    return response;
  }
  // An update of one binary frame of `bytes` bytes.
  static std::vector<ViewerFrame> Update(size_t bytes) {
    return {ViewerFrame{true, std::string(bytes, '\x01')}};
  }

  std::string web_root_;
  std::unique_ptr<ViewerServer> server_;
};

// The page is served; paths outside the folder are not.
TEST_F(ViewerServerTest, ServesThePageAndNothingOutsideItsFolder) {
  const std::string page = HttpGet("/");
  EXPECT_EQ(page.rfind("HTTP/1.1 200", 0), 0u) << page;
  EXPECT_NE(page.find("<p>kestrel</p>"), std::string::npos);
  EXPECT_NE(page.find("text/html"), std::string::npos);
  EXPECT_EQ(HttpGet("/../../etc/passwd").rfind("HTTP/1.1 404", 0), 0u);
  EXPECT_EQ(HttpGet("/missing.js").rfind("HTTP/1.1 404", 0), 0u);
  EXPECT_EQ(server_->counters().http_not_found, 2);
}

// Only the page this server served may open a WebSocket: a page of another origin in the same
// browser is refused with 403 (and counted), the page's own origin and a program without an
// Origin header are accepted.
TEST_F(ViewerServerTest, RefusesWebSocketsFromForeignOrigins) {
  const std::string own = "http://127.0.0.1:" + std::to_string(server_->port());
  for (const std::string& foreign : {std::string("http://evil.example"), std::string("null"),
                                     "http://127.0.0.1:" + std::to_string(server_->port() + 1),
                                     "https://127.0.0.1:" + std::to_string(server_->port())}) {
    const int fd = Connect();
    const std::string response = Handshake(fd, "Origin: " + foreign + "\r\n");
    EXPECT_EQ(response.rfind("HTTP/1.1 403", 0), 0u) << foreign << ": " << response;
    close(fd);
  }
  EXPECT_EQ(server_->counters().refused_origin, 4);
  EXPECT_EQ(server_->counters().connections, 0);
  for (const std::string& header : {"Origin: " + own + "\r\n", std::string()}) {
    const int fd = Connect();
    const std::string response = Handshake(fd, header);
    EXPECT_EQ(response.rfind("HTTP/1.1 101", 0), 0u) << header << response;
    close(fd);
  }
  EXPECT_EQ(server_->counters().connections, 2);
}

TEST(WebSocketOrigin, OnlyThisServersPages) {
  EXPECT_TRUE(WebSocketOriginAllowed("", 8740));
  EXPECT_TRUE(WebSocketOriginAllowed("http://127.0.0.1:8740", 8740));
  EXPECT_TRUE(WebSocketOriginAllowed("HTTP://LocalHost:8740", 8740));
  EXPECT_TRUE(WebSocketOriginAllowed("http://[::1]:8740", 8740));
  EXPECT_FALSE(WebSocketOriginAllowed("http://evil.example", 8740));
  EXPECT_FALSE(WebSocketOriginAllowed("null", 8740));
  EXPECT_FALSE(WebSocketOriginAllowed("http://127.0.0.1:9000", 8740));
  EXPECT_FALSE(WebSocketOriginAllowed("https://127.0.0.1:8740", 8740));
  EXPECT_FALSE(WebSocketOriginAllowed("http://rebound.example:8740", 8740));  // DNS rebinding
}

// allowed_origins adds whole origins, compared without regard to case; a prefix, another scheme
// or another port of a listed origin is not it.
TEST(WebSocketOrigin, AllowedOriginsAreMatchedWhole) {
  const std::vector<std::string> allowed{"https://app.foxglove.dev", "http://10.0.0.5:8080"};
  EXPECT_TRUE(WebSocketOriginAllowed("https://app.foxglove.dev", 8765, allowed));
  EXPECT_TRUE(WebSocketOriginAllowed("HTTPS://APP.FOXGLOVE.DEV", 8765, allowed));
  EXPECT_TRUE(WebSocketOriginAllowed("http://10.0.0.5:8080", 8765, allowed));
  EXPECT_TRUE(WebSocketOriginAllowed("http://127.0.0.1:8765", 8765, allowed));  // its own
  EXPECT_FALSE(WebSocketOriginAllowed("https://app.foxglove.dev", 8765));       // not listed
  EXPECT_FALSE(WebSocketOriginAllowed("http://app.foxglove.dev", 8765, allowed));
  EXPECT_FALSE(WebSocketOriginAllowed("https://app.foxglove.dev.evil.example", 8765, allowed));
  EXPECT_FALSE(WebSocketOriginAllowed("https://app.foxglove.dev:444", 8765, allowed));
  EXPECT_FALSE(WebSocketOriginAllowed("http://10.0.0.5", 8765, allowed));
  EXPECT_FALSE(WebSocketOriginAllowed("null", 8765, allowed));
}

TEST(WebSocketOrigin, AnAllowedOriginMustBeOneOrigin) {
  for (const char* ok : {"https://app.foxglove.dev", "http://localhost:3000", "http://[::1]:80",
                         "http://10.0.0.5:65535", "HTTPS://Example.COM"}) {
    EXPECT_EQ(CheckAllowedOrigin(ok), "") << ok;
  }
  const std::vector<std::pair<std::string, std::string>> refused = {
      {"*", "every"},
      {"null", "every local file"},
      {"app.foxglove.dev", "http:// or https://"},
      {"ws://app.foxglove.dev", "http:// or https://"},
      {"https://app.foxglove.dev/", "'/'"},
      {"https://app.foxglove.dev/path", "'/'"},
      {"https://", "no host"},
      {"https://host:", "without a port"},
      {"https://host:0", "outside [1, 65535]"},
      {"https://host:70000", "outside [1, 65535]"},
      {"https://host:80/", "not a number"},
      {"https://ho st", "' ' in the host"},
      {"http://[::1", "without its ']'"}};
  for (const auto& [origin, why] : refused) {
    const std::string said = CheckAllowedOrigin(origin);
    EXPECT_NE(said.find(why), std::string::npos) << origin << ": " << said;
  }
}

// A page of an origin in allowed_origins may open the page's WebSocket; others still may not.
TEST_F(ViewerServerTest, AcceptsWebSocketsFromAllowedOrigins) {
  ViewerServer::Options options;
  options.port = 0;
  options.web_root = web_root_;
  options.allowed_origins = {"http://10.0.0.5:8080"};
  server_ = std::make_unique<ViewerServer>(options);
  int fd = Connect();
  std::string response = Handshake(fd, "Origin: http://10.0.0.5:8080\r\n");
  EXPECT_EQ(response.rfind("HTTP/1.1 101", 0), 0u) << response;
  close(fd);
  fd = Connect();
  response = Handshake(fd, "Origin: http://10.0.0.6:8080\r\n");
  EXPECT_EQ(response.rfind("HTTP/1.1 403", 0), 0u) << response;
  close(fd);
  EXPECT_EQ(server_->counters().connections, 1);
  EXPECT_EQ(server_->counters().refused_origin, 1);
}

// A page that goes away (reset) while a large update is being written costs an error count, not
// the bridge: the next page still gets its snapshot.
TEST_F(ViewerServerTest, APageThatDisconnectsMidSendIsForgotten) {
  const int first = OpenWebSocket(4096);
  std::string ignored;
  ASSERT_TRUE(Pump(-1, &ignored, [&](const std::string&) { return server_->clients() == 1; }));
  int snapshots = 0;
  const auto snapshot = [&] {
    ++snapshots;
    return Update(100);
  };
  server_->Broadcast({}, snapshot);               // the first page's snapshot
  server_->Broadcast(Update(3 << 20), snapshot);  // 3 MiB: far more than the socket holds
  server_->Poll();
  linger reset{1, 0};  // close with RST, in the middle of the write
  setsockopt(first, SOL_SOCKET, SO_LINGER, &reset, sizeof reset);
  close(first);
  for (int i = 0; i < 20; ++i) server_->Broadcast(Update(1 << 16), snapshot);
  ASSERT_TRUE(Pump(-1, &ignored, [&](const std::string&) { return server_->clients() == 0; }));
  EXPECT_GE(server_->counters().updates_sent, 1);  // the 3 MiB were being written
  const int second = OpenWebSocket();
  std::string received;
  ASSERT_TRUE(Pump(second, &received, [&](const std::string&) {
    server_->Broadcast({}, snapshot);
    return server_->clients() == 1 && snapshots == 2;
  }));
  // The snapshot arrives as one binary WebSocket frame of 100 bytes (0x82, length 100).
  ASSERT_TRUE(Pump(second, &received, [](const std::string& r) { return r.size() >= 102; }));
  EXPECT_EQ(static_cast<uint8_t>(received[0]), 0x82);
  EXPECT_EQ(static_cast<uint8_t>(received[1]), 100);
  close(second);
}

// A page that stops reading is skipped once its unsent bytes pass the limit (the updates it
// missed are counted as coalesced); when it reads again it gets one snapshot of the present.
TEST_F(ViewerServerTest, APageThatStopsReadingGetsCoalescedState) {
  const int fd = OpenWebSocket(4096);
  std::string received;
  ASSERT_TRUE(Pump(-1, &received, [&](const std::string&) { return server_->clients() == 1; }));
  int snapshots = 0;
  const auto snapshot = [&] {
    ++snapshots;
    return Update(10);
  };
  server_->Broadcast({}, snapshot);
  for (int i = 0; i < 40; ++i) {  // 40 MiB offered to a page that reads nothing
    server_->Broadcast(Update(1 << 20), snapshot);
    server_->Poll();
  }
  const ViewerServer::Counters before = server_->counters();
  EXPECT_GT(before.updates_coalesced, 30);
  EXPECT_LT(before.updates_sent, 10);
  EXPECT_EQ(snapshots, 1);
  // Reading again: the backlog drains and one snapshot follows.
  ASSERT_TRUE(Pump(
      fd, &received,
      [&](const std::string&) {
        server_->Broadcast({}, snapshot);
        return snapshots == 2;
      },
      20.0));
  EXPECT_EQ(server_->counters().snapshots_sent, 2);
  close(fd);
}

}  // namespace
}  // namespace kestrel
