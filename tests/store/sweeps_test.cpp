// Sweeps in the store: ingestSweep reads back what went in, replaces a job's
// earlier sweep, refuses a malformed result naming the field (and stores
// nothing); listSweeps filters and pages like listRuns. And each run's
// counter_headroom, stored when the result has one.
#include "store_fixture.hpp"

namespace tally::store::testing {
namespace {

class Sweeps : public StoreTest {
 protected:
  int64_t newSweepJob() {
    auto job = store_->jobs().create({{"sweep", "depth-reconstruction"}});
    EXPECT_TRUE(job) << job.error();
    return job ? job->job.id : 0;
  }
  int64_t count(const char* table) { return scalar(*store_, std::string("SELECT COUNT(*) FROM ") + table); }
};

TEST_F(Sweeps, ReadsBackWhatWentIn) {
  int64_t jobId = newSweepJob();
  json result = sweepResult();
  auto id = store_->runs().ingestSweep(jobId, result);
  ASSERT_TRUE(id) << id.error();

  auto sweep = store_->runs().sweep(*id);
  ASSERT_TRUE(sweep && sweep->has_value()) << (sweep ? "" : sweep.error());
  const SweepRow& row = (*sweep)->row;
  EXPECT_EQ((*sweep)->result, result);  // the whole result, as it came
  EXPECT_EQ(row.id, *id);
  EXPECT_EQ(row.jobId, jobId);
  EXPECT_EQ(row.name, "depth-reconstruction");
  EXPECT_EQ(row.parameters, result["parameters"]);
  EXPECT_EQ(row.threshold, result["threshold"]);
  EXPECT_EQ(row.failsAt, result["fails_at"]);
  EXPECT_EQ(row.pointCount, 4);
  EXPECT_FALSE(row.createdAt.empty());
  EXPECT_EQ(row.device.name, result["device"]["name"]);
  EXPECT_EQ(row.device.driver, "Mesa 22.3.6");
  EXPECT_EQ(row.device.info, result["device"]);

  auto ids = store_->runs().jobSweepIds(jobId);
  ASSERT_TRUE(ids) << ids.error();
  EXPECT_EQ(*ids, std::vector<int64_t>{*id});
  auto none = store_->runs().jobSweepIds(newJob());
  ASSERT_TRUE(none);
  EXPECT_TRUE(none->empty());
  auto missing = store_->runs().sweep(*id + 1000);
  ASSERT_TRUE(missing);
  EXPECT_FALSE(missing->has_value());
}

TEST_F(Sweeps, NothingFailingIsStoredAsNull) {
  json result = sweepResult();
  result["fails_at"] = nullptr;
  auto id = store_->runs().ingestSweep(newSweepJob(), result);
  ASSERT_TRUE(id) << id.error();
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM sweeps WHERE fails_at IS NULL"), 1);
  auto sweep = store_->runs().sweep(*id);
  ASSERT_TRUE(sweep && sweep->has_value());
  EXPECT_TRUE((*sweep)->row.failsAt.is_null());
}

// Sweeps that vary a named choice (a renderer, a variant) beside a number,
// and state fails_at as one list of groups, are stored as they come.
TEST_F(Sweeps, NamedParametersAndAListOfGroups) {
  json result = sweepResult("material-edges");
  result["parameters"] = {"selection", "distance"};
  for (auto& p : result["points"]) p["selection"] = p["near"] == 1.0 ? "uniform" : "first_lane";
  result["plots"][0]["series"] = {"selection"};
  result["fails_at"] = {{{"selection", "first_lane"}, {"distance", 300.0}}, {{"selection", "uniform"}, {"distance", nullptr}}};
  auto id = store_->runs().ingestSweep(newSweepJob(), result);
  ASSERT_TRUE(id) << id.error();
  auto sweep = store_->runs().sweep(*id);
  ASSERT_TRUE(sweep && sweep->has_value());
  EXPECT_EQ((*sweep)->row.failsAt, result["fails_at"]);
  EXPECT_EQ((*sweep)->result, result);
}

TEST_F(Sweeps, IngestingTwiceKeepsOneSweepPerJob) {
  int64_t jobId = newSweepJob();
  json result = sweepResult();
  ASSERT_TRUE(store_->runs().ingestSweep(jobId, result));
  result["threshold"] = {{"relative", 1e-3}};
  auto again = store_->runs().ingestSweep(jobId, result);
  ASSERT_TRUE(again) << again.error();
  EXPECT_EQ(count("sweeps"), 1);
  EXPECT_EQ((*store_->runs().sweep(*again))->row.threshold, result["threshold"]);
  EXPECT_EQ(count("devices"), 1);  // the same device, not a second row
}

TEST_F(Sweeps, DeletingTheJobDeletesItsSweep) {
  int64_t jobId = newSweepJob();
  ASSERT_TRUE(store_->runs().ingestSweep(jobId, sweepResult()));
  ASSERT_EQ(count("sweeps"), 1);
  ASSERT_NO_THROW(store_->connection().exec("DELETE FROM jobs WHERE id = " + std::to_string(jobId)));
  EXPECT_EQ(count("sweeps"), 0);
}

TEST_F(Sweeps, BadInputNamesTheFieldAndStoresNothing) {
  int64_t jobId = newSweepJob();
  struct Case {
    const char* name;
    std::function<void(json&)> edit;
    const char* error;
  };
  const std::vector<Case> cases = {
      {"no name", [](json& r) { r.erase("sweep"); }, "sweep: missing"},
      {"no device", [](json& r) { r.erase("device"); }, "device: missing"},
      {"no parameters", [](json& r) { r["parameters"] = json::array(); }, "parameters: must name"},
      {"parameter not text", [](json& r) { r["parameters"][1] = 3; }, "parameters[1]: must be a non-empty string"},
      {"no threshold", [](json& r) { r.erase("threshold"); }, "threshold: missing"},
      {"no fails_at", [](json& r) { r.erase("fails_at"); }, "fails_at: missing"},
      {"fails_at a number", [](json& r) { r["fails_at"] = 3; }, "fails_at: must be an object, an array or null"},
      {"no points", [](json& r) { r["points"] = json::array(); }, "points: missing, empty"},
      {"point without a parameter", [](json& r) { r["points"][2].erase("near"); }, "points[2].near: missing"},
      {"parameter an object", [](json& r) { r["points"][1]["near"] = {{"m", 1}}; },
       "points[1].near: must be a number or a name"},
      {"plotted parameter not a number", [](json& r) { r["points"][1]["distance"] = "far"; },
       "points[1].distance: must be a number (named by plots[0])"},
      {"no plots", [](json& r) { r.erase("plots"); }, "plots: missing"},
      {"plot without y", [](json& r) { r["plots"][0].erase("y"); }, "plots[0].y: missing"},
      {"plot x_log not a flag", [](json& r) { r["plots"][0]["x_log"] = "yes"; }, "plots[0].x_log: must be true or false"},
      {"plot threshold not a number", [](json& r) { r["plots"][0]["threshold"] = "low"; },
       "plots[0].threshold: must be a number"},
      {"plot without threshold", [](json& r) { r["plots"][0].erase("threshold"); }, "plots[0].threshold: missing"},
      {"plot without series", [](json& r) { r["plots"][0].erase("series"); }, "plots[0].series: missing"},
      {"plot without y_label", [](json& r) { r["plots"][0].erase("y_label"); }, "plots[0].y_label: missing"},
      {"plotted field missing from a point", [](json& r) { r["points"][3]["error"].erase("max_relative"); },
       "points[3].error.max_relative: missing (named by plots[0])"},
      {"plotted field not a number", [](json& r) { r["points"][0]["error"]["max_relative"] = "x"; },
       "points[0].error.max_relative: must be a number (named by plots[0])"},
      {"series field missing",
       [](json& r) {
         r["plots"][0]["series"] = {"far_over_near"};
         r["points"][1].erase("far_over_near");
       },
       "points[1].far_over_near: missing (named by plots[0])"},
  };
  for (const auto& test : cases) {
    json result = sweepResult();
    test.edit(result);
    auto stored = store_->runs().ingestSweep(jobId, result);
    ASSERT_FALSE(stored) << test.name;
    EXPECT_NE(stored.error().find(test.error), std::string::npos) << test.name << ": " << stored.error();
    EXPECT_EQ(count("sweeps"), 0) << test.name;
    EXPECT_EQ(count("devices"), 0) << test.name;
  }
  auto unknownJob = store_->runs().ingestSweep(9999, sweepResult());
  ASSERT_FALSE(unknownJob);
  EXPECT_NE(unknownJob.error().find("job 9999 not found"), std::string::npos) << unknownJob.error();
}

TEST_F(Sweeps, FailedReingestKeepsThePreviousSweep) {
  int64_t jobId = newSweepJob();
  auto first = store_->runs().ingestSweep(jobId, sweepResult());
  ASSERT_TRUE(first);
  json bad = sweepResult();
  bad["points"][0].erase("distance");
  ASSERT_FALSE(store_->runs().ingestSweep(jobId, bad));
  auto kept = store_->runs().sweep(*first);
  ASSERT_TRUE(kept && kept->has_value());
  EXPECT_EQ((*kept)->result, sweepResult());
}

TEST_F(Sweeps, ListFiltersAndPages) {
  // Three sweeps: two names, two devices, newest first.
  std::vector<int64_t> jobs, ids;
  const std::vector<std::pair<std::string, std::string>> made = {
      {"depth-reconstruction", "llvmpipe (LLVM 15.0.6, 256 bits)"},
      {"id-capacity", "llvmpipe (LLVM 15.0.6, 256 bits)"},
      {"depth-reconstruction", "NVIDIA H200"}};
  for (const auto& [name, deviceName] : made) {
    jobs.push_back(newSweepJob());
    auto id = store_->runs().ingestSweep(jobs.back(), sweepResult(name, deviceName));
    ASSERT_TRUE(id) << id.error();
    ids.push_back(*id);
  }
  auto idsOf = [&](const SweepFilter& filter, const Page& page = {}) {
    auto listed = store_->runs().sweeps(filter, page);
    EXPECT_TRUE(listed) << listed.error();
    std::vector<int64_t> out;
    if (listed) {
      for (const auto& s : listed->sweeps) out.push_back(s.id);
    }
    return out;
  };
  EXPECT_EQ(idsOf({}), (std::vector<int64_t>{ids[2], ids[1], ids[0]}));
  EXPECT_EQ(idsOf({.name = "depth-reconstruction"}), (std::vector<int64_t>{ids[2], ids[0]}));
  EXPECT_EQ(idsOf({.name = "material-edges"}), std::vector<int64_t>{});
  EXPECT_EQ(idsOf({.deviceName = "NVIDIA H200"}), std::vector<int64_t>{ids[2]});
  auto listed = store_->runs().sweeps({.jobId = jobs[1]}, {});
  ASSERT_TRUE(listed);
  ASSERT_EQ(listed->sweeps.size(), 1u);
  EXPECT_EQ(listed->sweeps[0].name, "id-capacity");
  EXPECT_EQ(idsOf({.deviceId = listed->sweeps[0].device.id}), (std::vector<int64_t>{ids[1], ids[0]}));
  std::string created = listed->sweeps[0].createdAt;
  EXPECT_EQ(idsOf({.createdSince = created.substr(0, 10), .createdUntil = created.substr(0, 10)}).size(), 3u);
  EXPECT_EQ(idsOf({.createdUntil = "2000-01-01"}), std::vector<int64_t>{});

  // Pages of one: each page's cursor leads to the next, the last has none.
  std::vector<int64_t> walked;
  Page page{.limit = 1};
  for (int i = 0; i < 5; ++i) {
    auto one = store_->runs().sweeps({}, page);
    ASSERT_TRUE(one) << one.error();
    for (const auto& s : one->sweeps) walked.push_back(s.id);
    if (one->nextCursor.empty()) break;
    page.cursor = one->nextCursor;
  }
  EXPECT_EQ(walked, (std::vector<int64_t>{ids[2], ids[1], ids[0]}));
  EXPECT_FALSE(store_->runs().sweeps({}, {.limit = 0}));
  EXPECT_FALSE(store_->runs().sweeps({}, {.cursor = "nope"}));
}

TEST_F(Sweeps, RunsKeepTheirCounterHeadroom) {
  Capture c = realisticCapture();
  json headroom = {{"width", "int64"},
                   {"frames_accumulated", 1},
                   {"max_slot_count_per_frame", 23040000},
                   {"max_slot", "lighting/gbuffer.normal"},
                   {"wrap_factor_32bit", 4294967296.0 / 23040000},
                   {"wrap_factor", 18446744073709551616.0 / 23040000}};
  c.result["runs"][0]["counter_headroom"] = headroom;  // runs[1] has none, as results before it did
  int64_t jobId = newJob();
  ASSERT_EQ(ingest(jobId, c), 2);
  auto page = store_->runs().list({.jobId = jobId}, {});
  ASSERT_TRUE(page);
  ASSERT_EQ(page->runs.size(), 2u);
  auto forward = store_->runs().get(page->runs[1].id), deferred = store_->runs().get(page->runs[0].id);
  ASSERT_TRUE(forward && forward->has_value() && deferred && deferred->has_value());
  EXPECT_EQ((*forward)->row.renderer, "forward");
  EXPECT_EQ((*forward)->counterHeadroom, headroom);
  EXPECT_TRUE((*deferred)->counterHeadroom.is_null());

  c.result["runs"][1]["counter_headroom"] = "plenty";
  auto bad = store_->runs().ingestCapture(newJob(), c.result, c.screenshots);
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().find("runs[1].counter_headroom: must be an object"), std::string::npos) << bad.error();
}

}  // namespace
}  // namespace tally::store::testing
