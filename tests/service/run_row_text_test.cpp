// The runs listing's JSON written as text (service/json_text.hpp,
// runPageText) against nlohmann's dump() of the same values, as the HTTP
// transport dumps them (compact, invalid UTF-8 replaced): scalars, strings
// with every kind of byte, run rows with every optional null and set, and
// whole pages against the json the listing built before.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <stdexcept>

#include "service/json_rows.hpp"

namespace {
using nlohmann::json;
using tally::service::detail::JsonText;
namespace sd = tally::service::detail;
namespace store = tally::store;

std::string dumped(const json& j) { return j.dump(-1, ' ', false, json::error_handler_t::replace); }

template <class T>
std::string written(const T& v) {
  std::string out;
  JsonText text(out);
  text.value(v);
  return out;
}

std::vector<double> someDoubles() {
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> v = {0.0, -0.0, 0.1, 0.2, 0.3, 1.0, -1.0, 2.5, 1e21, 1e22, 1e-7, 1e-5, 1e-6, 123456789012345678.0,
                           1e15, 1e16, 1e17, 9007199254740993.0, 3.14159, 100.0, 42.0, -273.15, 5e-324, 2.2250738585072014e-308,
                           std::numeric_limits<double>::max(), std::numeric_limits<double>::lowest(),
                           std::numeric_limits<double>::min(), std::nan(""), inf, -inf, 1.0 / 3.0, 2.0 / 3.0, 16.666666666666668};
  std::mt19937_64 rng(20261129);
  for (int i = 0; i < 20000; ++i) {
    uint64_t bits = rng();
    double d;
    std::memcpy(&d, &bits, sizeof d);
    v.push_back(d);  // every exponent, NaNs and infinities among them
  }
  std::uniform_real_distribution<double> ms(0, 100);
  for (int i = 0; i < 5000; ++i) v.push_back(ms(rng));         // frame times
  for (int i = 0; i < 2000; ++i) v.push_back(std::round(ms(rng)));  // integral values
  return v;
}

std::vector<std::string> someStrings() {
  std::vector<std::string> v = {"", "forward", "say \"hi\"", "back\\slash", "tab\there", "nl\nx", "cr\rx", "\b\f",
                                std::string("nul\0byte", 8), "\x01\x1f\x7f", "caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x98\x80",
                                "bad \xff byte", "cut \xe2\x82", "\xc3", "over\xc0\xaf long", "surrogate \xed\xa0\x80",
                                "</script>", "a/b", "\xe2\x80\xa8"};
  // Random strings over a few of each kind of byte.
  const std::string alphabet = std::string("ab\"\\/ \x01\x1f\x7f\x80\xbf\xc3\xa9\xe2\x82\xac\xf0\x9f\xff\xed\xa0", 22) + '\0';
  std::mt19937 rng(7);
  for (int i = 0; i < 20000; ++i) {
    std::string s(rng() % 12, ' ');
    for (char& c : s) c = alphabet[rng() % alphabet.size()];
    v.push_back(s);
  }
  return v;
}

TEST(JsonText, ScalarsAsDump) {
  for (double d : someDoubles()) EXPECT_EQ(written(d), dumped(json(d))) << std::hexfloat << d;
  for (int64_t i : {int64_t{0}, int64_t{-1}, int64_t{7}, int64_t{-273}, std::numeric_limits<int64_t>::max(),
                    std::numeric_limits<int64_t>::min(), int64_t{1} << 53})
    EXPECT_EQ(written(i), dumped(json(i))) << i;
  for (const auto& s : someStrings()) EXPECT_EQ(written(s), dumped(json(s))) << json(s).dump(-1, ' ', true, json::error_handler_t::replace);
  EXPECT_EQ(written(true), "true");
  EXPECT_EQ(written(std::optional<double>()), "null");
  json nested = {{"b", {1, 2.5, "x\"y"}}, {"a", json::object()}, {"c", "bad \xff"}};
  EXPECT_EQ(written(nested), dumped(nested));
}

TEST(JsonText, RefusesKeysOutOfOrder) {
  std::string out;
  JsonText text(out);
  text.beginObject();
  text.key("b");
  text.value(1);
  EXPECT_THROW(text.key("a"), std::logic_error);
  EXPECT_THROW(text.key("b"), std::logic_error);  // twice
  text.key("device_id");
  EXPECT_THROW(text.value(1); text.value(2), std::logic_error);  // a value without its key
}

store::RunRow someRun(int64_t id, bool set, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0, 1000);
  store::RunRow r;
  r.id = id;
  r.jobId = id / 3;
  r.deviceId = -id;  // negative ints
  r.deviceName = set ? "NVIDIA H200 \"SXM\" \\ caf\xc3\xa9" : "lavapipe";
  r.renderer = "forward";
  r.scene = set ? "atrium\tbad \xff" : "sponza";
  r.sceneParams = set ? json{{"lights", 64}, {"z", 0.1}, {"name", "q\"\x01"}} : json::object();
  r.width = 1920;
  r.height = 1080;
  r.counting = set ? "back\\slash" : "exact";
  r.lights = static_cast<int>(id % 100);
  r.notes = set ? json{{"why", "line\nbreak"}, {"n", -0.0}} : json::object();
  r.createdAt = "2026-11-29T12:00:00Z";
  r.sampleCount = set ? 10 : 0;
  r.options = set ? json{{"uv_derivatives", "unorm16-clamped"}} : json::object();
  r.variant = set ? "visbuffer uv_derivatives=unorm16-clamped" : "forward";
  r.labels = set ? json{{"commit", "more-lights"}, {"\xe2\x82\xac", "\xc3"}} : json::object();
  if (set) {
    r.renderTargetBytes = int64_t{1} << 40;
    r.meanFrameMs = u(rng);
    r.meanBytes = 1e21;
    r.meanFrameMsInstrumented = 1e-7;
    r.meanOverheadRatio = 2.0;
    r.imageCompared = 3;
    r.imageIdentical = 1;
    r.meanPsnr = u(rng);
    r.minPsnr = std::numeric_limits<double>::infinity();
    r.tallyVersion = "0.9.0";
    r.tallyCommit = "2ca8eb1\x7f";
    r.footprintBlockBytes = 64;
    r.meanFootprintBytes = u(rng);
    r.meanFootprintRequestedBytes = u(rng) * 3;
    r.host = "gpu-01";
  } else if (id % 2) {
    r.imageCompared = 2;  // image_error present, PSNRs null
    r.imageIdentical = 2;
    r.meanFootprintBytes = 0.0;  // reuse null at 0
  }
  return r;
}

