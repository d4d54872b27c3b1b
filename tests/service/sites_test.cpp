// GET /api/samples/{id}/sites and /draws, /api/runs/{id}/shaders and
// /api/runs/{id}/shaders/{name}, the trace's top lines and `tally hotspots`,
// over a capture result with sites, draws and materials computed from its
// own lines (tests/store/sites_fixture.hpp), ingested into a database that a
// real `tallyd serve` answers from. Every answer matches /api/openapi.json;
// pages join into the whole; bad ids and parameters are clear 4xx; the
// CLI's rows are sorted by bytes and its shares sum to 100 % with the rest.
#include <signal.h>

#include <cmath>
#include <cstdlib>
#include <regex>

#include <gtest/gtest.h>

#include "../api/openapi_schema.hpp"
#include "../store/sites_fixture.hpp"
#include "../store/store_fixture.hpp"
#include "daemon.hpp"

namespace {
using namespace tally::service::test;
namespace st = tally::store::testing;

class SitesRoutes : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = makeTempDir("tally-sites-test");
    fs::path db = dir_ / "tally.db";
    result_ = new json(st::withSites(st::realisticCapture(3).result, {.sitesPerLine = 4, .drawsPerPass = 300}));
    {
      auto store = st::openStore(db.string());
      ASSERT_NE(store, nullptr);
      auto job = store->jobs().create({{"renderers", {"forward"}}});
      ASSERT_TRUE(job) << job.error();
      auto stored = store->runs().ingestCapture(job->job.id, *result_, st::realisticCapture(3).screenshots);
      ASSERT_TRUE(stored) << stored.error();
      // A capture without sites, as every capture before them.
      auto plain = store->jobs().create({{"renderers", {"forward"}}});
      ASSERT_TRUE(plain && store->runs().ingestCapture(plain->job.id, st::realisticCapture(4).result,
                                                       st::realisticCapture(4).screenshots));
    }
    daemon_ = new Daemon(dir_, db, {"--role", "api"});
    ASSERT_TRUE(daemon_->start()) << "tallyd serve did not start";
    document_ = new json(get("/api/openapi.json"));
    json runs = get("/api/runs?limit=10")["runs"];
    ASSERT_EQ(runs.size(), 4u);
    // Newest first: the plain capture's two runs, then forward (id 1) and deferred.
    run_ = runs[3]["id"];
    plainRun_ = runs[1]["id"];
    samples_ = new json(get("/api/runs/" + std::to_string(run_) + "/samples")["samples"]);
  }
  static void TearDownTestSuite() {
    if (daemon_) {
      EXPECT_EQ(daemon_->stop(SIGTERM), 0);
    }
    delete daemon_;
    delete document_;
    delete result_;
    delete samples_;
    daemon_ = nullptr;
    fs::remove_all(dir_);
  }
  // The body of GET path, checked against the documented schema of templ.
  static json get(const std::string& path, int status = 200, const std::string& templ = "") {
    Reply r = daemon_->request("GET", path);
    EXPECT_EQ(r.status, status) << path << ": " << r.body;
    json body = r.j();
    if (!templ.empty() && status == 200) {
      tally::testing::OpenApiChecker checker(*document_);
      for (const auto& problem : checker.check(body, checker.responseSchema(templ, "get", "200"))) {
        ADD_FAILURE() << path << ": " << problem;
      }
    }
    return body;
  }
  static std::string sample(size_t i) { return std::to_string((*samples_)[i]["id"].get<int64_t>()); }
  // The result's pass as ingested, by sample index (of the forward run) and pass name.
  static const json& pass(size_t s, const std::string& name) {
    for (const auto& p : (*result_)["runs"][0]["samples"][s]["passes"]) {
      if (p["name"] == name) return p;
    }
    static const json none;
    return none;
  }
  static std::string tally(const std::string& args, int* rc) {
    std::string out = (dir_ / "tally.out").string();
    std::string cmd = std::string(TALLY_PATH) + " --server " + daemon_->url() + " " + args + " > " + out + " 2>&1";
    int status = std::system(cmd.c_str());
    *rc = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return slurp(out);
  }

  static inline fs::path dir_;
  static inline Daemon* daemon_ = nullptr;
  static inline json *document_ = nullptr, *result_ = nullptr, *samples_ = nullptr;
  static inline int64_t run_ = 0, plainRun_ = 0;
};

