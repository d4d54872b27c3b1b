// `tallyd serve` end to end: a real daemon (child process) on 127.0.0.1 with
// an ephemeral port and a temp database. One tiny capture on lavapipe feeds
// the query tests; a table of bad requests; kill -9 during a job and restart.
#include <signal.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <sqlite3.h>

#include "daemon.hpp"
#include "store/store.hpp"

namespace {
using namespace tally::service::test;

// Runs `tallyd capture` directly: the reference the stored sample must match.
json captureDirectly(const fs::path& dir, const json& spec) {
  fs::path specPath = dir / "direct-spec.json", out = dir / "direct-result.json";
  std::ofstream(specPath) << spec.dump();
  std::string cmd = std::string(TALLYD_PATH) + " capture --quiet --spec " + specPath.string() + " --out " + out.string();
  if (std::system(cmd.c_str()) != 0) return nullptr;
  std::ifstream in(out);
  return json::parse(in, nullptr, false);
}

class ServiceTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = makeTempDir("tally-service-test");
    fs::create_directories(dir_ / "scenes");
    std::ofstream(dir_ / "scenes" / "a.gltf") << "{}";
    fs::create_symlink("/etc/hostname", dir_ / "scenes" / "escape.gltf");
    daemon_ = new Daemon(dir_, dir_ / "tally.db", {"--scenes", (dir_ / "scenes").string()});
    ASSERT_TRUE(daemon_->start()) << "tallyd serve did not start";
  }
  static void TearDownTestSuite() {
    if (daemon_) {
      EXPECT_EQ(daemon_->stop(SIGTERM), 0) << "SIGTERM should stop the daemon cleanly";
    }
    delete daemon_;
    daemon_ = nullptr;
    fs::remove_all(dir_);
  }
  static inline fs::path dir_;
  static inline Daemon* daemon_ = nullptr;
};

