// The server end to end on 127.0.0.1: built-in routes, what handlers see,
// static files, internal errors.
#include <fcntl.h>
#include <httplib.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>

#include <future>
#include <thread>

#include "common/version.hpp"
#include "protocol.hpp"
#include "test_util.hpp"

namespace tally::api::test {
namespace {

class ServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_.write("outside.txt", "top secret");
    dir_.write("web/index.html", "<!doctype html><title>Tally</title>");
    dir_.write("web/js/app.js", "console.log('tally');");
    dir_.write("web/style.css", "body{}");
    dir_.write("web/.env", "TOKEN=x");
    std::filesystem::create_symlink(dir_.path() / "outside.txt", dir_.path() / "web/leak.txt");
    ServerOptions options;
    options.webRoot = dir_.path() / "web";
    options.log = log_.fn();
    auto server = HttpServer::create(std::move(options), testRouter());
    ASSERT_TRUE(server.ok()) << server.error();
    server_ = std::move(*server);
    server_->start();
    port_ = server_->port();
  }

  TempDir dir_;
  LogSink log_;
  std::unique_ptr<HttpServer> server_;
  int port_ = 0;
};

TEST_F(ServerTest, Health) {
  httplib::Client cli("127.0.0.1", port_);
  auto res = cli.Get("/api/health");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(res->get_header_value("Content-Type"), "application/json");
  EXPECT_EQ(res->get_header_value("Cache-Control"), "no-store");
  EXPECT_EQ(res->get_header_value("X-Content-Type-Options"), "nosniff");
  auto body = nlohmann::json::parse(res->body);
  EXPECT_EQ(body["status"], "ok");
  EXPECT_EQ(body["version"], std::string(version()));
  EXPECT_EQ(body["commit"], std::string(gitCommit()));
  EXPECT_EQ(body["api_version"], protocol::kApiVersion);
  EXPECT_FALSE(server_->tokensRequired());
}

TEST_F(ServerTest, OpenApiAndRenderers) {
  httplib::Client cli("127.0.0.1", port_);
  auto doc = cli.Get("/api/openapi.json");
  ASSERT_TRUE(doc);
  EXPECT_EQ(doc->status, 200);
  EXPECT_EQ(nlohmann::json::parse(doc->body), nlohmann::json::parse(openApiDocument()));
  auto renderers = cli.Get("/api/renderers");
  ASSERT_TRUE(renderers);
  EXPECT_EQ(nlohmann::json::parse(renderers->body),
            nlohmann::json::parse(R"({"renderers":["forward","deferred"],"options":[],"workloads":["volume-fog"]})"));
}

TEST_F(ServerTest, HandlersSeeParsedRequests) {
  httplib::Client cli("127.0.0.1", port_);
  httplib::Headers headers = {{"Idempotency-Key", "key-123"}};
  auto res = cli.Post("/api/test/echo?limit=5&renderer=visbuffer%20lean", headers,
                      R"({"scene":"atrium","width":640})", "application/json; charset=utf-8");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200) << res->body;
  auto body = nlohmann::json::parse(res->body);
  EXPECT_EQ(body["method"], "POST");
  EXPECT_EQ(body["body"]["scene"], "atrium");
  EXPECT_EQ(body["body"]["width"], 640);
  EXPECT_EQ(body["query"]["limit"], "5");
  EXPECT_EQ(body["query"]["renderer"], "visbuffer lean");
  EXPECT_EQ(body["idempotency_key"], "key-123");
  EXPECT_EQ(body["principal"], "capture");  // no tokens: everything allowed
  EXPECT_EQ(body["remote_addr"], "127.0.0.1");

  auto item = cli.Get("/api/test/items/run%2042");
  ASSERT_TRUE(item);
  EXPECT_EQ(nlohmann::json::parse(item->body)["params"]["id"], "run 42");
  EXPECT_TRUE(nlohmann::json::parse(cli.Get("/api/test/items/special")->body)["special"]);
  auto del = cli.Delete("/api/test/items/9");
  ASSERT_TRUE(del);
  EXPECT_EQ(del->status, 200);
  EXPECT_EQ(nlohmann::json::parse(del->body)["body"], nullptr);

  // An empty POST body reaches the handler as null (the service decides).
  auto empty = cli.Post("/api/test/echo", "", "application/json");
  ASSERT_TRUE(empty);
  EXPECT_EQ(empty->status, 200);
  EXPECT_EQ(nlohmann::json::parse(empty->body)["body"], nullptr);
}

TEST_F(ServerTest, RawBodiesAndHead) {
  auto png = get(port_, "/api/test/png");
  EXPECT_EQ(png.status, 200);
  EXPECT_EQ(png.header("content-type"), "image/png");
  EXPECT_EQ(png.body, std::string("\x89PNG\r\n", 6));
  auto head = rawRequest(port_, "HEAD /api/health HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n");
  EXPECT_EQ(head.status, 200);
  EXPECT_TRUE(head.body.empty());
}

TEST_F(ServerTest, StaticFiles) {
  auto index = get(port_, "/");
  EXPECT_EQ(index.status, 200);
  EXPECT_EQ(index.header("content-type"), "text/html; charset=utf-8");
  EXPECT_EQ(index.body, "<!doctype html><title>Tally</title>");
  EXPECT_EQ(get(port_, "/index.html").body, index.body);
  auto js = get(port_, "/js/app.js");
  EXPECT_EQ(js.status, 200);
  EXPECT_EQ(js.header("content-type"), "text/javascript; charset=utf-8");
  EXPECT_EQ(get(port_, "/style.css").header("content-type"), "text/css; charset=utf-8");
  for (const char* missing : {"/leak.txt", "/.env", "/js", "/nope.html", "/outside.txt"}) {
    auto r = get(port_, missing);
    EXPECT_EQ(r.status, 404) << missing;
    EXPECT_EQ(r.json()["error"]["code"], "not_found") << missing;
    EXPECT_EQ(r.body.find("secret"), std::string::npos);
  }
}

