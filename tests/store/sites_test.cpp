// Sites, draws, materials and shader sources (migration 0011): a capture
// result with them (tests/store/sites_fixture.hpp, computed from the
// result's own lines) is read back as it went in, ranked by bytes and paged;
// bad fields are refused naming the field with nothing stored; the limits
// hold (257 draws: the heaviest 256 kept, the rest summed).
#include <algorithm>
#include <set>

#include "sites_fixture.hpp"
#include "store_fixture.hpp"

namespace tally::store::testing {
namespace {

class Sites : public StoreTest {
 protected:
  // The stored samples of the capture's runs, in the result's order.
  std::vector<int64_t> sampleIds() {
    std::vector<int64_t> ids;
    auto page = store_->runs().list({}, {});
    EXPECT_TRUE(page) << page.error();
    std::vector<int64_t> runs;
    for (const auto& run : page->runs) runs.push_back(run.id);
    std::sort(runs.begin(), runs.end());
    for (int64_t run : runs) {
      auto samples = store_->runs().samples(run);
      EXPECT_TRUE(samples) << samples.error();
      if (samples) {
        for (const auto& sample : *samples) ids.push_back(sample.id);
      }
    }
    return ids;
  }
  SitePage allSites(int64_t sample, SiteGrouping grouping = SiteGrouping::Site, std::optional<std::string> pass = {}) {
    auto page = store_->runs().sites(sample, {pass, grouping, 1000, 0});
    EXPECT_TRUE(page) << page.error();
    EXPECT_TRUE(page->has_value());
    return page->value_or(SitePage{});
  }
  // The ingest's error for `result`; nothing of it must be stored.
  std::string refused(const json& result) {
    auto stored = store_->runs().ingestCapture(newJob(), result, realisticCapture().screenshots);
    EXPECT_FALSE(stored);
    EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM runs"), 0);
    EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM pass_sites"), 0);
    EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM shader_sources"), 0);
    return stored ? "" : stored.error();
  }
};

TEST_F(Sites, ReadBackAsTheyWentIn) {
  Capture c = realisticCapture(1);
  c.result = withSites(c.result);
  ingest(newJob(), c);
  std::vector<int64_t> samples = sampleIds();
  ASSERT_EQ(samples.size(), 4u);
  size_t s = 0;
  for (const auto& run : c.result["runs"]) {
    for (const auto& sample : run["samples"]) {
      SitePage page = allSites(samples[s++]);
      std::multiset<std::string> expected, got;
      size_t sites = 0;
      for (const auto& pass : sample["passes"]) {
        for (const auto& site : pass["sites"]) {
          expected.insert(pass["name"].get<std::string>() + "|" + site["shader"].get<std::string>() + "|" +
                          std::to_string(site["instruction"].get<int>()) + "|" + site["resource"].get<std::string>() + "|" +
                          site["access"].get<std::string>() + "|" + (site.contains("line") ? site["line"].dump() : "-") + "|" +
                          site["disassembly"].get<std::string>() + "|" + json(site["bytes"].get<double>()).dump() + "|" +
                          json(site["count"].get<double>()).dump());
          ++sites;
        }
      }
      for (const auto& row : page.rows) {
        EXPECT_EQ(row.stage, "fragment");
        EXPECT_EQ(row.entryPoint, "main");
        EXPECT_EQ(row.opcode, "OpImageSampleImplicitLod");
        got.insert(row.pass + "|" + row.shader + "|" + std::to_string(row.instruction.value_or(-1)) + "|" + row.resource + "|" + row.access +
                   "|" + (row.line ? std::to_string(*row.line) : "-") + "|" + row.disassembly + "|" + json(row.bytes).dump() +
                   "|" + json(row.count).dump());
      }
      EXPECT_EQ(got, expected);
      EXPECT_EQ(page.total, static_cast<int64_t>(sites));
      EXPECT_TRUE(std::is_sorted(page.rows.begin(), page.rows.end(),
                                 [](const SiteRow& a, const SiteRow& b) { return a.bytes > b.bytes; }));
      // Each pass's bytes are its lines' sum.
      ASSERT_EQ(page.passes.size(), sample["passes"].size());
      for (size_t p = 0; p < page.passes.size(); ++p) {
        double bytes = 0;
        for (const auto& line : sample["passes"][p]["resources"]) bytes += line["bytes"].get<double>();
        EXPECT_DOUBLE_EQ(page.passes[p].bytes, bytes);
        EXPECT_EQ(page.passes[p].name, sample["passes"][p]["name"]);
      }
    }
  }
  // The shaders, once each.
  auto runs = store_->runs().list({}, {});
  for (const auto& run : runs->runs) {
    auto shaders = store_->runs().shaderSources(run.id);
    ASSERT_TRUE(shaders) << shaders.error();
    EXPECT_EQ(shaders->size(), 4u);
    for (const auto& shader : *shaders) {
      auto one = store_->runs().shaderSource(run.id, shader.name);
      ASSERT_TRUE(one && *one);
      const json& given = c.result["runs"][run.renderer == "forward" ? 0 : 1]["shader_sources"][shader.name];
      EXPECT_EQ((*one)->text, given.get<std::string>());
      EXPECT_EQ((*one)->length, static_cast<int64_t>(given.get<std::string>().size()));
      EXPECT_EQ((*one)->lines, std::count((*one)->text.begin(), (*one)->text.end(), '\n'));
    }
  }
  auto none = store_->runs().shaderSource(runs->runs.front().id, "no.such.glsl");
  ASSERT_TRUE(none);
  EXPECT_FALSE(none->has_value());
}

// As an application's module may give them: no instruction, an empty kind,
// shader and entry point.
TEST_F(Sites, SitesWithoutInstructionOrNames) {
  Capture c = realisticCapture(8);
  c.result = withSites(c.result);
  json& site = c.result["runs"][0]["samples"][0]["passes"][1]["sites"][0];
  site.erase("instruction");
  site["kind"] = "";
  site["shader"] = "";
  site["entry_point"] = "";
  double bytes = site["bytes"];
  ingest(newJob(), c);
  SitePage page = allSites(sampleIds().front(), SiteGrouping::Site, "opaque");
  auto found = std::find_if(page.rows.begin(), page.rows.end(), [](const SiteRow& r) { return !r.instruction; });
  ASSERT_NE(found, page.rows.end());
  EXPECT_DOUBLE_EQ(found->bytes, bytes);
  EXPECT_FALSE(found->kind);
  EXPECT_EQ(found->shader, "");
  EXPECT_EQ(std::count_if(page.rows.begin(), page.rows.end(), [](const SiteRow& r) { return !r.instruction; }), 1);
}

TEST_F(Sites, ByLineSumsTheSitesOfEachLine) {
  Capture c = realisticCapture(2);
  c.result = withSites(c.result);
  ingest(newJob(), c);
  int64_t sample = sampleIds().front();
  const json& pass = c.result["runs"][0]["samples"][0]["passes"][1];
  std::map<std::string, std::pair<double, int>> expected;  // line (or "#instruction") -> bytes, sites
  for (const auto& site : pass["sites"]) {
    std::string key = site.contains("line") ? site["line"].dump() : "#" + site["instruction"].dump();
    expected[key].first += site["bytes"].get<double>();
    expected[key].second += 1;
  }
  SitePage page = allSites(sample, SiteGrouping::Line, pass["name"].get<std::string>());
  ASSERT_EQ(page.rows.size(), expected.size());
  EXPECT_EQ(page.total, static_cast<int64_t>(expected.size()));
  double sum = 0;
  for (const auto& row : page.rows) {
    std::string key = row.line ? std::to_string(*row.line) : "#" + std::to_string(row.instruction.value_or(-1));
    ASSERT_TRUE(expected.count(key)) << key;
    EXPECT_DOUBLE_EQ(row.bytes, expected[key].first) << key;
    EXPECT_EQ(row.sites, expected[key].second) << key;
    EXPECT_EQ(row.pass, pass["name"]);
    EXPECT_FALSE(row.resources.empty());
    sum += row.bytes;
  }
  EXPECT_TRUE(std::is_sorted(page.rows.begin(), page.rows.end(),
                             [](const SiteRow& a, const SiteRow& b) { return a.bytes > b.bytes; }));
  // Every counted line has sites, so the lines sum to the pass's counted
  // lines (a derived line, such as the depth writes, has no site).
  double counted = 0;
  for (const auto& line : pass["resources"]) {
    if (line["source"] == "counter") counted += line["bytes"].get<double>();
  }
  EXPECT_NEAR(sum, counted, 1e-9 * counted);
  EXPECT_LT(counted, page.passes[1].bytes);
}

TEST_F(Sites, PagesJoinIntoTheWhole) {
  Capture c = realisticCapture(3);
  c.result = withSites(c.result, {.sitesPerLine = 5, .drawsPerPass = 40});
  ingest(newJob(), c);
  int64_t sample = sampleIds().back();
  SitePage whole = allSites(sample);
  std::vector<SiteRow> joined;
  for (int64_t offset = 0;; offset += 7) {
    auto page = store_->runs().sites(sample, {std::nullopt, SiteGrouping::Site, 7, offset});
    ASSERT_TRUE(page && *page);
    EXPECT_EQ((*page)->total, whole.total);
    if ((*page)->rows.empty()) break;
    joined.insert(joined.end(), (*page)->rows.begin(), (*page)->rows.end());
  }
  ASSERT_EQ(joined.size(), whole.rows.size());
  for (size_t i = 0; i < joined.size(); ++i) {
    EXPECT_EQ(joined[i].instruction, whole.rows[i].instruction);
    EXPECT_EQ(joined[i].pass, whole.rows[i].pass);
  }
  // Draws of one pass, paged, in bytes order.
  std::string passName = c.result["runs"][1]["samples"][1]["passes"][2]["name"];
  std::vector<DrawRow> draws;
  for (int64_t offset = 0; offset < 100; offset += 15) {
    auto page = store_->runs().draws(sample, {passName, false, 15, offset});
    ASSERT_TRUE(page && *page);
    EXPECT_EQ((*page)->total, 40);
    draws.insert(draws.end(), (*page)->draws.begin(), (*page)->draws.end());
  }
  ASSERT_EQ(draws.size(), 40u);
  EXPECT_TRUE(std::is_sorted(draws.begin(), draws.end(), [](const DrawRow& a, const DrawRow& b) { return a.bytes > b.bytes; }));
  for (const auto& d : draws) EXPECT_EQ(d.pass, passName);
  // Materials: as the result gave them.
  auto materials = store_->runs().draws(sample, {passName, true, 100, 0});
  ASSERT_TRUE(materials && *materials);
  const json& given = c.result["runs"][1]["samples"][1]["passes"][2]["materials"];
  ASSERT_EQ((*materials)->materials.size(), given.size());
  for (size_t m = 0; m < given.size(); ++m) {
    EXPECT_EQ((*materials)->materials[m].material, given[m]["material"]);
    EXPECT_DOUBLE_EQ((*materials)->materials[m].bytes, given[m]["bytes"].get<double>());
    EXPECT_EQ((*materials)->materials[m].draws, given[m]["draws"].get<int64_t>());
  }
  // A pass the sample lacks selects nothing; an unknown sample is empty.
  auto other = store_->runs().draws(sample, {"no such pass", false, 10, 0});
  ASSERT_TRUE(other && *other);
  EXPECT_TRUE((*other)->draws.empty());
  auto unknown = store_->runs().sites(999999, {});
  ASSERT_TRUE(unknown);
  EXPECT_FALSE(unknown->has_value());
  EXPECT_FALSE(store_->runs().sites(sample, {std::nullopt, SiteGrouping::Site, 0, 0}));
  EXPECT_FALSE(store_->runs().draws(sample, {std::nullopt, false, 10, -1}));
}

TEST_F(Sites, DrawsBeyondTheLimitAreSummedIntoTheRest) {
  Capture c = realisticCapture(4);
  c.result = withSites(c.result, {.sitesPerLine = 1, .drawsPerPass = 257, .foldDraws = false});
  const json& pass = c.result["runs"][0]["samples"][1]["passes"][3];
  ASSERT_EQ(pass["draws"].size(), 257u);
  double total = 0, lightest = pass["draws"].back()["bytes"];
  for (const auto& d : pass["draws"]) total += d["bytes"].get<double>();
  ingest(newJob(), c);
  int64_t sample = sampleIds()[1];
  auto page = store_->runs().draws(sample, {pass["name"].get<std::string>(), false, 1000, 0});
  ASSERT_TRUE(page && *page);
  ASSERT_EQ((*page)->draws.size(), 256u);
  EXPECT_EQ((*page)->total, 256);
  ASSERT_EQ((*page)->rests.size(), 1u);
  EXPECT_EQ((*page)->rests[0].draws, 1);
  EXPECT_DOUBLE_EQ((*page)->rests[0].bytes, lightest);
  double stored = (*page)->rests[0].bytes;
  for (const auto& d : (*page)->draws) stored += d.bytes;
  EXPECT_NEAR(stored, total, 1e-9 * total);
  EXPECT_EQ((*page)->draws.front().rank, 0);
  EXPECT_EQ((*page)->draws.back().rank, 255);
}

TEST_F(Sites, ShaderSourcesAreStoredOncePerText) {
  Capture c = realisticCapture(5);
  c.result = withSites(c.result);
  ingest(newJob(), c);
  // Each run names 4 shaders; forward and deferred share skybox's and
  // post's texts, so 6 texts; a second capture of the same build adds none.
  std::set<std::string> texts;
  for (const auto& run : c.result["runs"]) {
    for (const auto& [name, text] : run["shader_sources"].items()) texts.insert(text.get<std::string>());
  }
  ASSERT_EQ(texts.size(), 6u);
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM shader_sources"), 6);
  ingest(newJob(), c);
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM shader_sources"), 6);
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM run_shaders"), 16);
}

TEST_F(Sites, BadFieldsAreRefusedNamingThem) {
  json good = withSites(realisticCapture(6).result);
  auto with = [&](const std::function<void(json&)>& change) {
    json result = good;
    change(result);
    return refused(result);
  };
  auto site = [](json& r) -> json& { return r["runs"][0]["samples"][1]["passes"][2]["sites"][3]; };
  EXPECT_NE(with([&](json& r) { site(r)["bytes"] = -1; }).find("runs[0].samples[1].passes[2].sites[3].bytes: must not be negative"),
            std::string::npos);
  EXPECT_NE(with([&](json& r) { site(r)["access"] = "modify"; }).find("sites[3].access: must be \"read\" or \"write\""),
            std::string::npos);
  EXPECT_NE(with([&](json& r) { site(r)["line"] = 0; }).find("sites[3].line: must be at least 1"), std::string::npos);
  EXPECT_NE(with([&](json& r) { site(r).erase("disassembly"); }).find("sites[3].disassembly"), std::string::npos);
  EXPECT_NE(with([&](json& r) { site(r)["resource"] = "elsewhere"; })
                .find("sites[3].resource: \"elsewhere\" (write) is not a resource line of this pass"),
            std::string::npos);
  // A site's bytes moved off its line: the line's sites no longer sum to it.
  EXPECT_NE(with([&](json& r) { site(r)["bytes"] = site(r)["bytes"].get<double>() + 1000; })
                .find("runs[0].samples[1].passes[2].sites: the sites of"),
            std::string::npos);
  EXPECT_NE(with([&](json& r) { r["runs"][1]["samples"][0]["passes"][0]["draws"][2]["bytes"] = 1e12; })
                .find("runs[1].samples[0].passes[0].draws[2].bytes: must be bytes_read + bytes_written"),
            std::string::npos);
  EXPECT_NE(with([&](json& r) { r["runs"][1]["samples"][0]["passes"][0]["materials"][1]["draws"] = -2; })
                .find("runs[1].samples[0].passes[0].materials[1].draws: must not be negative"),
            std::string::npos);
  EXPECT_NE(with([&](json& r) { r["runs"][0]["samples"][0]["passes"][0]["draws_rest"] = {{"draws", 0}}; })
                .find("runs[0].samples[0].passes[0].draws_rest.draws: must be at least 1"),
            std::string::npos);
  EXPECT_NE(with([&](json& r) { r["runs"][0]["shader_sources"]["depth.frag.glsl"] = 3; })
                .find("runs[0].shader_sources[\"depth.frag.glsl\"]: must be the shader's source text"),
            std::string::npos);
}

TEST_F(Sites, LimitsAreRefusedNamingThem) {
  json result = withSites(realisticCapture(7).result);
  json& pass = result["runs"][0]["samples"][0]["passes"][1];
  json many = json::array();
  // 4097 sites over the pass's first line, summing to it.
  double bytes = pass["resources"][0]["bytes"].get<double>();
  for (size_t i = 0; i <= kMaxSitesPerPass; ++i) {
    json site = pass["sites"][0];
    site["bytes"] = bytes / static_cast<double>(kMaxSitesPerPass + 1);
    many.push_back(site);
  }
  json tooMany = result;
  tooMany["runs"][0]["samples"][0]["passes"][1]["sites"] = many;
  EXPECT_NE(refused(tooMany).find("runs[0].samples[0].passes[1].sites: at most 4096 sites per pass, got 4097"),
            std::string::npos);
  json large = result;
  large["runs"][1]["shader_sources"]["big.frag.glsl"] = std::string(kMaxShaderSourceBytes + 1, 'x');
  EXPECT_NE(refused(large).find("runs[1].shader_sources[\"big.frag.glsl\"]: at most 1048576 bytes of source, got 1048577"),
            std::string::npos);
  // Exactly at the limit is fine.
  large["runs"][1]["shader_sources"]["big.frag.glsl"] = std::string(kMaxShaderSourceBytes, 'x');
  EXPECT_TRUE(store_->runs().ingestCapture(newJob(), large, realisticCapture(7).screenshots));
}

}  // namespace
}  // namespace tally::store::testing