TEST_F(ServiceTest, CaptureQueryCompareExport) {
  Daemon& d = *daemon_;
  json spec = tinySpec();
  // The reference capture runs beside the daemon's.
  json reference;
  std::thread direct([&] { reference = captureDirectly(dir_, spec); });

  Reply posted = d.request("POST", "/api/captures", spec.dump(), "key-1");
  ASSERT_EQ(posted.status, 202) << posted.body;
  int64_t id = posted.j()["id"];
  EXPECT_EQ(posted.j()["status"], "queued");
  // The same key and spec: the same job.
  Reply again = d.request("POST", "/api/captures", spec.dump(), "key-1");
  EXPECT_EQ(again.status, 202);
  EXPECT_EQ(again.j()["id"], id);
  // The same key, another spec: a conflict.
  json other = spec;
  other["frames"] = 3;
  Reply conflict = d.request("POST", "/api/captures", other.dump(), "key-1");
  EXPECT_EQ(conflict.status, 409) << conflict.body;
  EXPECT_EQ(conflict.j()["error"]["code"], "conflict");

  json job = d.waitFinished(id);
  direct.join();
  ASSERT_EQ(job.value("status", ""), "done") << job.dump();
  EXPECT_EQ(job["attempts"], 1);
  EXPECT_EQ(job["progress"]["done"], job["progress"]["total"]);
  EXPECT_TRUE(job["finished_at"].is_string());
  // Finished: cancelling is a conflict.
  EXPECT_EQ(d.request("DELETE", "/api/captures/" + std::to_string(id)).status, 409);

  Reply captures = d.request("GET", "/api/captures?limit=10");
  ASSERT_EQ(captures.status, 200);
  EXPECT_EQ(captures.j()["captures"].size(), 1u);

  Reply runs = d.request("GET", "/api/runs?capture=" + std::to_string(id));
  ASSERT_EQ(runs.status, 200) << runs.body;
  ASSERT_EQ(runs.j()["runs"].size(), 2u);
  EXPECT_EQ(d.request("GET", "/api/runs?renderer=forward&width=64&height=36").j()["runs"].size(), 1u);
  std::map<std::string, int64_t> runIds;
  json runList = runs.j();
  for (const auto& r : runList["runs"]) runIds[r["renderer"].get<std::string>()] = r["id"].get<int64_t>();
  ASSERT_EQ(runIds.size(), 2u);

  Reply run = d.request("GET", "/api/runs/" + std::to_string(runIds["deferred"]));
  ASSERT_EQ(run.status, 200);
  EXPECT_FALSE(run.j()["resources"].empty());

  Reply samples = d.request("GET", "/api/runs/" + std::to_string(runIds["deferred"]) + "/samples");
  ASSERT_EQ(samples.status, 200);
  ASSERT_EQ(samples.j()["samples"].size(), 1u);
  int64_t sampleId = samples.j()["samples"][0]["id"];

  Reply sample = d.request("GET", "/api/samples/" + std::to_string(sampleId));
  ASSERT_EQ(sample.status, 200);
  json passes = sample.j()["passes"];
  ASSERT_FALSE(passes.empty());
  // Counts equal the capture result's (exact counting is deterministic).
  ASSERT_TRUE(reference.is_object()) << "the direct capture failed";
  json refSample;
  for (const auto& r : reference["runs"]) {
    if (r["renderer"] == "deferred") refSample = r["samples"][0];
  }
  ASSERT_TRUE(refSample.is_object());
  ASSERT_EQ(passes.size(), refSample["passes"].size());
  size_t compared = 0;
  for (size_t p = 0; p < passes.size(); ++p) {
    const auto& got = passes[p];
    const auto& want = refSample["passes"][p];
    EXPECT_EQ(got["name"], want["name"]);
    ASSERT_EQ(got["resources"].size(), want["resources"].size()) << got["name"];
    for (size_t r = 0; r < got["resources"].size(); ++r) {
      EXPECT_EQ(got["resources"][r]["name"], want["resources"][r]["name"]);
      EXPECT_EQ(got["resources"][r]["access"], want["resources"][r]["access"]);
      EXPECT_DOUBLE_EQ(got["resources"][r]["count"].get<double>(), want["resources"][r]["count"].get<double>())
          << got["name"] << " " << got["resources"][r]["name"];
      ++compared;
    }
  }
  EXPECT_GT(compared, 0u);

  Reply png = d.request("GET", "/api/samples/" + std::to_string(sampleId) + "/screenshot.png");
  ASSERT_EQ(png.status, 200);
  EXPECT_EQ(png.contentType, "image/png");
  ASSERT_GE(png.body.size(), 8u);
  EXPECT_EQ(png.body.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));

  Reply cmp = d.request("GET", "/api/compare?runs=" + std::to_string(runIds["forward"]) + "," +
                                   std::to_string(runIds["deferred"]));
  ASSERT_EQ(cmp.status, 200) << cmp.body;
  ASSERT_EQ(cmp.j()["frame_ms"].size(), 2u);
  EXPECT_TRUE(cmp.j()["frame_ms"][1]["ratio"].is_number()) << cmp.j()["frame_ms"].dump();
  EXPECT_TRUE(cmp.j()["total_bytes"][1]["ratio"].is_number());
  EXPECT_FALSE(cmp.j()["passes"].empty());
  // Forward against deferred on lavapipe: the same cameras, every frame's time
  // tested, and counts that differ (different passes write different bytes).
  const json comparison = cmp.j();
  const json& sig = comparison["significance"];
  ASSERT_EQ(sig.size(), 1u) << cmp.body;
  EXPECT_EQ(sig[0]["run_b"], runIds["deferred"]);
  EXPECT_GT(sig[0]["cameras"].get<int>(), 0);
  ASSERT_TRUE(sig[0]["frame"].is_object()) << sig[0].dump();
  EXPECT_EQ(sig[0]["frame"]["n_a"].get<int>(), sig[0]["frame"]["n_b"].get<int>());
  double ratio = sig[0]["frame"]["ratio"], medianA = sig[0]["frame"]["median_a"], medianB = sig[0]["frame"]["median_b"];
  EXPECT_NEAR(ratio, medianB / medianA, 1e-12);
  EXPECT_EQ(sig[0]["counts"]["verdict"], "changed");

  Reply csv = d.request("GET", "/api/export?format=csv&capture=" + std::to_string(id));
  ASSERT_EQ(csv.status, 200);
  EXPECT_EQ(csv.contentType.rfind("text/csv", 0), 0u);
  std::istringstream lines(csv.body);
  std::string header, row;
  std::getline(lines, header);
  EXPECT_EQ(header, "run,renderer,scene,width,height,device,pass,resource,access,count,bytes\r");
  int rows = 0;
  while (std::getline(lines, row)) rows += row.empty() ? 0 : 1;
  EXPECT_GT(rows, 0);
  Reply exported = d.request("GET", "/api/export?format=json");
  ASSERT_EQ(exported.status, 200);
  EXPECT_EQ(static_cast<int>(exported.j()["rows"].size()), rows);
  // runs= narrows the export to those runs: only forward's rows, and fewer than all.
  Reply one = d.request("GET", "/api/export?format=json&runs=" + std::to_string(runIds["forward"]));
  ASSERT_EQ(one.status, 200) << one.body;
  ASSERT_FALSE(one.j()["rows"].empty());
  EXPECT_LT(static_cast<int>(one.j()["rows"].size()), rows);
  for (const auto& r : one.j()["rows"]) EXPECT_EQ(r["renderer"], "forward");

  Reply devices = d.request("GET", "/api/devices");
  ASSERT_EQ(devices.status, 200);
  EXPECT_EQ(devices.j()["devices"].size(), 1u);
  Reply scenes = d.request("GET", "/api/scenes");
  ASSERT_EQ(scenes.status, 200);
  EXPECT_EQ(scenes.j()["procedural"].size(), 3u);
  EXPECT_EQ(scenes.j()["gltf"][0]["files"], json::array({"a.gltf"}));  // not the link out of the folder
  EXPECT_EQ(d.request("GET", "/api/renderers").status, 200);
}

