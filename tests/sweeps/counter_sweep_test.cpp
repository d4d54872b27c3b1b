// The counter-headroom sweep on lavapipe. The largest slot is a per-fragment
// site (the forward pass's light loop), so its count is the load times a
// constant: the counts per fragment must be the same at every point, scale
// with the light count (x4 lights, x4 counts), and a threshold of few bits
// must be reached exactly at the points whose load passes 2^bits over that
// constant.
#include <cmath>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "sweeps/sweep.hpp"
#include "renderers/renderer.hpp"
#include "sweep_fixture.hpp"

namespace tally::sweeps {
namespace {

using nlohmann::json;

json sweep(const json& spec) { return fixture::runSpec(spec); }

json spec(uint32_t lights, int bits) {
  return {{"sweep", "counter-headroom"}, {"renderers", {"forward"}}, {"layers", {1, 3}},
          {"resolutions", {{16, 9}, {48, 27}}}, {"lights", lights}, {"threshold", {{"bits", bits}}}};
}

TEST(CounterSweep, SlotGrowsWithTheLoadAndTheLights) {
  json few = sweep(spec(25, 32)), many = sweep(spec(100, 32));
  ASSERT_EQ(few["points"].size(), 4u);
  ASSERT_EQ(many["points"].size(), 4u);
  for (size_t i = 0; i < 4; ++i) {
    const json &a = few["points"][i], &b = many["points"][i];
    // Back to front, every layer is shaded: the heaviest pass shades layers x pixels.
    EXPECT_EQ(a["load"].get<double>(), a["pixels"].get<double>() * a["layers"].get<double>()) << a.dump();
    EXPECT_EQ(a["counts_per_fragment"], few["points"][0]["counts_per_fragment"]) << a.dump();
    EXPECT_EQ(b["max_slot_count"].get<uint64_t>(), 4 * a["max_slot_count"].get<uint64_t>()) << b.dump();
    EXPECT_FALSE(a["error"]["wraps"].get<bool>());
  }
  const double perFragment = many["points"][0]["counts_per_fragment"].get<double>();
  ASSERT_EQ(many["fails_at"]["load"].size(), 2u);  // forward at 1 and at 3 layers
  for (const auto& at : many["fails_at"]["load"]) {
    EXPECT_DOUBLE_EQ(at["load"].get<double>(), std::ldexp(1.0, 32) / perFragment);
    // Forward shades every layer: the pixels that wrap fall with the overshading.
    EXPECT_DOUBLE_EQ(at["pixels"].get<double>(), at["load"].get<double>() / at["layers"].get<double>());
    EXPECT_TRUE(at["measured_load"].is_null());
  }
}

TEST(CounterSweep, FewBitsWrapWhereTheCountsPerFragmentSay) {
  // 100 lights, 16 bits: the smaller points stay under 65536, the larger wrap.
  json r = sweep(spec(100, 16));
  ASSERT_EQ(r["points"].size(), 4u);
  const double perFragment = r["points"][0]["counts_per_fragment"].get<double>();
  const double wrapLoad = 65536.0 / perFragment;
  bool anyWrapped = false;
  for (const auto& at : r["fails_at"]["load"]) {
    double smallest = -1;
    for (const auto& p : r["points"]) {
      if (p["layers"] != at["layers"]) continue;
      const bool past = p["load"].get<double>() >= wrapLoad;
      EXPECT_EQ(p["error"]["wraps"].get<bool>(), past) << p.dump();
      if (past && (smallest < 0 || p["load"].get<double>() < smallest)) smallest = p["load"].get<double>();
    }
    EXPECT_DOUBLE_EQ(at["load"].get<double>(), wrapLoad);
    if (smallest < 0) {
      EXPECT_TRUE(at["measured_load"].is_null()) << at.dump();
    } else {
      anyWrapped = true;
      EXPECT_EQ(at["measured_load"].get<double>(), smallest) << at.dump();
    }
  }
  ASSERT_TRUE(anyWrapped) << "no point reached 2^16; the spec no longer tests a crossing";
}

TEST(CounterSweep, DeferredLightingDoesNotGrowWithOvershading) {
  // Deferred's light loop runs once per covered pixel in the lighting pass,
  // whatever the G-buffer pass's overshading: its largest slot is the same at
  // 1 and 3 layers, and forward's grows x3.
  json s = spec(50, 32);
  s["renderers"] = {"forward", "deferred"};
  s["resolutions"] = {{32, 18}};
  json r = sweep(s);
  ASSERT_EQ(r["points"].size(), 4u);
  auto slot = [&](const std::string& renderer, int layers) {
    for (const auto& p : r["points"]) {
      if (p["renderer"] == renderer && p["layers"] == layers) return p["max_slot_count"].get<uint64_t>();
    }
    ADD_FAILURE() << renderer << " " << layers;
    return uint64_t{0};
  };
  EXPECT_EQ(slot("forward", 3), 3 * slot("forward", 1));
  EXPECT_EQ(slot("deferred", 3), slot("deferred", 1));
  EXPECT_EQ(slot("deferred", 1), slot("forward", 1));
}

TEST(CounterSweep, BadSpecsNameTheField) {
  auto error = [](json s) {
    auto parsed = parseSweepSpec(s, renderers::rendererNames());
    return parsed ? std::string() : parsed.error();
  };
  json good = spec(100, 32);
  EXPECT_TRUE(error(good).empty());
  auto with = [&](const std::string& key, json value) {
    json s = good;
    s[key] = value;
    return error(s);
  };
  EXPECT_TRUE(with("layers", {1, 0}).starts_with("layers[1]: must be an integer from 1 to 64")) << with("layers", {1, 0});
  EXPECT_TRUE(with("resolutions", {{16, 0}}).starts_with("resolutions[0][1]: must be an integer")) << with("resolutions", {{16, 0}});
  EXPECT_TRUE(with("renderers", {"nope"}).starts_with("renderers[0]: unknown renderer")) << with("renderers", {"nope"});
  EXPECT_TRUE(with("threshold", {{"bits", 4}}).starts_with("threshold.bits: must be an integer from 8 to 64"));
  EXPECT_TRUE(with("lights", -1).starts_with("lights: must be an integer from 1"));
  EXPECT_TRUE(with("colour", 1).starts_with("colour: unknown field"));
}

}  // namespace
}  // namespace tally::sweeps