TEST_F(SitesRoutes, SitesArePagedByBytesWithShares) {
  std::string base = "/api/samples/" + sample(1) + "/sites";
  json whole = get(base + "?limit=1000", 200, "/api/samples/{id}/sites");
  size_t expected = 0;
  for (const auto& p : (*result_)["runs"][0]["samples"][1]["passes"]) expected += p["sites"].size();
  ASSERT_EQ(whole["total"], expected);
  ASSERT_EQ(whole["sites"].size(), expected);
  EXPECT_TRUE(whole["next_offset"].is_null());
  double previous = INFINITY;
  for (const auto& site : whole["sites"]) {
    EXPECT_LE(site["bytes"].get<double>(), previous);
    previous = site["bytes"];
    double passBytes = 0;
    for (const auto& line : pass(1, site["pass"])["resources"]) passBytes += line["bytes"].get<double>();
    if (passBytes > 0) {
      EXPECT_NEAR(site["share"].get<double>(), site["bytes"].get<double>() / passBytes, 1e-12);
    }
  }
  // Pages of 5, followed by next_offset, join into the whole.
  json joined = json::array();
  std::string next = "0";
  while (true) {
    json page = get(base + "?limit=5&offset=" + next, 200, "/api/samples/{id}/sites");
    for (const auto& s : page["sites"]) joined.push_back(s);
    if (page["next_offset"].is_null()) break;
    next = std::to_string(page["next_offset"].get<int64_t>());
  }
  EXPECT_EQ(joined, whole["sites"]);
  // One pass, by line: the pass's lines sum to its counted lines.
  json lines = get(base + "?pass=opaque&by=line&limit=1000", 200, "/api/samples/{id}/sites");
  double sum = 0, counted = 0;
  for (const auto& line : lines["sites"]) {
    EXPECT_EQ(line["pass"], "opaque");
    sum += line["bytes"].get<double>();
  }
  for (const auto& line : pass(1, "opaque")["resources"]) {
    if (line["source"] == "counter") counted += line["bytes"].get<double>();
  }
  EXPECT_NEAR(sum, counted, 1e-9 * counted);
}

TEST_F(SitesRoutes, DrawsAndMaterials) {
  std::string base = "/api/samples/" + sample(0) + "/draws";
  json draws = get(base + "?pass=depth&limit=1000", 200, "/api/samples/{id}/draws");
  EXPECT_EQ(draws["draws"].size(), 256u);
  EXPECT_EQ(draws["total"], 256);
  ASSERT_EQ(draws["rest"].size(), 1u);
  EXPECT_EQ(draws["rest"][0]["draws"], 300 - 256);
  double sum = draws["rest"][0]["bytes"];
  for (const auto& d : draws["draws"]) sum += d["bytes"].get<double>();
  double lines = 0;
  for (const auto& line : pass(0, "depth")["resources"]) lines += line["bytes"].get<double>();
  EXPECT_NEAR(sum, lines, 1e-9 * std::max(1.0, lines));
  json materials = get(base + "?by=material", 200, "/api/samples/{id}/draws");
  EXPECT_TRUE(materials["draws"].empty());
  EXPECT_EQ(materials["materials"].size(), 4u * 5u);  // 4 passes x 5 materials
  double previous = INFINITY;
  for (const auto& m : materials["materials"]) {
    EXPECT_LE(m["bytes"].get<double>(), previous);
    previous = m["bytes"];
  }
}

TEST_F(SitesRoutes, ShadersByName) {
  std::string base = "/api/runs/" + std::to_string(run_) + "/shaders";
  json list = get(base, 200, "/api/runs/{id}/shaders");
  ASSERT_EQ(list["shaders"].size(), 4u);
  for (const auto& s : list["shaders"]) {
    json one = get(base + "/" + s["name"].get<std::string>(), 200, "/api/runs/{id}/shaders/{name}");
    EXPECT_EQ(one["source"], (*result_)["runs"][0]["shader_sources"][s["name"].get<std::string>()]);
    EXPECT_EQ(one["hash"], s["hash"]);
  }
  EXPECT_TRUE(get("/api/runs/" + std::to_string(plainRun_) + "/shaders", 200, "/api/runs/{id}/shaders")["shaders"].empty());
  EXPECT_EQ(get(base + "/nothing.glsl", 404)["error"]["message"],
            "run " + std::to_string(run_) + " has no shader source \"nothing.glsl\"");
  EXPECT_EQ(get("/api/runs/999999/shaders", 404)["error"]["message"], "no run 999999");
}