// Footprint end to end: "footprint": 64 reaches the stored run as its block
// size; footprint values put on its lines (as the counting will measure them:
// here half of each counted line's requested bytes, so reuse is 2) come back
// from every route beside the requested bytes, and a run without footprint
// reads null there.
TEST_F(ServiceTest, FootprintReachesTheRunCompareAndExportRoutes) {
  Daemon& d = *daemon_;
  json spec = tinySpec();
  spec["renderers"] = {"deferred"};
  spec["counting"] = {"accumulate", "exact"};
  spec["footprint"] = 64;
  Reply posted = d.request("POST", "/api/captures", spec.dump());
  ASSERT_EQ(posted.status, 202) << posted.body;
  int64_t job = posted.j()["id"];
  ASSERT_EQ(d.waitFinished(job).value("status", ""), "done");
  Reply runs = d.request("GET", "/api/runs?capture=" + std::to_string(job));
  ASSERT_EQ(runs.status, 200);
  ASSERT_EQ(runs.j()["runs"].size(), 2u);
  int64_t fp = 0, plain = 0;
  json runList = runs.j();
  for (const auto& r : runList["runs"]) {
    EXPECT_EQ(r["footprint_block_bytes"], 64) << r.dump();  // every instrumented run of the spec
    (r["counting"] == "accumulate" ? fp : plain) = r["id"].get<int64_t>();
  }
  ASSERT_TRUE(fp && plain) << runs.body;

  // Known footprints (half of each counted line's bytes) written as ingest
  // stores them, so that every route can be checked against them; the
  // exact run's are removed.
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open((dir_ / "tally.db").c_str(), &db), SQLITE_OK);
    sqlite3_busy_timeout(db, 5000);
    std::string run = std::to_string(fp);
    std::string sql =
        "UPDATE counters SET footprint_bytes = bytes / 2 WHERE footprint_bytes IS NOT NULL AND pass_id IN "
        "(SELECT p.id FROM passes p JOIN samples s ON s.id = p.sample_id WHERE s.run_id = " + run + ");"
        "UPDATE samples SET footprint_bytes = (SELECT SUM(c.footprint_bytes) FROM counters c JOIN passes p "
        "ON p.id = c.pass_id WHERE p.sample_id = samples.id), footprint_requested_bytes = (SELECT SUM(c.bytes) "
        "FROM counters c JOIN passes p ON p.id = c.pass_id WHERE p.sample_id = samples.id AND c.footprint_bytes "
        "IS NOT NULL) WHERE run_id = " + run + ";"
        "UPDATE runs SET footprint_block_bytes = NULL WHERE id = " + std::to_string(plain) + ";"
        // The other run as if captured without footprint.
        "UPDATE counters SET footprint_bytes = NULL WHERE pass_id IN (SELECT p.id FROM passes p JOIN samples s "
        "ON s.id = p.sample_id WHERE s.run_id = " + std::to_string(plain) + ");"
        "UPDATE samples SET footprint_bytes = NULL, footprint_requested_bytes = NULL WHERE run_id = " +
        std::to_string(plain) + ";"
        // And the runs' means over their samples, as ingest keeps them on the run (migration 0013).
        "UPDATE runs SET (mean_footprint_bytes, mean_footprint_requested_bytes) = (SELECT AVG(s.footprint_bytes), "
        "AVG(s.footprint_requested_bytes) FROM samples s WHERE s.run_id = runs.id) WHERE id IN (" + run + ", " +
        std::to_string(plain) + ");";
    ASSERT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr), SQLITE_OK) << sqlite3_errmsg(db);
    sqlite3_close(db);
  }

  Reply run = d.request("GET", "/api/runs/" + std::to_string(fp));
  ASSERT_EQ(run.status, 200) << run.body;
  json r = run.j();
  EXPECT_EQ(r["footprint_block_bytes"], 64);
  double counted = 0;  // requested bytes of the counted lines, per frame
  int lines = 0;
  for (const auto& pass : r["passes"]) {
    double passCounted = 0;
    for (const auto& line : pass["resources"]) {
      // Counted lines have a footprint but the sky's (a cube, not modelled),
      // and of the derived ones the index buffer's (from the ranges drawn).
      const bool measured = (line["source"] == "counter" && line["name"] != "sky") || line["name"] == "indices";
      EXPECT_EQ(!line["footprint_bytes"].is_null(), measured) << line.dump();
      if (measured) {
        EXPECT_DOUBLE_EQ(line["footprint_bytes"].get<double>(), line["bytes"].get<double>() / 2) << line.dump();
        if (line["bytes"].get<double>() > 0) {
          EXPECT_DOUBLE_EQ(line["reuse"].get<double>(), 2.0) << line.dump();
        }
        passCounted += line["bytes"].get<double>();
        ++lines;
      } else {
        EXPECT_TRUE(line["footprint_bytes"].is_null()) << line.dump();
        EXPECT_TRUE(line["reuse"].is_null()) << line.dump();
      }
    }
    if (passCounted > 0) {
      EXPECT_DOUBLE_EQ(pass["footprint_bytes"].get<double>(), passCounted / 2) << pass["name"];
      EXPECT_DOUBLE_EQ(pass["reuse"].get<double>(), 2.0) << pass["name"];
    }
    counted += passCounted;
  }
  ASSERT_GT(lines, 0);
  ASSERT_GT(counted, 0);
  EXPECT_DOUBLE_EQ(r["mean_footprint_bytes"].get<double>(), counted / 2);
  EXPECT_DOUBLE_EQ(r["mean_reuse"].get<double>(), 2.0);
  EXPECT_GT(r["mean_bytes"].get<double>(), r["mean_footprint_bytes"].get<double>());

  Reply samples = d.request("GET", "/api/runs/" + std::to_string(fp) + "/samples");
  ASSERT_EQ(samples.status, 200);
  ASSERT_EQ(samples.j()["samples"].size(), 1u);
  EXPECT_DOUBLE_EQ(samples.j()["samples"][0]["footprint_bytes"].get<double>(), counted / 2);
  EXPECT_DOUBLE_EQ(samples.j()["samples"][0]["reuse"].get<double>(), 2.0);

  Reply cmp = d.request("GET", "/api/compare?runs=" + std::to_string(fp) + "," + std::to_string(plain));
  ASSERT_EQ(cmp.status, 200) << cmp.body;
  json c = cmp.j();
  EXPECT_DOUBLE_EQ(c["total_footprint_bytes"][0]["value"].get<double>(), counted / 2);
  EXPECT_TRUE(c["total_footprint_bytes"][1]["value"].is_null());
  EXPECT_DOUBLE_EQ(c["reuse"][0]["value"].get<double>(), 2.0);
  EXPECT_TRUE(c["reuse"][1]["value"].is_null());
  // Requested bytes: the same counts in both modes (accumulate is exact).
  EXPECT_DOUBLE_EQ(c["total_bytes"][1]["ratio"].get<double>(), 1.0);
  for (const auto& pass : c["passes"]) {
    ASSERT_EQ(pass["footprint_bytes"].size(), 2u);
    EXPECT_TRUE(pass["footprint_bytes"][1]["value"].is_null());
  }
  for (const auto& res : c["resources"]) {
    if (!res["footprint_bytes"][0]["value"].is_null() && res["bytes"][0]["value"].get<double>() > 0) {
      EXPECT_DOUBLE_EQ(res["reuse"][0]["value"].get<double>(), 2.0) << res.dump();
    }
  }

  Reply exported = d.request("GET", "/api/export?format=json&runs=" + std::to_string(fp) + "," + std::to_string(plain));
  ASSERT_EQ(exported.status, 200);
  int withFootprint = 0;
  json rows = exported.j();
  for (const auto& row : rows["rows"]) {
    if (row["run"] == plain) {
      EXPECT_TRUE(row["footprint_bytes"].is_null()) << row.dump();
    } else if (!row["footprint_bytes"].is_null() && row["bytes"].get<double>() > 0) {
      EXPECT_DOUBLE_EQ(row["reuse"].get<double>(), 2.0) << row.dump();
      ++withFootprint;
    }
  }
  EXPECT_GT(withFootprint, 0);
  Reply csv = d.request("GET", "/api/export?format=csv&runs=" + std::to_string(fp));
  ASSERT_EQ(csv.status, 200);
  // With footprint rows, two columns follow the requested bytes.
  EXPECT_EQ(csv.body.substr(0, csv.body.find('\n')),
            "run,renderer,scene,width,height,device,pass,resource,access,count,bytes,footprint_bytes,reuse\r");
  EXPECT_NE(csv.body.find(",256.0,2.0\r\n"), std::string::npos) << csv.body;  // footprint, then reuse: the last columns
  EXPECT_NE(csv.body.find(",,\r\n"), std::string::npos) << csv.body;  // the derived depth line: empty cells

  // The accuracy rows name the block size: footprint runs are points of their own.
  Reply accuracy = d.request("GET", "/api/accuracy?capture=" + std::to_string(job));
  ASSERT_EQ(accuracy.status, 200);
  ASSERT_EQ(accuracy.j()["rows"].size(), 1u);
  EXPECT_EQ(accuracy.j()["rows"][0]["footprint_block_bytes"], 64);
}