// The frame median as addFrameMedian added it to the row before.
json oldRow(const store::RunRow& r, const store::RunFrameTime& t) {
  json j = sd::runRowJson(r);
  j["frame_ms_median"] = t.median ? json(*t.median) : json(nullptr);
  j["frame_ms_median_source"] = t.source;
  return j;
}

TEST(JsonText, RunRowsAndPagesAsTheJsonDumped) {
  std::mt19937 rng(1);
  store::RunPage page;
  std::map<int64_t, store::RunFrameTime> frameTimes;
  for (int64_t id = 60; id > 0; --id) {
    page.runs.push_back(someRun(id, id % 3 != 0, rng));
    if (id % 4 == 0) continue;  // no frame time: the page writes source "none"
    store::RunFrameTime t;
    if (id % 5) t.median = id * 0.1;
    t.source = id % 2 ? "frames" : "samples";
    frameTimes[id] = t;
  }
  json runs = json::array();
  for (const auto& r : page.runs) {
    store::RunFrameTime t = frameTimes.count(r.id) ? frameTimes[r.id] : store::RunFrameTime{};
    std::string out;
    JsonText text(out);
    sd::writeRunRow(text, r, &t);
    json expected = oldRow(r, t);
    EXPECT_EQ(out, dumped(expected)) << r.id;
    EXPECT_EQ(dumped(sd::runRowJson(r, &t)), dumped(expected)) << r.id;
    runs.push_back(expected);
  }
  for (std::string cursor : {"", "NTA"}) {
    page.nextCursor = cursor;
    json old = {{"runs", runs}, {"next_cursor", cursor.empty() ? json(nullptr) : json(cursor)}};
    EXPECT_EQ(sd::runPageText(page, frameTimes), dumped(old)) << "cursor '" << cursor << "'";
  }
  store::RunPage empty;
  EXPECT_EQ(sd::runPageText(empty, {}), dumped({{"runs", json::array()}, {"next_cursor", nullptr}}));
}