// A FIFO, a device and a link out of the folder: each answers 404 at once.
// The FIFO is never opened: opened blocking it would wait for a writer and
// hold a request thread for ever.
TEST_F(ServerTest, OnlyRegularFilesInsideTheFolderAreServed) {
  const auto web = dir_.path() / "web";
  const auto fifo = web / "pipe.js";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0) << std::strerror(errno);
  std::filesystem::create_symlink("/etc/passwd", web / "passwd.txt");
  // A device node needs root (CI runs as root); a link to one inside the folder does not.
  bool device = ::mknod((web / "null.txt").c_str(), S_IFCHR | 0644, makedev(1, 3)) == 0;
  // Whatever happens below, set free a request thread that a build opening
  // the FIFO blocking left waiting in open(), so that the server can stop.
  struct Release {
    std::filesystem::path fifo;
    ~Release() {
      int writer = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
      if (writer >= 0) ::close(writer);
    }
  } release{fifo};
  std::vector<std::string> targets = {"/pipe.js", "/passwd.txt"};
  if (device) targets.push_back("/null.txt");
  for (const auto& target : targets) {
    auto start = std::chrono::steady_clock::now();
    auto r = get(port_, target);
    double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_EQ(r.status, 404) << target;
    const nlohmann::json body = r.json();
    EXPECT_TRUE(body.is_object() && body.contains("error") && body["error"]["code"] == "not_found") << target;
    EXPECT_EQ(r.body.find("root:"), std::string::npos) << target;
    EXPECT_LT(seconds, 2.0) << target;
  }
  // The server still answers.
  EXPECT_EQ(get(port_, "/").status, 200);
}

// Browsers accept brotli, which cpp-httplib 0.11.4 runs at its slowest
// quality (0.35 s for the dashboard's chart library): bodies go uncompressed.
TEST_F(ServerTest, BodiesAreSentUncompressed) {
  const std::string browser = "Accept-Encoding: gzip, deflate, br\r\n";
  auto js = get(port_, "/js/app.js", browser);
  EXPECT_EQ(js.status, 200);
  EXPECT_EQ(js.header("content-encoding"), "");
  EXPECT_EQ(js.header("content-length"), "21");
  EXPECT_EQ(js.body, "console.log('tally');");
  auto health = get(port_, "/api/health", browser);
  EXPECT_EQ(health.status, 200);
  EXPECT_EQ(health.header("content-encoding"), "");
  EXPECT_EQ(health.json()["status"], "ok");
}

TEST_F(ServerTest, ExceptionsBecomeAGeneric500) {
  for (const char* route : {"/api/test/throw", "/api/test/throw-int"}) {
    auto r = get(port_, route);
    EXPECT_EQ(r.status, 500) << route;
    EXPECT_EQ(r.json()["error"]["code"], "internal");
    EXPECT_EQ(r.header("content-type"), "application/json");
    EXPECT_EQ(r.header("x-content-type-options"), "nosniff");
    EXPECT_EQ(r.raw.find("secret-detail"), std::string::npos) << r.raw;
    EXPECT_EQ(r.raw.find("/etc/shadow"), std::string::npos) << r.raw;
    EXPECT_EQ(r.raw.find("EXCEPTION_WHAT"), std::string::npos) << r.raw;
    EXPECT_EQ(r.headers.count("exception_what"), 0u);
  }
  // ... and the text goes to the server's log instead.
  EXPECT_NE(log_.all().find("secret-detail-7f3a"), std::string::npos) << log_.all();
  EXPECT_EQ(get(port_, "/api/health").status, 200);
}

TEST_F(ServerTest, ManyClientsAtOnce) {
  std::vector<std::future<int>> results;
  for (int i = 0; i < 64; ++i) {
    results.push_back(std::async(std::launch::async, [this, i] {
      httplib::Client cli("127.0.0.1", port_);
      auto res = cli.Get(i % 2 ? "/api/health" : "/");
      return res ? res->status : -1;
    }));
  }
  for (auto& r : results) EXPECT_EQ(r.get(), 200);
}

TEST(ServerCreate, Errors) {
  ServerOptions options;
  options.webRoot = "/nonexistent/web/root";
  auto r = HttpServer::create(options, Router());
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("web root"), std::string::npos);

  ServerOptions first;
  auto a = HttpServer::create(first, Router());
  ASSERT_TRUE(a.ok()) << a.error();
  ServerOptions second;
  second.port = (*a)->port();
  auto b = HttpServer::create(second, Router());
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.error().find("cannot bind"), std::string::npos) << b.error();
}

TEST(ServerCreate, StopFromAnotherThreadEndsRun) {
  auto s = HttpServer::create(ServerOptions{}, Router());
  ASSERT_TRUE(s.ok());
  auto done = std::async(std::launch::async, [&] { (*s)->run(); });
  while (get((*s)->port(), "/api/health").status != 404)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  (*s)->stop();
  EXPECT_EQ(done.wait_for(std::chrono::seconds(5)), std::future_status::ready);
}

}  // namespace
}  // namespace tally::api::test
