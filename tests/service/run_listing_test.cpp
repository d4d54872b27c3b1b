// GET /api/runs, /api/runs/{id} and /api/compare from the
// summary and frame time stored at ingest (migration 0013) are the same JSON
// as from the samples, the way they were computed before 0013 and still are
// for runs stored before it: the stored frame time against the one computed
// from the samples (the readers' fallback), and the stored aggregates against
// the old query's over the same samples.
#include <gtest/gtest.h>

#include <set>

#include "../store/store_fixture.hpp"
#include "api/router.hpp"
#include "service/service.hpp"

namespace {
namespace st = tally::store::testing;
using nlohmann::json;
using tally::api::Request;
using tally::api::Router;

class RunListing : public ::testing::Test {
 protected:
  void SetUp() override {
    store_ = st::openStore(db_.path());
    ASSERT_NE(store_, nullptr);
    for (double shift : {0.0, 2.0, 3.0}) {
      auto job = store_->jobs().create({{"renderers", {"forward"}}});
      ASSERT_TRUE(job) << job.error();
      st::Capture c = st::mixedCapture(shift);
      auto stored = store_->runs().ingestCapture(job->job.id, c.result, c.screenshots);
      ASSERT_TRUE(stored) << stored.error();
    }
    context_.writer = store_.get();
    context_.dbPath = db_.path();
    tally::service::addServiceRoutes(router_, context_);
  }
  json get(const std::string& path, std::map<std::string, std::string> query = {}) {
    Request req;
    req.method = "GET";
    req.path = path;
    req.query = std::move(query);
    auto response = router_.dispatch(req);
    EXPECT_EQ(response.status, 200) << path << ": " << response.json.dump();
    // The listing answers its JSON as text (application/json), the others a json value.
    if (response.isRaw()) {
      EXPECT_EQ(response.contentType, "application/json") << path;
      return json::parse(response.bytes);
    }
    return response.json;
  }
  // Every read that shows a run row with its frame time.
  json reads() {
    json out;
    out["list"] = get("/api/runs", {{"limit", "50"}});
    out["page"] = get("/api/runs", {{"limit", "4"}});
    std::vector<std::string> withSamples;
    for (const auto& r : out["list"]["runs"]) {
      std::string id = std::to_string(r["id"].get<int64_t>());
      out["run " + id] = get("/api/runs/" + id);
      if (r["sample_count"].get<int>() > 0) withSamples.push_back(id);
    }
    // Two runs with samples, as the first read found them.
    if (compareIds_.empty() && withSamples.size() >= 2) compareIds_ = withSamples[0] + "," + withSamples[1];
    out["compare"] = get("/api/compare", {{"runs", compareIds_}});
    return out;
  }

  st::TempDb db_;
  std::unique_ptr<tally::store::Store> store_;
  tally::service::ServiceContext context_;
  Router router_;
  std::string compareIds_;
};

TEST_F(RunListing, SameJsonFromTheStoredSummaryAsFromTheSamples) {
  json stored = reads();
  ASSERT_EQ(stored["list"]["runs"].size(), 9u);
  ASSERT_EQ(stored["page"]["runs"].size(), 4u);
  EXPECT_FALSE(stored["page"]["next_cursor"].is_null());
  std::set<std::string> sources;
  for (const auto& r : stored["list"]["runs"]) sources.insert(r["frame_ms_median_source"].get<std::string>());
  EXPECT_EQ(sources, (std::set<std::string>{"frames", "samples", "none"}));

  // A page of runs with and without a stored frame time (some stored before
  // 0013): the same JSON, the missing ones computed from their samples.
  auto& db = store_->connection();
  db.exec(
      "UPDATE runs SET frame_time_median = NULL, frame_time_lower = NULL, frame_time_upper = NULL, "
      "frame_time_frames = NULL, frame_time_source = NULL WHERE id % 2 = 0");
  EXPECT_GT(st::scalar(*store_, "SELECT COUNT(*) FROM runs WHERE frame_time_source IS NULL"), 0);
  EXPECT_GT(st::scalar(*store_, "SELECT COUNT(*) FROM runs WHERE frame_time_source IS NOT NULL"), 0);
  json mixed = reads();
  EXPECT_EQ(mixed, stored);

  // As runs stored before 0013: the frame time from the samples, and the
  // aggregates as the old query computed them (here over the same samples,
  // from columns zeroed first so that nothing stored survives).
  db.exec(
      "UPDATE runs SET frame_time_median = NULL, frame_time_lower = NULL, frame_time_upper = NULL, "
      "frame_time_frames = NULL, frame_time_source = NULL, sample_count = 0, mean_frame_ms = NULL, "
      "mean_bytes = NULL, mean_frame_ms_instrumented = NULL, mean_overhead_ratio = NULL, image_compared = 0, "
      "image_identical = 0, mean_psnr = NULL, min_psnr = NULL, mean_footprint_bytes = NULL, "
      "mean_footprint_requested_bytes = NULL");
  json zeroed = reads();
  EXPECT_NE(zeroed["list"], stored["list"]);  // the listing reads the columns
  db.exec(
      "UPDATE runs SET (sample_count, mean_frame_ms, mean_bytes, mean_frame_ms_instrumented, mean_overhead_ratio, "
      "image_compared, image_identical, mean_psnr, min_psnr, mean_footprint_bytes, mean_footprint_requested_bytes) "
      "= (SELECT COUNT(s.id), AVG(s.frame_ms), AVG(s.bytes), AVG(s.frame_ms_instrumented), AVG(s.overhead_ratio), "
      "COUNT(s.image_against), COUNT(CASE WHEN s.image_identical = 1 THEN 1 END), AVG(s.psnr), MIN(s.psnr), "
      "AVG(s.footprint_bytes), AVG(s.footprint_requested_bytes) FROM samples s WHERE s.run_id = runs.id)");
  EXPECT_EQ(st::scalar(*store_, "SELECT COUNT(*) FROM runs WHERE frame_time_source IS NULL"), 9);
  json computed = reads();
  EXPECT_EQ(computed, stored) << "stored:\n" << stored.dump(1) << "\ncomputed:\n" << computed.dump(1);
}

}  // namespace
