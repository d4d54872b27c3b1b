// Admission of POST /api/captures (docs/api.md, "Limits"): whatever a spec
// holds, checking it is cheap (no scene is built, nothing is loaded), its
// lists are capped, a repeated entry is refused at its index, its cost is
// bounded, and the queue has limits per daemon and per client (429 with
// Retry-After, counted in /metrics). SIGTERM ends the daemon within 5 s in
// the middle of a capture, and the job goes back to the queue with the reason.
#include <signal.h>
#include <time.h>

#include <atomic>
#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "api/request_checks.hpp"
#include "api/router.hpp"
#include "daemon.hpp"
#include "renderers/renderer.hpp"
#include "service/service.hpp"
#include "store/store.hpp"

namespace {
using namespace tally::service::test;
namespace api = tally::api;
namespace store = tally::store;

constexpr size_t kBodyLimit = 1u << 20;  // api::ServerOptions::maxBodyBytes
constexpr double kCpuBudgetMs = 50;      // issue 31: admission in under 50 ms of CPU

double threadCpuMs() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return double(t.tv_sec) * 1e3 + double(t.tv_nsec) / 1e6;
}

// `spec` with `key` an array of as many copies of entry(i) as fit in the body limit.
json fillBody(json spec, const std::string& key, const std::function<json(size_t)>& entry) {
  spec[key] = json::array();
  size_t size = spec.dump().size();
  for (size_t i = 0;; ++i) {
    json e = entry(i);
    size_t grows = e.dump().size() + 1;
    if (size + grows > kBodyLimit) break;
    spec[key].push_back(std::move(e));
    size += grows;
  }
  return spec;
}

// The service's routes over a fresh SQLite store, as tallyd serve has them, without HTTP.
class InProcess : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = makeTempDir("tally-admission-test");
    auto opened = store::Store::open((dir_ / "tally.db").string());
    ASSERT_TRUE(opened) << opened.error();
    store_ = std::move(*opened);
    ctx_.writer = store_.get();
    ctx_.dbPath = (dir_ / "tally.db").string();
    ctx_.rendererNames = tally::renderers::rendererNames();
    ctx_.onQueueLimited = [this](const std::string& limit) { limited_.push_back(limit); };
    fs::create_directories(dir_ / "scenes");
    std::ofstream(dir_ / "scenes" / "a.gltf") << "{}";
    ctx_.options.sceneFolders = {dir_ / "scenes"};
  }
  void TearDown() override {
    router_.reset();
    store_.reset();
    fs::remove_all(dir_);
  }
  api::Router& router() {
    if (!router_) {
      router_ = std::make_unique<api::Router>();
      addServiceRoutes(*router_, ctx_);
    }
    return *router_;
  }
  // Parses the body as the HTTP server does, then dispatches: the request thread's work.
  api::Response post(const std::string& body, const std::string& client = "peer:127.0.0.1") {
    api::Request req;
    req.method = "POST";
    req.path = "/api/captures";
    req.client = client;
    auto parsed = api::parseJsonBody(body);
    if (!parsed) return api::errorResponse(400, api::code::kBadJson, parsed.error(), "body");
    req.body = std::move(*parsed);
    return router().dispatch(std::move(req));
  }

  fs::path dir_;
  std::unique_ptr<store::Store> store_;
  tally::service::ServiceContext ctx_;
  std::unique_ptr<api::Router> router_;
  std::vector<std::string> limited_;
};

// Every list at its cap with distinct, valid entries: the most checking a
// spec can ask for (its matrix is then over the limit: a 400 at the end).
json everyListFull(const fs::path& scenes) {
  json spec;
  spec["renderers"] = tally::renderers::rendererNames();
  json sceneList = json::array({"atrium", "sky", {{"gltf", (scenes / "a.gltf").string()}}});
  for (int layers = 1024; sceneList.size() < 32; --layers)
    sceneList.push_back({{"name", "planes"}, {"layers", layers}});
  spec["scenes"] = sceneList;
  spec["resolutions"] = json::array();
  for (int i = 0; i < 64; ++i) spec["resolutions"].push_back({3840 - i, 2160});
  spec["cameras"] = json::array();
  for (int i = 0; i < 256; ++i) {
    spec["cameras"].push_back(
        {{"eye", {i, 1.5, 3}}, {"target", {0, 1, 0}}, {"label", std::string(200, 'c')}});
  }
  spec["counting"] = {"accumulate", "exact", "subgroup", "sampled:4"};
  spec["frames"] = 200;
  spec["labels"] = json::object();
  for (int i = 0; i < 16; ++i) spec["labels"]["k" + std::to_string(i)] = std::string(256, 'v');
  return spec;
}