TEST_F(ServiceTest, CancelARunningCaptureKillsItsChild) {
  Daemon& d = *daemon_;
  Reply posted = d.request("POST", "/api/captures", longSpec().dump());  // still running when cancelled
  ASSERT_EQ(posted.status, 202);
  int64_t id = posted.j()["id"];
  json job = d.waitProgress(id);
  ASSERT_EQ(job.value("status", ""), "running") << job.dump();
  Reply cancelled = d.request("DELETE", "/api/captures/" + std::to_string(id));
  ASSERT_EQ(cancelled.status, 200) << cancelled.body;
  EXPECT_EQ(cancelled.j()["status"], "cancelled");
  // The child is killed within a couple of polls, and nothing is ingested.
  bool childGone = false;
  for (int i = 0; i < 50 && !childGone; ++i) {
    std::this_thread::sleep_for(100ms);
    childGone = true;
    std::error_code ec;
    for (const auto& entry : fs::directory_iterator("/proc", ec)) {
      std::string cmd = tally::test::readProcFile(entry.path() / "cmdline");
      if (cmd.find(d.tmp().string() + "/tally-job-" + std::to_string(id) + "-") != std::string::npos) childGone = false;
    }
  }
  EXPECT_TRUE(childGone);
  EXPECT_EQ(d.waitFinished(id)["status"], "cancelled");
  EXPECT_EQ(d.request("GET", "/api/runs?capture=" + std::to_string(id)).j()["runs"].size(), 0u);
  // Cancelling again: it has finished (as cancelled).
  EXPECT_EQ(d.request("DELETE", "/api/captures/" + std::to_string(id)).status, 409);
}

