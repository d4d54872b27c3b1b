// A run's passes averaged over its samples (Runs::passes and Runs::detail,
// store/run_passes.cpp) against a second mechanism: the same averages
// computed in SQL by GROUP BY, as the store computed them before it summed
// the pass rows itself. Both engines (store.postgresql runs RunPasses.*).
#include <cmath>

#include "store/internal.hpp"
#include "store_fixture.hpp"

namespace tally::store::testing {
namespace {

class RunPasses : public StoreTest {
 protected:
  // The SQL aggregation, by GROUP BY over the passes and their counters
  // (unnested arrays on PostgreSQL, the counters table on SQLite).
  std::vector<Pass> sqlPasses(int64_t runId) {
    Connection* db = &store_->connection();
    Statement count(db, "SELECT COUNT(*) FROM samples WHERE run_id = ?1");
    count.bind(1, runId);
    count.step();
    const double samples = static_cast<double>(count.getInt(0));
    auto mean = [samples](std::optional<double> sum) { return sum ? std::optional(*sum / samples) : sum; };
    std::vector<Pass> out;
    Statement passes(db,
                     "SELECT p.name, SUM(p.gpu_ms), SUM(p.gpu_ms_instrumented), AVG(p.overhead_ratio), "
                     "SUM(p.fragment_invocations), SUM(p.fragment_invocations_statistic) "
                     "FROM passes p JOIN samples s ON s.id = p.sample_id WHERE s.run_id = ?1 "
                     "GROUP BY p.name ORDER BY MIN(p.position), p.name");
    passes.bind(1, runId);
    std::map<std::string, size_t> byName;
    while (passes.step()) {
      RowReader pass(passes);
      std::string name = pass.getText();
      byName[name] = out.size();
      out.push_back(Pass{name, pass.getDouble() / samples, nullptr, mean(pass.getOptDouble()), pass.getOptDouble(),
                         mean(pass.getOptDouble()), mean(pass.getOptDouble()), {}});
      pass.end();
    }
    Statement counters(db,
                       "SELECT p.name, c.resource, MIN(c.kind), MIN(c.format), c.access, SUM(c.count), SUM(c.bytes), "
                       "c.source, SUM(c.footprint_bytes) FROM samples s JOIN passes p ON p.sample_id = s.id" +
                           detail::joinPassCounters(*db, {"resource", "kind", "format", "access", "count", "bytes",
                                                          "source", "footprint_bytes"}) +
                           " WHERE s.run_id = ?1 GROUP BY p.name, c.resource, c.access, c.source "
                           "ORDER BY MIN(p.position), MIN(c.position)");
    counters.bind(1, runId);
    while (counters.step()) {
      RowReader c(counters);
      size_t pass = byName.at(c.getText());
      out[pass].counters.push_back(Counter{c.getText(), c.getOptText(), c.getOptText(), c.getText(),
                                           c.getDouble() / samples, c.getDouble() / samples, nullptr, c.getText(),
                                           mean(c.getOptDouble())});
      c.end();
    }
    return out;
  }
};

// Sums in another order may differ in the last bits.
void expectNear(std::optional<double> a, std::optional<double> b, const std::string& what) {
  ASSERT_EQ(a.has_value(), b.has_value()) << what;
  if (a) {
    EXPECT_NEAR(*a, *b, 1e-12 * std::max(1.0, std::abs(*b))) << what;
  }
}

void expectSame(const std::vector<Pass>& got, const std::vector<Pass>& want) {
  ASSERT_EQ(got.size(), want.size());
  for (size_t i = 0; i < got.size(); ++i) {
    const Pass& a = got[i];
    const Pass& b = want[i];
    EXPECT_EQ(a.name, b.name) << "pass " << i;
    expectNear(a.gpuMs, b.gpuMs, a.name + " gpu_ms");
    expectNear(a.gpuMsInstrumented, b.gpuMsInstrumented, a.name + " gpu_ms_instrumented");
    expectNear(a.overheadRatio, b.overheadRatio, a.name + " overhead_ratio");
    expectNear(a.fragmentInvocations, b.fragmentInvocations, a.name + " fragment_invocations");
    expectNear(a.fragmentInvocationsStatistic, b.fragmentInvocationsStatistic, a.name + " statistic");
    ASSERT_EQ(a.counters.size(), b.counters.size()) << a.name;
    for (size_t k = 0; k < a.counters.size(); ++k) {
      const Counter& x = a.counters[k];
      const Counter& y = b.counters[k];
      const std::string what = a.name + " counter " + std::to_string(k) + " " + y.resource;
      EXPECT_EQ(x.resource, y.resource) << what;
      EXPECT_EQ(x.kind, y.kind) << what;
      EXPECT_EQ(x.format, y.format) << what;
      EXPECT_EQ(x.access, y.access) << what;
      EXPECT_EQ(x.source, y.source) << what;
      expectNear(x.count, y.count, what + " count");
      expectNear(x.bytes, y.bytes, what + " bytes");
      expectNear(x.footprintBytes, y.footprintBytes, what + " footprint");
      EXPECT_TRUE(x.countSpread.is_null()) << what;
    }
  }
}

json counter(const std::string& name, const std::string& access, double count, const std::string& source = "counter") {
  return makeCounter(name, access, count, count * 4, source);
}

// Passes that come and go between samples and change places, a pass without
// counters, counters that come and go, kinds and formats that differ or are
// missing, a footprint on some samples only, and resource names that an
// array's text form must quote: commas, quotes, backslashes, braces,
// spaces, the word NULL and non-ASCII letters.
Capture unevenCapture() {
  const std::vector<std::string> names = {"a,b", "q\"uote", "back\\slash", "{brace}", "sp ace", "NULL", "null",
                                          "\xc3\xbc" "ber", "plain"};
  std::vector<json> samples;
  for (int s = 0; s < 3; ++s) {
    std::vector<json> passes;
    // The same resource written, and read as a derived count: with the
    // "plain" read below, three lines. Then the names, the last s of them
    // missing from sample s (each name keeps its position: no ties in order).
    std::vector<json> first = {counter("plain", "write", 7 + s), counter("plain", "read", 9 + s, "derived")};
    for (size_t n = 0; n + static_cast<size_t>(s) < names.size(); ++n) {
      double count = 1000.0 * static_cast<double>(n + 1) + 0.1 * s + 1e15 * (n == 0);
      json c = counter(names[n], n % 2 ? "write" : "read", count, n == 2 ? "derived" : "counter");
      if (n == 1) c["kind"] = s == 1 ? json(nullptr) : json(s == 0 ? "texture" : "buffer");
      if (n == 3) c["format"] = s == 2 ? "A8_UNORM" : "R32_UINT";
      if (n == 4 && s != 1) c["footprint_bytes"] = 64.0 * (s + 1);
      first.push_back(c);
    }
    json opaque = makePass("opaque", 0.5 + 0.25 * s, 1000 + s, first);
    if (s == 2) {
      opaque.erase("gpu_ms_instrumented");
      opaque.erase("overhead_ratio");
      opaque.erase("fragment_invocations_statistic");
    }
    // sky: "stars" in sample 0, where sky is the second pass, and "cube" in
    // sample 1, where it is the first: cube comes first though seen second.
    json sky = makePass("sky", 0.125, 50, {s == 0 ? counter("stars", "read", 5) : counter("cube", "read", 30 + s)});
    json post = makePass("post", 0.0625 * (s + 1), 0, {});  // no counters
    json extra = makePass("extra", 0.03, 5, {counter("plain", "read", 2), counter("lut", "read", 3 + s)});
    if (s == 0) passes = {opaque, sky, post};
    if (s == 1) passes = {sky, opaque, extra, post};  // places changed, and a pass only here
    if (s == 2) passes = {opaque, post};
    samples.push_back(makeSample(s, 2.0 + s, std::move(passes)));
  }
  Capture c;
  c.result = makeCapture({makeRun("forward", "atrium", 320, 180, std::move(samples))});
  return c;
}

TEST_F(RunPasses, SummedAsSqlGroupsThem) {
  int64_t job = newJob();
  ingest(job, unevenCapture());
  ingest(newJob(), realisticCapture(3));  // other runs' passes stay out
  auto runs = store_->runs().list({.jobId = job}, {});
  ASSERT_TRUE(runs) << runs.error();
  ASSERT_EQ(runs->runs.size(), 1u);
  const int64_t id = runs->runs[0].id;

  std::vector<Pass> want = sqlPasses(id);
  ASSERT_EQ(want.size(), 4u);  // opaque, sky, post, extra
  auto passes = store_->runs().passes(id);
  ASSERT_TRUE(passes) << passes.error();
  expectSame(*passes, want);
  auto detailed = store_->runs().detail(id);
  ASSERT_TRUE(detailed && detailed->has_value()) << (detailed ? "" : detailed.error());
  expectSame((*detailed)->passes, want);

  // Figures derived by hand, beside the SQL: opaque is in all 3 samples,
  // extra in one; "plain" (the last name) is read in sample 0 only, and its
  // mean is over all 3.
  const Pass& opaque = (*passes)[0];
  EXPECT_EQ(opaque.name, "opaque");
  EXPECT_DOUBLE_EQ(opaque.gpuMs, (0.5 + 0.75 + 1.0) / 3);
  EXPECT_DOUBLE_EQ(*opaque.overheadRatio, 1.1);              // the two samples that have one
  EXPECT_DOUBLE_EQ(*opaque.gpuMsInstrumented, (0.5 * 1.1 + 0.75 * 1.1) / 3);
  const Pass& extra = (*passes)[3];
  EXPECT_EQ(extra.name, "extra");
  EXPECT_DOUBLE_EQ(extra.gpuMs, 0.03 / 3);
  EXPECT_TRUE((*passes)[2].counters.empty());  // post
  ASSERT_EQ((*passes)[1].counters.size(), 2u);
  EXPECT_EQ((*passes)[1].counters[0].resource, "cube");
  EXPECT_EQ((*passes)[1].counters[1].resource, "stars");
  ASSERT_EQ(opaque.counters.size(), 11u);
  EXPECT_EQ(opaque.counters[0].resource, "plain");
  EXPECT_EQ(opaque.counters[0].access, "write");
  EXPECT_EQ(opaque.counters[10].resource, "plain");
  EXPECT_DOUBLE_EQ(opaque.counters[10].count, 9000.0 / 3);
  bool sawNull = false, sawBrace = false;
  for (const Counter& c : opaque.counters) {
    if (c.resource == "NULL") {
      sawNull = true;
      EXPECT_DOUBLE_EQ(c.count, (6000.0 + 6000.1 + 6000.2) / 3);
    }
    if (c.resource == "{brace}") {
      sawBrace = true;
      EXPECT_EQ(c.format, "A8_UNORM");  // the least
    }
    if (c.resource == "q\"uote") {
      EXPECT_EQ(c.kind, "buffer");  // the least of texture, none and buffer
    }
    if (c.resource == "sp ace") {
      EXPECT_DOUBLE_EQ(*c.footprintBytes, (64.0 + 192.0) / 3);
    }
  }
  EXPECT_TRUE(sawNull);
  EXPECT_TRUE(sawBrace);
}

// The Sponza-shaped captures of the other suites agree as well, run by run.
TEST_F(RunPasses, RealisticRunsAgreeWithSql) {
  ingest(newJob(), realisticCapture(1));
  ingest(newJob(), mixedCapture(0.5));
  auto runs = store_->runs().list({}, {});
  ASSERT_TRUE(runs) << runs.error();
  ASSERT_GE(runs->runs.size(), 4u);
  for (const RunRow& run : runs->runs) {
    auto passes = store_->runs().passes(run.id);
    ASSERT_TRUE(passes) << passes.error();
    expectSame(*passes, sqlPasses(run.id));
  }
}

}  // namespace
}  // namespace tally::store::testing