// The worst specs that fit the body limit, each answered (accepted or
// refused) in under 50 ms of the request thread's CPU. The first is the
// issue's 116-byte spec of four procedural scenes (each was built while the
// request was checked); the 1 MiB ones held a request thread for hours.
TEST_F(InProcess, WorstSpecsAreAnsweredInUnder50msOfCpu) {
  json base = {{"renderers", {"forward"}}, {"resolutions", {{64, 36}}}, {"frames", 1}};
  struct Case {
    std::string name;
    json spec;
  };
  std::vector<Case> cases;
  {
    json four = base;
    four["scenes"] = {
        "atrium", {{"name", "planes"}, {"layers", 1024}}, "sky", {{"name", "planes"}, {"layers", 512}}};
    cases.push_back({"four scenes (116 bytes)", four});
  }
  cases.push_back({"every list at its cap", everyListFull(dir_ / "scenes")});
  cases.push_back({"1 MiB of scenes", fillBody(base, "scenes", [](size_t) { return json("atrium"); })});
  cases.push_back(
      {"1 MiB of distinct scenes", fillBody(base, "scenes", [](size_t i) {
         return json{{"name", "planes"}, {"layers", 1 + i % 1024}, {"coverage", 1.0 / double(1 + i / 1024)}};
       })});
  cases.push_back({"1 MiB of glTF scenes", fillBody(base, "scenes", [](size_t i) {
                     return json{{"gltf", "a.gltf"}, {"max_texture_size", 1 + i}};
                   })});
  cases.push_back({"1 MiB of cameras", fillBody(base, "cameras", [](size_t i) {
                     return json{{"eye", {double(i), 1.5, 3}}, {"target", {0, 1, 0}}};
                   })});
  cases.push_back({"1 MiB of resolutions", fillBody(base, "resolutions", [](size_t i) {
                     return json::array({1 + i % 16384, 1 + i / 16384});
                   })});
  cases.push_back(
      {"1 MiB of renderers", fillBody(base, "renderers", [](size_t) { return json("forward"); })});
  cases.push_back({"1 MiB of counting modes", fillBody(base, "counting", [](size_t i) {
                     return json("sampled:" + std::to_string(2 + i % 65535));
                   })});
  {
    // Values up to the parser's bound (api::kMaxJsonValues), each a long number.
    json many =
        fillBody(base, "frames", [](size_t i) { return json(0.1234567890123456789 * double(i + 1)); });
    many["frames"].erase(many["frames"].begin() + (api::kMaxJsonValues - 16), many["frames"].end());
    cases.push_back({"16,000 numbers", many});
  }
  {
    json label = base;
    label["cameras"] = {
        {{"eye", {0, 0, 1}}, {"target", {0, 0, 0}}, {"label", std::string(kBodyLimit - 200, 'x')}}};
    cases.push_back({"a 1 MiB camera label", label});
  }
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    std::string body = c.spec.dump();
    ASSERT_LE(body.size(), kBodyLimit);
    double before = threadCpuMs();
    api::Response r = post(body);
    double cpuMs = threadCpuMs() - before;
    std::printf("%-28s %8zu bytes: %d in %.2f ms of CPU\n", c.name.c_str(), body.size(), r.status, cpuMs);
    // ASSERT: on a build that builds scenes while checking, the next case would run for hours.
    ASSERT_LT(cpuMs, kCpuBudgetMs) << r.json.dump();
    EXPECT_TRUE(r.status == 202 || r.status == 400) << r.json.dump();
  }
}