// A capture that fails in the child (a glTF file that is not a scene) fails
// only its own job, with the child's reason; the daemon keeps serving.
TEST_F(ServiceTest, AFailingCaptureFailsOnlyItsJob) {
  Daemon& d = *daemon_;
  json spec = tinySpec();
  spec["scenes"] = {{{"gltf", "a.gltf"}}};
  Reply posted = d.request("POST", "/api/captures", spec.dump());
  ASSERT_EQ(posted.status, 202) << posted.body;
  int64_t id = posted.j()["id"];
  json job = d.waitFinished(id);
  EXPECT_EQ(job.value("status", ""), "failed") << job.dump();
  ASSERT_TRUE(job["error"].is_string());
  EXPECT_NE(job["error"].get<std::string>().find("capture exited with status"), std::string::npos) << job["error"];
  // Stored with the canonical path under the scene folder.
  EXPECT_EQ(job["spec"]["scenes"][0]["gltf"], fs::canonical(dir_ / "scenes" / "a.gltf").string());
  EXPECT_EQ(d.request("GET", "/api/health").status, 200);
  Reply runs = d.request("GET", "/api/runs?capture=" + std::to_string(id));
  EXPECT_EQ(runs.j()["runs"].size(), 0u);
}

struct BadRequest {
  std::string name, method, path;
  json body;  // POST: the spec
  int status;
  std::string code, field;  // field empty: not checked
};

