// Baselines, regression alerts, trends and the webhook through a real
// `tallyd serve --role api` over captures stored with the store's ingest
// (synthetic per-frame times and counts, so what must alert is known): a run
// 1.5x slower with a changed counter alerts on its frame time, its passes and
// its counts; a repeat of the baseline does not; every route's bad input is a
// 400 naming the field, unknown ids 404. The webhook: a receiver that fails
// its first requests gets every alert once, after retries in backoff order;
// an unreachable one changes nothing else. No GPU.
#include <signal.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>
#include <mutex>
#include <set>
#include <thread>

#include <gtest/gtest.h>
#include <httplib.h>

#include "../store/store_fixture.hpp"
#include "daemon.hpp"
#include "postgres_server.hpp"
#include "service/alert_evaluator.hpp"
#include "service/webhook.hpp"

namespace {
using namespace tally::service::test;
namespace st = tally::store::testing;

constexpr int kFrames = 20;

// kFrames times around `base` ms: a deterministic +-5% wobble.
json frameTimes(double base, int seed) {
  json out = json::array();
  for (int k = 0; k < kFrames; ++k)
    out.push_back(base * (1.0 + 0.05 * (((k * 7 + seed * 3) % 11) - 5) / 5.0));
  return out;
}

// One forward run of two cameras and two passes, every time scaled by
// `slowdown`, with per-frame times; `lightBytes` is the lighting pass's
// counter (the count that changes with the lights).
json captureOf(double slowdown, double lightBytes, int lights, int seed) {
  std::vector<json> samples;
  for (int cam = 0; cam < 2; ++cam) {
    json depth = st::makePass("depth", 0.4 * slowdown, 2304, {st::makeCounter("depth", "write", 2304, 9216)});
    json shade = st::makePass("shade", 0.8 * slowdown, 2304,
                              {st::makeCounter("lights", "read", lightBytes / 16, lightBytes)});
    depth["gpu_ms_frames"] = frameTimes(0.4 * slowdown, seed + cam);
    shade["gpu_ms_frames"] = frameTimes(0.8 * slowdown, seed + cam + 1);
    json sample = st::makeSample(cam, 1.2 * slowdown, {depth, shade});
    sample["camera"]["eye"] = {1.0 + cam, 2.0, 3.0};
    sample["frames"] = kFrames;
    sample["frame_ms_frames"] = frameTimes(1.2 * slowdown, seed + cam + 2);
    samples.push_back(sample);
  }
  json run = st::makeRun("forward", "atrium", 64, 36, samples);
  run["lights"] = lights;
  return st::makeCapture({run});
}

class AlertRoutes : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = makeTempDir("tally-alerts-test");
    db_ = dir_ / "tally.db";
    baselineRun_ = store({{"commit", "a1"}}, captureOf(1.0, 65536, 4, 0));
    daemon_ = new Daemon(dir_, db_, {"--role", "api"});
    ASSERT_TRUE(daemon_->start()) << "tallyd serve did not start";
  }
  static void TearDownTestSuite() {
    if (daemon_) {
      EXPECT_EQ(daemon_->stop(SIGTERM), 0);
    }
    delete daemon_;
    daemon_ = nullptr;
    fs::remove_all(dir_);
  }
  // Stores a capture with these labels, as a worker would; its (one) run's id.
  static int64_t store(const json& labels, const json& result) {
    auto s = st::openStore(db_.string());
    EXPECT_NE(s, nullptr);
    auto job = s->jobs().create({{"renderers", {"forward"}}, {"labels", labels}});
    EXPECT_TRUE(job) << job.error();
    auto stored = s->runs().ingestCapture(job->job.id, result, {});
    EXPECT_TRUE(stored) << stored.error();
    EXPECT_TRUE(s->jobs().finish(job->job.id, tally::store::JobStatus::Done));
    tally::store::RunFilter f;
    f.jobId = job->job.id;
    return s->runs().list(f, {})->runs.at(0).id;
  }
  static json call(const std::string& method, const std::string& path, const std::string& body, int status) {
    Reply r = daemon_->request(method, path, body);
    EXPECT_EQ(r.status, status) << method << " " << path << " " << body << ": " << r.body;
    return r.j();
  }
  // Waits until the run has `n` alerts (the evaluator polls every second).
  static json alertsOf(int64_t run, size_t n) {
    json reply;
    for (int i = 0; i < 100; ++i) {
      reply = call("GET", "/api/alerts?run=" + std::to_string(run), "", 200);
      if (reply["alerts"].size() >= n) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    return reply["alerts"];
  }
  static inline fs::path dir_, db_;
  static inline Daemon* daemon_ = nullptr;
  static inline int64_t baselineRun_ = 0;
};

