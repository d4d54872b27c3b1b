// Stability sweeps through a real `tallyd serve` on lavapipe: POST
// /api/captures takes a sweep spec (bad ones are 400s naming the field), the
// job runs the sweep and stores it, and GET /api/sweeps, /api/sweeps/{id} and
// /api/captures/{id} serve what the database holds (read here with this
// test's own SQL). Also each run's counter_headroom in GET /api/runs/{id}.
#include <sqlite3.h>

#include <cmath>
#include <map>
#include <vector>

#include <gtest/gtest.h>

#include "daemon.hpp"

namespace tally::service::test {
namespace {

// Rows of a query on a read-only connection beside the daemon's: integers,
// reals, text (JSON columns parsed when `jsonColumns` names them) and null.
json query(const fs::path& db, const std::string& sql, const std::vector<int64_t>& params = {},
           const std::vector<int>& jsonColumns = {}) {
  sqlite3* handle = nullptr;
  json out = json::array();
  if (sqlite3_open_v2(db.c_str(), &handle, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
    ADD_FAILURE() << "cannot open " << db;
    sqlite3_close(handle);
    return out;
  }
  sqlite3_busy_timeout(handle, 5000);
  sqlite3_stmt* stmt = nullptr;
  if (sqlite3_prepare_v2(handle, sql.c_str(), -1, &stmt, nullptr) != SQLITE_OK) {
    ADD_FAILURE() << sqlite3_errmsg(handle) << " in " << sql;
  } else {
    for (size_t i = 0; i < params.size(); ++i) sqlite3_bind_int64(stmt, static_cast<int>(i) + 1, params[i]);
    while (sqlite3_step(stmt) == SQLITE_ROW) {
      json row = json::array();
      for (int c = 0; c < sqlite3_column_count(stmt); ++c) {
        bool asJson = std::find(jsonColumns.begin(), jsonColumns.end(), c) != jsonColumns.end();
        switch (sqlite3_column_type(stmt, c)) {
          case SQLITE_INTEGER: row.push_back(sqlite3_column_int64(stmt, c)); break;
          case SQLITE_FLOAT: row.push_back(sqlite3_column_double(stmt, c)); break;
          case SQLITE_NULL: row.push_back(nullptr); break;
          default: {
            std::string text = reinterpret_cast<const char*>(sqlite3_column_text(stmt, c));
            row.push_back(asJson ? json::parse(text) : json(text));
          }
        }
      }
      out.push_back(row);
    }
  }
  sqlite3_finalize(stmt);
  sqlite3_close(handle);
  return out;
}

// The smallest depth sweep with a failure and a hold: 1 near x 1 far x 2
// distances at 32x18. Measured max relative errors on lavapipe: 6.5e-5 at
// 3 m and 4.8e-3 at 300 m, an order of magnitude either side of 1e-3.
json tinySweep(double threshold = 1e-3) {
  return {{"sweep", "depth-reconstruction"}, {"near", {0.01}}, {"far", {1000}}, {"distances", {3, 300}},
          {"resolution", {32, 18}}, {"threshold", {{"relative", threshold}}}};
}

class Sweeps : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = makeTempDir("tally-sweeps-test");
    daemon_ = new Daemon(dir_, db());
    ASSERT_TRUE(daemon_->start()) << "tallyd serve did not start";
  }
  static void TearDownTestSuite() {
    delete daemon_;
    daemon_ = nullptr;
    fs::remove_all(dir_);
  }
  static fs::path db() { return dir_ / "tally.db"; }

  // Posts a spec and waits for it; the finished job.
  static json run(const json& spec) {
    Reply posted = daemon_->request("POST", "/api/captures", spec.dump());
    EXPECT_EQ(posted.status, 202) << posted.body;
    if (posted.status != 202) return {};
    json job = daemon_->waitFinished(posted.j()["id"]);
    EXPECT_EQ(job.value("status", ""), "done") << job.dump();
    return job;
  }
  static json get(const std::string& path) {
    Reply r = daemon_->request("GET", path);
    EXPECT_EQ(r.status, 200) << path << ": " << r.body;
    return r.j();
  }
  static std::vector<int64_t> ids(const json& list) {
    std::vector<int64_t> out;
    for (const auto& s : list["sweeps"]) out.push_back(s["id"]);
    return out;
  }

