// /api/openapi.json describes what the daemon really answers: every route it
// serves is documented, and every response of a real daemon (after a real
// capture on lavapipe) matches its documented schema field by field, with no
// undocumented field, for successes and errors alike.
#include <chrono>
#include <set>
#include <thread>

#include <gtest/gtest.h>

#include "../api/openapi_schema.hpp"
#include "daemon.hpp"

namespace tally::service::test {
namespace {

class OpenApiTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = makeTempDir("tally-openapi-test");
    fs::create_directories(dir_ / "scenes");
    daemon_ = new Daemon(dir_, dir_ / "tally.db", {"--scenes", (dir_ / "scenes").string()});
    ASSERT_TRUE(daemon_->start()) << "tallyd serve did not start";
    Reply doc = daemon_->request("GET", "/api/openapi.json");
    ASSERT_EQ(doc.status, 200);
    document_ = new json(doc.j());
    ASSERT_TRUE(document_->is_object());
    Reply posted = daemon_->request("POST", "/api/captures", tinySpec().dump());
    ASSERT_EQ(posted.status, 202) << posted.body;
    accepted_ = new json(posted.j());
    captureId_ = (*accepted_)["id"];
    ASSERT_EQ(daemon_->waitFinished(captureId_).value("status", ""), "done");
  }
  static void TearDownTestSuite() {
    delete daemon_;
    delete document_;
    delete accepted_;
    daemon_ = nullptr;
    fs::remove_all(dir_);
  }

  // The response to METHOD PATH must have STATUS and match the schema documented
  // for TEMPLATE (the path as the document names it).
  static json expect(const std::string& method, const std::string& path, const std::string& templ, int status) {
    Reply r = daemon_->request(method, path);
    EXPECT_EQ(r.status, status) << method << " " << path << ": " << r.body;
    json body = r.j();
    expectMatches(body, method, templ, status);
    return body;
  }

