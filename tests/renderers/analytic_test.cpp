// The exactness suite: on planes and sky at odd and even resolutions, every
// renderer's per-pass, per-resource counts equal the analytic predictions of
// analytic.cpp, and every access a pass makes is one the prediction names.
// Beside each pass's counted fragment invocations the test prints the
// pipeline statistic and its deviation: equal on NVIDIA (asserted); on
// lavapipe at least the rasterized fragments (asserted), see checkStatistic.
// Runs on lavapipe in CI and on the GPU through tests/gpu/run.sh.
#include <cinttypes>
#include <cstdio>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include "analytic.hpp"
#include "sweeps/headroom.hpp"
#include "renderers/options.hpp"
#include "render_fixture.hpp"

namespace tally::renderers {
using namespace fixture;
namespace {

constexpr uint32_t kNvidiaVendorId = 0x10DE;  // pipeline statistics exact (docs/gpu.md)

bool nameMatches(const std::string& resource, const std::string& term) {
  return term.back() == '.' ? resource.rfind(term, 0) == 0 : resource == term;
}

const analytic::Term* termFor(const analytic::PassPrediction& p, const Access& a) {
  for (const auto& t : p.terms) {
    if (t.write == a.write && t.source == a.source && nameMatches(a.resource, t.resource)) return &t;
  }
  return nullptr;
}

uint64_t sumMatching(const PassResult& p, const analytic::Term& t, uint64_t* bytes) {
  uint64_t n = 0;
  for (const auto& a : p.accesses) {
    if (a.write == t.write && a.source == t.source && nameMatches(a.resource, t.resource)) {
      n += a.count;
      *bytes += a.bytes;
    }
  }
  return n;
}

// Vertex invocations of a mesh pass, from its vertex-attribute reads: the
// one per-vertex quantity the device chooses (vertex reuse), so it is
// measured once and bounded, and every other per-vertex term must agree.
uint64_t vertexInvocations(const analytic::PassPrediction& want, const PassResult& got, const std::string& where) {
  if (want.vertexAttributes == 0) return 0;
  for (const auto& t : want.terms) {
    if (t.resource != "vertices" || t.write || t.source != "counter") continue;
    uint64_t b = 0;
    const uint64_t reads = sumMatching(got, t, &b);
    const uint64_t fragmentPart = t.perFragment * want.fragments + t.constant;
    EXPECT_GE(reads, fragmentPart) << where;
    const uint64_t vertexPart = reads - std::min(reads, fragmentPart);
    EXPECT_EQ(vertexPart % t.perVertex, 0u) << where << ": vertex reads " << vertexPart;
    const uint64_t v = vertexPart / t.perVertex;
    EXPECT_GE(v, want.minVertices) << where << ": vertex invocations";
    EXPECT_LE(v, want.maxVertices) << where << ": vertex invocations";
    return v;
  }
  ADD_FAILURE() << where << ": a mesh pass without vertex reads in its prediction";
  return 0;
}

// The fragment-shader-invocation statistic beside the count. NVIDIA's is
// exact: it must equal the counted invocations. lavapipe's counts every
// fragment the rasterizer generates, before the early depth and stencil tests
// (rejected layers, the pre-pass's EQUAL test and the sky mask do not lower
// it), plus whole 4x4 blocks where a triangle covers part of one: it must be
// at least the predicted rasterized fragments; the block excess is printed,
// not bounded (docs/measurement.md, "Analytic predictions").
void checkStatistic(const gpu::Context& ctx, const analytic::PassPrediction& want, const PassResult& got,
                    const std::string& where) {
  const int64_t statistic = got.fragmentInvocationsStatistic;
  const int64_t deviation = statistic - int64_t(got.fragmentInvocations);
  std::printf("  %-44s counted %8" PRIu64 "  statistic %8" PRId64 "  deviation %+8" PRId64
              "  (rasterized %" PRIu64 ")\n",
              where.c_str(), got.fragmentInvocations, statistic, deviation, want.rasterized);
  if (statistic < 0) return;  // the device has no pipeline statistics
  if (ctx.properties.vendorID == kNvidiaVendorId) {
    EXPECT_EQ(uint64_t(statistic), got.fragmentInvocations) << where << ": NVIDIA's statistic is exact";
    return;
  }
  EXPECT_GE(uint64_t(statistic), want.rasterized) << where;
}

void checkPass(const analytic::PassPrediction& want, const PassResult& got, const std::string& where) {
  EXPECT_EQ(got.fragmentInvocations, want.fragments) << where << ": fragment invocations";
  const uint64_t vertices = vertexInvocations(want, got, where);
  for (const auto& t : want.terms) {
    uint64_t b = 0;
    const uint64_t n = sumMatching(got, t, &b);
    const uint64_t expected = t.count(want.fragments, vertices);
    EXPECT_EQ(n, expected) << where << ": " << (t.write ? "write " : "read ") << t.resource << " (" << t.source
                           << ")";
    if (t.elementBytes != 0) {
      EXPECT_EQ(b, n * t.elementBytes) << where << ": bytes of " << t.resource;
    }
  }
  for (const auto& a : got.accesses) {
    EXPECT_NE(termFor(want, a), nullptr) << where << ": an access no prediction names: "
                                         << (a.write ? "write " : "read ") << a.resource << " (" << a.source
                                         << "), " << a.count;
  }
}

// Every resource the renderer declares is named by a prediction of some pass.
void checkDeclared(const std::vector<analytic::PassPrediction>& want, const Rendered& r, const std::string& where) {
  for (const auto& resource : r.resources) {
    bool named = false;
    for (const auto& p : want) {
      for (const auto& t : p.terms) named = named || nameMatches(resource.name, t.resource);
    }
    EXPECT_TRUE(named) << where << ": resource " << resource.name << " is declared but no prediction names it";
  }
}

// The counting modes whose counts are exact: the analytic suite runs each.
const std::string kExactModes[] = {"exact", "accumulate", "accumulate:subgroup", "accumulate:lane"};

using Param = std::tuple<VkExtent2D, nlohmann::json, std::string>;

class AnalyticCounts : public ::testing::TestWithParam<Param> {};

TEST_P(AnalyticCounts, EveryRendererMatchesThePrediction) {
  const auto& [extent, spec, modeName] = GetParam();
  auto mode = spirv::parseMode(modeName);
  ASSERT_TRUE(mode.ok()) << mode.error();
  const analytic::Geometry g = analytic::geometryOf(spec, extent);
  ASSERT_FALSE(g.rows.ambiguous) << "an edge of " << spec.dump() << " lies on a snapping midpoint at "
                                 << extent.height << " rows: choose another coverage";
  std::printf("%s %ux%u: %u rows from row %u, %" PRIu64 " of %" PRIu64 " pixels covered per layer\n",
              spec.dump().c_str(), extent.width, extent.height, g.rows.count, g.rows.first, g.covered, g.pixels);
  gpu::Context* ctx = context();
  ASSERT_NE(ctx, nullptr);
  for (const auto& name : rendererNames()) {
    Rendered r = render(name, spec, extent, [&](RendererOptions& o) { o.counting = *mode; });
    ASSERT_TRUE(r.ok) << name << " (" << modeName << "): " << r.error;
    analytic::DeviceTraits device;
    device.lights = kTestLights;
    device.barycentricExtension = r.notes.value("barycentrics", "") == "extension";
    const auto want = analytic::predict(name, g, device);
    ASSERT_EQ(want.size(), r.frame.passes.size()) << name << ": passes predicted";
    for (size_t i = 0; i < want.size(); ++i) {
      const PassResult& got = r.frame.passes[i];
      ASSERT_EQ(got.name, want[i].name) << name;
      const std::string where = name + " " + got.name + " (" + modeName + ")";
      checkPass(want[i], got, where);
      checkStatistic(*ctx, want[i], got, where);
    }
    checkDeclared(want, r, name);
  }
}

// Three odd resolutions (rows and columns that no 2x2 quad or 4x4 block
// divides) and one even; aspects from 0.74 to 3.15, all within the scenes'
// kMaxAnalyticAspect. Coverages put edges on pixel centres (0.5 at an odd
// height: the top-left rule decides), between centres, and off screen.
const VkExtent2D kExtents[] = {{157, 91}, {211, 67}, {97, 131}, {160, 90}};

std::vector<nlohmann::json> specs() {
  return {planes(1, "back-to-front", 1.0),  planes(3, "back-to-front", 0.5), planes(3, "front-to-back", 0.5),
          planes(4, "back-to-front", 0.37), planes(4, "front-to-back", 1.0), sky(0.0),
          sky(0.5),                         sky(0.3),                        sky(1.0)};
}

std::string paramName(const ::testing::TestParamInfo<Param>& info) {
  const auto& [extent, spec, mode] = info.param;
  std::string label = mode;
  for (char& c : label) c = c == ':' ? '_' : c;
  std::string name = label + "_" + std::to_string(extent.width) + "x" + std::to_string(extent.height) + "_" +
                     spec.value("name", "");
  if (spec.contains("layers")) {
    name += std::to_string(spec["layers"].get<int>()) +
            (spec["order"] == "back-to-front" ? "BackToFront" : "FrontToBack");
  }
  name += "Coverage" + std::to_string(int(spec.value("coverage", 0.0) * 100 + 0.5));
  return name;
}

INSTANTIATE_TEST_SUITE_P(Renderers, AnalyticCounts,
                         ::testing::Combine(::testing::ValuesIn(kExtents), ::testing::ValuesIn(specs()),
                                            ::testing::ValuesIn(kExactModes)),
                         paramName);

// The variants (options.hpp) whose passes change: forward's count outputs
// and depth pre-pass, deferred's depth pre-pass. Every pass equals its
// prediction for the variant, as above; each G-buffer or forward pass's
// shaded fragments per covered pixel (overshading) and the frame's total
// bytes are printed beside the variant's.
struct Variant {
  const char* renderer;
  const char* options;  // JSON
};
const Variant kVariants[] = {
    {"forward", R"({"zprepass": true})"},
    {"forward", R"({"output": "overdraw"})"},
    {"forward", R"({"output": "overshading"})"},
    {"forward", R"({"output": "overdraw", "zprepass": true})"},
    {"forward-zprepass", R"({"output": "overshading"})"},
    {"deferred", R"({"zprepass": true})"},
    {"deferred", R"({})"},
};

uint64_t totalBytes(const FrameResult& f) {
  uint64_t n = 0;
  for (const auto& p : f.passes) {
    for (const auto& a : p.accesses) n += a.bytes;
  }
  return n;
}

TEST(AnalyticVariants, EveryVariantMatchesThePrediction) {
  gpu::Context* ctx = context();
  ASSERT_NE(ctx, nullptr);
  for (const VkExtent2D extent : {VkExtent2D{157, 91}, VkExtent2D{160, 90}}) {
    for (const auto& spec : {planes(3, "back-to-front", 0.5), planes(4, "front-to-back", 1.0)}) {
      const analytic::Geometry g = analytic::geometryOf(spec, extent);
      ASSERT_FALSE(g.rows.ambiguous) << spec.dump();
      for (const auto& v : kVariants) for (const std::string& modeName : kExactModes) {
        auto mode = spirv::parseMode(modeName);
        ASSERT_TRUE(mode.ok()) << mode.error();
        auto options = canonicalOptions(v.renderer, nlohmann::json::parse(v.options));
        ASSERT_TRUE(options.ok()) << v.renderer << " " << v.options << ": " << options.error();
        const std::string label = variantLabel(v.renderer, *options) + " " + spec.dump() + " " +
                                  std::to_string(extent.width) + "x" + std::to_string(extent.height) + " (" +
                                  modeName + ")";
        Rendered r = render(v.renderer, spec, extent, [&](RendererOptions& o) {
          applyOptions(*options, o);
          o.counting = *mode;
        });
        ASSERT_TRUE(r.ok) << label << ": " << r.error;
        analytic::DeviceTraits device;
        device.lights = kTestLights;
        const auto want = analytic::predict(v.renderer, g, device, *options);
        ASSERT_EQ(want.size(), r.frame.passes.size()) << label << ": passes predicted";
        for (size_t i = 0; i < want.size(); ++i) {
          const PassResult& got = r.frame.passes[i];
          ASSERT_EQ(got.name, want[i].name) << label;
          checkPass(want[i], got, label + " " + got.name);
          checkStatistic(*ctx, want[i], got, label + " " + got.name);
          if (got.name == "gbuffer" || got.name == "forward") {
            std::printf("  %s: %s shades %.3f fragments per covered pixel; %" PRIu64 " bytes in the frame\n",
                        label.c_str(), got.name.c_str(), double(got.fragmentInvocations) / double(g.covered),
                        totalBytes(r.frame));
          }
        }
        checkDeclared(want, r, label);
      }
    }
  }
}

// The counter headroom of a frame (docs/measurement.md, "Counter overflow"):
// the largest slot is the largest predicted count, the lights buffer read by
// every forward fragment of four back-to-front planes (layers x covered x
// lights), and the 32-bit wrap factor is 2^32 over it (one frame accumulates).
TEST(CounterHeadroom, LargestSlotIsThePredictedLargestCount) {
  const VkExtent2D extent = {157, 91};
  const nlohmann::json spec = planes(4, "back-to-front", 1.0);
  const analytic::Geometry g = analytic::geometryOf(spec, extent);
  ASSERT_FALSE(g.rows.ambiguous);
  Rendered r = render("forward", spec, extent);
  ASSERT_TRUE(r.ok) << r.error;
  analytic::DeviceTraits device;
  device.lights = kTestLights;
  uint64_t largest = 0;
  std::string largestName;
  for (const auto& p : analytic::predict("forward", g, device)) {
    for (const auto& t : p.terms) {
      if (t.source != "counter" || t.perVertex != 0) continue;  // vertex counts: far below (a few quads)
      if (t.count(p.fragments, 0) > largest) {
        largest = t.count(p.fragments, 0);
        largestName = p.name + "/" + t.resource;
      }
    }
  }
  EXPECT_EQ(largestName, "forward/lights");
  EXPECT_EQ(largest, uint64_t(g.layers) * g.covered * kTestLights);

  tally::sweeps::CounterHeadroom headroom;
  headroom.note(r.frame);
  EXPECT_EQ(headroom.maxSlotCount, largest);
  EXPECT_EQ(headroom.maxSlot, largestName);
  const auto json = tally::sweeps::toJson(headroom, spirv::CounterWidth::Int64, 1);
  EXPECT_DOUBLE_EQ(json["wrap_factor_32bit"].get<double>(), 4294967296.0 / double(largest));
  EXPECT_EQ(json["max_slot_count_per_frame"].get<uint64_t>(), largest);
  std::printf("forward, 4 planes at 157x91, %u lights: largest slot %s = %" PRIu64
              " per frame; a 32-bit counter would wrap at %.0fx the resolution x overshading\n",
              kTestLights, largestName.c_str(), largest, json["wrap_factor_32bit"].get<double>());
}

}  // namespace
}  // namespace tally::renderers