TEST_F(SitesRoutes, BadIdsAndParameters) {
  std::string base = "/api/samples/" + sample(0);
  EXPECT_EQ(get("/api/samples/999999/sites", 404)["error"]["message"], "no sample 999999");
  EXPECT_EQ(get("/api/samples/abc/draws", 400)["error"]["field"], "id");
  EXPECT_EQ(get(base + "/sites?by=word", 400)["error"]["message"], "by: must be site or line");
  EXPECT_EQ(get(base + "/draws?by=line", 400)["error"]["message"], "by: must be draw or material");
  EXPECT_EQ(get(base + "/sites?limit=0", 400)["error"]["field"], "limit");
  EXPECT_EQ(get(base + "/draws?offset=-1", 400)["error"]["field"], "offset");
  EXPECT_EQ(get(base + "/sites?cursor=x", 400)["error"]["field"], "cursor");
  EXPECT_EQ(get(base + "/sites?pass=nowhere", 404)["error"]["message"],
            "sample " + sample(0) + " has no pass \"nowhere\" (its passes: depth, opaque, skybox, post)");
  // A sample without sites: empty, not an error.
  std::string plain = std::to_string(get("/api/runs/" + std::to_string(plainRun_) + "/samples")["samples"][0]["id"].get<int64_t>());
  json empty = get("/api/samples/" + plain + "/sites", 200, "/api/samples/{id}/sites");
  EXPECT_EQ(empty["total"], 0);
  EXPECT_EQ(empty["passes"].size(), 4u);
}

TEST_F(SitesRoutes, TraceCarriesTopLinesPerPass) {
  json trace = get("/api/samples/" + sample(1) + "/trace", 200, "/api/samples/{id}/trace");
  json lines = get("/api/samples/" + sample(1) + "/sites?by=line&pass=post&limit=5");
  int seen = 0;
  for (const auto& event : trace["traceEvents"]) {
    if (event["cat"] != "pass" || event["name"] != "post") continue;
    ASSERT_TRUE(event["args"].contains("top_lines")) << event.dump();
    const json& top = event["args"]["top_lines"];
    ASSERT_EQ(top.size(), lines["sites"].size());
    for (size_t i = 0; i < top.size(); ++i) {
      EXPECT_EQ(top[i]["line"], lines["sites"][i]["line"]);
      EXPECT_EQ(top[i]["bytes"], lines["sites"][i]["bytes"]);
    }
    ++seen;
  }
  EXPECT_GT(seen, 0);
  EXPECT_TRUE(trace["metadata"].contains("top_lines"));
}

// The CLI's rows per pass: sorted by bytes, shares that sum (rest included) to 100 %.
TEST_F(SitesRoutes, HotspotsSortedWithSharesSummingToWhole) {
  for (std::string by : {"line", "draw", "material"}) {
    int rc = 0;
    std::string text = tally("--json hotspots " + std::to_string(run_) + " --sample " + sample(1) + " --by " + by + " --top 3", &rc);
    ASSERT_EQ(rc, 0) << text;
    json out = json::parse(text);
    ASSERT_EQ(out["passes"].size(), 4u) << by;
    for (const auto& p : out["passes"]) {
      double shares = p["rest"]["share"].get<double>() + p["outside"]["share"].get<double>();
      double previous = INFINITY;
      EXPECT_LE(p["top"].size(), 3u);
      for (const auto& row : p["top"]) {
        EXPECT_LE(row["bytes"].get<double>(), previous);
        previous = row["bytes"];
        shares += row["share"].get<double>();
      }
      EXPECT_NEAR(shares, 1.0, 1e-9) << by << " " << p["pass"];
    }
  }
  int rc = 0;
  std::string text = tally("hotspots " + std::to_string(run_) + " --pass opaque --top 2", &rc);
  ASSERT_EQ(rc, 0) << text;
  EXPECT_NE(text.find("pass opaque"), std::string::npos) << text;
  EXPECT_NE(text.find("rest ("), std::string::npos) << text;
  EXPECT_NE(text.find("(lines without sites)"), std::string::npos) << text;
  EXPECT_TRUE(std::regex_search(text, std::regex("total\\s*$|100\\.0%\\s+total"))) << text;
  EXPECT_EQ(text.find("pass depth"), std::string::npos) << text;
  // Without sites, and a sample of another run: exit 1 with the reason.
  text = tally("hotspots " + std::to_string(plainRun_), &rc);
  EXPECT_EQ(rc, 1);
  EXPECT_NE(text.find("has no sites"), std::string::npos) << text;
  text = tally("hotspots " + std::to_string(run_) + " --sample 999999", &rc);
  EXPECT_EQ(rc, 1);
  EXPECT_NE(text.find("sample 999999 is not a sample of run " + std::to_string(run_)), std::string::npos) << text;
  text = tally("hotspots " + std::to_string(run_) + " --pass nowhere", &rc);
  EXPECT_EQ(rc, 1);
  EXPECT_NE(text.find("has no pass \"nowhere\""), std::string::npos) << text;
}

}  // namespace