TEST_F(InProcess, ListsAreCappedAndRepeatsNamed) {
  const json base = {{"renderers", {"forward"}}, {"resolutions", {{64, 36}}}, {"frames", 1}};
  auto with = [&](const char* key, json value) {
    json s = base;
    s[key] = std::move(value);
    return s;
  };
  json cameras = json::array();
  for (int i = 0; i < 257; ++i) cameras.push_back({{"eye", {i, 1, 1}}, {"target", {0, 0, 0}}});
  json resolutions = json::array();
  for (int i = 0; i < 65; ++i) resolutions.push_back({64 + i, 36});
  json scenes = json::array();
  for (int i = 0; i < 33; ++i) scenes.push_back({{"name", "planes"}, {"layers", i + 1}});
  struct Case {
    json spec;
    std::string field, message;
  };
  const std::vector<Case> cases = {
      {with("scenes", {"atrium", "atrium"}), "scenes[1]", "a duplicate of scenes[0]"},
      {with("scenes", {"sky", "atrium", {{"name", "atrium"}}}), "scenes[2]", "a duplicate of scenes[1]"},
      {with("scenes",
            {{{"name", "planes"}}, {{"name", "planes"}, {"layers", 8}, {"order", "back-to-front"}}}),
       "scenes[1]", "a duplicate of scenes[0]"},
      {with("scenes", {{{"gltf", "a.gltf"}}, {{"gltf", "./a.gltf"}}}), "scenes[1]",
       "a duplicate of scenes[0]"},
      {with("scenes", scenes), "scenes", "at most 32 entries, got 33"},
      {with("resolutions", {{64, 36}, {32, 18}, {64, 36}}), "resolutions[2]",
       "a duplicate of resolutions[0]"},
      {with("resolutions", resolutions), "resolutions", "at most 64 entries, got 65"},
      {with("cameras", {{{"eye", {0, 0, 1}}, {"target", {0, 0, 0}}},
                        {{"eye", {0, 0, 1}}, {"target", {0, 0, 0}}, {"label", "b"}}}),
       "cameras[1]", "a duplicate of cameras[0]"},
      {with("cameras", cameras), "cameras", "at most 256 entries, got 257"},
      {with("renderers", {"forward", "deferred", "forward"}), "renderers[2]", "a duplicate of renderers[0]"},
      {with("renderers", json(std::vector<std::string>(33, "forward"))), "renderers",
       "at most 32 entries, got 33"},
      {with("counting", {"exact", "accumulate", "exact"}), "counting[2]", "a duplicate of counting[0]"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.spec.dump().substr(0, 200));
    api::Response r = post(c.spec.dump());
    EXPECT_EQ(r.status, 400) << r.json.dump();
    EXPECT_EQ(r.json["error"].value("field", ""), c.field) << r.json.dump();
    EXPECT_NE(r.json["error"].value("message", "").find(c.message), std::string::npos) << r.json.dump();
  }
  auto jobs = store_->jobs().counts();
  ASSERT_TRUE(jobs);
  EXPECT_EQ(jobs->at("queued"), 0) << "a refused spec was queued";
}

TEST_F(InProcess, CostIsBoundedAndTheBoundNamed) {
  // 1 renderer x 1 scene x 2 resolutions x 10 auto cameras x 1 mode x 20 frames.
  json spec = {{"renderers", {"forward"}}, {"resolutions", {{640, 360}, {1280, 720}}}, {"frames", 20}};
  const uint64_t cost = uint64_t(20) * 10 * (640 * 360 + 1280 * 720);
  ctx_.options.maxCost = cost - 1;
  api::Response r = post(spec.dump());
  EXPECT_EQ(r.status, 400) << r.json.dump();
  EXPECT_EQ(r.json["error"].value("field", ""), "spec");
  const std::string message = r.json["error"].value("message", "");
  EXPECT_NE(message.find(std::to_string(cost) + " pixel-frames"), std::string::npos) << message;
  EXPECT_NE(message.find("max_cost"), std::string::npos) << message;
  EXPECT_NE(message.find(std::to_string(cost - 1)), std::string::npos) << message;
  ctx_.options.maxCost = cost;
  EXPECT_EQ(post(spec.dump()).status, 202);
}

TEST_F(InProcess, QueueLimitsPerDaemonAndPerClient) {
  ctx_.options.maxQueued = 3;
  ctx_.options.maxQueuedPerClient = 2;
  json spec = {{"renderers", {"forward"}}, {"resolutions", {{64, 36}}}, {"frames", 1}};
  auto retryAfter = [](const api::Response& r) {
    for (const auto& [k, v] : r.headers)
      if (k == "Retry-After") return v;
    return std::string();
  };
  EXPECT_EQ(post(spec.dump(), "peer:10.0.0.1").status, 202);
  EXPECT_EQ(post(spec.dump(), "peer:10.0.0.1").status, 202);
  api::Response mine = post(spec.dump(), "peer:10.0.0.1");
  EXPECT_EQ(mine.status, 429) << mine.json.dump();
  EXPECT_EQ(mine.json["error"].value("code", ""), "too_many_requests");
  EXPECT_NE(mine.json["error"].value("message", "").find("max_queued_per_client 2"), std::string::npos);
  EXPECT_EQ(retryAfter(mine), "30");
  EXPECT_EQ(post(spec.dump(), "peer:10.0.0.2").status, 202);  // another client: 3 queued
  api::Response full = post(spec.dump(), "peer:10.0.0.3");
  EXPECT_EQ(full.status, 429) << full.json.dump();
  EXPECT_NE(full.json["error"].value("message", "").find("max_queued 3"), std::string::npos);
  EXPECT_FALSE(retryAfter(full).empty());
  EXPECT_EQ(limited_, (std::vector<std::string>{"client", "queue"}));
  auto jobs = store_->jobs().counts();
  ASSERT_TRUE(jobs);
  EXPECT_EQ(jobs->at("queued"), 3);

  // A job that leaves the queue frees its place.
  auto claimed = store_->jobs().claim();
  ASSERT_TRUE(claimed && claimed->has_value());
  EXPECT_EQ(post(spec.dump(), "peer:10.0.0.3").status, 202);
}

