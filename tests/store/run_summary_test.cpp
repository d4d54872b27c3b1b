// Each run's summary over its samples and its frame time on the run's row
// (migration 0013): written at ingest, backfilled by the migration, equal to
// what the listing computed from the samples before (the old query, kept
// here), on both engines.
#include <sqlite3.h>

#include <cmath>
#include <cstdio>
#include <set>

#include "store/frame_time.hpp"
#include "store_fixture.hpp"

namespace tally::store::testing {
namespace {

// The eleven aggregates the listing computed per run before 0013
// (detail::runSelect at schema 12): COUNT and AVG over the run's samples.
struct Aggregates {
  int64_t sampleCount = 0, imageCompared = 0, imageIdentical = 0;
  std::optional<double> meanFrameMs, meanBytes, meanFrameMsInstrumented, meanOverheadRatio, meanPsnr, minPsnr,
      meanFootprintBytes, meanFootprintRequestedBytes;
  bool operator==(const Aggregates&) const = default;
};

std::ostream& operator<<(std::ostream& out, const Aggregates& a) {
  auto opt = [](const std::optional<double>& v) {
    if (!v) return std::string("null");
    char text[32];
    std::snprintf(text, sizeof text, "%.17g", *v);
    return std::string(text);
  };
  return out << "{n " << a.sampleCount << ", frame " << opt(a.meanFrameMs) << ", bytes " << opt(a.meanBytes)
             << ", instrumented " << opt(a.meanFrameMsInstrumented) << ", overhead " << opt(a.meanOverheadRatio)
             << ", compared " << a.imageCompared << ", identical " << a.imageIdentical << ", psnr "
             << opt(a.meanPsnr) << ", min psnr " << opt(a.minPsnr) << ", footprint " << opt(a.meanFootprintBytes)
             << ", requested " << opt(a.meanFootprintRequestedBytes) << "}";
}

constexpr const char* kOldAggregates =
    "COUNT(s.id), AVG(s.frame_ms), AVG(s.bytes), AVG(s.frame_ms_instrumented), AVG(s.overhead_ratio), "
    "COUNT(s.image_against), COUNT(CASE WHEN s.image_identical = 1 THEN 1 END), AVG(s.psnr), MIN(s.psnr), "
    "AVG(s.footprint_bytes), AVG(s.footprint_requested_bytes)";

Aggregates readAggregates(RowReader& row) {
  Aggregates a;
  a.sampleCount = row.getInt();
  a.meanFrameMs = row.getOptDouble();
  a.meanBytes = row.getOptDouble();
  a.meanFrameMsInstrumented = row.getOptDouble();
  a.meanOverheadRatio = row.getOptDouble();
  a.imageCompared = row.getInt();
  a.imageIdentical = row.getInt();
  a.meanPsnr = row.getOptDouble();
  a.minPsnr = row.getOptDouble();
  a.meanFootprintBytes = row.getOptDouble();
  a.meanFootprintRequestedBytes = row.getOptDouble();
  return a;
}

// By run id, as the old query computed them: PostgreSQL in a LATERAL
// subquery per run, SQLite by grouping a join.
std::map<int64_t, Aggregates> oldAggregates(Connection& db) {
  std::string sql = db.engine() == Engine::Postgres
                        ? std::string("SELECT r.id, a.* FROM runs r CROSS JOIN LATERAL (SELECT ") + kOldAggregates +
                              " FROM samples s WHERE s.run_id = r.id) a ORDER BY r.id"
                        : std::string("SELECT r.id, ") + kOldAggregates +
                              " FROM runs r LEFT JOIN samples s ON s.run_id = r.id GROUP BY r.id ORDER BY r.id";
  Statement query(db, sql);
  std::map<int64_t, Aggregates> out;
  while (query.step()) {
    RowReader row(query);
    int64_t id = row.getInt();
    out[id] = readAggregates(row);
    row.end();
  }
  return out;
}

// The runs' stored columns (0013), by run id.
std::map<int64_t, Aggregates> storedAggregates(Connection& db) {
  Statement query(db,
                  "SELECT id, sample_count, mean_frame_ms, mean_bytes, mean_frame_ms_instrumented, "
                  "mean_overhead_ratio, image_compared, image_identical, mean_psnr, min_psnr, mean_footprint_bytes, "
                  "mean_footprint_requested_bytes FROM runs ORDER BY id");
  std::map<int64_t, Aggregates> out;
  while (query.step()) {
    RowReader row(query);
    int64_t id = row.getInt();
    out[id] = readAggregates(row);
    row.end();
  }
  return out;
}

Aggregates aggregatesOf(const RunRow& r) {
  return {r.sampleCount,       r.imageCompared,           r.imageIdentical,    r.meanFrameMs,
          r.meanBytes,         r.meanFrameMsInstrumented, r.meanOverheadRatio, r.meanPsnr,
          r.minPsnr,           r.meanFootprintBytes,      r.meanFootprintRequestedBytes};
}

void expectSameFrameTime(const RunFrameTime& got, const RunFrameTime& want) {
  EXPECT_EQ(got.median, want.median);
  EXPECT_EQ(got.lower, want.lower);
  EXPECT_EQ(got.upper, want.upper);
  EXPECT_EQ(got.frames, want.frames);
  EXPECT_EQ(got.source, want.source);
}

class RunSummary : public StoreTest {
 protected:
  // Every run's stored summary equals the old query's aggregates, list()
  // reads it, and its frame time equals runFrameTime over its samples.
  void expectSummariesMatchSamples(size_t runs) {
    auto& db = store_->connection();
    auto old = oldAggregates(db);
    auto stored = storedAggregates(db);
    ASSERT_EQ(old.size(), runs);
    EXPECT_EQ(stored, old);
    auto page = store_->runs().list({}, {.limit = 1000});
    ASSERT_TRUE(page) << page.error();
    ASSERT_EQ(page->runs.size(), runs);
    std::set<std::string> sources;
    for (const RunRow& r : page->runs) {
      SCOPED_TRACE("run " + std::to_string(r.id));
      EXPECT_EQ(aggregatesOf(r), old[r.id]);
      auto samples = store_->runs().sampleFrameTimes(r.id);
      ASSERT_TRUE(samples) << samples.error();
      ASSERT_TRUE(r.frameTime) << "no frame time stored at ingest";
      expectSameFrameTime(*r.frameTime, runFrameTime(*samples));
      sources.insert(r.frameTime->source);
      auto one = store_->runs().get(r.id);
      ASSERT_TRUE(one && *one);
      EXPECT_EQ(aggregatesOf((*one)->row), old[r.id]);
      ASSERT_TRUE((*one)->row.frameTime);
      expectSameFrameTime(*(*one)->row.frameTime, *r.frameTime);
    }
    // Every kind of run is among them.
    EXPECT_EQ(sources, (std::set<std::string>{"frames", "samples", "none"}));
  }
};

TEST_F(RunSummary, IngestWritesTheOldAggregatesAndTheFrameTime) {
  int64_t first = newJob();
  ASSERT_EQ(ingest(first, mixedCapture(0)), 3);
  ASSERT_EQ(ingest(newJob(), mixedCapture(2)), 3);
  expectSummariesMatchSamples(6);
  // The first capture's run: every frame pooled (18), with an interval.
  auto& db = store_->connection();
  Statement forward(db,
                    "SELECT frame_time_source, frame_time_frames, frame_time_lower IS NOT NULL, sample_count "
                    "FROM runs WHERE job_id = ?1 AND renderer = 'forward'");
  forward.bind(1, first);
  ASSERT_TRUE(forward.step());
  EXPECT_EQ(forward.getText(0), "frames");
  EXPECT_EQ(forward.getInt(1), 18);
  EXPECT_EQ(forward.getInt(2), 1);
  EXPECT_EQ(forward.getInt(3), 2);
  // A re-ingest of the first job with other values re-writes its summaries.
  Capture again = mixedCapture(5);
  again.result["runs"][0]["samples"].erase(1);
  ASSERT_EQ(ingest(first, again), 3);
  expectSummariesMatchSamples(6);
  EXPECT_EQ(scalar(*store_, "SELECT sample_count FROM runs WHERE renderer = 'forward' ORDER BY id DESC LIMIT 1"), 1);
}

// The summary is summed in camera order, whatever order the result lists
// the samples in: the walk of 0013's statement over its (run_id,
// camera_index) index. The values make the order show in the last bit:
// 1e16 + 1 is 1e16 in doubles, so cameras 0, 1, 2 sum to 0, and the
// result's order (2, 0, 1) would sum to 1.
TEST_F(RunSummary, SumsAddInCameraOrderWhateverTheResultsOrder) {
  Capture c = mixedCapture(0);
  json& samples = c.result["runs"][1]["samples"];
  ASSERT_EQ(samples.size(), 3u);
  const double frame[3] = {1e16, 1.0, -1e16}, psnr[3] = {1e16, 1.0, -1e16};
  for (int s = 0; s < 3; ++s) {
    samples[s]["camera"]["index"] = s;
    samples[s]["frame_ms"] = frame[s];
    samples[s]["frame_ms_frames"] = json::array();
    samples[s]["image_error"] = {{"psnr", psnr[s]}, {"max_abs", 1}, {"mean_abs", 0.5}};
  }
  json listed = json::array({samples[2], samples[0], samples[1]});
  samples = listed;
  ASSERT_EQ(ingest(newJob(), c), 3);
  Statement run(store_->connection(),
                "SELECT mean_frame_ms, mean_psnr, min_psnr, sample_count, image_compared, image_identical "
                "FROM runs WHERE renderer = 'deferred'");
  ASSERT_TRUE(run.step());
  EXPECT_EQ(run.getDouble(0), 0.0);
  EXPECT_EQ(run.getDouble(1), 0.0);
  EXPECT_EQ(run.getDouble(2), -1e16);
  EXPECT_EQ(run.getInt(3), 3);
  EXPECT_EQ(run.getInt(4), 3);
  EXPECT_EQ(run.getInt(5), 0);  // a psnr and no "identical": not identical
  EXPECT_FALSE(run.step());
}

// A mean whose sum of finite values leaves the doubles is refused, naming
// the column, as PostgreSQL's AVG refused it; nothing of the capture is stored.
TEST_F(RunSummary, SumBeyondTheDoublesIsRefused) {
  Capture c = mixedCapture(0);
  json& samples = c.result["runs"][1]["samples"];
  samples[0]["frame_ms"] = 1.5e308;
  samples[1]["frame_ms"] = 1.5e308;
  auto stored = store_->runs().ingestCapture(newJob(), c.result, c.screenshots);
  ASSERT_FALSE(stored);
  EXPECT_NE(stored.error().find("runs[1].samples: the sum of the samples' frame_ms is beyond the largest double"),
            std::string::npos)
      << stored.error();
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM runs"), 0);
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM samples"), 0);
}

// The columns' checks: a frame time's source is one of three, its frame count not negative.
TEST_F(RunSummary, StoredFrameTimeColumnsAreChecked) {
  ASSERT_EQ(ingest(newJob(), mixedCapture(0)), 3);
  auto& db = store_->connection();
  for (const char* bad : {"UPDATE runs SET frame_time_source = 'mean'", "UPDATE runs SET frame_time_frames = -1"}) {
    SCOPED_TRACE(bad);
    EXPECT_THROW(db.exec(bad), DbError);
  }
  db.exec("UPDATE runs SET frame_time_source = NULL");  // runs stored before 0013
  auto page = store_->runs().list({}, {});
  ASSERT_TRUE(page) << page.error();
  ASSERT_EQ(page->runs.size(), 3u);
  for (const auto& r : page->runs) EXPECT_FALSE(r.frameTime) << r.id;
}

// A database of schema 12 with runs and samples (missing values, per-frame
// times on some samples, a run without samples) upgrades to 13: the eleven
// aggregates backfilled equal to the old query's on the same rows, the frame
// time left NULL, so readers compute it from the samples.
TEST(RunSummaryMigration, SchemaTwelveBackfillsTheAggregatesAndLeavesTheFrameTime) {
  TempDb db;
  const char* rows =
      "INSERT INTO devices (id, fingerprint, name, vendor, driver, api_version) "
      "VALUES (1, 'llvmpipe', 'llvmpipe', '0x10005', 'Mesa', '1.3');"
      "INSERT INTO scenes (id, name, params) VALUES (1, 'atrium', '{}');"
      "INSERT INTO jobs (id, status, spec) VALUES (1, 'done', '{}');"
      "INSERT INTO runs (id, job_id, device_id, renderer, scene_id, width, height, counting, lights, variant) VALUES "
      "(1, 1, 1, 'forward', 1, 64, 36, 'exact', 4, 'forward'), (2, 1, 1, 'deferred', 1, 64, 36, 'exact', 4, "
      "'deferred'), (3, 1, 1, 'visbuffer', 1, 64, 36, 'exact', 4, 'visbuffer');"
      "INSERT INTO samples (id, run_id, camera_index, camera, frame_ms, bytes, frame_ms_instrumented, "
      "overhead_ratio, image_against, image_identical, psnr, max_abs, mean_abs, footprint_bytes, "
      "footprint_requested_bytes, frame_ms_frames) VALUES "
      "(1, 1, 0, '{}', 0.1, 96, 0.11, 1.1, 'forward', 1, NULL, 0, 0, NULL, NULL, '[0.3, 0.1, 0.2]'), "
      "(2, 1, 1, '{}', 0.2, 0.1, NULL, NULL, 'forward', 0, 41.5, 3, 0.25, 0.7, 0.2, '[0.4, 0.5]'), "
      "(3, 1, 2, '{}', 0.3, 0.2, 0.33, 1.3, NULL, NULL, NULL, NULL, NULL, 0.1, 0.3, '[0.6]'), "
      "(4, 2, 0, '{}', 1.5, 0.3, NULL, NULL, 'forward', 0, 30.25, 9, 1.5, NULL, NULL, '[1.5, 1.25]'), "
      "(5, 2, 1, '{}', 2.5, 0.7, NULL, NULL, 'forward', 0, 20.75, 9, 1.5, NULL, NULL, NULL)";
  std::map<int64_t, Aggregates> before;
  if (db.postgres()) {
    auto c = openPostgres(db.path());
    auto twelve = migrate(*c, embeddedMigrations(Engine::Postgres).first(12));
    ASSERT_TRUE(twelve) << twelve.error();
    ASSERT_EQ(*twelve, 12);
    c->exec(rows);
    before = oldAggregates(*c);
  } else {
    sqlite3* raw = nullptr;
    ASSERT_EQ(sqlite3_open(db.path().c_str(), &raw), SQLITE_OK);
    auto twelve = migrate(raw, embeddedMigrations().first(12));
    ASSERT_TRUE(twelve) << twelve.error();
    ASSERT_EQ(*twelve, 12);
    ASSERT_EQ(sqlite3_exec(raw, rows, nullptr, nullptr, nullptr), SQLITE_OK) << sqlite3_errmsg(raw);
    {
      SqliteConnection connection(raw, "test", /*owns=*/false);
      before = oldAggregates(connection);
    }
    sqlite3_close(raw);
  }
  ASSERT_EQ(before.size(), 3u);
  EXPECT_EQ(before[1].sampleCount, 3);
  EXPECT_EQ(before[3].sampleCount, 0);

  auto store = openStore(db.path());
  ASSERT_NE(store, nullptr);
  EXPECT_GE(store->schemaVersion(), 13);  // and later ones
  EXPECT_EQ(storedAggregates(store->connection()), before);
  EXPECT_EQ(scalar(*store, "SELECT COUNT(*) FROM runs WHERE frame_time_source IS NULL AND frame_time_median IS NULL"),
            3);
  auto page = store->runs().list({}, {});
  ASSERT_TRUE(page) << page.error();
  ASSERT_EQ(page->runs.size(), 3u);
  for (const RunRow& r : page->runs) {
    EXPECT_EQ(aggregatesOf(r), before[r.id]) << r.id;
    EXPECT_FALSE(r.frameTime) << r.id;  // computed by the readers from the samples
  }
  // What the readers compute: run 1 pools its six frames, run 2 (a sample
  // without frames) takes its samples' medians, run 3 has none.
  auto samples = store->runs().sampleFrameTimes(std::vector<int64_t>{1, 2, 3});
  ASSERT_TRUE(samples) << samples.error();
  RunFrameTime one = runFrameTime((*samples)[1]), two = runFrameTime((*samples)[2]), three = runFrameTime({});
  EXPECT_EQ(one.source, "frames");
  EXPECT_EQ(one.frames, 6u);
  EXPECT_DOUBLE_EQ(*one.median, 0.35);
  EXPECT_EQ(two.source, "samples");
  EXPECT_DOUBLE_EQ(*two.median, 2.0);
  EXPECT_EQ(three.source, "none");
  EXPECT_EQ(samples->count(3), 0u);
}

}  // namespace
}  // namespace tally::store::testing
