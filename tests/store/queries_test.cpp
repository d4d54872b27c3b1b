// listRuns (filters, pagination), compareRuns (hand-computed), exportRuns.
#include <set>

#include "store_fixture.hpp"

namespace tally::store::testing {
namespace {

// Averages and differences of decimal fractions: equal up to rounding.
#define EXPECT_CLOSE(actual, expected) EXPECT_NEAR(actual, expected, 1e-9)

class Queries : public StoreTest {
 protected:
  // 6 jobs x 2 runs: atrium 320x180 on llvmpipe (jobs 0-2), planes 640x360 on
  // llvmpipe (job 3), atrium 320x180 on "NVIDIA H200" (jobs 4-5).
  void ingestMany() {
    for (int i = 0; i < 6; ++i) {
      int64_t job = newJob();
      jobs_.push_back(job);
      if (i < 3) ingest(job, realisticCapture(i));
      if (i == 3) ingest(job, realisticCapture(i, "planes", 640, 360));
      if (i > 3) ingest(job, realisticCapture(i, "atrium", 320, 180, "NVIDIA H200"));
    }
  }
  std::vector<int64_t> jobs_;
};

TEST_F(Queries, PaginationWalksEveryRunOnce) {
  ingestMany();
  for (int limit : {1, 3, 5, 12, 1000}) {
    std::vector<int64_t> seen;
    Page page{.limit = limit};
    int pages = 0;
    while (true) {
      auto got = store_->runs().list({}, page);
      ASSERT_TRUE(got) << got.error();
      ASSERT_LE(got->runs.size(), static_cast<size_t>(limit));
      for (const auto& run : got->runs) seen.push_back(run.id);
      ++pages;
      if (got->nextCursor.empty()) break;
      page.cursor = got->nextCursor;
      ASSERT_LT(pages, 100);
    }
    EXPECT_EQ(seen.size(), 12u) << "limit " << limit;
    EXPECT_EQ(std::set<int64_t>(seen.begin(), seen.end()).size(), 12u) << "limit " << limit;
    EXPECT_TRUE(std::is_sorted(seen.rbegin(), seen.rend())) << "newest first";
    EXPECT_EQ(pages, (12 + limit - 1) / limit) << "limit " << limit;  // no empty last page
  }
  // Filtered pagination: 4 H200 runs, 2 a page.
  RunFilter h200{.deviceName = "NVIDIA H200"};
  auto first = store_->runs().list(h200, {.limit = 2});
  ASSERT_TRUE(first && first->runs.size() == 2 && !first->nextCursor.empty());
  auto second = store_->runs().list(h200, {.limit = 2, .cursor = first->nextCursor});
  ASSERT_TRUE(second && second->runs.size() == 2);
  EXPECT_TRUE(second->nextCursor.empty());
}

// A scene name with two parameter sets is two scene ids, whose runs
// interleave: the index gives each id's runs in order but not both together,
// so the page is sorted before LIMIT. Pages stay newest first, each run once.
TEST_F(Queries, NameOfSeveralIdsPagesNewestFirst) {
  for (int i = 0; i < 4; ++i) {
    Capture capture = realisticCapture(i);
    for (json& run : capture.result["runs"]) run["scene_params"] = {{"seed", i % 2}};
    ingest(newJob(), capture);
  }
  ASSERT_EQ(scalar(*store_, "SELECT COUNT(*) FROM scenes WHERE name = 'atrium'"), 2);
  for (int limit : {1, 3, 1000}) {
    std::vector<int64_t> seen;
    Page page{.limit = limit};
    for (int pages = 0; pages < 100; ++pages) {
      auto got = store_->runs().list({.scene = "atrium"}, page);
      ASSERT_TRUE(got) << got.error();
      for (const auto& run : got->runs) {
        seen.push_back(run.id);
        EXPECT_EQ(run.sampleCount, 2) << "run " << run.id;
      }
      if (got->nextCursor.empty()) break;
      page.cursor = got->nextCursor;
    }
    EXPECT_EQ(seen.size(), 8u) << "limit " << limit;
    EXPECT_EQ(std::set<int64_t>(seen.begin(), seen.end()).size(), 8u) << "limit " << limit;
    EXPECT_TRUE(std::is_sorted(seen.rbegin(), seen.rend())) << "limit " << limit;
  }
}

TEST_F(Queries, BadPagesAreRefused) {
  EXPECT_FALSE(store_->runs().list({}, {.limit = 0}));
  EXPECT_FALSE(store_->runs().list({}, {.limit = 1001}));
  for (const char* cursor : {"x", "r", "r-1", "r0", "12", "rzz", "r1 OR 1=1"}) {
    auto got = store_->runs().list({}, {.limit = 10, .cursor = cursor});
    ASSERT_FALSE(got) << cursor;
    EXPECT_NE(got.error().find("cursor"), std::string::npos);
  }
  EXPECT_EQ(decodeCursor(encodeCursor(123456789)), 123456789);
}

struct FilterCase {
  const char* name;
  RunFilter filter;
  size_t runs;
};

TEST_F(Queries, Filters) {
  ingestMany();
  auto deviceId = scalar(*store_, "SELECT id FROM devices WHERE name = 'NVIDIA H200'");
  const std::vector<FilterCase> cases = {
      {"none", {}, 12},
      {"renderer", {.renderer = "deferred"}, 6},
      {"scene", {.scene = "planes"}, 2},
      {"width", {.width = 640}, 2},
      {"width and height", {.width = 320, .height = 180}, 10},
      {"height alone", {.height = 360}, 2},
      {"device name", {.deviceName = "NVIDIA H200"}, 4},
      {"device id", {.deviceId = deviceId}, 4},
      {"job", {.jobId = jobs_[1]}, 2},
      {"renderer and device", {.renderer = "forward", .deviceName = "NVIDIA H200"}, 2},
      {"renderer, scene, size", {.renderer = "forward", .scene = "atrium", .width = 320, .height = 180}, 5},
      {"no such renderer", {.renderer = "warp"}, 0},
      {"no such scene", {.scene = "sponza"}, 0},
      {"quote in value", {.renderer = "forward' OR '1'='1"}, 0},
      {"run ids", {.runIds = {1, 3, 4}}, 3},
      {"run ids and renderer", {.renderer = "forward", .runIds = {1, 2, 3, 4}}, 2},
      {"unknown run ids", {.runIds = {999, 1000}}, 0},
  };
  for (const auto& test : cases) {
    auto got = store_->runs().list(test.filter, {.limit = 1000});
    ASSERT_TRUE(got) << test.name << ": " << got.error();
    EXPECT_EQ(got->runs.size(), test.runs) << test.name;
    for (const auto& run : got->runs) {
      if (test.filter.renderer) {
        EXPECT_EQ(run.renderer, *test.filter.renderer) << test.name;
      }
      if (test.filter.scene) {
        EXPECT_EQ(run.scene, *test.filter.scene) << test.name;
      }
      if (test.filter.width) {
        EXPECT_EQ(run.width, *test.filter.width) << test.name;
      }
      if (test.filter.deviceName) {
        EXPECT_EQ(run.deviceName, *test.filter.deviceName) << test.name;
      }
      if (test.filter.jobId) {
        EXPECT_EQ(run.jobId, *test.filter.jobId) << test.name;
      }
    }
    // Export honours the same filters: 4 passes x 3 counters per run.
    auto rows = store_->runs().exportRows(test.filter);
    ASSERT_TRUE(rows) << test.name << ": " << rows.error();
    EXPECT_EQ(rows->size(), test.runs * 12) << test.name;
  }
}

// Two runs with literal values, so the expectations below are computed by hand.
Capture compareFixture() {
  auto tex = [](double n) { return makeCounter("tex", "read", n, n * 4); };
  auto fb = [](double n) { return makeCounter("fb", "write", n, n * 4); };
  auto sky = [](double n) { return makeCounter("sky", "read", n, n * 4); };
  auto gbWrite = [](double n) { return makeCounter("gb", "write", n, n * 8); };
  auto gbRead = [](double n) { return makeCounter("gb", "read", n, n * 8); };
  json a = makeRun(
      "forward", "atrium", 320, 180,
      {makeSample(0, 1.2,
                  {makePass("opaque", 1.0, 50, {tex(100), fb(50)}), makePass("skybox", 0.2, 10, {sky(10)})}),
       makeSample(
           1, 3.4,
           {makePass("opaque", 3.0, 150, {tex(300), fb(150)}), makePass("skybox", 0.4, 30, {sky(30)})})});
  std::vector<json> deferredSamples;
  for (int s = 0; s < 2; ++s) {
    deferredSamples.push_back(makeSample(
        s, 3.2,
        {makePass("gbuffer", 2.0, 100, {tex(100), gbWrite(200)}),
         makePass("lighting", 1.0, 50, {gbRead(200), fb(50)}), makePass("skybox", 0.2, 10, {sky(10)})}));
  }
  json b = makeRun("deferred", "atrium", 320, 180, std::move(deferredSamples));
  return Capture{makeCapture({a, b}), {}};
}

TEST_F(Queries, CompareAgainstTheFirstRun) {
  int64_t jobId = newJob();
  ingest(jobId, compareFixture());
  auto runs = store_->runs().list({.jobId = jobId}, {});
  ASSERT_TRUE(runs && runs->runs.size() == 2);
  int64_t forward = runs->runs[1].id, deferred = runs->runs[0].id;

  // Per-sample and per-run byte totals: forward 640 and 1920 (mean 1280), deferred 3840.
  auto samples = store_->runs().samples(forward);
  ASSERT_TRUE(samples && samples->size() == 2);
  EXPECT_CLOSE((*samples)[0].bytes, 640);
  EXPECT_CLOSE((*samples)[1].bytes, 1920);
  EXPECT_CLOSE(*runs->runs[1].meanBytes, 1280);
  EXPECT_CLOSE(*runs->runs[0].meanBytes, 3840);

  auto cmp = store_->runs().compare({forward, deferred});
  ASSERT_TRUE(cmp) << cmp.error();
  ASSERT_EQ(cmp->runs.size(), 2u);
  EXPECT_EQ(cmp->runs[0].renderer, "forward");
  EXPECT_EQ(cmp->runs[1].renderer, "deferred");

  // frame: forward (1.2 + 3.4) / 2 = 2.3, deferred 3.2.
  EXPECT_CLOSE(*cmp->frameMs[0].value, 2.3);
  EXPECT_CLOSE(*cmp->frameMs[0].delta, 0.0);
  EXPECT_CLOSE(*cmp->frameMs[0].ratio, 1.0);
  EXPECT_CLOSE(*cmp->frameMs[1].value, 3.2);
  EXPECT_CLOSE(*cmp->frameMs[1].delta, 0.9);
  EXPECT_CLOSE(*cmp->frameMs[1].ratio, 3.2 / 2.3);
  // bytes per frame: forward (400+200+40 + 1200+600+120) / 2 = 1280;
  // deferred 400+1600+1600+200+40 = 3840.
  EXPECT_CLOSE(*cmp->totalBytes[0].value, 1280);
  EXPECT_CLOSE(*cmp->totalBytes[1].value, 3840);
  EXPECT_CLOSE(*cmp->totalBytes[1].delta, 2560);
  EXPECT_CLOSE(*cmp->totalBytes[1].ratio, 3.0);

  // Passes: forward's order, then deferred's new ones.
  ASSERT_EQ(cmp->passes.size(), 4u);
  EXPECT_EQ(cmp->passes[0].pass, "opaque");
  EXPECT_EQ(cmp->passes[1].pass, "skybox");
  EXPECT_EQ(cmp->passes[2].pass, "gbuffer");
  EXPECT_EQ(cmp->passes[3].pass, "lighting");
  const PassComparison& opaque = cmp->passes[0];
  EXPECT_CLOSE(*opaque.gpuMs[0].value, 2.0);                // (1 + 3) / 2
  EXPECT_CLOSE(*opaque.bytes[0].value, 1200);               // (600 + 1800) / 2
  EXPECT_CLOSE(*opaque.fragmentInvocations[0].value, 100);  // (50 + 150) / 2
  EXPECT_FALSE(opaque.gpuMs[1].value);                      // deferred has no opaque pass
  EXPECT_FALSE(opaque.gpuMs[1].delta);
  EXPECT_FALSE(opaque.gpuMs[1].ratio);
  const PassComparison& skybox = cmp->passes[1];
  EXPECT_CLOSE(*skybox.gpuMs[0].value, 0.3);
  EXPECT_CLOSE(*skybox.gpuMs[1].value, 0.2);
  EXPECT_CLOSE(*skybox.gpuMs[1].delta, -0.1);
  EXPECT_CLOSE(*skybox.gpuMs[1].ratio, 2.0 / 3.0);
  EXPECT_CLOSE(*skybox.bytes[0].value, 80);
  EXPECT_CLOSE(*skybox.bytes[1].value, 40);
  EXPECT_CLOSE(*skybox.bytes[1].ratio, 0.5);
  const PassComparison& gbuffer = cmp->passes[2];
  EXPECT_FALSE(gbuffer.gpuMs[0].value);
  EXPECT_CLOSE(*gbuffer.gpuMs[1].value, 2.0);
  EXPECT_CLOSE(*gbuffer.bytes[1].value, 2000);  // 400 + 1600
  EXPECT_FALSE(gbuffer.bytes[1].delta);         // nothing to compare against

  // Resources by name then access: fb/write, gb/read, gb/write, sky/read, tex/read.
  ASSERT_EQ(cmp->resources.size(), 5u);
  std::vector<std::string> keys;
  for (const auto& r : cmp->resources) keys.push_back(r.resource + "/" + r.access);
  EXPECT_EQ(keys, (std::vector<std::string>{"fb/write", "gb/read", "gb/write", "sky/read", "tex/read"}));
  const ResourceComparison& fbw = cmp->resources[0];
  EXPECT_CLOSE(*fbw.count[0].value, 100);  // (50 + 150) / 2
  EXPECT_CLOSE(*fbw.count[1].value, 50);
  EXPECT_CLOSE(*fbw.bytes[0].value, 400);
  EXPECT_CLOSE(*fbw.bytes[1].delta, -200);
  EXPECT_CLOSE(*fbw.bytes[1].ratio, 0.5);
  const ResourceComparison& gbr = cmp->resources[1];
  EXPECT_FALSE(gbr.bytes[0].value);
  EXPECT_CLOSE(*gbr.bytes[1].value, 1600);
  const ResourceComparison& texr = cmp->resources[4];
  EXPECT_CLOSE(*texr.bytes[0].value, 800);
  EXPECT_CLOSE(*texr.bytes[1].value, 400);
  EXPECT_CLOSE(*texr.count[1].ratio, 0.5);

  // The other way round: ratios invert.
  auto back = store_->runs().compare({deferred, forward});
  ASSERT_TRUE(back);
  EXPECT_CLOSE(*back->totalBytes[1].ratio, 1.0 / 3.0);
  EXPECT_EQ(back->passes[0].pass, "gbuffer");

  // Export: one row per run x pass x resource x access, averaged over samples.
  auto rows = store_->runs().exportRows({.jobId = jobId});
  ASSERT_TRUE(rows) << rows.error();
  ASSERT_EQ(rows->size(), 3u + 5u);
  const ExportRow& first = (*rows)[0];
  EXPECT_EQ(first.runId, forward);
  EXPECT_EQ(first.renderer, "forward");
  EXPECT_EQ(first.scene, "atrium");
  EXPECT_EQ(first.width, 320);
  EXPECT_EQ(first.height, 180);
  EXPECT_EQ(first.device, "llvmpipe (LLVM 15.0.6, 256 bits)");
  EXPECT_EQ(first.pass, "opaque");
  EXPECT_EQ(first.resource, "fb");
  EXPECT_EQ(first.access, "write");
  EXPECT_CLOSE(first.count, 100);
  EXPECT_CLOSE(first.bytes, 400);
  EXPECT_EQ((*rows)[1].resource, "tex");
  EXPECT_CLOSE((*rows)[1].bytes, 800);
  EXPECT_EQ((*rows)[2].pass, "skybox");
  EXPECT_EQ((*rows)[3].pass, "gbuffer");
  EXPECT_EQ((*rows)[3].runId, deferred);
}

// The run and sample summaries the dashboard reads: a run's passes averaged
// over its samples, its means and image error, a sample's read/written split.
TEST_F(Queries, RunSummaries) {
  Capture c = compareFixture();
  json& forwardSamples = c.result["runs"][0]["samples"];
  forwardSamples[0]["image_error"] = {
      {"against", "forward"}, {"psnr", nullptr}, {"identical", true}, {"max_abs", 0}, {"mean_abs", 0}};
  forwardSamples[1]["image_error"]["psnr"] = 30.0;
  int64_t jobId = newJob();
  ingest(jobId, c);
  auto runs = store_->runs().list({.jobId = jobId}, {});
  ASSERT_TRUE(runs && runs->runs.size() == 2);
  const RunRow& forward = runs->runs[1];
  const RunRow& deferred = runs->runs[0];

  // Frame 1.2 and 3.4 ms, instrumented x1.1 each; overhead 1.1 on both samples.
  EXPECT_CLOSE(*forward.meanFrameMsInstrumented, (1.2 + 3.4) * 1.1 / 2);
  EXPECT_CLOSE(*forward.meanOverheadRatio, 1.1);
  EXPECT_EQ(forward.imageCompared, 2);
  EXPECT_EQ(forward.imageIdentical, 1);
  EXPECT_CLOSE(*forward.meanPsnr, 30.0);  // over the sample that differs
  EXPECT_CLOSE(*forward.minPsnr, 30.0);
  EXPECT_EQ(deferred.imageIdentical, 0);
  EXPECT_CLOSE(*deferred.meanPsnr, 41.5);

  // Samples: read tex + sky, written fb.
  auto samples = store_->runs().samples(forward.id);
  ASSERT_TRUE(samples && samples->size() == 2);
  EXPECT_CLOSE((*samples)[0].bytesRead, 400 + 40);
  EXPECT_CLOSE((*samples)[0].bytesWritten, 200);
  EXPECT_CLOSE((*samples)[1].bytesRead, 1200 + 120);
  EXPECT_CLOSE((*samples)[1].bytesWritten, 600);
  auto sample = store_->runs().sample((*samples)[1].id);
  ASSERT_TRUE(sample && *sample);
  EXPECT_CLOSE((*sample)->row.bytesRead + (*sample)->row.bytesWritten, (*sample)->row.bytes);

  // Passes in frame order, averaged over the two samples.
  auto passes = store_->runs().passes(forward.id);
  ASSERT_TRUE(passes) << passes.error();
  ASSERT_EQ(passes->size(), 2u);
  const Pass& opaque = (*passes)[0];
  EXPECT_EQ(opaque.name, "opaque");
  EXPECT_CLOSE(opaque.gpuMs, 2.0);                  // (1 + 3) / 2
  EXPECT_CLOSE(*opaque.gpuMsInstrumented, 2.2);     // (1.1 + 3.3) / 2
  EXPECT_CLOSE(*opaque.overheadRatio, 1.1);
  EXPECT_CLOSE(*opaque.fragmentInvocations, 100);   // (50 + 150) / 2
  EXPECT_CLOSE(*opaque.fragmentInvocationsStatistic, 108);
  EXPECT_TRUE(opaque.gpuMsSpread.is_null());
  ASSERT_EQ(opaque.counters.size(), 2u);
  EXPECT_EQ(opaque.counters[0].resource, "tex");
  EXPECT_EQ(opaque.counters[0].access, "read");
  EXPECT_EQ(*opaque.counters[0].format, "R8G8B8A8_UNORM");
  EXPECT_CLOSE(opaque.counters[0].count, 200);
  EXPECT_CLOSE(opaque.counters[0].bytes, 800);
  EXPECT_EQ(opaque.counters[1].resource, "fb");
  EXPECT_CLOSE(opaque.counters[1].bytes, 400);
  EXPECT_EQ((*passes)[1].name, "skybox");
  EXPECT_CLOSE((*passes)[1].gpuMs, 0.3);
  EXPECT_CLOSE((*passes)[1].counters[0].bytes, 80);
  auto none = store_->runs().passes(forward.id + 1000);
  ASSERT_TRUE(none);
  EXPECT_TRUE(none->empty());

  // detail(): the run as get() reads it and its passes as passes() averages
  // them (over the run row's sample count, not a COUNT of its samples), in
  // one transaction.
  auto detailed = store_->runs().detail(forward.id);
  ASSERT_TRUE(detailed && detailed->has_value()) << (detailed ? "" : detailed.error());
  auto run = store_->runs().get(forward.id);
  ASSERT_TRUE(run && run->has_value());
  const RunDetail& d = **detailed;
  EXPECT_EQ(d.run.row.id, forward.id);
  EXPECT_EQ(d.run.row.sampleCount, 2);
  EXPECT_EQ(d.run.device.name, (*run)->device.name);
  EXPECT_EQ(d.run.shaders, (*run)->shaders);
  EXPECT_EQ(d.run.counterHeadroom, (*run)->counterHeadroom);
  ASSERT_EQ(d.run.resources.size(), (*run)->resources.size());
  for (size_t i = 0; i < d.run.resources.size(); ++i) EXPECT_EQ(d.run.resources[i].name, (*run)->resources[i].name);
  ASSERT_EQ(d.passes.size(), passes->size());
  for (size_t i = 0; i < d.passes.size(); ++i) {
    const Pass& a = d.passes[i];
    const Pass& b = (*passes)[i];
    EXPECT_EQ(a.name, b.name);
    EXPECT_CLOSE(a.gpuMs, b.gpuMs);
    EXPECT_EQ(a.gpuMsInstrumented, b.gpuMsInstrumented);
    EXPECT_EQ(a.fragmentInvocations, b.fragmentInvocations);
    ASSERT_EQ(a.counters.size(), b.counters.size());
    for (size_t k = 0; k < a.counters.size(); ++k) {
      EXPECT_EQ(a.counters[k].resource, b.counters[k].resource);
      EXPECT_CLOSE(a.counters[k].count, b.counters[k].count);
      EXPECT_CLOSE(a.counters[k].bytes, b.counters[k].bytes);
    }
  }
  EXPECT_CLOSE(d.passes[0].gpuMs, 2.0);  // (1 + 3) / 2, as above
  auto unknown = store_->runs().detail(forward.id + 1000);
  ASSERT_TRUE(unknown) << unknown.error();
  EXPECT_FALSE(unknown->has_value());
}

TEST_F(Queries, CreatedBetween) {
  int64_t jobId = newJob();
  ingest(jobId, realisticCapture());
  auto all = store_->runs().list({.jobId = jobId}, {});
  ASSERT_TRUE(all && all->runs.size() == 2);
  const std::string created = all->runs[0].createdAt;  // 2026-11-21T06:30:00.123Z
  ASSERT_EQ(created.size(), 24u);
  auto count = [&](std::optional<std::string> since, std::optional<std::string> until) {
    RunFilter f{.jobId = jobId};
    f.createdSince = since;
    f.createdUntil = until;
    auto page = store_->runs().list(f, {});
    EXPECT_TRUE(page) << page.error();
    auto rows = store_->runs().exportRows(f);  // the same filter
    EXPECT_TRUE(rows) << rows.error();
    return page ? page->runs.size() : 0u;
  };
  EXPECT_EQ(count("2000-01-01", std::nullopt), 2u);
  EXPECT_EQ(count(std::nullopt, "2000-01-01"), 0u);
  EXPECT_EQ(count("9999-12-31", std::nullopt), 0u);
  // until is inclusive at its precision: the day, the minute, the very time.
  for (size_t length : {10u, 16u, 19u, 24u}) {
    std::string prefix = created.substr(0, length);
    size_t expected = 0;
    for (const auto& r : all->runs) expected += r.createdAt.compare(0, length, prefix) == 0 ? 1 : 0;
    EXPECT_GE(expected, 1u);
    EXPECT_EQ(count(prefix, prefix), expected) << prefix;
  }
}

TEST_F(Queries, Devices) {
  ingestMany();
  auto devices = store_->runs().devices();
  ASSERT_TRUE(devices) << devices.error();
  ASSERT_EQ(devices->size(), 2u);
  EXPECT_EQ((*devices)[0].name, "llvmpipe (LLVM 15.0.6, 256 bits)");
  EXPECT_EQ((*devices)[1].name, "NVIDIA H200");
  EXPECT_EQ((*devices)[1].driver, "Mesa 22.3.6");
  EXPECT_EQ((*devices)[1].features["int64Atomics"], true);
  EXPECT_EQ((*devices)[1].info["subgroupSize"], 8);
}

TEST_F(Queries, CompareRefusesBadRequests) {
  ingestMany();
  auto runs = store_->runs().list({}, {.limit = 5});
  ASSERT_TRUE(runs && runs->runs.size() == 5);
  std::vector<int64_t> ids;
  for (const auto& r : runs->runs) ids.push_back(r.id);
  EXPECT_FALSE(store_->runs().compare({ids[0]}));
  EXPECT_FALSE(store_->runs().compare(ids));  // 5
  EXPECT_FALSE(store_->runs().compare({ids[0], ids[0]}));
  auto unknown = store_->runs().compare({ids[0], 99999});
  ASSERT_FALSE(unknown);
  EXPECT_NE(unknown.error().find("runs[1]: run 99999 not found"), std::string::npos) << unknown.error();
  auto four = store_->runs().compare({ids[0], ids[1], ids[2], ids[3]});
  ASSERT_TRUE(four) << four.error();
  EXPECT_EQ(four->runs.size(), 4u);
  EXPECT_EQ(four->frameMs.size(), 4u);
}

}  // namespace
}  // namespace tally::store::testing