  static void expectMatches(const json& body, const std::string& method, const std::string& templ, int status) {
    std::string lower = method;
    for (auto& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    testing::OpenApiChecker checker(*document_);
    json schema;
    try {
      if (status < 400) {
        schema = checker.responseSchema(templ, lower, std::to_string(status));
      } else {
        // Errors refer to the shared Error response.
        const json& response = document_->at("paths").at(templ).at(lower).at("responses").at(std::to_string(status));
        ASSERT_EQ(response.value("$ref", ""), "#/components/responses/Error") << templ << " " << status;
        schema = document_->at("components").at("responses").at("Error").at("content").at("application/json").at("schema");
      }
    } catch (const json::exception& e) {
      ADD_FAILURE() << method << " " << templ << " " << status << " is not documented: " << e.what();
      return;
    }
    for (const auto& problem : checker.check(body, schema)) {
      ADD_FAILURE() << method << " " << templ << " " << status << ": " << problem;
    }
  }

  static inline fs::path dir_;
  static inline Daemon* daemon_ = nullptr;
  static inline json* document_ = nullptr;
  static inline json* accepted_ = nullptr;
  static inline int64_t captureId_ = 0;
};

TEST_F(OpenApiTest, EveryRouteIsDocumented) {
  // The routes of server/service and server/api/builtin_routes, as served.
  const std::set<std::string> served = {
      "/api/health",       "/api/openapi.json", "/api/renderers",         "/api/scenes",
      "/api/devices",      "/api/captures",     "/api/captures/{id}",     "/api/runs",
      "/api/runs/{id}",    "/api/runs/{id}/samples", "/api/samples/{id}", "/api/samples/{id}/screenshot.png",
      "/api/samples/{id}/trace", "/api/samples/{id}/sites", "/api/samples/{id}/draws",
      "/api/runs/{id}/shaders", "/api/runs/{id}/shaders/{name}",
      "/api/compare",      "/api/export",       "/api/accuracy",          "/api/repeats",
      "/api/crossover",    "/api/heatmap",      "/api/heatmap/{id}/topdown.png",
      "/api/sweeps",       "/api/sweeps/{id}",  "/api/hosts",             "/metrics",
      "/api/baselines",    "/api/baselines/{id}", "/api/alerts",          "/api/alerts/{id}",
      "/api/trend"};
  std::set<std::string> documented;
  for (const auto& [path, unused] : (*document_)["paths"].items()) documented.insert(path);
  EXPECT_EQ(documented, served);
  // Undocumented paths are not served: the document is not describing a wish.
  for (const auto& path : documented) {
    std::string concrete = path;
    if (size_t at = concrete.find("{id}"); at != std::string::npos) concrete.replace(at, 4, "1");
    EXPECT_NE(daemon_->request("GET", concrete).status, 0) << path;
  }
}

TEST_F(OpenApiTest, ResponsesMatchTheirSchemas) {
  expectMatches(*accepted_, "POST", "/api/captures", 202);
  expect("GET", "/api/health", "/api/health", 200);
  expect("GET", "/api/renderers", "/api/renderers", 200);
  expect("GET", "/api/scenes", "/api/scenes", 200);
  json devices = expect("GET", "/api/devices", "/api/devices", 200);
  EXPECT_EQ(devices["devices"].size(), 1u);
  json captures = expect("GET", "/api/captures", "/api/captures", 200);
  EXPECT_FALSE(captures["captures"].empty());
  expect("GET", "/api/captures/" + std::to_string(captureId_), "/api/captures/{id}", 200);

  json runs = expect("GET", "/api/runs?capture=" + std::to_string(captureId_), "/api/runs", 200);
  ASSERT_EQ(runs["runs"].size(), 2u);
  std::string a = std::to_string(runs["runs"][0]["id"].get<int64_t>());
  std::string b = std::to_string(runs["runs"][1]["id"].get<int64_t>());
  expect("GET", "/api/runs/" + a, "/api/runs/{id}", 200);
  json samples = expect("GET", "/api/runs/" + a + "/samples", "/api/runs/{id}/samples", 200);
  ASSERT_FALSE(samples["samples"].empty());
  json sample = expect("GET", "/api/samples/" + std::to_string(samples["samples"][0]["id"].get<int64_t>()),
                       "/api/samples/{id}", 200);
  EXPECT_FALSE(sample["passes"].empty());
  // A capture stores every frame's time: one entry per frame, per pass too.
  ASSERT_TRUE(sample["frame_ms_frames"].is_array());
  EXPECT_EQ(sample["frame_ms_frames"].size(), sample["frames"].get<size_t>());
  EXPECT_TRUE(sample["passes"][0]["gpu_ms_frames"].is_array());
  json trace = expect("GET", "/api/samples/" + std::to_string(sample["id"].get<int64_t>()) + "/trace",
                      "/api/samples/{id}/trace", 200);
  EXPECT_EQ(trace["metadata"]["frame_times"], "measured");
  EXPECT_FALSE(trace["traceEvents"].empty());
  // A capture without "sites": true stores none: empty pages, every pass listed.
  std::string sampleId = std::to_string(sample["id"].get<int64_t>());
  json sites = expect("GET", "/api/samples/" + sampleId + "/sites?by=line", "/api/samples/{id}/sites", 200);
  EXPECT_EQ(sites["total"], 0);
  EXPECT_EQ(sites["passes"].size(), sample["passes"].size());
  expect("GET", "/api/samples/" + sampleId + "/draws?by=material", "/api/samples/{id}/draws", 200);
  expect("GET", "/api/runs/" + a + "/shaders", "/api/runs/{id}/shaders", 200);
  expect("GET", "/api/runs/" + a + "/shaders/forward.frag.glsl", "/api/runs/{id}/shaders/{name}", 404);
  expect("GET", "/api/samples/987654/sites", "/api/samples/{id}/sites", 404);
  expect("GET", "/api/samples/" + sampleId + "/draws?limit=0", "/api/samples/{id}/draws", 400);
  expect("GET", "/api/compare?runs=" + a + "," + b, "/api/compare", 200);
  json exported = expect("GET", "/api/export?format=json&capture=" + std::to_string(captureId_), "/api/export", 200);
  EXPECT_FALSE(exported["rows"].empty());
  // Both renderers' samples, so both the reference (no image error) and a compared one are checked.
  expect("GET", "/api/runs/" + b + "/samples", "/api/runs/{id}/samples", 200);

  // /api/accuracy needs a run in another mode: one with a reference, one without.
  json modes = tinySpec();
  modes["renderers"] = {"forward"};
  modes["counting"] = {"exact", "sampled:4"};
  Reply posted = daemon_->request("POST", "/api/captures", modes.dump());
  ASSERT_EQ(posted.status, 202) << posted.body;
  int64_t modesId = posted.j()["id"];
  ASSERT_EQ(daemon_->waitFinished(modesId).value("status", ""), "done");
  modes["counting"] = "subgroup";
  modes["resolutions"] = {{32, 18}};
  posted = daemon_->request("POST", "/api/captures", modes.dump());
  ASSERT_EQ(posted.status, 202) << posted.body;
  ASSERT_EQ(daemon_->waitFinished(posted.j()["id"]).value("status", ""), "done");
  json accuracy = expect("GET", "/api/accuracy", "/api/accuracy", 200);
  // The first capture's two runs (accumulate, the default: forward's has the
  // exact reference, deferred's none), sampled:4's, subgroup's (none).
  ASSERT_EQ(accuracy["rows"].size(), 4u) << accuracy.dump();
  int withReference = 0;
  for (const auto& row : accuracy["rows"]) withReference += row["reference"].is_null() ? 0 : 1;
  EXPECT_EQ(withReference, 2) << accuracy.dump();
  expect("GET", "/api/accuracy?limit=3", "/api/accuracy", 400);

  // /api/repeats needs a repeat: the first modes capture again (exact and sampled:4).
  modes["counting"] = {"exact", "sampled:4"};
  modes["resolutions"] = tinySpec()["resolutions"];
  posted = daemon_->request("POST", "/api/captures", modes.dump());
  ASSERT_EQ(posted.status, 202) << posted.body;
  ASSERT_EQ(daemon_->waitFinished(posted.j()["id"]).value("status", ""), "done");
  json repeats = expect("GET", "/api/repeats", "/api/repeats", 200);
  EXPECT_GE(repeats["groups"].size(), 2u) << repeats.dump();
  expect("GET", "/api/repeats?limit=3", "/api/repeats", 400);

  // /api/crossover: the first capture (one resolution: no fit, an error, no
  // crossing) and one at three resolutions (fits and a crossing).
  json single = expect("GET", "/api/crossover?capture=" + std::to_string(captureId_), "/api/crossover", 200);
  ASSERT_EQ(single["series"].size(), 2u) << single.dump();
  EXPECT_TRUE(single["series"][0]["fit"].is_null());
  EXPECT_TRUE(single["crossings"].empty());
  json sweep3 = tinySpec();
  sweep3["resolutions"] = {{32, 18}, {48, 27}, {64, 36}};
  posted = daemon_->request("POST", "/api/captures", sweep3.dump());
  ASSERT_EQ(posted.status, 202) << posted.body;
  int64_t sweep3Id = posted.j()["id"];
  ASSERT_EQ(daemon_->waitFinished(sweep3Id).value("status", ""), "done");
  for (std::string metric : {"bytes", "frame_ms"}) {
    json crossover = expect("GET", "/api/crossover?capture=" + std::to_string(sweep3Id) + "&metric=" + metric,
                            "/api/crossover", 200);
    ASSERT_EQ(crossover["series"].size(), 2u) << crossover.dump();
    EXPECT_TRUE(crossover["series"][0]["fit"].is_object()) << crossover.dump();
    ASSERT_EQ(crossover["crossings"].size(), 1u) << crossover.dump();
  }
  expect("GET", "/api/crossover", "/api/crossover", 400);

  // /api/heatmap: a tiny floor heatmap, two renderers, frame time and bytes.
  json heatmap = tinySpec();
  heatmap.erase("cameras");
  heatmap["scenes"] = {"atrium"};
  heatmap["heatmap"] = {{"layout", "floor"}, {"cells", {2, 1}}, {"yaws", 1}};
  posted = daemon_->request("POST", "/api/captures", heatmap.dump());
  ASSERT_EQ(posted.status, 202) << posted.body;
  int64_t heatmapId = posted.j()["id"];
  ASSERT_EQ(daemon_->waitFinished(heatmapId).value("status", ""), "done");
  json renderersOf = expect("GET", "/api/runs?capture=" + std::to_string(heatmapId), "/api/runs", 200);
  ASSERT_EQ(renderersOf["runs"].size(), 2u);
  const std::string first = renderersOf["runs"][1]["variant"], second = renderersOf["runs"][0]["variant"];
  for (std::string metric : {"frame_ms", "bytes"}) {
    json map = expect("GET", "/api/heatmap?capture=" + std::to_string(heatmapId) + "&renderer=" + first + "&versus=" +
                                 second + "&metric=" + metric,
                      "/api/heatmap", 200);
    EXPECT_EQ(map["cells"].size(), 2u) << map.dump();
  }
  expect("GET", "/api/heatmap?capture=" + std::to_string(heatmapId) + "&renderer=" + first, "/api/heatmap", 200);
  expect("GET", "/api/heatmap?capture=" + std::to_string(heatmapId), "/api/heatmap", 400);

  // A variant run: options, variant label, extras and variant_error (the
  // clamped uv derivatives against their float32 reference), found by the
  // variant filter; GET /api/renderers lists the option table.
  json variant = tinySpec();
  variant["renderers"] = {{{"renderer", "visbuffer"}, {"options", {{"uv_derivatives", "unorm16-clamped"}}}}};
  posted = daemon_->request("POST", "/api/captures", variant.dump());
  ASSERT_EQ(posted.status, 202) << posted.body;
  ASSERT_EQ(daemon_->waitFinished(posted.j()["id"]).value("status", ""), "done");
  json variantRuns =
      expect("GET", "/api/runs?variant=visbuffer%20uv_derivatives%3Dunorm16-clamped", "/api/runs", 200);
  ASSERT_EQ(variantRuns["runs"].size(), 1u) << variantRuns.dump();
  const json& variantRun = variantRuns["runs"][0];
  EXPECT_EQ(variantRun["variant"], "visbuffer uv_derivatives=unorm16-clamped");
  EXPECT_EQ(variantRun["options"], json({{"uv_derivatives", "unorm16-clamped"}}));
  EXPECT_EQ(runs["runs"][0]["options"], json::object());
  EXPECT_EQ(runs["runs"][0]["variant"], runs["runs"][0]["renderer"]);
  std::string v = std::to_string(variantRun["id"].get<int64_t>());
  expect("GET", "/api/runs/" + v, "/api/runs/{id}", 200);
  json variantSamples = expect("GET", "/api/runs/" + v + "/samples", "/api/runs/{id}/samples", 200);
  ASSERT_FALSE(variantSamples["samples"].empty());
  for (const auto& s : variantSamples["samples"]) {
    ASSERT_TRUE(s["variant_error"].is_object()) << s.dump();
    EXPECT_EQ(s["variant_error"]["against"], "visbuffer uv_derivatives=float32");
    EXPECT_TRUE(s["extras"].is_object());
  }
  EXPECT_TRUE(samples["samples"][0]["variant_error"].is_null());
  expect("GET", "/api/samples/" + std::to_string(variantSamples["samples"][0]["id"].get<int64_t>()),
         "/api/samples/{id}", 200);
  expect("GET", "/api/compare?runs=" + a + "," + v, "/api/compare", 200);
  json table = expect("GET", "/api/renderers", "/api/renderers", 200);
  ASSERT_TRUE(table["options"].is_array());
  bool listed = false;
  for (const auto& o : table["options"]) listed = listed || o["name"] == "uv_derivatives";
  EXPECT_TRUE(listed) << table.dump();
  expect("GET", "/api/runs?variant=nothing%20like%20it", "/api/runs", 200);

  // A stability sweep: its job, the list and the sweep with its whole result
  // (one failing and one holding point, so fails_at has a value and a null).
  json sweepSpec = {{"sweep", "depth-reconstruction"}, {"near", {0.01}}, {"far", {1000}},
                    {"distances", {3, 300}}, {"resolution", {32, 18}}, {"threshold", {{"relative", 1e-3}}}};
  posted = daemon_->request("POST", "/api/captures", sweepSpec.dump());
  ASSERT_EQ(posted.status, 202) << posted.body;
  expectMatches(posted.j(), "POST", "/api/captures", 202);
  int64_t sweepJob = posted.j()["id"];
  ASSERT_EQ(daemon_->waitFinished(sweepJob).value("status", ""), "done");
  json job = expect("GET", "/api/captures/" + std::to_string(sweepJob), "/api/captures/{id}", 200);
  ASSERT_EQ(job["sweeps"].size(), 1u);
  json sweeps = expect("GET", "/api/sweeps", "/api/sweeps", 200);
  ASSERT_EQ(sweeps["sweeps"].size(), 1u);
  EXPECT_FALSE(sweeps["sweeps"][0]["fails_at"].is_null());
  json sweep = expect("GET", "/api/sweeps/" + std::to_string(job["sweeps"][0].get<int64_t>()), "/api/sweeps/{id}", 200);
  EXPECT_FALSE(sweep["result"]["plots"].empty());
  expect("GET", "/api/sweeps?name=depth-reconstruction&limit=1", "/api/sweeps", 200);
  // The run detail's counter headroom is an object here, documented field by field.
  EXPECT_TRUE(daemon_->request("GET", "/api/runs/" + a).j()["counter_headroom"].is_object());
}

TEST_F(OpenApiTest, ErrorsMatchTheErrorSchema) {
  expect("GET", "/api/runs/987654", "/api/runs/{id}", 404);
  expect("GET", "/api/runs?limit=0", "/api/runs", 400);
  expect("GET", "/api/compare?runs=1", "/api/compare", 400);
  expect("GET", "/api/crossover?capture=987654", "/api/crossover", 404);
  expect("GET", "/api/crossover?capture=1&metric=watts", "/api/crossover", 400);
  expect("GET", "/api/sweeps/987654", "/api/sweeps/{id}", 404);
  expect("GET", "/api/samples/987654/trace", "/api/samples/{id}/trace", 404);
  expect("GET", "/api/sweeps?limit=0", "/api/sweeps", 400);
  Reply badSweep = daemon_->request("POST", "/api/captures", R"({"sweep": "nope"})");
  EXPECT_EQ(badSweep.status, 400);
  expectMatches(badSweep.j(), "POST", "/api/captures", 400);
  expect("DELETE", "/api/captures/" + std::to_string(captureId_), "/api/captures/{id}", 409);
  Reply bad = daemon_->request("POST", "/api/captures", "{\"frames\": ");
  EXPECT_EQ(bad.status, 400);
  expectMatches(bad.j(), "POST", "/api/captures", 400);
}

TEST_F(OpenApiTest, CancelAnswersTheDocumentedJob) {
  json spec = longSpec();
  Reply posted = daemon_->request("POST", "/api/captures", spec.dump());
  ASSERT_EQ(posted.status, 202);
  json cancelled = expect("DELETE", "/api/captures/" + std::to_string(posted.j()["id"].get<int64_t>()),
                          "/api/captures/{id}", 200);
  EXPECT_EQ(cancelled["status"], "cancelled");
}

// Baselines, alerts and trends: a baseline on the first capture's forward
// run, then the same spec with more lights and labels, whose alerts (counts
// change with the lights) and trend must match their schemas, as must the
// replies to bad and unknown ids.
TEST_F(OpenApiTest, BaselinesAlertsAndTrendsMatchTheirSchemas) {
  json runs = daemon_->request("GET", "/api/runs?capture=" + std::to_string(captureId_) + "&renderer=forward").j();
  ASSERT_EQ(runs["runs"].size(), 1u);
  int64_t run = runs["runs"][0]["id"];
  Reply set = daemon_->request("POST", "/api/baselines", json{{"run", run}, {"name", "forward planes"}}.dump());
  ASSERT_EQ(set.status, 201) << set.body;
  expectMatches(set.j(), "POST", "/api/baselines", 201);
  std::string id = std::to_string(set.j()["id"].get<int64_t>());
  expect("GET", "/api/baselines", "/api/baselines", 200);
  expect("GET", "/api/baselines?all=true", "/api/baselines", 200);
  expect("GET", "/api/baselines/" + id, "/api/baselines/{id}", 200);

  json more = tinySpec();
  more["lights"] = 64;
  more["labels"] = {{"commit", "more-lights"}};
  Reply posted = daemon_->request("POST", "/api/captures", more.dump());
  ASSERT_EQ(posted.status, 202) << posted.body;
  ASSERT_EQ(daemon_->waitFinished(posted.j()["id"]).value("status", ""), "done");
  json labelled = expect("GET", "/api/runs?label=commit%3Dmore-lights", "/api/runs", 200);
  EXPECT_EQ(labelled["runs"].size(), 2u);
  json alerts;
  for (int i = 0; i < 100; ++i) {
    alerts = expect("GET", "/api/alerts?baseline=" + id, "/api/alerts", 200);
    if (!alerts["alerts"].empty()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  ASSERT_FALSE(alerts["alerts"].empty()) << "more lights changed no count";
  std::string alert = std::to_string(alerts["alerts"][0]["id"].get<int64_t>());
  expect("GET", "/api/alerts/" + alert, "/api/alerts/{id}", 200);
  for (const char* method : {"PATCH", "POST"}) {
    Reply changed = daemon_->request(method, "/api/alerts/" + alert, R"({"status":"acknowledged"})");
    ASSERT_EQ(changed.status, 200) << changed.body;
    expectMatches(changed.j(), method, "/api/alerts/{id}", 200);
  }
  json trend = expect("GET", "/api/trend?baseline=" + id, "/api/trend", 200);
  // The baseline run, other captures of this configuration by the other
  // tests, and last the run with more lights.
  ASSERT_GE(trend["runs"].size(), 2u);
  EXPECT_EQ(trend["runs"][0]["id"], run);
  EXPECT_TRUE(trend["runs"][0]["baseline"].get<bool>());
  EXPECT_EQ(trend["runs"].back()["lights"], 64);
  EXPECT_FALSE(trend["runs"].back()["alerts"].empty());

  expect("GET", "/api/alerts/987654", "/api/alerts/{id}", 404);
  expect("GET", "/api/alerts?status=closed", "/api/alerts", 400);
  expect("GET", "/api/trend", "/api/trend", 400);
  expect("GET", "/api/baselines/987654", "/api/baselines/{id}", 404);
  expect("DELETE", "/api/baselines/" + id, "/api/baselines/{id}", 200);
}

}  // namespace
}  // namespace tally::service::test