TEST_F(AlertRoutes, ARegressionAlertsAndARepeatDoesNot) {
  json baseline =
      call("POST", "/api/baselines",
           json{{"run", baselineRun_}, {"threshold", 0.05}, {"name", "forward atrium"}}.dump(), 201);
  EXPECT_EQ(baseline["run"], baselineRun_);
  EXPECT_EQ(baseline["status"], "active");
  EXPECT_EQ(baseline["configuration"]["renderer"], "forward");
  EXPECT_EQ(baseline["labels"], json({{"commit", "a1"}}));
  int64_t baselineId = baseline["id"];
  EXPECT_EQ(call("GET", "/api/baselines", "", 200)["baselines"].size(), 1u);
  EXPECT_EQ(call("GET", "/api/baselines/" + std::to_string(baselineId), "", 200)["name"], "forward atrium");

  // A repeat (the same times, shifted a little in order) and a regression
  // (1.5x the time, 16x the lights and their bytes), stored in that order,
  // so once the regression has its alerts the repeat was evaluated too.
  int64_t repeat = store({{"commit", "b2"}}, captureOf(1.0, 65536, 4, 1));
  int64_t slower = store({{"commit", "c3"}}, captureOf(1.5, 65536 * 16, 64, 0));
  json alerts = alertsOf(slower, 4);
  // frame, pass depth, pass shade, counts
  ASSERT_EQ(alerts.size(), 4u) << alerts.dump(2);
  std::set<std::string> metrics;
  for (const auto& a : alerts) {
    metrics.insert(a["metric"].get<std::string>());
    EXPECT_EQ(a["baseline"], baselineId);
    EXPECT_EQ(a["baseline_run"], baselineRun_);
    EXPECT_EQ(a["status"], "open");
    EXPECT_EQ(a["delivery"]["state"], "none");  // no webhook on this daemon
    if (a["kind"] == "time") {
      EXPECT_EQ(a["verdict"], "slower");
      EXPECT_NEAR(a["ratio"].get<double>(), 1.5, 0.05);
      ASSERT_TRUE(a["interval"].is_array());
      EXPECT_GT(a["interval"][0].get<double>(), 1.0);
      EXPECT_LT(a["p_value"].get<double>(), 0.05);
      EXPECT_GT(a["value_b"].get<double>(), a["value_a"].get<double>());
    } else {
      EXPECT_EQ(a["verdict"], "changed");
      // The total and the lights line, each from the stored counts, per frame (the mean over the cameras).
      std::set<std::string> lines;
      for (const auto& c : a["details"]["changes"]) lines.insert(c["line"].get<std::string>());
      EXPECT_EQ(lines, (std::set<std::string>{"total", "shade/lights read"}));
      EXPECT_DOUBLE_EQ(a["value_b"].get<double>() - a["value_a"].get<double>(), 65536.0 * 16 - 65536.0);
    }
  }
  EXPECT_EQ(metrics, (std::set<std::string>{"frame", "pass depth", "pass shade", "counts"}));
  EXPECT_TRUE(call("GET", "/api/alerts?run=" + std::to_string(repeat), "", 200)["alerts"].empty());

  json open = call("GET", "/api/alerts?status=open", "", 200);
  EXPECT_EQ(open["counts"]["open"], 4);
  // /metrics: the store's alerts by status, and those this daemon raised.
  Reply scraped = daemon_->request("GET", "/metrics");
  ASSERT_EQ(scraped.status, 200);
  auto metric = [&](const std::string& series) {
    size_t at = scraped.body.find("\n" + series + " ");
    return at == std::string::npos ? -1.0 : std::stod(scraped.body.substr(at + series.size() + 2));
  };
  EXPECT_EQ(metric("tally_alerts{status=\"open\"}"), 4.0) << scraped.body;
  EXPECT_EQ(metric("tally_alerts{status=\"fixed\"}"), 0.0) << scraped.body;
  EXPECT_EQ(metric("tally_alerts_raised_total"), 4.0) << scraped.body;
  EXPECT_EQ(open["alerts"].size(), 4u);

  // One alert with its run and baseline; acknowledged by PATCH, fixed by POST.
  int64_t first = alerts[0]["id"];
  std::string path = "/api/alerts/" + std::to_string(first);
  json one = call("GET", path, "", 200);
  EXPECT_EQ(one["run_row"]["id"], slower);
  EXPECT_EQ(one["run_row"]["labels"], json({{"commit", "c3"}}));
  EXPECT_EQ(one["baseline_row"]["id"], baselineId);
  EXPECT_EQ(call("PATCH", path, R"({"status":"acknowledged"})", 200)["status"], "acknowledged");
  EXPECT_EQ(call("GET", "/api/alerts?status=open", "", 200)["counts"]["open"], 3);
  EXPECT_EQ(call("POST", path, R"({"status":"fixed"})", 200)["status"], "fixed");
  EXPECT_EQ(call("GET", "/api/alerts?status=fixed", "", 200)["alerts"].size(), 1u);

  // The trend: the three runs in order, the baseline marked, the alerts on the regression.
  json trend = call("GET", "/api/trend?baseline=" + std::to_string(baselineId), "", 200);
  ASSERT_EQ(trend["runs"].size(), 3u) << trend.dump(2);
  EXPECT_EQ(trend["runs"][0]["id"], baselineRun_);
  EXPECT_TRUE(trend["runs"][0]["baseline"].get<bool>());
  EXPECT_EQ(trend["runs"][1]["id"], repeat);
  EXPECT_TRUE(trend["runs"][1]["alerts"].empty());
  EXPECT_EQ(trend["runs"][2]["alerts"].size(), 4u);
  EXPECT_EQ(trend["runs"][2]["labels"]["commit"], "c3");
  EXPECT_EQ(trend["runs"][2]["lights"], 64);
  EXPECT_EQ(trend["alerts"].size(), 4u);
  for (const auto& r : trend["runs"]) {
    const json& f = r["frame_ms"];
    EXPECT_EQ(f["frames"], 2 * kFrames);
    ASSERT_TRUE(f["lower"].is_number()) << r.dump();
    EXPECT_LE(f["lower"].get<double>(), f["median"].get<double>());
    EXPECT_GE(f["upper"].get<double>(), f["median"].get<double>());
  }
  EXPECT_NEAR(trend["runs"][2]["frame_ms"]["median"].get<double>() /
                  trend["runs"][0]["frame_ms"]["median"].get<double>(),
              1.5, 0.05);

  // One frame time per run everywhere: the median of every frame of both
  // cameras, computed here from the frames stored, in the runs list, the
  // run, the trend, the frame alert and compare; bytes per frame in the
  // counts alert as in the runs list.
  auto pooledMedian = [](double base, int seed) {
    std::vector<double> all;
    for (int cam = 0; cam < 2; ++cam)
      for (const auto& v : frameTimes(base, seed + cam + 2)) all.push_back(v.get<double>());
    std::sort(all.begin(), all.end());
    return (all[all.size() / 2 - 1] + all[all.size() / 2]) / 2;
  };
  const double baseMedian = pooledMedian(1.2, 0), slowMedian = pooledMedian(1.2 * 1.5, 0);
  EXPECT_DOUBLE_EQ(trend["runs"][0]["frame_ms"]["median"].get<double>(), baseMedian);
  EXPECT_EQ(trend["runs"][0]["frame_ms"]["source"], "frames");
  json baseRow = call("GET", "/api/runs/" + std::to_string(baselineRun_), "", 200);
  json slowRow = call("GET", "/api/runs/" + std::to_string(slower), "", 200);
  EXPECT_DOUBLE_EQ(baseRow["frame_ms_median"].get<double>(), baseMedian);
  EXPECT_EQ(baseRow["frame_ms_median_source"], "frames");
  EXPECT_DOUBLE_EQ(slowRow["frame_ms_median"].get<double>(), slowMedian);
  for (const auto& r : call("GET", "/api/runs", "", 200)["runs"]) {
    if (r["id"] == slower) {
      EXPECT_DOUBLE_EQ(r["frame_ms_median"].get<double>(), slowMedian);
    }
  }
  for (const auto& a : alerts) {
    if (a["metric"] == "frame") {
      EXPECT_DOUBLE_EQ(a["value_a"].get<double>(), baseMedian);
      EXPECT_DOUBLE_EQ(a["value_b"].get<double>(), slowMedian);
    } else if (a["metric"] == "counts") {
      EXPECT_DOUBLE_EQ(a["value_a"].get<double>(), baseRow["mean_bytes"].get<double>());
      EXPECT_DOUBLE_EQ(a["value_b"].get<double>(), slowRow["mean_bytes"].get<double>());
    }
  }
  json compared =
      call("GET", "/api/compare?runs=" + std::to_string(baselineRun_) + "," + std::to_string(slower), "", 200);
  EXPECT_DOUBLE_EQ(compared["frame_ms_median"][0]["value"].get<double>(), baseMedian);
  EXPECT_DOUBLE_EQ(compared["frame_ms_median"][1]["ratio"].get<double>(), slowMedian / baseMedian);
  EXPECT_DOUBLE_EQ(compared["runs"][1]["frame_ms_median"].get<double>(), slowMedian);
  EXPECT_DOUBLE_EQ(compared["significance"][0]["frame"]["run_median_a"].get<double>(), baseMedian);
  EXPECT_DOUBLE_EQ(compared["significance"][0]["frame"]["run_median_b"].get<double>(), slowMedian);

  // Runs carry their labels and filter by them.
  json labelled = call("GET", "/api/runs?label=commit%3Dc3", "", 200);
  ASSERT_EQ(labelled["runs"].size(), 1u);
  EXPECT_EQ(labelled["runs"][0]["id"], slower);

  // A new baseline of the same configuration replaces the old one; removing it
  // stops the tests but keeps the alerts.
  json replaced = call("POST", "/api/baselines", json{{"run", repeat}}.dump(), 201);
  EXPECT_EQ(replaced["replaced"], baselineId);
  EXPECT_DOUBLE_EQ(replaced["threshold"].get<double>(), 0.05);
  EXPECT_EQ(call("GET", "/api/baselines/" + std::to_string(baselineId), "", 200)["status"], "replaced");
  int64_t replacedId = replaced["id"];
  EXPECT_EQ(call("DELETE", "/api/baselines/" + std::to_string(replacedId), "", 200)["status"], "removed");
  EXPECT_TRUE(call("GET", "/api/baselines", "", 200)["baselines"].empty());
  EXPECT_EQ(call("GET", "/api/baselines?all=true", "", 200)["baselines"].size(), 2u);
  EXPECT_EQ(call("GET", "/api/alerts", "", 200)["alerts"].size(), 4u);
}

