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

}  // namespace
