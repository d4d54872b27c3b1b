// The front door (api/connection_gate.hpp) against an in-process server:
// requests read whole before a thread sees them, a deadline on the whole
// request (not per read), limits per peer, and the refusals counted in the
// metrics. tests/service/slow_clients_test.cpp holds 200 slow connections
// against a real tallyd.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "api/connection_gate.hpp"
#include "common/metrics.hpp"
#include "test_util.hpp"

namespace tally::api::test {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

TEST(RequestExtent, HeaderEndAndBody) {
  EXPECT_FALSE(requestExtent("GET / HTTP/1.1\r\nHost: x\r\n", 100).headerComplete);
  auto get = requestExtent("GET / HTTP/1.1\r\nHost: x\r\n\r\n", 100);
  EXPECT_TRUE(get.headerComplete);
  EXPECT_EQ(get.headerBytes, 27u);
  EXPECT_EQ(get.bodyBytes, 0u);
  auto post = requestExtent("POST / HTTP/1.1\r\ncontent-LENGTH:  12 \r\nExpect: 100-continue\r\n\r\n{", 100);
  EXPECT_EQ(post.bodyBytes, 12u);
  EXPECT_TRUE(post.expectContinue);
}

TEST(RequestExtent, OddFramingWaitsForNoBody) {
  // The handler refuses these from the header alone; the gate must not wait.
  for (const char* header : {"Content-Length: 5\r\nContent-Length: 5\r\n", "Content-Length: 5x\r\n",
                             "Content-Length: -1\r\n", "Content-Length: 5\r\nTransfer-Encoding: chunked\r\n", "Content-Length: 5\r\nContent-Encoding: gzip\r\n",
                             "Content-Length: 101\r\n", "Content-Length: 99999999999999999999999\r\n"}) {
    auto e = requestExtent(std::string("POST / HTTP/1.1\r\n") + header + "\r\n", 100);
    EXPECT_TRUE(e.headerComplete) << header;
    EXPECT_EQ(e.bodyBytes, 0u) << header;
    EXPECT_FALSE(e.expectContinue) << header;
  }
}

// A connection from a chosen loopback address (all of 127/8 reaches the
// server on 127.0.0.1), so that tests can be several peers.
int connectFrom(const char* source, int port) {
  int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in from{};
  from.sin_family = AF_INET;
  inet_pton(AF_INET, source, &from.sin_addr);
  if (::bind(fd, reinterpret_cast<sockaddr*>(&from), sizeof from) != 0) {
    ::close(fd);
    return -1;
  }
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<uint16_t>(port));
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&to), sizeof to) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

void sendAll(int fd, const std::string& bytes) {
  for (size_t at = 0; at < bytes.size();) {
    ssize_t n = ::send(fd, bytes.data() + at, bytes.size() - at, MSG_NOSIGNAL);
    if (n <= 0) return;
    at += size_t(n);
  }
}

// What the server sends until it closes, `until` appears in it (when not
// empty), or `limit` passes.
std::string readUntilClosed(int fd, std::chrono::milliseconds limit, std::string_view until = {}) {
  std::string out;
  auto deadline = Clock::now() + limit;
  char buf[4096];
  while (Clock::now() < deadline && (until.empty() || out.find(until) == std::string::npos)) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 20) <= 0) continue;
    ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    out.append(buf, size_t(n));
  }
  return out;
}

int statusOf(const std::string& response) {
  return response.rfind("HTTP/1.1 ", 0) == 0 ? std::atoi(response.c_str() + 9) : 0;
}

class GateTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ServerOptions o;
    o.requestTimeout = 400ms;
    o.maxConnectionsPerPeer = 4;
    o.threads = 2;
    o.metrics = &metrics_;
    auto s = HttpServer::create(o, testRouter());
    ASSERT_TRUE(s.ok()) << s.error();
    server_ = std::move(*s);
    server_->start();
    port_ = server_->port();
  }
  void TearDown() override {
    for (int fd : open_) ::close(fd);
  }
  int keep(int fd) {
    if (fd >= 0) open_.push_back(fd);
    return fd;
  }
  metrics::Registry metrics_;
  std::unique_ptr<HttpServer> server_;
  int port_ = 0;
  std::vector<int> open_;
};