TEST_F(AlertRoutes, BadInputNamesTheFieldAndUnknownIdsAre404) {
  struct Case {
    std::string method, path, body, field;
  };
  std::vector<Case> cases = {
      {"POST", "/api/baselines", "{}", "run"},
      {"POST", "/api/baselines", R"({"run":"3"})", "run"},
      {"POST", "/api/baselines", R"({"run":0})", "run"},
      {"POST", "/api/baselines", R"({"run":1,"threshold":-0.1})", "threshold"},
      {"POST", "/api/baselines", R"({"run":1,"threshold":"5%"})", "threshold"},
      {"POST", "/api/baselines", R"({"run":1,"name":""})", "name"},
      {"POST", "/api/baselines", R"({"run":1,"colour":"red"})", "colour"},
      {"GET", "/api/baselines?all=maybe", "", "all"},
      {"GET", "/api/baselines/x", "", "id"},
      {"GET", "/api/alerts?status=closed", "", "status"},
      {"GET", "/api/alerts?baseline=0", "", "baseline"},
      {"GET", "/api/alerts?limit=0", "", "limit"},
      {"GET", "/api/alerts?cursor=zz", "", "cursor"},
      {"GET", "/api/alerts?colour=red", "", "colour"},
      {"PATCH", "/api/alerts/1", R"({"status":"closed"})", "status"},
      {"PATCH", "/api/alerts/1", R"({})", "status"},
      {"PATCH", "/api/alerts/1", R"({"status":"open","note":"x"})", "note"},
      {"GET", "/api/trend", "", "baseline"},
      {"GET", "/api/trend?baseline=1&limit=501", "", "limit"},
      {"GET", "/api/runs?label=commit", "", "label"},
      {"POST", "/api/captures", R"({"renderers":["forward"],"resolutions":[[64,36]],"labels":{"commit":3}})",
       "labels.commit"},
      {"POST", "/api/captures", R"({"renderers":["forward"],"resolutions":[[64,36]],"labels":["a"]})",
       "labels"},
      {"POST", "/api/captures",
       R"({"renderers":["forward"],"resolutions":[[64,36]],"labels":{"bad key":"x"}})", "labels"},
  };
  for (const auto& c : cases) {
    json e = call(c.method, c.path, c.body, 400);
    EXPECT_EQ(e["error"]["field"], c.field) << c.method << " " << c.path << " " << c.body << ": " << e.dump();
    EXPECT_NE(e["error"]["message"].get<std::string>().find(c.field), std::string::npos) << e.dump();
  }
  for (auto [method, path, body] : std::vector<std::tuple<std::string, std::string, std::string>>{
           {"POST", "/api/baselines", R"({"run":987654})"},
           {"GET", "/api/baselines/987654", ""},
           {"DELETE", "/api/baselines/987654", ""},
           {"GET", "/api/alerts/987654", ""},
           {"PATCH", "/api/alerts/987654", R"({"status":"fixed"})"},
           {"GET", "/api/trend?baseline=987654", ""}}) {
    json e = call(method, path, body, 404);
    EXPECT_EQ(e["error"]["code"], "not_found") << path;
  }
  // The daemon lives on.
  EXPECT_EQ(daemon_->request("GET", "/api/health").status, 200);
}

