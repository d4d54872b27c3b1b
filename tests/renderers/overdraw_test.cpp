// Forward's overdraw and overshading outputs and the depth pre-pass option
// (docs/techniques.md, "Overdraw and overshading"): the per-pixel count
// histogram equals the analytic one of the planes scene, its fragment sum
// equals the fragment invocations the instrumented forward pass counted, the
// defaults leave forward and deferred as they are, and bad option values are
// refused with the option named. Per-pass counts of these variants are
// checked in analytic_test.cpp (AnalyticVariants).
#include <cinttypes>
#include <cstdio>
#include <map>
#include <string>

#include <gtest/gtest.h>

#include "analytic.hpp"
#include "render_fixture.hpp"
#include "renderers/options.hpp"

namespace tally::renderers {
using namespace fixture;
namespace {

constexpr VkExtent2D kExtent = {157, 91};

std::function<void(RendererOptions&)> withOptions(const std::string& renderer, const nlohmann::json& options) {
  auto canonical = canonicalOptions(renderer, options);
  EXPECT_TRUE(canonical.ok()) << (canonical ? "" : canonical.error());
  const nlohmann::json c = canonical ? *canonical : nlohmann::json::object();
  return [c](RendererOptions& o) { applyOptions(c, o); };
}

std::map<uint64_t, uint64_t> histogramOf(const nlohmann::json& overdraw) {
  std::map<uint64_t, uint64_t> out;
  uint64_t last = 0;
  bool first = true;
  for (const auto& bin : overdraw.at("histogram")) {
    const uint64_t count = bin.at("count").get<uint64_t>();
    EXPECT_TRUE(first || count > last) << "histogram not ascending at count " << count;
    first = false;
    last = count;
    out[count] = bin.at("pixels").get<uint64_t>();
  }
  return out;
}

// One variant on one planes scene: the histogram equals the analytic one,
// the derived figures follow from it, and its fragments equal the counted
// invocations of the forward pass.
void checkCounts(const std::string& renderer, const nlohmann::json& options, const nlohmann::json& spec) {
  const std::string label = renderer + " " + options.dump() + " " + spec.dump();
  const analytic::Geometry g = analytic::geometryOf(spec, kExtent);
  ASSERT_FALSE(g.rows.ambiguous) << label;
  Rendered r = render(renderer, spec, kExtent, withOptions(renderer, options));
  ASSERT_TRUE(r.ok) << label << ": " << r.error;
  ASSERT_TRUE(r.extras.contains("overdraw")) << label << ": " << r.extras.dump();
  const nlohmann::json& o = r.extras["overdraw"];
  EXPECT_EQ(o.at("mode"), options.at("output")) << label;

  const bool prepass = renderer == "forward-zprepass" || options.value("zprepass", false);
  const auto want = analytic::countHistogram(g, options.at("output"), prepass);
  const auto got = histogramOf(o);
  EXPECT_EQ(got, want) << label << ": " << o.dump();

  uint64_t fragments = 0, covered = 0, max = 0;
  for (const auto& [count, pixels] : want) {
    fragments += count * pixels;
    if (count > 0) covered += pixels;
    max = std::max(max, count);
  }
  EXPECT_EQ(o.at("fragments").get<uint64_t>(), fragments) << label;
  EXPECT_EQ(o.at("covered_pixels").get<uint64_t>(), covered) << label;
  EXPECT_EQ(o.at("max").get<uint64_t>(), max) << label;
  EXPECT_DOUBLE_EQ(o.at("mean_per_covered_pixel").get<double>(), double(fragments) / double(covered)) << label;
  EXPECT_TRUE(o.at("counts_exact").get<bool>()) << label;

  // The count target against the counters: the same fragments.
  const PassResult& forward = passNamed(r, "forward");
  EXPECT_EQ(o.at("counted_fragments").get<uint64_t>(), forward.fragmentInvocations) << label;
  EXPECT_EQ(o.at("fragments").get<uint64_t>(), forward.fragmentInvocations) << label;
  EXPECT_TRUE(o.at("agrees").get<bool>()) << label;
  std::printf("  %s: %" PRIu64 " fragments over %" PRIu64 " covered pixels (%.3f per pixel), counted %" PRIu64
              ", statistic %s\n",
              label.c_str(), o["fragments"].get<uint64_t>(), covered, o["mean_per_covered_pixel"].get<double>(),
              forward.fragmentInvocations, o["statistic_fragments"].dump().c_str());
}

TEST(Overdraw, HistogramIsEveryLayerOnEveryCoveredPixel) {
  // No depth test: every layer in either order.
  for (const char* order : {"back-to-front", "front-to-back"}) {
    checkCounts("forward", {{"output", "overdraw"}}, planes(3, order, 0.5));
    checkCounts("forward", {{"output", "overdraw"}}, planes(4, order, 1.0));
  }
}

TEST(Overshading, FrontToBackShadesOncePerPixelBackToFrontEveryLayer) {
  checkCounts("forward", {{"output", "overshading"}}, planes(4, "front-to-back", 0.5));
  checkCounts("forward", {{"output", "overshading"}}, planes(4, "back-to-front", 0.5));
  // After the pre-pass, once per covered pixel in either order.
  checkCounts("forward-zprepass", {{"output", "overshading"}}, planes(4, "back-to-front", 0.5));
  checkCounts("forward", {{"output", "overshading"}, {"zprepass", true}}, planes(3, "back-to-front", 1.0));
}

// The counting modes' image: the heat ramp on covered pixels, not the
// shaded colour, and the sky where no quad is.
TEST(Overdraw, ImageShowsTheCounts) {
  const nlohmann::json spec = planes(4, "back-to-front", 0.5);
  const analytic::Geometry g = analytic::geometryOf(spec, kExtent);
  Rendered shaded = render("forward", spec, kExtent);
  Rendered counted = render("forward", spec, kExtent, withOptions("forward", {{"output", "overdraw"}}));
  ASSERT_TRUE(shaded.ok && counted.ok);
  const size_t centre = (size_t(g.rows.first + g.rows.count / 2) * kExtent.width + kExtent.width / 2) * 4;
  const size_t sky = (size_t(0) * kExtent.width + kExtent.width / 2) * 4;  // row 0: above the quads
  ASSERT_GT(g.rows.first, 0u);
  // 4 fragments: log2(4) / 4 = 0.5 on the ramp, yellow (red = green, no blue).
  EXPECT_EQ(counted.image[centre + 0], counted.image[centre + 1]);
  EXPECT_GT(counted.image[centre + 0], 128);
  EXPECT_EQ(counted.image[centre + 2], 0);
  for (int c = 0; c < 4; ++c) EXPECT_EQ(counted.image[sky + c], shaded.image[sky + c]) << "sky channel " << c;
}

// Options left at their defaults (or given explicitly as the defaults)
// change nothing: same passes, resources, counts and image.
TEST(RendererOptionsDefaults, ForwardAndDeferredUnchanged) {
  const nlohmann::json spec = planes(3, "back-to-front", 0.5);
  const std::map<std::string, std::vector<std::string>> passes = {
      {"forward", {"forward", "tonemap", "skybox"}}, {"deferred", {"gbuffer", "lighting", "tonemap", "skybox"}}};
  for (const auto& [name, names] : passes) {
    nlohmann::json explicitDefaults = {{"zprepass", false}};
    if (name == "forward") explicitDefaults["output"] = "shaded";
    auto canonical = canonicalOptions(name, explicitDefaults);
    ASSERT_TRUE(canonical.ok()) << canonical.error();
    EXPECT_EQ(*canonical, nlohmann::json::object()) << name;
    EXPECT_EQ(variantLabel(name, *canonical), name);
    Rendered plain = render(name, spec, kExtent);
    Rendered given = render(name, spec, kExtent, withOptions(name, explicitDefaults));
    ASSERT_TRUE(plain.ok && given.ok) << name;
    ASSERT_EQ(plain.frame.passes.size(), names.size()) << name;
    for (size_t i = 0; i < names.size(); ++i) {
      const PassResult& a = plain.frame.passes[i];
      const PassResult& b = given.frame.passes[i];
      EXPECT_EQ(a.name, names[i]);
      EXPECT_EQ(b.name, names[i]);
      EXPECT_EQ(a.fragmentInvocations, b.fragmentInvocations) << name << " " << a.name;
      ASSERT_EQ(a.accesses.size(), b.accesses.size()) << name << " " << a.name;
      for (size_t k = 0; k < a.accesses.size(); ++k) {
        EXPECT_EQ(a.accesses[k].resource, b.accesses[k].resource);
        EXPECT_EQ(a.accesses[k].write, b.accesses[k].write);
        EXPECT_EQ(a.accesses[k].count, b.accesses[k].count) << name << " " << a.name << " " << a.accesses[k].resource;
        EXPECT_EQ(a.accesses[k].bytes, b.accesses[k].bytes);
      }
    }
    ASSERT_EQ(plain.resources.size(), given.resources.size()) << name;
    for (size_t k = 0; k < plain.resources.size(); ++k) {
      EXPECT_EQ(plain.resources[k].name, given.resources[k].name);
      EXPECT_NE(plain.resources[k].name, "overdraw.count") << name << ": the count target only in counting modes";
      EXPECT_EQ(plain.resources[k].formatName, given.resources[k].formatName);
    }
    EXPECT_EQ(plain.image, given.image) << name;
    EXPECT_EQ(plain.extras, nlohmann::json::object()) << name << ": no technique measurements by default";
  }
}

TEST(RendererOptionsTable, BadValuesAreRefusedWithTheOptionNamed) {
  auto bad = canonicalOptions("forward", {{"output", "wireframe"}});
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error(), "output: \"wireframe\" is not one of shaded, overdraw, overshading, density");
  bad = canonicalOptions("forward", {{"zprepass", "yes"}});
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().rfind("zprepass: ", 0), 0u) << bad.error();
  bad = canonicalOptions("forward", {{"zprepass", 1}});
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().rfind("zprepass: ", 0), 0u) << bad.error();
  bad = canonicalOptions("deferred", {{"output", "overdraw"}});
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().rfind("output: deferred takes no option output", 0), 0u) << bad.error();
  bad = canonicalOptions("forward-zprepass", {{"zprepass", true}});
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().rfind("zprepass: forward-zprepass takes no option zprepass", 0), 0u) << bad.error();

  auto good = canonicalOptions("forward", {{"zprepass", true}, {"output", "overshading"}});
  ASSERT_TRUE(good.ok()) << good.error();
  EXPECT_EQ(variantLabel("forward", *good), "forward output=overshading zprepass=true");
  RendererOptions o;
  applyOptions(*good, o);
  EXPECT_EQ(o.forwardOutput, ForwardOutput::Overshading);
  EXPECT_TRUE(o.zprepass);
}

}  // namespace
}  // namespace tally::renderers