TEST_F(GateTest, HalfAHeaderIsCutAtTheDeadline) {
  int fd = keep(connectFrom("127.0.0.1", port_));
  ASSERT_GE(fd, 0);
  auto start = Clock::now();
  sendAll(fd, "GET /api/health HTTP/1.1\r\nHost: 127.");
  // The 408 itself says the deadline cut it; the read's own deadline only
  // bounds a hang. Not before the deadline, however busy the machine.
  std::string reply = readUntilClosed(fd, 30s);
  double waited = std::chrono::duration<double>(Clock::now() - start).count();
  EXPECT_EQ(statusOf(reply), 408) << reply;
  EXPECT_NE(reply.find("\"request_timeout\""), std::string::npos) << reply;
  EXPECT_GE(waited, 0.35);
  EXPECT_EQ(metrics_.value("tally_http_connections_refused_total", {{"reason", "timeout"}}), 1);
}

TEST_F(GateTest, TheDeadlineIsOnTheWholeRequestNotEachRead) {
  // A byte every 50 ms keeps any per-read timeout happy for ever.
  int fd = keep(connectFrom("127.0.0.1", port_));
  ASSERT_GE(fd, 0);
  const std::string request = "GET /api/health HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: " + std::string(200, 'a');
  // Sent whole, the request takes at least 50 ms x its length (over 13 s),
  // far past the 400 ms deadline: it must be cut before its last byte. A
  // busy machine only slows the sending, so it is cut sooner, not later.
  int status = 0;
  size_t sent = 0;
  for (; sent < request.size() && status == 0; ++sent) {
    sendAll(fd, request.substr(sent, 1));
    std::string reply = readUntilClosed(fd, 50ms);
    status = statusOf(reply);
  }
  if (status == 0) status = statusOf(readUntilClosed(fd, 30s));
  EXPECT_EQ(status, 408);
  EXPECT_LT(sent, request.size()) << "the whole header was read: the deadline is per read";
}

TEST_F(GateTest, ABodyThatNeverComesIsCutToo) {
  int fd = keep(connectFrom("127.0.0.1", port_));
  ASSERT_GE(fd, 0);
  sendAll(fd, "POST /api/test/echo HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
              "Content-Length: 100\r\n\r\n{\"a\":");
  EXPECT_EQ(statusOf(readUntilClosed(fd, 30s)), 408);
}

TEST_F(GateTest, APeerPastItsLimitIsTurnedAwayOthersAreNot) {
  for (int i = 0; i < 4; ++i) ASSERT_GE(keep(connectFrom("127.0.0.3", port_)), 0);
  // The gate has accepted all four before the fifth: wait for its count, not a time.
  for (auto until = Clock::now() + 30s; Clock::now() < until; std::this_thread::sleep_for(5ms)) {
    (void)metrics_.text();  // fills tally_http_connections_open
    if (metrics_.value("tally_http_connections_open") >= 4) break;
  }
  ASSERT_EQ(metrics_.value("tally_http_connections_open"), 4);
  int fifth = keep(connectFrom("127.0.0.3", port_));
  ASSERT_GE(fifth, 0);
  std::string reply = readUntilClosed(fifth, 30s);
  EXPECT_EQ(statusOf(reply), 503) << reply;
  EXPECT_NE(reply.find("Retry-After: 1"), std::string::npos) << reply;
  EXPECT_EQ(metrics_.value("tally_http_connections_refused_total", {{"reason", "peer_limit"}}), 1);
  // Another address is served meanwhile: while the first peer still holds
  // its four connections (the read's deadline only bounds a hang).
  int other = keep(connectFrom("127.0.0.4", port_));
  sendAll(other, "GET /api/health HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n");
  std::string ok = readUntilClosed(other, 30s);
  EXPECT_EQ(statusOf(ok), 200) << ok;
  EXPECT_EQ(metrics_.value("tally_http_connections_refused_total", {{"reason", "peer_limit"}}), 1)
      << "the other address was refused too";
}

TEST_F(GateTest, AHugeHeaderIsRefused) {
  int fd = keep(connectFrom("127.0.0.1", port_));
  ASSERT_GE(fd, 0);
  sendAll(fd, "GET /api/health HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Big: " + std::string(70 * 1024, 'b'));
  EXPECT_EQ(statusOf(readUntilClosed(fd, 30s)), 431);
  EXPECT_EQ(metrics_.value("tally_http_connections_refused_total", {{"reason", "header_too_large"}}), 1);
}