// Through a real daemon: the 429 with Retry-After on the wire, and /metrics
// counting it. An API-only daemon runs nothing, so the queue stays full.
TEST(Daemon, QueueLimitOnTheWireAndInMetrics) {
  fs::path dir = makeTempDir("tally-admission-limits");
  {
    Daemon d(dir, dir / "tally.db", {"--role", "api", "--max-queued", "3", "--max-queued-per-client", "2"});
    ASSERT_TRUE(d.start());
    json spec = tinySpec();
    EXPECT_EQ(d.request("POST", "/api/captures", spec.dump()).status, 202);
    EXPECT_EQ(d.request("POST", "/api/captures", spec.dump()).status, 202);
    httplib::Client client("127.0.0.1", d.port());
    auto r = client.Post("/api/captures", spec.dump(), "application/json");
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 429) << r->body;
    EXPECT_EQ(r->get_header_value("Retry-After"), "30");
    Reply metrics = d.request("GET", "/metrics");
    EXPECT_NE(metrics.body.find("tally_captures_limited_total{limit=\"client\"} 1"), std::string::npos)
        << metrics.body;
    EXPECT_NE(metrics.body.find("tally_captures_limited_total{limit=\"queue\"} 0"), std::string::npos);
    EXPECT_NE(metrics.body.find("tally_queue_limit{limit=\"queue\"} 3"), std::string::npos);
    EXPECT_NE(metrics.body.find("tally_queue_limit{limit=\"client\"} 2"), std::string::npos);
    EXPECT_EQ(d.stop(SIGTERM), 0);
  }
  fs::remove_all(dir);
}

// SIGTERM in the middle of a capture, with requests arriving: the daemon is
// gone within 5 s, its capture child with it, and the job is back in the
// queue with the reason (or failed with one), never left running.
TEST(Daemon, SigtermMidCaptureEndsWithin5sAndRequeuesTheJob) {
  fs::path dir = makeTempDir("tally-admission-sigterm");
  int64_t id = 0;
  {
    Daemon d(dir, dir / "tally.db");
    ASSERT_TRUE(d.start());
    json spec = longSpec();
    spec["resolutions"] = {{640, 360}, {960, 540}, {1280, 720}};
    spec["frames"] = 100;  // minutes on lavapipe
    Reply posted = d.request("POST", "/api/captures", spec.dump());
    ASSERT_EQ(posted.status, 202) << posted.body;
    id = posted.j()["id"].get<int64_t>();
    json job = d.waitProgress(id, 60s);
    ASSERT_EQ(job.value("status", ""), "running") << job.dump();
    ASSERT_FALSE(d.runningJobChildren().empty());

    // Requests in flight while the signal arrives.
    std::atomic<bool> posting{true};
    std::thread clients([&] {
      json worst = fillBody(tinySpec(), "scenes", [](size_t) { return json("atrium"); });
      std::string body = worst.dump();
      while (posting) {
        httplib::Client c("127.0.0.1", d.port());
        c.set_read_timeout(10, 0);
        c.Post("/api/captures", body, "application/json");
      }
    });
    std::this_thread::sleep_for(200ms);
    auto signalled = std::chrono::steady_clock::now();
    int status = d.stopWithin(10s);  // -1: still running after 10 s (then killed)
    double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - signalled).count();
    posting = false;
    clients.join();
    EXPECT_EQ(status, 0);
    std::printf("SIGTERM to exit: %.2f s\n", seconds);
    EXPECT_LT(seconds, 5.0) << "SIGTERM took " << seconds << " s";
    EXPECT_TRUE(d.waitNoJobChildren()) << "a capture child outlived its daemon";
  }
  auto opened = store::Store::open((dir / "tally.db").string(), {.readOnly = true});
  ASSERT_TRUE(opened) << opened.error();
  auto job = (*opened)->jobs().get(id);
  ASSERT_TRUE(job && job->has_value());
  const store::Job& j = **job;
  ASSERT_NE(j.status, store::JobStatus::Running) << "the job was left running";
  if (j.status == store::JobStatus::Queued) {
    ASSERT_TRUE(j.attemptErrors.is_array() && !j.attemptErrors.empty()) << j.attemptErrors.dump();
    EXPECT_NE(j.attemptErrors.back().get<std::string>().find("shutting down"), std::string::npos)
        << j.attemptErrors.dump();
    EXPECT_EQ(j.attempts, 0) << "a stop counted as an attempt";
  } else {
    EXPECT_EQ(j.status, store::JobStatus::Failed);
    EXPECT_TRUE(j.error && !j.error->empty());
  }
  opened->reset();
  fs::remove_all(dir);
}

}  // namespace