// GET /api/runs/{id}'s body as the route built it before, as json: the row
// with its frame time, then each part with its keys listed here.
json oldDetail(const store::RunDetail& d, const store::RunFrameTime& t) {
  auto opt = [](const auto& v) { return v ? json(*v) : json(nullptr); };
  auto reuse = [](std::optional<double> requested, std::optional<double> footprint) {
    return footprint && *footprint > 0 ? json(requested.value_or(0) / *footprint) : json(nullptr);
  };
  json j = sd::runRowJson(d.run.row, &t);
  const store::Device& dev = d.run.device;
  j["device_info"] = {{"id", dev.id},           {"name", dev.name},         {"vendor", dev.vendor}, {"driver", dev.driver},
                      {"api_version", dev.apiVersion}, {"features", dev.features}, {"info", dev.info}};
  json resources = json::array();
  for (const auto& r : d.run.resources) {
    resources.push_back({{"name", r.name}, {"kind", r.kind}, {"format", opt(r.format)},
                         {"element_bytes", opt(r.elementBytes)}, {"width", opt(r.width)}, {"height", opt(r.height)},
                         {"allocation_bytes", opt(r.allocationBytes)}, {"format_bytes", opt(r.formatBytes)},
                         {"usage", opt(r.usage)}});
  }
  j["resources"] = resources;
  j["shaders"] = d.run.shaders;
  j["counter_headroom"] = d.run.counterHeadroom;
  j["ceilings"] = d.run.ceilings;
  json passes = json::array();
  for (const auto& p : d.passes) {
    json lines = json::array();
    double bytes = 0;
    std::optional<double> footprint, requested;
    for (const auto& c : p.counters) {
      lines.push_back({{"name", c.resource}, {"kind", opt(c.kind)}, {"format", opt(c.format)}, {"access", c.access},
                       {"count", c.count}, {"bytes", c.bytes}, {"footprint_bytes", opt(c.footprintBytes)},
                       {"reuse", reuse(c.bytes, c.footprintBytes)}, {"count_spread", c.countSpread},
                       {"source", c.source}});
      bytes += c.bytes;
      if (c.footprintBytes) {
        footprint = footprint.value_or(0) + *c.footprintBytes;
        requested = requested.value_or(0) + c.bytes;
      }
    }
    passes.push_back({{"name", p.name}, {"gpu_ms", p.gpuMs}, {"gpu_ms_spread", p.gpuMsSpread},
                      {"gpu_ms_instrumented", opt(p.gpuMsInstrumented)}, {"overhead_ratio", opt(p.overheadRatio)},
                      {"fragment_invocations", opt(p.fragmentInvocations)},
                      {"fragment_invocations_statistic", opt(p.fragmentInvocationsStatistic)},
                      {"compute_invocations", opt(p.computeInvocations)},
                      {"compute_invocations_statistic", opt(p.computeInvocationsStatistic)}, {"bytes", bytes},
                      {"footprint_bytes", opt(footprint)}, {"reuse", reuse(requested, footprint)},
                      {"resources", lines}});
  }
  j["passes"] = passes;
  return j;
}

TEST(JsonText, RunDetailAsTheJsonDumped) {
  std::mt19937 rng(3);
  const std::vector<double> doubles = someDoubles();
  const std::vector<std::string> strings = someStrings();
  auto number = [&]() { return doubles[rng() % doubles.size()]; };
  auto text = [&]() { return strings[rng() % strings.size()]; };
  auto maybe = [&](auto value) { return rng() % 3 ? std::optional(value) : std::nullopt; };
  for (int64_t id = 1; id <= 200; ++id) {
    store::RunDetail d;
    d.run.row = someRun(id, id % 3 != 0, rng);
    d.run.device = {id, text(), text(), text(), text(), id % 2 ? json{{"shaderInt64", true}} : json::object(),
                    id % 4 ? json{{"sub", {{"x", number()}}}} : json::object()};
    for (int r = 0; r < static_cast<int>(id % 5); ++r) {
      d.run.resources.push_back({text(), text(), maybe(text()), maybe(int64_t{8}), maybe(int64_t{1920}),
                                 maybe(int64_t{-1}), maybe(int64_t{1} << 40), maybe(int64_t{0}), maybe(text())});
    }
    d.run.shaders = id % 2 ? json{{"forward.frag", "9c1d00aa"}, {text(), text()}} : json::object();
    d.run.counterHeadroom = id % 3 ? json{{"wrap_factor", number()}} : json(nullptr);
    d.run.ceilings = id % 4 ? json{{"bandwidth_bytes_per_s", number()}, {"ridge_intensity", number()}} : json(nullptr);
    for (int p = 0; p < static_cast<int>(id % 6); ++p) {
      store::Pass pass;
      pass.name = text();
      pass.gpuMs = number();
      pass.gpuMsSpread = id % 2 ? json(nullptr) : json{{"median", number()}, {"n", 20}};
      pass.gpuMsInstrumented = maybe(number());
      pass.overheadRatio = maybe(number());
      pass.fragmentInvocations = maybe(number());
      pass.fragmentInvocationsStatistic = maybe(number());
      pass.computeInvocations = maybe(number());
      pass.computeInvocationsStatistic = maybe(number());
      for (int c = 0; c < static_cast<int>(rng() % 8); ++c) {
        // Footprints of 0, absent and any double: reuse null, and not.
        std::optional<double> footprint = rng() % 3 == 0 ? std::nullopt : std::optional(rng() % 4 ? number() : 0.0);
        pass.counters.push_back({text(), maybe(text()), maybe(text()), c % 2 ? "read" : "write", number(), number(),
                                 rng() % 2 ? json(nullptr) : json{{"n", 20}, {"q1", number()}}, text(), footprint});
      }
      d.passes.push_back(std::move(pass));
    }
    store::RunFrameTime t;
    if (id % 5) t.median = number();
    t.source = id % 2 ? "frames" : "none";
    EXPECT_EQ(sd::runDetailText(d, &t), dumped(oldDetail(d, t))) << id;
    if (!d.passes.empty()) {  // passJson, which a sample's route uses, from the same list of keys
      EXPECT_EQ(dumped(sd::passJson(d.passes[0])), dumped(oldDetail(d, t)["passes"][0])) << id;
    }
  }
}

}  // namespace
