// Pieces of the transport without a socket: router, error bodies, request
// checks, token parsing, static file lookup.
#include <sys/stat.h>

#include <fstream>
#include <set>

#include <gtest/gtest.h>

#include "api/auth.hpp"
#include "api/builtin_routes.hpp"
#include "api/request_checks.hpp"
#include "api/router.hpp"
#include "api/static_files.hpp"
#include "test_util.hpp"

namespace tally::api {
namespace {

Handler named(std::string name) {
  return [name](const Request& req) { return Response::ok({{"name", name}, {"params", req.params}}); };
}

TEST(Router, MatchesParametersAndPrefersLiterals) {
  Router r;
  r.get("/api/runs/{id}", named("run"))
      .get("/api/runs/latest", named("latest"))
      .get("/api/runs/{id}/samples", named("samples"));
  auto m = r.match("GET", "/api/runs/42");
  ASSERT_EQ(m.outcome, Router::Outcome::kFound);
  EXPECT_EQ(m.route->pattern, "/api/runs/{id}");
  EXPECT_EQ(m.params.at("id"), "42");
  EXPECT_EQ(r.match("GET", "/api/runs/latest").route->pattern, "/api/runs/latest");
  EXPECT_EQ(r.match("GET", "/api/runs/7/samples").params.at("id"), "7");
  EXPECT_EQ(r.match("GET", "/api/runs/").outcome, Router::Outcome::kNotFound);
  EXPECT_EQ(r.match("GET", "/api/runs").outcome, Router::Outcome::kNotFound);
  EXPECT_EQ(r.match("GET", "/api/runs/7/samples/x").outcome, Router::Outcome::kNotFound);
  EXPECT_EQ(r.match("HEAD", "/api/runs/7").outcome, Router::Outcome::kFound);
}

TEST(Router, MethodNotAllowedListsAllowedMethods) {
  Router r;
  r.get("/api/captures/{id}", named("get")).del("/api/captures/{id}", named("del"));
  auto m = r.match("POST", "/api/captures/3");
  ASSERT_EQ(m.outcome, Router::Outcome::kMethodNotAllowed);
  EXPECT_EQ(joinAllowed(m.allowed), "DELETE, GET, HEAD");
  auto resp = r.dispatch(Request{.method = "POST", .path = "/api/captures/3"});
  EXPECT_EQ(resp.status, 405);
  EXPECT_EQ(resp.json["error"]["code"], "method_not_allowed");
  EXPECT_EQ(r.dispatch(Request{.method = "GET", .path = "/nope"}).status, 404);
  auto ok = r.dispatch(Request{.method = "GET", .path = "/api/captures/9"});
  EXPECT_EQ(ok.json["params"]["id"], "9");
}

TEST(Router, AccessDefaultsByMethod) {
  Router r;
  r.get("/a", named("a")).post("/a", named("b")).add("POST", "/b", named("c"), Principal::kRead);
  EXPECT_EQ(r.match("GET", "/a").route->need, Principal::kRead);
  EXPECT_EQ(r.match("POST", "/a").route->need, Principal::kCapture);
  EXPECT_EQ(r.match("POST", "/b").route->need, Principal::kRead);
  EXPECT_TRUE(allows(Principal::kCapture, Principal::kRead));
  EXPECT_FALSE(allows(Principal::kRead, Principal::kCapture));
}

TEST(Router, RefusesMalformedPatterns) {
  Router r;
  EXPECT_THROW(r.get("api/x", named("x")), std::invalid_argument);
  EXPECT_THROW(r.get("/api//x", named("x")), std::invalid_argument);
  EXPECT_THROW(r.get("/api/{}", named("x")), std::invalid_argument);
  EXPECT_THROW(r.get("/api/{id", named("x")), std::invalid_argument);
  EXPECT_THROW(r.add("HEAD", "/x", named("x")), std::invalid_argument);
  r.get("/api/x/{id}", named("x"));
  EXPECT_THROW(r.get("/api/x/{id}", named("y")), std::invalid_argument);
}

TEST(Service, ErrorBodyShape) {
  auto r = errorResponse(400, "invalid_field", "width must be positive", "width");
  EXPECT_EQ(r.status, 400);
  EXPECT_EQ(r.json,
            nlohmann::json::parse(
                R"({"error":{"code":"invalid_field","message":"width must be positive","field":"width"}})"));
  EXPECT_FALSE(notFound("no run 3").json["error"].contains("field"));
  EXPECT_EQ(badRequest("x", "f").json["error"]["code"], "invalid_field");
  EXPECT_EQ(conflict("x").status, 409);
  EXPECT_STREQ(defaultErrorCode(413), "payload_too_large");
  EXPECT_STREQ(defaultErrorCode(502), "internal");
}

TEST(RequestChecks, Targets) {
  for (const char* ok : {"/", "/api/runs/12", "/api/runs?renderer=forward&width=1920", "/app.js", "/a%20b",
                         "/api/x?q=%2e%2e"}) {
    EXPECT_FALSE(checkTarget(ok, std::string(ok).substr(0, std::string(ok).find('?')))) << ok;
  }
  struct Bad {
    std::string raw;
    std::string decoded;
  };
  for (Bad b :
       {Bad{"/../etc/passwd", "/../etc/passwd"}, Bad{"/%2e%2e/etc", "/../etc"}, Bad{"/%2E%2E/etc", "/../etc"},
        Bad{"/a%2fb", "/a/b"}, Bad{"/a/..", "/a/.."}, Bad{"/a/./b", "/a/./b"},
        Bad{"//etc/passwd", "//etc/passwd"}, Bad{"http://x/api", "http://x/api"}, Bad{"*", "*"},
        Bad{"/a\\b", "/a\\b"}, Bad{"/a%00b", std::string("/a\0b", 4)}, Bad{"/a%5cb", "/a\\b"},
        Bad{"/a%252e", "/a%2e"}, Bad{"", ""}}) {
    EXPECT_TRUE(checkTarget(b.raw, b.decoded)) << b.raw;
  }
}

TEST(RequestChecks, HeadersAndBodies) {
  EXPECT_EQ(parseContentLength("0"), 0u);
  EXPECT_EQ(parseContentLength("1048576"), 1048576u);
  EXPECT_FALSE(parseContentLength(""));
  EXPECT_FALSE(parseContentLength("-1"));
  EXPECT_FALSE(parseContentLength("12abc"));
  EXPECT_FALSE(parseContentLength(" 12"));
  EXPECT_FALSE(parseContentLength("99999999999999999999"));
  EXPECT_TRUE(isJsonMediaType("application/json"));
  EXPECT_TRUE(isJsonMediaType("Application/JSON; charset=utf-8"));
  EXPECT_FALSE(isJsonMediaType("text/plain"));
  EXPECT_FALSE(isJsonMediaType("application/jsonx"));
  EXPECT_FALSE(isJsonMediaType(""));
  for (const char* h :
       {"localhost", "localhost:8080", "127.0.0.1", "127.0.0.1:9", "[::1]:80", "[::1]", "LOCALHOST"})
    EXPECT_TRUE(isLoopbackHost(h)) << h;
  for (const char* h : {"evil.example", "evil.example:80", "10.0.0.1", "127.0.0.1.evil.example", "[::2]",
                        "localhost.evil", ""})
    EXPECT_FALSE(isLoopbackHost(h)) << h;
  EXPECT_TRUE(isValidIdempotencyKey("abc-123"));
  EXPECT_FALSE(isValidIdempotencyKey(""));
  EXPECT_FALSE(isValidIdempotencyKey("a b"));
  EXPECT_FALSE(isValidIdempotencyKey(std::string(201, 'a')));
  EXPECT_TRUE(parseJsonBody(R"({"a":[1,2,{"b":null}]})").ok());
  EXPECT_FALSE(parseJsonBody("[1,2]").ok());
  EXPECT_FALSE(parseJsonBody("{").ok());
  EXPECT_FALSE(parseJsonBody("").ok());
  EXPECT_FALSE(parseJsonBody(R"({"a":1} x)").ok());
  std::string deep = "{\"a\":" + std::string(100, '[') + std::string(100, ']') + "}";
  auto r = parseJsonBody(deep);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("deeper"), std::string::npos);
  // At most kMaxJsonValues values: the parser stops at the first one over.
  std::string many = "{\"a\":[0";
  for (size_t i = 1; i < kMaxJsonValues - 2; ++i) many += ",0";
  EXPECT_TRUE(parseJsonBody(many + "]}").ok());  // the object, the array and its values
  auto tooMany = parseJsonBody(many + ",0]}");
  ASSERT_FALSE(tooMany.ok());
  EXPECT_NE(tooMany.error().find("more than 16384 JSON values"), std::string::npos) << tooMany.error();
  EXPECT_FALSE(parseJsonBody(R"({"a":[1,2,3]})", kMaxJsonDepth, 3).ok());
  EXPECT_TRUE(parseJsonBody(R"({"a":[1,2]})", kMaxJsonDepth, 4).ok());
}

const std::string kRead = "r3ad-0123456789abcdefghijklmnopqrstuv";
const std::string kCapture = "c4pture-0123456789abcdefghijklmnopqrst";

TEST(Tokens, ParsesBothTokens) {
  auto t = parseTokens("# tallyd tokens\nread=" + kRead + "\n\ncapture = " + kCapture + "\r\n");
  ASSERT_TRUE(t.ok()) << t.error();
  EXPECT_EQ(t->read, kRead);
  EXPECT_EQ(t->capture, kCapture);
}

TEST(Tokens, RefusesWeakOrIncompleteFiles) {
  struct Case {
    std::string text;
    std::string mention;
  };
  for (const auto& c : std::vector<Case>{
           {"", "no read"},
           {"read=" + kRead + "\n", "no capture"},
           {"capture=" + kCapture + "\n", "no read"},
           {"read=\ncapture=" + kCapture, "empty"},
           {"read=short\ncapture=" + kCapture, "too short"},
           {"read=" + std::string(40, 'a') + "\ncapture=" + kCapture, "repetitive"},
           {"read=" + kRead + " x\ncapture=" + kCapture, "character"},
           {"read=" + kRead + "\ncapture=" + kRead, "differ"},
           {"read=" + kRead + "\nread=" + kRead + "\ncapture=" + kCapture, "twice"},
           {"admin=" + kRead + "\ncapture=" + kCapture, "unknown key"},
           {kRead + "\n", "expected read"},
       }) {
    auto t = parseTokens(c.text);
    ASSERT_FALSE(t.ok()) << c.text;
    EXPECT_NE(t.error().find(c.mention), std::string::npos) << t.error();
  }
}

// application= is optional; when given, its token runs applications and is unlike the others.
TEST(Tokens, ApplicationLine) {
  const std::string kApplication = "d41d8cd98f00b204e9800998ecf8427e-apps";
  auto without = parseTokens("read=" + kRead + "\ncapture=" + kCapture + "\n");
  ASSERT_TRUE(without.ok()) << without.error();
  EXPECT_EQ(without->application, "");
  auto with = parseTokens("read=" + kRead + "\ncapture=" + kCapture + "\napplication=" + kApplication + "\n");
  ASSERT_TRUE(with.ok()) << with.error();
  EXPECT_EQ(with->application, kApplication);
  for (const std::string& text : {"read=" + kRead + "\ncapture=" + kCapture + "\napplication=" + kCapture,
                                  "read=" + kRead + "\ncapture=" + kCapture + "\napplication=" + kRead}) {
    auto t = parseTokens(text);
    ASSERT_FALSE(t.ok()) << text;
    EXPECT_NE(t.error().find("application token must differ"), std::string::npos) << t.error();
  }
  auto weak = parseTokens("read=" + kRead + "\ncapture=" + kCapture + "\napplication=short");
  ASSERT_FALSE(weak.ok());
  EXPECT_NE(weak.error().find("application token is too short"), std::string::npos) << weak.error();
}

TEST(Tokens, FileMustBePrivate) {
  test::TempDir dir;
  auto p = dir.write("tokens", "read=" + kRead + "\ncapture=" + kCapture + "\n");
  ::chmod(p.c_str(), 0644);
  auto t = loadTokenFile(p);
  ASSERT_FALSE(t.ok());
  EXPECT_NE(t.error().find("chmod 600"), std::string::npos);
  ::chmod(p.c_str(), 0600);
  EXPECT_TRUE(loadTokenFile(p).ok());
  EXPECT_FALSE(loadTokenFile(dir.path() / "missing").ok());
}

TEST(Tokens, ConstantTimeEqualsIsEquality) {
  EXPECT_TRUE(constantTimeEquals("abc", "abc"));
  EXPECT_FALSE(constantTimeEquals("abd", "abc"));
  EXPECT_FALSE(constantTimeEquals("ab", "abc"));
  EXPECT_FALSE(constantTimeEquals("abcd", "abc"));
  EXPECT_FALSE(constantTimeEquals("", "abc"));
  EXPECT_TRUE(constantTimeEquals("", ""));
}

TEST(Auth, Authenticate) {
  auto open = Auth::open();
  EXPECT_FALSE(open.required());
  EXPECT_EQ(open.authenticate(""), Principal::kCapture);
  auto a = Auth::withTokens({kRead, kCapture});
  EXPECT_TRUE(a.required());
  EXPECT_EQ(a.authenticate("Bearer " + kRead), Principal::kRead);
  EXPECT_EQ(a.authenticate("bearer " + kCapture), Principal::kCapture);
  EXPECT_FALSE(a.authenticate(""));
  EXPECT_FALSE(a.authenticate("Bearer "));
  EXPECT_FALSE(a.authenticate(kRead));
  EXPECT_FALSE(a.authenticate("Basic " + kRead));
  EXPECT_FALSE(a.authenticate("Bearer " + kRead + "x"));
  EXPECT_FALSE(a.authenticate("Bearer " + kRead.substr(1)));
}

// Only the application token is kApplication; it may do what a capture token may.
TEST(Auth, ApplicationToken) {
  const std::string kApplication = "d41d8cd98f00b204e9800998ecf8427e-apps";
  auto a = Auth::withTokens({kRead, kCapture, kApplication});
  EXPECT_TRUE(a.hasApplicationToken());
  EXPECT_EQ(a.authenticate("Bearer " + kApplication), Principal::kApplication);
  EXPECT_EQ(a.authenticate("Bearer " + kCapture), Principal::kCapture);
  EXPECT_EQ(a.authenticate("Bearer " + kRead), Principal::kRead);
  EXPECT_FALSE(a.authenticate("Bearer " + kApplication + "x"));
  EXPECT_FALSE(Auth::withTokens({kRead, kCapture}).hasApplicationToken());
  EXPECT_FALSE(Auth::withTokens({kRead, kCapture}).authenticate("Bearer "));
  EXPECT_FALSE(Auth::open().hasApplicationToken());
  EXPECT_TRUE(allows(Principal::kApplication, Principal::kCapture));
  EXPECT_TRUE(allows(Principal::kApplication, Principal::kRead));
  EXPECT_FALSE(allows(Principal::kCapture, Principal::kApplication));
  EXPECT_STREQ(principalName(Principal::kApplication), "application");
}

TEST(Auth, LoopbackRule) {
  for (const char* a : {"127.0.0.1", "127.1.2.3", "::1", "[::1]", "localhost", "::ffff:127.0.0.1"})
    EXPECT_TRUE(isLoopbackAddress(a)) << a;
  for (const char* a : {"0.0.0.0", "::", "10.0.0.1", "192.168.1.2", "example.com", ""})
    EXPECT_FALSE(isLoopbackAddress(a)) << a;
  EXPECT_TRUE(Auth::forBind("127.0.0.1", "").ok());
  EXPECT_FALSE(Auth::forBind("127.0.0.1", "").value().required());
  for (const char* a : {"0.0.0.0", "::", "192.168.1.2", "example.com"}) {
    auto r = Auth::forBind(a, "");
    ASSERT_FALSE(r.ok()) << a;
    EXPECT_NE(r.error().find("--token-file"), std::string::npos) << r.error();
  }
}

TEST(StaticFilesLookup, ServesInsideRootOnly) {
  test::TempDir dir;
  dir.write("outside.txt", "secret");
  dir.write("web/index.html", "<h1>tally</h1>");
  dir.write("web/js/app.js", "export {}");
  dir.write("web/.hidden", "x");
  std::filesystem::create_directory_symlink(dir.path(), dir.path() / "web/up");
  std::filesystem::create_symlink(dir.path() / "outside.txt", dir.path() / "web/leak.txt");
  std::filesystem::create_symlink(dir.path() / "web/js/app.js", dir.path() / "web/alias.js");
  auto files = StaticFiles::open(dir.path() / "web");
  ASSERT_TRUE(files.ok()) << files.error();
  auto index = files->lookup("/");
  ASSERT_TRUE(index);
  EXPECT_EQ(index->bytes, "<h1>tally</h1>");
  EXPECT_EQ(index->contentType, "text/html; charset=utf-8");
  EXPECT_EQ(files->lookup("/js/app.js")->contentType, "text/javascript; charset=utf-8");
  EXPECT_TRUE(files->lookup("/alias.js"));  // a symlink inside the root is fine
  for (const char* bad : {"/leak.txt", "/up/outside.txt", "/.hidden", "/js", "/js/", "/../outside.txt",
                          "/missing", "/js//app.js", "", "js/app.js"}) {
    EXPECT_FALSE(files->lookup(bad)) << bad;
  }
  EXPECT_FALSE(StaticFiles::open(dir.path() / "nope").ok());
  EXPECT_TRUE(isWithin("/a/web", "/a/web/x"));
  EXPECT_FALSE(isWithin("/a/web", "/a/webx/y"));
  EXPECT_FALSE(isWithin("/a/web", "/a"));
  EXPECT_EQ(contentTypeFor("x.PNG"), "image/png");
  EXPECT_EQ(contentTypeFor("x.bin"), "application/octet-stream");
}

TEST(OpenApi, EmbeddedDocumentMatchesFileAndCoversThePlannedApi) {
  std::ifstream in(TALLY_OPENAPI_PATH);
  auto file = nlohmann::json::parse(in);
  auto embedded = nlohmann::json::parse(openApiDocument());
  EXPECT_EQ(file, embedded);
  EXPECT_EQ(embedded["openapi"].get<std::string>().substr(0, 2), "3.");
  for (const char* path :
       {"/api/captures", "/api/captures/{id}", "/api/runs", "/api/runs/{id}", "/api/runs/{id}/samples",
        "/api/samples/{id}", "/api/samples/{id}/screenshot.png", "/api/compare", "/api/export", "/api/health",
        "/api/devices", "/api/renderers", "/api/scenes", "/api/openapi.json", "/api/sweeps", "/api/sweeps/{id}",
        "/api/hosts", "/api/crossover", "/api/heatmap", "/api/heatmap/{id}/topdown.png", "/api/baselines",
        "/api/baselines/{id}", "/api/alerts", "/api/alerts/{id}", "/api/trend"}) {
    EXPECT_TRUE(embedded["paths"].contains(path)) << path;
  }
  EXPECT_TRUE(embedded["paths"]["/api/captures"].contains("post"));
  EXPECT_TRUE(embedded["paths"]["/api/captures/{id}"].contains("delete"));
  EXPECT_TRUE(embedded["components"]["schemas"].contains("Error"));
  std::set<std::string> runFilters;
  for (auto& p : embedded["paths"]["/api/runs"]["get"]["parameters"]) runFilters.insert(p["name"]);
  EXPECT_EQ(runFilters, (std::set<std::string>{"renderer", "variant", "scene", "width", "height", "device", "capture",
                                               "host", "label", "since", "until", "limit", "cursor"}));
}

}  // namespace
}  // namespace tally::api