// The whole header in one write: the gate reads it in one go and finds its
// end, but 120 KB is still over the 64 KiB limit.
TEST_F(GateTest, AHugeHeaderInOneWriteIsRefused) {
  int fd = keep(connectFrom("127.0.0.1", port_));
  ASSERT_GE(fd, 0);
  std::string header = "GET /api/health HTTP/1.1\r\nHost: 127.0.0.1\r\n";
  for (int i = 0; i < 120; ++i)
    header += "X-Big-" + std::to_string(i) + ": " + std::string(1000, 'b') + "\r\n";
  header += "\r\n";
  ASSERT_GT(header.size(), 120000u);
  sendAll(fd, header);
  EXPECT_EQ(statusOf(readUntilClosed(fd, 3s)), 431);
  EXPECT_EQ(metrics_.value("tally_http_connections_refused_total", {{"reason", "header_too_large"}}), 1);
  // Just under the limit still passes.
  int ok = keep(connectFrom("127.0.0.1", port_));
  ASSERT_GE(ok, 0);
  std::string under = "GET /api/health HTTP/1.1\r\nHost: 127.0.0.1\r\n";
  for (int i = 0; i < 50; ++i) under += "X-Big-" + std::to_string(i) + ": " + std::string(1200, 'b') + "\r\n";
  sendAll(ok, under + "\r\n");
  EXPECT_EQ(statusOf(readUntilClosed(ok, 3s)), 200);
}

TEST_F(GateTest, TwoHostHeadersAreRefused) {
  int fd = keep(connectFrom("127.0.0.1", port_));
  ASSERT_GE(fd, 0);
  sendAll(fd, "GET /api/health HTTP/1.1\r\nHost: 127.0.0.1\r\nHost: evil.example\r\n\r\n");
  std::string answer = readUntilClosed(fd, 3s);
  EXPECT_EQ(statusOf(answer), 400) << answer;
  EXPECT_NE(answer.find("more than one Host header"), std::string::npos) << answer;
}

TEST_F(GateTest, ExpectContinueGetsItsInterimAnswer) {
  // curl sends bodies over 1 KiB this way and waits a second for "100 Continue".
  int fd = keep(connectFrom("127.0.0.1", port_));
  ASSERT_GE(fd, 0);
  const std::string body = "{\"x\":1}";
  sendAll(fd, "POST /api/test/echo HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
              "Expect: 100-continue\r\nContent-Length: " + std::to_string(body.size()) + "\r\n\r\n");
  std::string interim = readUntilClosed(fd, 30s, "\r\n\r\n");
  EXPECT_EQ(interim.rfind("HTTP/1.1 100 Continue\r\n\r\n", 0), 0u) << interim;
  sendAll(fd, body);
  std::string reply = readUntilClosed(fd, 30s, "\"body\":{\"x\":1}");
  size_t final = reply.find("HTTP/1.1 200");
  ASSERT_NE(final, std::string::npos) << reply;
  EXPECT_NE(reply.find("\"body\":{\"x\":1}"), std::string::npos) << reply;
}

TEST_F(GateTest, AnsweredRequestsAreCountedByRouteAndCode) {
  EXPECT_EQ(get(port_, "/api/health").status, 200);
  EXPECT_EQ(get(port_, "/api/test/items/7").status, 200);
  EXPECT_EQ(get(port_, "/api/nowhere").status, 404);
  EXPECT_EQ(metrics_.value("tally_http_requests_total", {{"route", "/api/health"}, {"code", "200"}}), 1);
  EXPECT_EQ(metrics_.value("tally_http_requests_total", {{"route", "/api/test/items/{id}"}, {"code", "200"}}), 1);
  EXPECT_EQ(metrics_.value("tally_http_requests_total", {{"route", "unmatched"}, {"code", "404"}}), 1);
  EXPECT_EQ(metrics_.value("tally_http_request_duration_seconds", {{"route", "/api/health"}}), 1);
}

}  // namespace
}  // namespace tally::api::test