// A local receiver that answers 503 to its first `failures` requests.
class Receiver {
 public:
  explicit Receiver(int failures) : failures_(failures) {
    server_.Post("/hook", [this](const httplib::Request& req, httplib::Response& res) {
      std::lock_guard lock(mutex_);
      times_.push_back(std::chrono::steady_clock::now());
      auto body = json::parse(req.body, nullptr, false);
      posted_.push_back(body.is_object() && body.contains("alert") ? body["alert"].value("id", int64_t(-1)) : -1);
      if (static_cast<int>(times_.size()) <= failures_) {
        res.status = 503;
        res.set_content("busy", "text/plain");
        return;
      }
      bodies_.push_back(json::parse(req.body));
      headers_.push_back(req.get_header_value("X-Tally-Delivery"));
      res.status = 204;
    });
    port_ = server_.bind_to_any_port("127.0.0.1");
    thread_ = std::thread([this] { server_.listen_after_bind(); });
  }
  ~Receiver() {
    server_.stop();
    thread_.join();
  }
  std::string url() const { return "http://127.0.0.1:" + std::to_string(port_) + "/hook"; }
  std::vector<json> bodies() {
    std::lock_guard lock(mutex_);
    return bodies_;
  }
  std::vector<std::chrono::steady_clock::time_point> times() {
    std::lock_guard lock(mutex_);
    return times_;
  }
  // The alert id of every request, in the order they arrived (failed ones too).
  std::vector<int64_t> posted() {
    std::lock_guard lock(mutex_);
    return posted_;
  }