  static inline fs::path dir_;
  static inline Daemon* daemon_ = nullptr;
};

TEST_F(Sweeps, ASweepJobIsStoredAndServedAsStored) {
  json job = run(tinySweep());
  ASSERT_FALSE(job.is_null());
  int64_t jobId = job["id"];
  json rows = query(db(),
                    "SELECT s.id, s.name, s.parameters, s.threshold, s.fails_at, s.point_count, s.result, "
                    "s.created_at, d.id, d.name FROM sweeps s JOIN devices d ON d.id = s.device_id WHERE s.job_id = ?1",
                    {jobId}, {2, 3, 4, 6});
  ASSERT_EQ(rows.size(), 1u) << rows.dump();
  const json& row = rows[0];
  int64_t id = row[0];
  EXPECT_EQ(job["sweeps"], json::array({id}));
  EXPECT_EQ(query(db(), "SELECT COUNT(*) FROM runs WHERE job_id = ?1", {jobId})[0][0], 0);

  json sweep = get("/api/sweeps/" + std::to_string(id));
  EXPECT_EQ(sweep["id"], id);
  EXPECT_EQ(sweep["job_id"], jobId);
  EXPECT_EQ(sweep["name"], row[1]);
  EXPECT_EQ(sweep["parameters"], row[2]);
  EXPECT_EQ(sweep["threshold"], row[3]);
  EXPECT_EQ(sweep["fails_at"], row[4]);
  EXPECT_EQ(sweep["point_count"], row[5]);
  EXPECT_EQ(sweep["result"], row[6]);
  EXPECT_EQ(sweep["created_at"], row[7]);
  EXPECT_EQ(sweep["device"]["id"], row[8]);
  EXPECT_EQ(sweep["device"]["name"], row[9]);

  // What the sweep measured, as the spec asked: the stored result is the sweep's.
  const json& result = sweep["result"];
  EXPECT_EQ(result["sweep"], "depth-reconstruction");
  EXPECT_EQ(result["spec"], tinySweep());
  EXPECT_EQ(result["threshold"], json({{"relative", 1e-3}}));
  ASSERT_EQ(result["points"].size(), 2u);
  EXPECT_EQ(sweep["point_count"], 2);
  EXPECT_FALSE(result["plots"].empty());
  // fails_at.distance, recomputed from the points: the smallest distance whose
  // max relative error reaches the threshold (one group: near 0.01, far 1000).
  json smallest = nullptr;
  for (const auto& p : result["points"]) {
    if (p["error"]["max_relative"].get<double>() >= 1e-3 &&
        (smallest.is_null() || p["distance"].get<double>() < smallest.get<double>())) {
      smallest = p["distance"];
    }
  }
  ASSERT_FALSE(smallest.is_null()) << "the 300 m point must fail: " << result["points"].dump();
  EXPECT_EQ(sweep["fails_at"]["distance"], json::array({{{"near", 0.01}, {"far", 1000.0}, {"distance", smallest}}}));

  // The list shows the same, without the result.
  json list = get("/api/sweeps?capture=" + std::to_string(jobId));
  ASSERT_EQ(list["sweeps"].size(), 1u);
  json listed = sweep;
  listed.erase("result");
  EXPECT_EQ(list["sweeps"][0], listed);
  EXPECT_TRUE(list["next_cursor"].is_null());
}

TEST_F(Sweeps, ListFiltersAndPages) {
  json failing = run(tinySweep());
  json holding = run(tinySweep(0.5));  // no point reaches half the distance
  ASSERT_FALSE(failing.is_null() || holding.is_null());
  int64_t a = failing["sweeps"][0], b = holding["sweeps"][0];
  json all = query(db(), "SELECT id FROM sweeps ORDER BY id DESC");
  std::vector<int64_t> expected;
  for (const auto& r : all) expected.push_back(r[0]);
  EXPECT_EQ(ids(get("/api/sweeps")), expected);
  EXPECT_EQ(expected.front(), b);

  json held = get("/api/sweeps/" + std::to_string(b));
  EXPECT_TRUE(held["fails_at"].is_null());
  EXPECT_EQ(query(db(), "SELECT fails_at IS NULL FROM sweeps WHERE id = ?1", {b})[0][0], 1);

  EXPECT_EQ(ids(get("/api/sweeps?name=depth-reconstruction")), expected);
  EXPECT_EQ(ids(get("/api/sweeps?name=material-edges")), std::vector<int64_t>{});
  json device = query(db(), "SELECT id, name FROM devices WHERE id = (SELECT device_id FROM sweeps WHERE id = ?1)", {a})[0];
  EXPECT_EQ(ids(get("/api/sweeps?device=" + std::to_string(device[0].get<int64_t>()))), expected);
  httplib::Params name = {{"device", device[1].get<std::string>()}};
  EXPECT_EQ(ids(get("/api/sweeps?" + httplib::detail::params_to_query_str(name))), expected);
  EXPECT_EQ(ids(get("/api/sweeps?capture=" + std::to_string(failing["id"].get<int64_t>()))), std::vector<int64_t>{a});
  std::string day = held["created_at"].get<std::string>().substr(0, 10);
  EXPECT_EQ(ids(get("/api/sweeps?since=" + day + "&until=" + day)), expected);
  EXPECT_EQ(ids(get("/api/sweeps?until=2000-01-01")), std::vector<int64_t>{});

  // A page at a time: the cursors walk the whole list once.
  std::vector<int64_t> walked;
  std::string path = "/api/sweeps?limit=1";
  for (size_t i = 0; i <= expected.size(); ++i) {
    json page = get(path);
    ASSERT_LE(page["sweeps"].size(), 1u);
    for (int64_t id : ids(page)) walked.push_back(id);
    if (page["next_cursor"].is_null()) break;
    path = "/api/sweeps?limit=1&cursor=" + page["next_cursor"].get<std::string>();
  }
  EXPECT_EQ(walked, expected);
}

TEST_F(Sweeps, BadSweepSpecsAreRefusedNamingTheField) {
  size_t before = get("/api/captures?limit=1000")["captures"].size();
  struct Case {
    std::function<void(json&)> edit;
    std::string field, words;
  };
  const std::vector<Case> cases = {
      {[](json& s) { s["sweep"] = "nope"; }, "sweep", "unknown sweep 'nope'"},
      {[](json& s) { s["sweep"] = 3; }, "sweep", "must be a sweep name"},
      {[](json& s) { s.erase("near"); }, "near", "required"},
      {[](json& s) { s["colour"] = "red"; }, "colour", "unknown field"},
      {[](json& s) { s["threshold"] = {{"relative", 2}}; }, "threshold.relative", "must be a number in (0, 1)"},
      {[](json& s) { s["renderer"] = "forward"; }, "renderer", "does not reconstruct position from depth"},
      {[](json& s) { s["distances"] = {3, 2000}; }, "distances[1]", "not all between near"},
  };
  for (const auto& c : cases) {
    json spec = tinySweep();
    c.edit(spec);
    Reply r = daemon_->request("POST", "/api/captures", spec.dump());
    EXPECT_EQ(r.status, 400) << spec.dump() << ": " << r.body;
    json error = r.j()["error"];
    EXPECT_EQ(error["code"], "invalid_field") << r.body;
    EXPECT_EQ(error["field"], c.field) << r.body;
    EXPECT_NE(error["message"].get<std::string>().find(c.words), std::string::npos) << r.body;
  }
  EXPECT_EQ(get("/api/captures?limit=1000")["captures"].size(), before) << "a refused spec stores no job";
}

TEST_F(Sweeps, BadRequestsForSweeps) {
  Reply missing = daemon_->request("GET", "/api/sweeps/987654");
  EXPECT_EQ(missing.status, 404);
  EXPECT_EQ(missing.j()["error"]["message"], "no sweep 987654");
  for (const auto& [path, field] : std::vector<std::pair<std::string, std::string>>{
           {"/api/sweeps/abc", "id"},
           {"/api/sweeps?colour=red", "colour"},
           {"/api/sweeps?renderer=deferred", "renderer"},  // a runs filter, not a sweeps one
           {"/api/sweeps?limit=0", "limit"},
           {"/api/sweeps?cursor=zz", "cursor"},
           {"/api/sweeps?since=yesterday", "since"},
           {"/api/sweeps?capture=-1", "capture"}}) {
    Reply r = daemon_->request("GET", path);
    EXPECT_EQ(r.status, 400) << path << ": " << r.body;
    EXPECT_EQ(r.j()["error"]["field"], field) << path << ": " << r.body;
  }
}

TEST_F(Sweeps, RunsShowTheirCounterHeadroom) {
  json job = run(tinySpec());
  ASSERT_FALSE(job.is_null());
  EXPECT_EQ(job["sweeps"], json::array());  // a capture matrix stores runs, no sweep
  json rows = query(db(), "SELECT id, counter_headroom FROM runs WHERE job_id = ?1 ORDER BY id",
                    {job["id"].get<int64_t>()}, {1});
  ASSERT_EQ(rows.size(), 2u);
  for (const auto& row : rows) {
    json run = get("/api/runs/" + std::to_string(row[0].get<int64_t>()));
    const json& h = run["counter_headroom"];
    EXPECT_EQ(h, row[1]);
    ASSERT_TRUE(h.is_object()) << run.dump();
    // The wrap factors are 2^bits over what one slot holds before a readback.
    double held = h["max_slot_count_per_frame"].get<double>() * h["frames_accumulated"].get<double>();
    ASSERT_GT(held, 0);
    EXPECT_DOUBLE_EQ(h["wrap_factor_32bit"].get<double>(), std::ldexp(1.0, 32) / held);
    EXPECT_DOUBLE_EQ(h["wrap_factor"].get<double>(), std::ldexp(1.0, 64) / held);
    EXPECT_NE(h["max_slot"].get<std::string>().find('/'), std::string::npos);  // "pass/resource"
  }
}

}  // namespace
}  // namespace tally::service::test