TEST_F(ServiceTest, BadRequestsNameTheField) {
  Daemon& d = *daemon_;
  auto with = [](const char* key, json value) {
    json s = tinySpec();
    s[key] = std::move(value);
    return s;
  };
  json manyResolutions = json::array();
  for (int i = 0; i < 60; ++i) manyResolutions.push_back({64 + i, 36});
  json huge = with("resolutions", manyResolutions);
  huge["cameras"] = "auto";  // 2 x 1 x 60 x 10 = 1200 samples
  std::string outside = (dir_ / "tally.db").string();

  const std::vector<BadRequest> table = {
      {"renderers not an array", "POST", "/api/captures", with("renderers", "forward"), 400, "invalid_field", "renderers"},
      {"renderer not a string", "POST", "/api/captures", with("renderers", {1}), 400, "invalid_field", "renderers[0]"},
      {"unknown renderer", "POST", "/api/captures", with("renderers", {"warp"}), 400, "invalid_field", "renderers[0]"},
      {"footprint block size not allowed", "POST", "/api/captures", with("footprint", 48), 400, "invalid_field", "footprint"},
      {"option value not allowed", "POST", "/api/captures",
       with("renderers", {{{"renderer", "visbuffer"}, {"options", {{"barycentrics", "half"}}}}}), 400, "invalid_field",
       "renderers[0].options.barycentrics"},
      {"option the renderer does not take", "POST", "/api/captures",
       with("renderers", {"forward", {{"renderer", "deferred"}, {"options", {{"uv_derivatives", "half"}}}}}), 400,
       "invalid_field", "renderers[1].options.uv_derivatives"},
      {"variant listed twice", "POST", "/api/captures",
       with("renderers", {"visbuffer", {{"renderer", "visbuffer"}, {"options", {{"barycentrics", "unorm16"}}}}}), 400,
       "invalid_field", "renderers[1]"},
      {"unknown scene", "POST", "/api/captures", with("scenes", {"nowhere"}), 400, "invalid_field", "scenes[0]"},
      {"zero width", "POST", "/api/captures", with("resolutions", {{0, 36}}), 400, "invalid_field", "resolutions[0][0]"},
      {"negative height", "POST", "/api/captures", with("resolutions", {{64, -1}}), 400, "invalid_field",
       "resolutions[0][1]"},
      {"huge width", "POST", "/api/captures", with("resolutions", {{100000, 36}}), 400, "invalid_field",
       "resolutions[0][0]"},
      {"beyond the server's pixel cap", "POST", "/api/captures", with("resolutions", {{7680, 4320}}), 400,
       "invalid_field", "resolutions[0]"},
      {"resolution not a pair", "POST", "/api/captures", with("resolutions", {"64x36"}), 400, "invalid_field", ""},
      {"huge matrix", "POST", "/api/captures", huge, 400, "invalid_field", "spec"},
      {"degenerate camera", "POST", "/api/captures",
       with("cameras", {{{"eye", {1, 2, 3}}, {"target", {1, 2, 3}}}}), 400, "invalid_field", "cameras[0].target"},
      {"frames 0", "POST", "/api/captures", with("frames", 0), 400, "invalid_field", "frames"},
      {"frames a string", "POST", "/api/captures", with("frames", "2"), 400, "invalid_field", "frames"},
      {"frames over the server's cap", "POST", "/api/captures", with("frames", 1000), 400, "invalid_field", "frames"},
      {"lights negative", "POST", "/api/captures", with("lights", -1), 400, "invalid_field", "lights"},
      {"unknown spec field", "POST", "/api/captures", with("color", "red"), 400, "invalid_field", "color"},
      {"gltf outside the scene folders", "POST", "/api/captures", with("scenes", {{{"gltf", outside}}}), 400,
       "invalid_field", "scenes[0].gltf"},
      {"gltf with ..", "POST", "/api/captures", with("scenes", {{{"gltf", "../tally.db"}}}), 400, "invalid_field",
       "scenes[0].gltf"},
      {"gltf symlink escape", "POST", "/api/captures", with("scenes", {{{"gltf", "escape.gltf"}}}), 400,
       "invalid_field", "scenes[0].gltf"},
      {"gltf missing", "POST", "/api/captures", with("scenes", {{{"gltf", "missing.gltf"}}}), 400, "invalid_field",
       "scenes[0].gltf"},
      {"runs limit 0", "GET", "/api/runs?limit=0", nullptr, 400, "invalid_field", "limit"},
      {"runs limit not a number", "GET", "/api/runs?limit=ten", nullptr, 400, "invalid_field", "limit"},
      {"runs limit too large", "GET", "/api/runs?limit=1001", nullptr, 400, "invalid_field", "limit"},
      {"runs bad cursor", "GET", "/api/runs?cursor=zzz", nullptr, 400, "invalid_field", "cursor"},
      {"runs bad width", "GET", "/api/runs?width=-3", nullptr, 400, "invalid_field", "width"},
      {"runs unknown parameter", "GET", "/api/runs?colour=red", nullptr, 400, "invalid_field", "colour"},
      {"captures bad status", "GET", "/api/captures?status=sleeping", nullptr, 400, "invalid_field", "status"},
      {"unknown run", "GET", "/api/runs/987654", nullptr, 404, "not_found", ""},
      {"run id not a number", "GET", "/api/runs/abc", nullptr, 400, "invalid_field", "id"},
      {"samples of an unknown run", "GET", "/api/runs/987654/samples", nullptr, 404, "not_found", ""},
      {"unknown sample", "GET", "/api/samples/987654", nullptr, 404, "not_found", ""},
      {"unknown screenshot", "GET", "/api/samples/987654/screenshot.png", nullptr, 404, "not_found", ""},
      {"unknown capture", "GET", "/api/captures/987654", nullptr, 404, "not_found", ""},
      {"cancel an unknown capture", "DELETE", "/api/captures/987654", nullptr, 404, "not_found", ""},
      {"compare one run", "GET", "/api/compare?runs=1", nullptr, 400, "invalid_field", "runs"},
      {"compare five runs", "GET", "/api/compare?runs=1,2,3,4,5", nullptr, 400, "invalid_field", "runs"},
      {"compare a run twice", "GET", "/api/compare?runs=1,1", nullptr, 400, "invalid_field", "runs"},
      {"compare without runs", "GET", "/api/compare", nullptr, 400, "invalid_field", "runs"},
      {"compare unknown runs", "GET", "/api/compare?runs=987654,987655", nullptr, 404, "not_found", ""},
      {"compare at confidence 1", "GET", "/api/compare?runs=1,2&confidence=1", nullptr, 400, "invalid_field", "confidence"},
      {"compare at confidence x", "GET", "/api/compare?runs=1,2&confidence=x", nullptr, 400, "invalid_field", "confidence"},
      {"compare with a negative threshold", "GET", "/api/compare?runs=1,2&threshold=-0.1", nullptr, 400, "invalid_field", "threshold"},
      {"compare with strata by pass", "GET", "/api/compare?runs=1,2&strata=passes", nullptr, 400, "invalid_field", "strata"},
      {"compare across_capture maybe", "GET", "/api/compare?runs=1,2&across_capture=maybe", nullptr, 400, "invalid_field", "across_capture"},
      {"export as xml", "GET", "/api/export?format=xml", nullptr, 400, "invalid_field", "format"},
      {"export runs not ids", "GET", "/api/export?runs=1,x", nullptr, 400, "invalid_field", "runs"},
  };
  ASSERT_GE(table.size(), 20u);
  for (const auto& c : table) {
    SCOPED_TRACE(c.name);
    Reply r = d.request(c.method, c.path, c.body.is_null() ? std::string() : c.body.dump());
    EXPECT_EQ(r.status, c.status) << r.body;
    json j = r.j();
    ASSERT_TRUE(j.is_object() && j.contains("error")) << r.body;
    EXPECT_EQ(j["error"]["code"], c.code) << r.body;
    EXPECT_TRUE(j["error"]["message"].is_string());
    if (!c.field.empty()) {
      EXPECT_EQ(j["error"].value("field", ""), c.field) << r.body;
    }
  }
  EXPECT_EQ(d.request("GET", "/api/health").status, 200);
  // Nothing was queued by the bad specs.
  json captures = d.request("GET", "/api/captures").j();
  for (const auto& job : captures["captures"]) {
    EXPECT_NE(job["spec"].value("frames", 0), 1000);
  }
}