 private:
  int failures_;
  httplib::Server server_;
  int port_ = 0;
  std::thread thread_;
  std::mutex mutex_;
  std::vector<std::chrono::steady_clock::time_point> times_;
  std::vector<int64_t> posted_;
  std::vector<json> bodies_;
  std::vector<std::string> headers_;
};

class Webhook : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = makeTempDir("tally-webhook-test");
    db_ = dir_ / "tally.db";
    store_ = st::openStore(db_.string());
    ASSERT_NE(store_, nullptr);
  }
  void TearDown() override {
    store_.reset();
    fs::remove_all(dir_);
  }
  int64_t storeCapture(const json& labels, const json& result) {
    auto job = store_->jobs().create({{"renderers", {"forward"}}, {"labels", labels}});
    EXPECT_TRUE(store_->runs().ingestCapture(job->job.id, result, {}));
    tally::store::RunFilter f;
    f.jobId = job->job.id;
    return store_->runs().list(f, {})->runs.at(0).id;
  }
  // A baseline and a regression evaluated with delivery on: the alerts' ids.
  std::vector<int64_t> pendingAlerts() {
    int64_t base = storeCapture({{"commit", "a"}}, captureOf(1.0, 4096, 4, 0));
    EXPECT_TRUE(*store_->alerts().setBaseline({base, 0.05, std::nullopt}));
    storeCapture({{"commit", "b"}}, captureOf(1.5, 8192, 8, 0));
    auto reader = st::openStore(db_.string(), {.readOnly = true});
    auto done = tally::service::evaluatePending(*store_, *reader, true, 100);
    EXPECT_TRUE(done) << done.error();
    return done->alertIds;
  }
  fs::path dir_, db_;
  std::unique_ptr<tally::store::Store> store_;
};

