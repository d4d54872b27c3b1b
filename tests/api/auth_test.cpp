// Tokens against a real server. A non-loopback bind cannot be tested here, so
// the rule is: any bind with a token file enforces tokens (127.0.0.1 below),
// and a non-loopback bind without one fails before binding.
#include <sys/stat.h>

#include <httplib.h>

#include "api/auth.hpp"
#include "test_util.hpp"

namespace tally::api::test {
namespace {

const std::string kRead = "read-9f86d081884c7d659a2feaa0c55ad015";
const std::string kCapture = "capt-a3bf4f1b2b0b822cd15d6c15b0f00a08";

class AuthServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto tokens = dir_.write("tokens", "read=" + kRead + "\ncapture=" + kCapture + "\n");
    ::chmod(tokens.c_str(), 0600);
    ServerOptions options;
    options.bindAddress = "127.0.0.1";
    options.tokenFile = tokens;
    dir_.write("web/index.html", "<!doctype html>");
    options.webRoot = dir_.path() / "web";
    auto server = HttpServer::create(std::move(options), testRouter());
    ASSERT_TRUE(server.ok()) << server.error();
    server_ = std::move(*server);
    server_->start();
  }
  std::string auth(const std::string& token) { return "Authorization: Bearer " + token + "\r\n"; }

  TempDir dir_;
  std::unique_ptr<HttpServer> server_;
};

TEST_F(AuthServerTest, TokenFileEnforcesTokensEvenOnLoopback) {
  EXPECT_TRUE(server_->tokensRequired());
  int port = server_->port();
  auto none = get(port, "/api/health");
  EXPECT_EQ(none.status, 401);
  EXPECT_EQ(none.json()["error"]["code"], "unauthorized");
  EXPECT_EQ(none.header("www-authenticate"), "Bearer");
  EXPECT_EQ(get(port, "/api/health", auth("wrong-token-wrong-token-wrong-token")).status, 401);
  EXPECT_EQ(get(port, "/api/health", "Authorization: " + kRead + "\r\n").status, 401);  // no scheme
  EXPECT_EQ(get(port, "/api/health", "Authorization: Basic " + kRead + "\r\n").status, 401);
  EXPECT_EQ(get(port, "/api/health", auth(kRead + "x")).status, 401);
  EXPECT_EQ(get(port, "/api/health", auth(kRead) + auth(kRead)).status, 400);
  // Unauthenticated clients cannot probe for routes either.
  EXPECT_EQ(get(port, "/api/no-such-route").status, 401);
  // Static files hold no data and stay public (a browser cannot attach tokens to page loads).
  EXPECT_EQ(get(port, "/").status, 200);
}

TEST_F(AuthServerTest, ReadTokenReadsCaptureTokenDoesBoth) {
  int port = server_->port();
  auto r = get(port, "/api/test/echo", auth(kRead));
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.json()["principal"], "read");
  r = get(port, "/api/test/echo", auth(kCapture));
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.json()["principal"], "capture");

  auto post = rawRequest(port, jsonPost("/api/test/echo", "{}", auth(kRead)));
  EXPECT_EQ(post.status, 403);
  EXPECT_EQ(post.json()["error"]["code"], "forbidden");
  auto del =
      rawRequest(port, "DELETE /api/test/items/1 HTTP/1.1\r\nHost: 127.0.0.1\r\n" + auth(kRead) + "\r\n");
  EXPECT_EQ(del.status, 403);

  httplib::Client cli("127.0.0.1", port);
  cli.set_bearer_token_auth(kCapture.c_str());
  auto ok = cli.Post("/api/test/echo", R"({"a":1})", "application/json");
  ASSERT_TRUE(ok);
  EXPECT_EQ(ok->status, 200);
  EXPECT_EQ(nlohmann::json::parse(ok->body)["principal"], "capture");
  auto okDel = cli.Delete("/api/test/items/1");
  ASSERT_TRUE(okDel);
  EXPECT_EQ(okDel->status, 200);
}

TEST_F(AuthServerTest, HostCheckIsForTokenlessServersOnly) {
  // With tokens the server may sit behind any name.
  auto r = rawRequest(server_->port(),
                      "GET /api/health HTTP/1.1\r\nHost: tally.example\r\n" + auth(kRead) + "\r\n");
  EXPECT_EQ(r.status, 200);
}

TEST(AuthBind, NonLoopbackWithoutTokenFileFailsBeforeBinding) {
  // Hold a loopback port so that a bind attempt would fail differently; the
  // token error proves the check comes first. Nothing binds 0.0.0.0.
  auto holder = HttpServer::create(ServerOptions{}, Router());
  ASSERT_TRUE(holder.ok());
  for (const char* addr : {"0.0.0.0", "::", "192.0.2.1"}) {
    ServerOptions options;
    options.bindAddress = addr;
    options.port = (*holder)->port();
    auto r = HttpServer::create(options, Router());
    ASSERT_FALSE(r.ok()) << addr;
    EXPECT_NE(r.error().find("without tokens"), std::string::npos) << r.error();
    EXPECT_NE(r.error().find("--token-file"), std::string::npos) << r.error();
  }
}

TEST(AuthBind, BadTokenFileFailsWithItsReason) {
  TempDir dir;
  auto weak = dir.write("tokens", "read=abc\ncapture=def\n");
  ::chmod(weak.c_str(), 0600);
  ServerOptions options;
  options.tokenFile = weak;
  auto r = HttpServer::create(options, Router());
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("too short"), std::string::npos) << r.error();
  options.tokenFile = dir.path() / "missing";
  EXPECT_FALSE(HttpServer::create(options, Router()).ok());
}

}  // namespace
}  // namespace tally::api::test
