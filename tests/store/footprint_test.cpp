// Footprint (migration 0006): lines' footprint bytes in, and back out of
// every query beside the requested bytes: runs, samples, a sample's and a
// run's passes, compare and export. Runs without footprint read NULL.
#include "store_fixture.hpp"

namespace tally::store::testing {
namespace {

json withFootprint(json counter, double footprint) {
  counter["footprint_bytes"] = footprint;
  return counter;
}

// One run of two samples; per sample: gbuffer reads "diffuse" (4000 requested
// bytes) and writes "depth" (200, derived: no footprint); lighting reads
// "normal" (512). `diffuse` and `normal` give the footprints per sample;
// empty: the run has no footprint (an older capture, or footprint off).
json footprintRun(const std::string& renderer, std::optional<int> blockBytes, std::vector<double> diffuse,
                  std::vector<double> normal) {
  std::vector<json> samples;
  for (int s = 0; s < 2; ++s) {
    json diffuseLine = makeCounter("diffuse", "read", 100, 4000);
    json normalLine = makeCounter("normal", "read", 64, 512);
    if (!diffuse.empty()) diffuseLine = withFootprint(diffuseLine, diffuse[s]);
    if (!normal.empty()) normalLine = withFootprint(normalLine, normal[s]);
    samples.push_back(makeSample(s, 1.5,
                                 {makePass("gbuffer", 0.5, 1000, {diffuseLine, makeCounter("depth", "write", 40, 200, "derived")}),
                                  makePass("lighting", 0.25, 1000, {normalLine})}));
  }
  json run = makeRun(renderer, "atrium", 64, 36, std::move(samples));
  if (blockBytes) run["footprint_block_bytes"] = *blockBytes;
  return run;
}

class Footprint : public StoreTest {
 protected:
  void SetUp() override {
    StoreTest::SetUp();
    jobId_ = newJob();
    // Runs 1, 2, 3: footprint 64; none (an older result); footprint 32.
    Capture c{makeCapture({footprintRun("deferred", 64, {1000, 3000}, {256, 256}),
                           footprintRun("forward", std::nullopt, {}, {}),
                           footprintRun("visbuffer", 32, {500, 500}, {256, 256})}),
              {}};
    ASSERT_EQ(ingest(jobId_, c), 3);
    auto page = store_->runs().list({.jobId = jobId_}, {});
    ASSERT_TRUE(page) << page.error();
    ASSERT_EQ(page->runs.size(), 3u);
    for (const auto& r : page->runs) ids_[r.renderer] = r.id;
  }
  int64_t jobId_ = 0;
  std::map<std::string, int64_t> ids_;
};

TEST_F(Footprint, RunsAndSamplesCarryItBesideTheRequestedBytes) {
  auto run = store_->runs().get(ids_["deferred"]);
  ASSERT_TRUE(run && run->has_value());
  const RunRow& row = (*run)->row;
  EXPECT_EQ(row.footprintBlockBytes, 64);
  ASSERT_TRUE(row.meanBytes);
  EXPECT_DOUBLE_EQ(*row.meanBytes, 4712);  // requested: every line, unchanged
  // Per sample 1000 + 256 and 3000 + 256: mean 2256; the requested bytes of
  // those lines 4512 (the derived depth line has no footprint).
  ASSERT_TRUE(row.meanFootprintBytes);
  EXPECT_DOUBLE_EQ(*row.meanFootprintBytes, 2256);
  ASSERT_TRUE(row.meanFootprintRequestedBytes);
  EXPECT_DOUBLE_EQ(*row.meanFootprintRequestedBytes, 4512);

  auto samples = store_->runs().samples(ids_["deferred"]);
  ASSERT_TRUE(samples) << samples.error();
  ASSERT_EQ(samples->size(), 2u);
  EXPECT_EQ((*samples)[0].footprintBytes, 1256);
  EXPECT_EQ((*samples)[1].footprintBytes, 3256);
  EXPECT_EQ((*samples)[1].footprintRequestedBytes, 4512);
  EXPECT_EQ((*samples)[1].bytes, 4712);

  auto sample = store_->runs().sample((*samples)[1].id);
  ASSERT_TRUE(sample && sample->has_value());
  const auto& gbuffer = (*sample)->passes[0].counters;
  ASSERT_EQ(gbuffer.size(), 2u);
  EXPECT_EQ(gbuffer[0].footprintBytes, 3000);
  EXPECT_EQ(gbuffer[0].bytes, 4000);
  EXPECT_FALSE(gbuffer[1].footprintBytes);  // derived: not measured

  // A run without footprint: NULL everywhere, its bytes as ever.
  auto plain = store_->runs().get(ids_["forward"]);
  ASSERT_TRUE(plain && plain->has_value());
  EXPECT_FALSE((*plain)->row.footprintBlockBytes);
  EXPECT_FALSE((*plain)->row.meanFootprintBytes);
  EXPECT_FALSE((*plain)->row.meanFootprintRequestedBytes);
  EXPECT_DOUBLE_EQ(*(*plain)->row.meanBytes, 4712);
  auto plainSamples = store_->runs().samples(ids_["forward"]);
  ASSERT_TRUE(plainSamples);
  EXPECT_FALSE((*plainSamples)[0].footprintBytes);
  EXPECT_FALSE((*plainSamples)[0].footprintRequestedBytes);
}

TEST_F(Footprint, RunPassesAverageItOverTheSamples) {
  auto passes = store_->runs().passes(ids_["deferred"]);
  ASSERT_TRUE(passes) << passes.error();
  ASSERT_EQ(passes->size(), 2u);
  ASSERT_EQ((*passes)[0].counters.size(), 2u);
  EXPECT_EQ((*passes)[0].counters[0].resource, "diffuse");
  EXPECT_EQ((*passes)[0].counters[0].footprintBytes, 2000);  // (1000 + 3000) / 2
  EXPECT_FALSE((*passes)[0].counters[1].footprintBytes);
  EXPECT_EQ((*passes)[1].counters[0].footprintBytes, 256);
  auto plain = store_->runs().passes(ids_["forward"]);
  ASSERT_TRUE(plain);
  EXPECT_FALSE((*plain)[0].counters[0].footprintBytes);
}

TEST_F(Footprint, CompareGivesFootprintAndReuseWithDeltasAndRatios) {
  auto c = store_->runs().compare({ids_["deferred"], ids_["forward"], ids_["visbuffer"]});
  ASSERT_TRUE(c) << c.error();
  // Totals: 2256 and (500 + 256) = 756; reuse 4512 / 2256 = 2 and 4512 / 756.
  ASSERT_EQ(c->totalFootprintBytes.size(), 3u);
  EXPECT_EQ(c->totalFootprintBytes[0].value, 2256);
  EXPECT_FALSE(c->totalFootprintBytes[1].value);  // no footprint: null, not 0
  EXPECT_FALSE(c->totalFootprintBytes[1].delta);
  EXPECT_EQ(c->totalFootprintBytes[2].value, 756);
  EXPECT_EQ(c->totalFootprintBytes[2].delta, 756 - 2256);
  ASSERT_TRUE(c->totalFootprintBytes[2].ratio);
  EXPECT_DOUBLE_EQ(*c->totalFootprintBytes[2].ratio, 756.0 / 2256);
  EXPECT_EQ(c->reuse[0].value, 2);
  EXPECT_FALSE(c->reuse[1].value);
  ASSERT_TRUE(c->reuse[2].value);
  EXPECT_DOUBLE_EQ(*c->reuse[2].value, 4512.0 / 756);
  EXPECT_EQ(c->totalBytes[1].value, 4712);  // requested bytes, every run

  ASSERT_EQ(c->passes.size(), 2u);
  const PassComparison& gbuffer = c->passes[0];
  EXPECT_EQ(gbuffer.pass, "gbuffer");
  EXPECT_EQ(gbuffer.footprintBytes[0].value, 2000);
  EXPECT_EQ(gbuffer.footprintBytes[2].value, 500);
  EXPECT_EQ(gbuffer.footprintBytes[2].ratio, 0.25);
  EXPECT_EQ(gbuffer.reuse[0].value, 2);  // 4000 / 2000: the depth line has no footprint
  EXPECT_EQ(gbuffer.reuse[2].value, 8);  // 4000 / 500
  EXPECT_EQ(gbuffer.reuse[2].ratio, 4);
  EXPECT_EQ(gbuffer.bytes[0].value, 4200);

  std::map<std::string, const ResourceComparison*> byLine;
  for (const auto& r : c->resources) byLine[r.resource + " " + r.access] = &r;
  ASSERT_TRUE(byLine.count("diffuse read"));
  EXPECT_EQ(byLine["diffuse read"]->footprintBytes[0].value, 2000);
  EXPECT_EQ(byLine["diffuse read"]->footprintBytes[2].delta, -1500);
  EXPECT_EQ(byLine["diffuse read"]->reuse[2].value, 8);
  ASSERT_TRUE(byLine.count("depth write"));
  EXPECT_FALSE(byLine["depth write"]->footprintBytes[0].value);
  EXPECT_FALSE(byLine["depth write"]->reuse[0].value);
  EXPECT_EQ(byLine["depth write"]->bytes[0].value, 200);
}

TEST_F(Footprint, ExportRowsCarryIt) {
  auto rows = store_->runs().exportRows({.jobId = jobId_});
  ASSERT_TRUE(rows) << rows.error();
  int checked = 0;
  for (const auto& r : *rows) {
    if (r.runId == ids_["deferred"] && r.resource == "diffuse") {
      EXPECT_EQ(r.footprintBytes, 2000);
      EXPECT_EQ(r.footprintRequestedBytes, 4000);
      EXPECT_EQ(r.bytes, 4000);
      ++checked;
    }
    if (r.runId == ids_["deferred"] && r.resource == "depth") {
      EXPECT_FALSE(r.footprintBytes);
      EXPECT_FALSE(r.footprintRequestedBytes);
      ++checked;
    }
    if (r.runId == ids_["forward"]) {
      EXPECT_FALSE(r.footprintBytes) << r.resource;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 5);
}

TEST_F(Footprint, BadValuesAreRefusedNamingThePath) {
  Capture negative{makeCapture({footprintRun("deferred", 64, {-1, 10}, {})}), {}};
  auto stored = store_->runs().ingestCapture(newJob(), negative.result, negative.screenshots);
  ASSERT_FALSE(stored);
  EXPECT_NE(stored.error().find("runs[0].samples[0].passes[0].resources[0].footprint_bytes: must not be negative"),
            std::string::npos)
      << stored.error();
  Capture block{makeCapture({footprintRun("deferred", 48, {10, 10}, {})}), {}};
  stored = store_->runs().ingestCapture(newJob(), block.result, block.screenshots);
  ASSERT_FALSE(stored);
  EXPECT_NE(stored.error().find("runs[0].footprint_block_bytes: must be 32, 64 or 128, got 48"), std::string::npos)
      << stored.error();
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM runs"), 3);  // nothing of either stored
}

}  // namespace
}  // namespace tally::store::testing