TEST_F(Webhook, RetriesWithBackoffThenDeliversEachAlertOnce) {
  auto ids = pendingAlerts();
  ASSERT_EQ(ids.size(), 4u);
  Receiver receiver(3);
  tally::service::WebhookOptions options;
  options.url = receiver.url();
  options.dashboardUrl = "http://tally.example.org/";
  options.firstRetryMs = 200;
  options.maxRetryMs = 2000;
  options.maxAttempts = 5;
  options.timeoutSeconds = 2;
  auto target = tally::api::parseHttpUrl(options.url);
  ASSERT_TRUE(target) << target.error();
  std::vector<std::string> logged;
  auto log = [&](std::string_view line) { logged.emplace_back(line); };
  // Passes until nothing is pending, as the sender's thread makes them.
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < deadline) {
    ASSERT_TRUE(tally::service::deliverDue(*store_, *target, options, log));
    if (st::scalar(*store_, "SELECT COUNT(*) FROM alerts WHERE delivery = 'pending'") == 0) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  // Each alert delivered once, with the body documented in docs/api.md.
  auto bodies = receiver.bodies();
  ASSERT_EQ(bodies.size(), ids.size());
  std::set<int64_t> delivered;
  for (const auto& b : bodies) {
    delivered.insert(b["alert"]["id"].get<int64_t>());
    EXPECT_EQ(b["event"], "tally.alert");
    EXPECT_EQ(b["labels"], json({{"commit", "b"}}));
    EXPECT_EQ(b["run"]["labels"], json({{"commit", "b"}}));
    EXPECT_EQ(b["run"]["lights"], 8);
    EXPECT_EQ(b["baseline"]["threshold"], 0.05);
    EXPECT_TRUE(b["figures"].contains("ratio"));
    EXPECT_EQ(b["link"],
              "http://tally.example.org/#/alerts/" + std::to_string(b["alert"]["id"].get<int64_t>()));
  }
  EXPECT_EQ(delivered, std::set<int64_t>(ids.begin(), ids.end()));
  EXPECT_EQ(st::scalar(*store_, "SELECT COUNT(*) FROM alerts WHERE delivery = 'delivered'"), 4);
  // The 3 failures were spent on the first three alerts claimed, each posted
  // again once its backoff (200 ms after one failure) had passed.
  auto times = receiver.times();
  ASSERT_EQ(times.size(), ids.size() + 3);
  EXPECT_EQ(st::scalar(*store_, "SELECT SUM(delivery_attempts) FROM alerts"),
            static_cast<int64_t>(ids.size() + 3));
  EXPECT_EQ(st::scalar(*store_, "SELECT MAX(delivery_attempts) FROM alerts"), 2);
  EXPECT_EQ(logged.size(), 3u);
  for (const auto& line : logged) EXPECT_NE(line.find("HTTP 503"), std::string::npos) << line;
  // Requests 1-3 failed, 4 delivered the fourth alert before any retry (a
  // due alert does not wait on another's backoff: an order, not a time), and
  // 5-7 are the retries of 1-3: none before firstRetryMs after the first failure.
  auto posted = receiver.posted();
  ASSERT_EQ(posted.size(), ids.size() + 3);
  EXPECT_EQ(std::set<int64_t>(posted.begin(), posted.begin() + 4), std::set<int64_t>(ids.begin(), ids.end()))
      << "a due alert waited on another's backoff";
  EXPECT_EQ(std::set<int64_t>(posted.begin() + 4, posted.end()), std::set<int64_t>(posted.begin(), posted.begin() + 3))
      << "the retries are not those of the failed requests";
  auto gap = std::chrono::duration_cast<std::chrono::milliseconds>(times[4] - times[0]).count();
  EXPECT_GE(gap, 200) << "retried before its backoff";
  EXPECT_EQ(tally::service::retryDelayMs(options, 1), 200);
  EXPECT_EQ(tally::service::retryDelayMs(options, 2), 400);
  EXPECT_EQ(tally::service::retryDelayMs(options, 3), 800);
  EXPECT_EQ(tally::service::retryDelayMs(options, 10), 2000);
}