TEST(ServiceRecovery, KillDuringAJobThenRestart) {
  fs::path dir = makeTempDir("tally-service-recovery");
  fs::path db = dir / "tally.db";
  int64_t id = 0;
  {
    Daemon d(dir, db);
    ASSERT_TRUE(d.start());
    Reply posted = d.request("POST", "/api/captures", longSpec().dump());
    ASSERT_EQ(posted.status, 202) << posted.body;
    id = posted.j()["id"];
    // Mid-capture: the child has reported progress.
    EXPECT_EQ(d.waitProgress(id).value("status", ""), "running");
    ASSERT_EQ(d.runningJobChildren().size(), 1u) << "the capture child should be running";
    EXPECT_EQ(d.stop(SIGKILL), 128 + SIGKILL);
    // The orphaned child goes with its daemon instead of rendering on to its deadline.
    EXPECT_TRUE(d.waitNoJobChildren()) << "a capture child outlived its daemon";
  }
  {
    // No daemon: the job is still marked running, nothing was lost.
    auto store = tally::store::Store::open(db.string(), {.readOnly = true});
    ASSERT_TRUE(store) << store.error();
    auto job = (*store)->jobs().get(id);
    ASSERT_TRUE(job && job->has_value());
    EXPECT_TRUE((*job)->status == tally::store::JobStatus::Running || (*job)->status == tally::store::JobStatus::Done);
  }
  Daemon d(dir, db);
  ASSERT_TRUE(d.start());
  json job = d.waitFinished(id);
  std::string status = job.value("status", "");
  ASSERT_TRUE(status == "done" || status == "failed") << job.dump();
  if (status == "failed") {
    EXPECT_TRUE(job["error"].is_string() && !job["error"].get<std::string>().empty());
  }
  EXPECT_GE(job["attempts"].get<int>(), 1);
  EXPECT_EQ(d.stop(SIGTERM), 0);

  auto store = tally::store::Store::open(db.string());
  ASSERT_TRUE(store) << store.error();
  auto integrity = (*store)->integrityCheck();
  ASSERT_TRUE(integrity);
  EXPECT_EQ(*integrity, "ok");
  // No half-written runs: every run belongs to a finished-done job and has its samples.
  auto runs = (*store)->runs().list({}, {});
  ASSERT_TRUE(runs);
  for (const auto& r : runs->runs) {
    EXPECT_EQ(r.jobId, id);
    EXPECT_EQ(r.sampleCount, kLongSpecSamplesPerRun);
  }
  EXPECT_EQ(runs->runs.size(), status == "done" ? size_t{kLongSpecRuns} : 0u);
  fs::remove_all(dir);
}

}  // namespace