TEST_F(Webhook, AnUnreachableWebhookFailsAfterItsAttemptsAndChangesNothingElse) {
  auto ids = pendingAlerts();
  ASSERT_FALSE(ids.empty());
  tally::service::WebhookOptions options;
  options.url = "http://127.0.0.1:9/hook";  // discard: nothing listens
  options.firstRetryMs = 10;
  options.maxAttempts = 3;
  options.timeoutSeconds = 1;
  auto target = tally::api::parseHttpUrl(options.url);
  ASSERT_TRUE(target);
  for (int i = 0; i < 200; ++i) {
    ASSERT_TRUE(tally::service::deliverDue(*store_, *target, options, {}));
    if (st::scalar(*store_, "SELECT COUNT(*) FROM alerts WHERE delivery = 'pending'") == 0) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_EQ(
      st::scalar(*store_, "SELECT COUNT(*) FROM alerts WHERE delivery = 'failed' AND delivery_attempts = 3"),
      static_cast<int64_t>(ids.size()));
  EXPECT_EQ(st::scalar(*store_, "SELECT COUNT(*) FROM alerts WHERE delivery_error IS NULL"), 0);
  // The alerts themselves are untouched: open, with their figures.
  EXPECT_EQ(st::scalar(*store_, "SELECT COUNT(*) FROM alerts WHERE status = 'open' AND ratio IS NOT NULL"),
            static_cast<int64_t>(ids.size()));

  // A daemon with that webhook serves and evaluates as one without.
  Daemon daemon(dir_, db_, {"--role", "api", "--alert-webhook", options.url});
  ASSERT_TRUE(daemon.start());
  int64_t later = storeCapture({{"commit", "c"}}, captureOf(1.5, 8192, 8, 1));
  json alerts;
  for (int i = 0; i < 100 && alerts.size() < 4; ++i) {
    alerts = daemon.request("GET", "/api/alerts?run=" + std::to_string(later)).j()["alerts"];
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_EQ(alerts.size(), 4u);
  EXPECT_EQ(alerts[0]["delivery"]["state"], "pending");
  EXPECT_EQ(daemon.request("GET", "/api/health").status, 200);
  EXPECT_EQ(daemon.stop(SIGTERM), 0);
}

// A fleet's API side: two daemons serving the API on one PostgreSQL, both
// evaluating and both posting to one webhook that fails its first requests,
// while captures are stored as workers store them. Every run gets its alerts
// once, and every alert reaches the receiver once.
TEST(AlertFleet, TwoApiDaemonsOnOnePostgresRaiseAndPostEachAlertOnce) {
  auto* server = tally::testing::requirePostgres();
  if (!server) return;
  std::string url = server->createDatabase();
  fs::path dir = makeTempDir("tally-alert-fleet-test");
  auto store = st::openStore(url);
  ASSERT_NE(store, nullptr);
  auto storeCapture = [&](const json& labels, const json& result) {
    auto job = store->jobs().create({{"renderers", {"forward"}}, {"labels", labels}});
    EXPECT_TRUE(job) << job.error();
    EXPECT_TRUE(store->runs().ingestCapture(job->job.id, result, {}));
    tally::store::RunFilter f;
    f.jobId = job->job.id;
    return store->runs().list(f, {})->runs.at(0).id;
  };
  int64_t base = storeCapture({{"commit", "a"}}, captureOf(1.0, 4096, 4, 0));
  ASSERT_TRUE(*store->alerts().setBaseline({base, 0.05, std::nullopt}));
  Receiver receiver(2);
  std::vector<std::unique_ptr<Daemon>> daemons;
  for (const char* name : {"api-1", "api-2"}) {
    fs::create_directories(dir / name);
    daemons.push_back(std::make_unique<Daemon>(
        dir / name, fs::path(url),
        std::vector<std::string>{"--role", "api", "--alert-webhook", receiver.url()}));
    ASSERT_TRUE(daemons.back()->start()) << name;
  }
  constexpr int kRegressions = 12;
  for (int i = 0; i < kRegressions; ++i)
    storeCapture({{"commit", "c" + std::to_string(i)}}, captureOf(1.5, 8192, 8, i));
  const int64_t expected = 4 * kRegressions;  // frame, two passes, counts
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(40);
  while (std::chrono::steady_clock::now() < deadline &&
         st::scalar(*store, "SELECT COUNT(*) FROM alerts WHERE delivery = 'delivered'") < expected) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  EXPECT_EQ(st::scalar(*store, "SELECT COUNT(*) FROM runs WHERE evaluated = 0"), 0);
  EXPECT_EQ(st::scalar(*store, "SELECT COUNT(*) FROM alerts"), expected);
  EXPECT_EQ(st::scalar(*store,
                       "SELECT COUNT(*) FROM (SELECT run_id, metric FROM alerts GROUP BY run_id, metric "
                       "HAVING COUNT(*) > 1) AS twice"),
            0);
  EXPECT_EQ(st::scalar(*store, "SELECT COUNT(DISTINCT run_id) FROM alerts"), kRegressions);
  EXPECT_EQ(st::scalar(*store, "SELECT COUNT(*) FROM alerts WHERE delivery = 'delivered'"), expected);
  std::multiset<int64_t> posted;
  for (const auto& b : receiver.bodies()) posted.insert(b["alert"]["id"].get<int64_t>());
  EXPECT_EQ(posted.size(), static_cast<size_t>(expected));
  EXPECT_EQ(std::set<int64_t>(posted.begin(), posted.end()).size(), static_cast<size_t>(expected));
  // The two failures were retried: two alerts needed a second attempt.
  EXPECT_EQ(st::scalar(*store, "SELECT SUM(delivery_attempts) FROM alerts"), expected + 2);
  for (auto& d : daemons) EXPECT_EQ(d->stop(SIGTERM), 0);
  daemons.clear();
  store.reset();
  fs::remove_all(dir);
}

TEST(WebhookUrl, OnlyPlainHttpUrls) {
  EXPECT_TRUE(tally::api::parseHttpUrl("http://hooks.example.org/tally"));
  EXPECT_EQ(tally::api::parseHttpUrl("http://127.0.0.1:8080")->path, "/");
  for (const char* bad : {"https://x/y", "ftp://x", "http://", "http://:80/x", "http://h:99999/",
                          "http://u:p@h/", "http://h/a b"}) {
    EXPECT_FALSE(tally::api::parseHttpUrl(bad)) << bad;
  }
}

}  // namespace
