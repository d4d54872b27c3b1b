// Shadow mapping (docs/techniques.md, "Shadow mapping"): the option table,
// and on the test device (lavapipe in CI) the shadow pass and the shading
// passes' map reads against counts derived from the parameters and an
// analytic scene, the shadowed pixels of that scene against its geometry,
// and every renderer's image against forward's with the same shadows.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <gtest/gtest.h>

#include "analysis/image.hpp"
#include "capture/spec.hpp"
#include "render_fixture.hpp"
#include "renderers/options.hpp"
#include "renderers/techniques/shadows.hpp"
#include "scenes/mesh_builder.hpp"
#include "scenes/textures.hpp"

namespace tally::renderers {
using namespace fixture;
namespace {

constexpr double kMinPsnrDb = 30.0;  // renderers_test.cpp's agreement with forward

// ---------------------------------------------------------------- the analytic scene
// The fixed head-on camera (origin, looking down -Z, 60 degrees vertical) sees
// a wall at z = -4 filling the view and, in front of it at z = -3, a
// horizontal strip y in [0, 1] spanning the width. The sun lies towards
// (0, 1.2, 1): a point of the strip casts onto the wall 1 m further back and
// 1.2 m lower, so the strip's shadow is the band y in [-1.2, -0.2] of the
// wall, below the strip's own image (which hides wall y in [0, 4/3]).
constexpr float kWallZ = -4.0f, kStripZ = -3.0f, kStripLo = 0.0f, kStripHi = 1.0f;
constexpr float kSunRise = 1.2f;  // sun direction (0, kSunRise, 1)
const double kTanHalfFov = std::tan(glm::radians(30.0));

scenes::Mesh quad(float z, float yLo, float yHi, float halfWidth, uint32_t material, const char* name) {
  const glm::vec3 n(0, 0, 1);
  scenes::MeshBuilder b;
  auto v = [&](float x, float y) { return b.vertex(glm::vec3(x, y, z), n, glm::vec2(x, -y) * 0.5f); };
  uint32_t i0 = v(-halfWidth, yLo), i1 = v(halfWidth, yLo), i2 = v(halfWidth, yHi), i3 = v(-halfWidth, yHi);
  b.triangle(i0, i1, i2, n);
  b.triangle(i0, i2, i3, n);
  return b.finish(name, material);
}

struct ShadowScene {
  scenes::Scene scene;
  GpuScene gpu;
  scenes::Camera camera;
};

// One per test: its GPU copy goes before the fixture's device does.
std::unique_ptr<ShadowScene> makeShadowScene() {
  auto s = std::make_unique<ShadowScene>();
  {
    uint32_t material = scenes::addProceduralMaterial(s->scene, scenes::ProceduralMaterial::Plaster, 64);
    s->scene.name = "shadow-strip";
    // Drawn wall first, then the strip: in the shadow pass both pass the depth test everywhere.
    s->scene.meshes.push_back(quad(kWallZ, -3.0f, 3.0f, 5.0f, material, "wall"));
    s->scene.meshes.push_back(quad(kStripZ, kStripLo, kStripHi, 5.0f, material, "strip"));
    scenes::updateBounds(s->scene);
    s->camera.eye = glm::vec3(0);
    s->camera.target = glm::vec3(0, 0, -1);
    s->camera.fovDeg = 60.0f;
    auto ok = s->gpu.upload(*context(), s->scene);
    EXPECT_TRUE(ok.ok()) << (ok ? "" : ok.error());
  }
  return s;
}

std::function<void(RendererOptions&)> shadowsWith(ShadowFilter filter, uint32_t size, bool strip = false,
                                                  bool instrumented = true) {
  return [=](RendererOptions& o) {
    o.shadows.filter = filter;
    o.shadows.mapSize = size;
    o.instrumented = instrumented;
    if (strip) {
      o.lights = 0;  // ambient + sun only: a shadowed pixel is exactly the shadows-off pixel
      o.shadows.sunDirection[0] = 0.0f;
      o.shadows.sunDirection[1] = kSunRise;
      o.shadows.sunDirection[2] = 1.0f;
    }
  };
}

// fixture::render, on the strip scene.
Rendered renderStrip(ShadowScene& s, const std::string& name, VkExtent2D extent,
                     const std::function<void(RendererOptions&)>& adjust) {
  Rendered out;
  gpu::Context* ctx = context();
  if (ctx == nullptr) return out;
  auto renderer = makeRenderer(name);
  if (!renderer) return out;
  RendererOptions options;
  options.extent = extent;
  adjust(options);
  auto ok = (*renderer)->setup(*ctx, s.gpu, options);
  EXPECT_TRUE(ok.ok()) << name << ": " << (ok ? "" : ok.error());
  if (!ok) return out;
  out.frame = (*renderer)->renderFrame(s.camera);
  out.image = (*renderer)->finalImage();
  out.extras = (*renderer)->frameExtras();
  out.resources = (*renderer)->resources();
  EXPECT_EQ(out.frame.passes.size(), (*renderer)->passNames().size());
  (*renderer)->destroy();
  out.ok = true;
  return out;
}

// Hardware PCF needs linear filtering of D32_SFLOAT; lavapipe lacks it (setup
// refuses, naming it: checked below), so the pcf variants run on GPUs only.
bool linearDepthFiltering() {
  gpu::Context* ctx = context();
  if (ctx == nullptr) return false;
  VkFormatProperties props = {};
  vkGetPhysicalDeviceFormatProperties(ctx->physicalDevice, VK_FORMAT_D32_SFLOAT, &props);
  return (props.optimalTilingFeatures & VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT) != 0;
}

std::vector<ShadowFilter> testedFilters() {
  if (linearDepthFiltering()) return {ShadowFilter::Hard, ShadowFilter::Pcf2x2, ShadowFilter::Pcf4x4};
  std::printf("no linear filtering of D32_SFLOAT on this device: pcf2x2 and pcf4x4 not rendered\n");
  return {ShadowFilter::Hard};
}

ShadowFilter agreeFilter() { return linearDepthFiltering() ? ShadowFilter::Pcf2x2 : ShadowFilter::Hard; }

uint64_t countedOn(const PassResult& p, const std::string& name, bool write, const std::string& source) {
  uint64_t n = 0;
  for (const auto& a : p.accesses) {
    if (a.write == write && a.source == source && a.resource == name) n += a.count;
  }
  return n;
}

// Texel centres (i + 0.5) / n * 2 - 1 inside [lo, hi] (NDC).
uint64_t centresInside(double lo, double hi, uint32_t n) {
  uint64_t c = 0;
  for (uint32_t i = 0; i < n; ++i) {
    double x = (i + 0.5) / n * 2.0 - 1.0;
    if (x >= lo && x <= hi) ++c;
  }
  return c;
}

// ---------------------------------------------------------------- option table

TEST(ShadowOptions, BadValuesAreRejectedNamingTheOption) {
  for (const auto& [option, value] : std::vector<std::pair<std::string, nlohmann::json>>{
           {"shadows", "soft"}, {"shadows", true}, {"shadow_map_size", 3000}, {"shadow_map_size", "2048"},
           {"shadow_map_size", 2048.0}, {"shadow_bias", -0.5}, {"shadow_bias", 9}, {"shadow_bias", "1"}}) {
    auto r = canonicalOptions("deferred", {{option, value}});
    ASSERT_FALSE(r.ok()) << option << "=" << value.dump();
    EXPECT_EQ(r.error().rfind(option + ":", 0), 0u) << r.error();
  }
  for (const auto& name : rendererNames()) {
    auto off = canonicalOptions(name, {{"shadows", "off"}, {"shadow_map_size", 2048}, {"shadow_bias", 1.5}});
    ASSERT_TRUE(off.ok()) << name << ": " << (off ? "" : off.error());
    EXPECT_EQ(*off, nlohmann::json::object()) << name;  // the renderer as it is
  }
  auto ok = canonicalOptions("forward", {{"shadows", "pcf4x4"}, {"shadow_map_size", 512}, {"shadow_bias", 0.5}});
  ASSERT_TRUE(ok.ok());
  RendererOptions o;
  applyOptions(*ok, o);
  EXPECT_EQ(o.shadows.filter, ShadowFilter::Pcf4x4);
  EXPECT_EQ(o.shadows.mapSize, 512u);
  EXPECT_FLOAT_EQ(o.shadows.bias, 0.5f);
  EXPECT_EQ(variantLabel("forward", *ok), "forward shadow_bias=0.5 shadow_map_size=512 shadows=pcf4x4");
}

TEST(ShadowOptions, ReferenceKeepsTheFilterAndTakesThe4096Map) {
  capture::RendererVariant v{"deferred", {{"shadows", "pcf2x2"}, {"shadow_map_size", 1024}}};
  EXPECT_EQ(v.reference().options, nlohmann::json({{"shadows", "pcf2x2"}, {"shadow_map_size", 4096}}));
  capture::RendererVariant b{"forward", {{"shadows", "hard"}, {"shadow_map_size", 512}, {"shadow_bias", 3}}};
  EXPECT_EQ(b.reference().options,
            nlohmann::json({{"shadows", "hard"}, {"shadow_map_size", 4096}, {"shadow_bias", 3}}));
  // The default map (2048, dropped from canonical options) is compared with 4096 too
  // (OptionDef::referenceWith), and a variant without shadows is its own reference.
  capture::RendererVariant d{"forward", {{"shadows", "hard"}}};
  EXPECT_EQ(d.reference().options, nlohmann::json({{"shadows", "hard"}, {"shadow_map_size", 4096}}));
  capture::RendererVariant none{"forward", {{"bloom", "naive"}}};
  EXPECT_EQ(none.reference(), none);
  for (const auto& def : optionDefs()) {
    if (def.name == "shadows" || def.name == "shadow_bias") {
      EXPECT_TRUE(def.parameter) << def.name;
    }
    if (def.name == "shadow_map_size") {
      EXPECT_FALSE(def.parameter);
      EXPECT_EQ(def.reference, 4096);
      EXPECT_EQ(def.defaultValue(), 2048);
    }
  }
  EXPECT_EQ(shadowTapsPerPixel(ShadowFilter::Hard), 1u);
  EXPECT_EQ(shadowTapsPerPixel(ShadowFilter::Pcf2x2), 1u);
  EXPECT_EQ(shadowTapsPerPixel(ShadowFilter::Pcf4x4), 4u);
}

// ---------------------------------------------------------------- counts

TEST(Shadows, PcfWithoutLinearDepthFilteringIsRefusedNamingIt) {
  if (linearDepthFiltering()) GTEST_SKIP() << "the device filters D32_SFLOAT linearly";
  auto strip = makeShadowScene();
  auto renderer = makeRenderer("forward");
  ASSERT_TRUE(renderer.ok());
  RendererOptions o;
  o.extent = {32, 18};
  o.shadows.filter = ShadowFilter::Pcf4x4;
  auto ok = (*renderer)->setup(*context(), strip->gpu, o);
  ASSERT_FALSE(ok.ok());
  EXPECT_NE(ok.error().find("linear-filter D32_SFLOAT"), std::string::npos) << ok.error();
}

TEST(Shadows, OffAddsNoPassNoResourceNoExtras) {
  auto strip = makeShadowScene();
  Rendered r = renderStrip(*strip, "deferred", {64, 36}, [](RendererOptions&) {});
  ASSERT_TRUE(r.ok);
  for (const auto& p : r.frame.passes) {
    EXPECT_NE(p.name, "shadow");
    EXPECT_EQ(countedOn(p, "shadow_map", false, "counter"), 0u) << p.name;
  }
  for (const auto& info : r.resources) EXPECT_NE(info.name, "shadow_map");
  EXPECT_FALSE(r.extras.contains("shadows"));
}

// Every renderer, every filter: the map's reads in each pass are taps x the
// pass's counted fragment invocations, and only the shading pass reads it;
// the shadow pass writes the texels the two quads cover in the map (derived
// from their light-space rectangles), one 4-byte depth per fragment.
TEST(Shadows, CountsFollowFromTheParameters) {
  auto strip = makeShadowScene();
  const VkExtent2D extent = {96, 54};
  const uint32_t size = 256;
  ShadowOptions so;
  so.mapSize = size;
  so.sunDirection[0] = 0.0f;
  so.sunDirection[1] = kSunRise;
  so.sunDirection[2] = 1.0f;
  const shaders::Shadow u = shadowUniform(strip->scene.bounds, so);
  // Each quad's texels: its corners in light NDC bound an axis-aligned
  // rectangle (the light's x axis is world x, its y axis in the y-z plane).
  auto texels = [&](float z, float yLo, float yHi) {
    glm::vec4 a = u.viewProj * glm::vec4(-5.0f, yLo, z, 1.0f), b = u.viewProj * glm::vec4(5.0f, yHi, z, 1.0f);
    return centresInside(std::min(a.x, b.x), std::max(a.x, b.x), size) *
           centresInside(std::min(a.y, b.y), std::max(a.y, b.y), size);
  };
  const uint64_t predictedWrites = texels(kWallZ, -3.0f, 3.0f) + texels(kStripZ, kStripLo, kStripHi);
  const std::map<std::string, std::string> shadingPass = {{"forward", "forward"},
                                                          {"forward-zprepass", "forward"},
                                                          {"deferred", "lighting"},
                                                          {"visbuffer", "shading"},
                                                          {"visbuffer-lean", "shading"}};
  for (ShadowFilter filter : testedFilters()) {
    for (const auto& name : rendererNames()) {
      SCOPED_TRACE(name + " shadows=" + std::string(toString(filter)));
      Rendered r = renderStrip(*strip, name, extent, shadowsWith(filter, size, true));
      ASSERT_TRUE(r.ok);
      ASSERT_FALSE(r.frame.passes.empty());
      const PassResult& shadow = r.frame.passes.front();
      EXPECT_EQ(shadow.name, "shadow");  // before the renderer's own passes
      EXPECT_EQ(countedOn(shadow, "shadow_map", true, "derived"), shadow.fragmentInvocations);
      EXPECT_EQ(bytes(shadow, "shadow_map", true, "derived"), 4 * shadow.fragmentInvocations);
      // Rectangle edges may round either way by one texel row or column.
      const double slack = 4.0 * (2 * size + 2);
      EXPECT_NEAR(double(shadow.fragmentInvocations), double(predictedWrites), slack);
      uint64_t readingPasses = 0;
      for (const auto& p : r.frame.passes) {
        const uint64_t reads = countedOn(p, "shadow_map", false, "counter");
        if (p.name != shadingPass.at(name)) {
          EXPECT_EQ(reads, 0u) << p.name;
          continue;
        }
        ++readingPasses;
        EXPECT_GT(p.fragmentInvocations, 0u);
        EXPECT_EQ(reads, shadowTapsPerPixel(filter) * p.fragmentInvocations) << p.name;
        EXPECT_EQ(bytes(p, "shadow_map", false), 4 * reads);
        // Full-screen shading passes shade every covered pixel, and the wall
        // covers them all. (Lavapipe's fragment statistic counts whole 2x2
        // quads' helper lanes too, so it is no cross-check there.)
        if (name != "forward" && name != "forward-zprepass") {
          EXPECT_EQ(p.fragmentInvocations, uint64_t(extent.width) * extent.height) << p.name;
        }
      }
      EXPECT_EQ(readingPasses, 1u);
      const ResourceInfo* map = nullptr;
      for (const auto& info : r.resources) {
        if (info.name == "shadow_map") map = &info;
      }
      ASSERT_NE(map, nullptr);
      EXPECT_EQ(map->format, VK_FORMAT_D32_SFLOAT);
      EXPECT_EQ(map->formatName, "D32_SFLOAT");
      EXPECT_EQ(map->elementBytes, 4u);
      EXPECT_EQ(map->width, size);
      EXPECT_GE(map->allocationBytes, uint64_t(size) * size * 4);
      ASSERT_TRUE(r.extras.contains("shadows"));
      EXPECT_EQ(r.extras["shadows"]["filter"], toString(filter));
      EXPECT_EQ(r.extras["shadows"]["map_size"], size);
      EXPECT_EQ(r.extras["shadows"]["taps_per_shaded_pixel"], shadowTapsPerPixel(filter));
    }
  }
}

// ---------------------------------------------------------------- images

// The strip's shadow on the wall: a pixel is shadowed when it equals the
// shadows-off pixel (ambient only: the sun adds nothing there), lit when the
// sun adds at least 16 levels. Rows farther than the penumbra (the kernel's
// reach in texels, projected onto the wall, plus one row) from the band's
// edges must be all shadowed inside and all lit outside; the shadowed
// fraction of the visible wall matches the band's within those edge rows.
TEST(Shadows, ShadowedWallPixelsMatchTheGeometry) {
  auto strip = makeShadowScene();
  const VkExtent2D extent = {160, 90};
  const uint32_t W = extent.width, H = extent.height;
  Rendered off = renderStrip(*strip, "forward", extent, [](RendererOptions& o) { o.lights = 0; });
  ASSERT_TRUE(off.ok);
  for (ShadowFilter filter : testedFilters()) {
    for (uint32_t size : {512u, 2048u}) {
      SCOPED_TRACE(std::string(toString(filter)) + " " + std::to_string(size));
      Rendered on = renderStrip(*strip, "forward", extent, shadowsWith(filter, size, true, false));
      ASSERT_TRUE(on.ok);
      const double texel = on.extras["shadows"]["texel_m"].get<double>();
      // Wall metres per row, and the penumbra's half-width on the wall: the
      // kernel reaches 0.5 (hard), 1 (2x2) or 2 (4x4) texels; a texel of the
      // light's y axis stretches by 1 / cos(angle to the wall normal).
      const double rowM = 2.0 * 4.0 * kTanHalfFov / H;
      const double reach = filter == ShadowFilter::Pcf4x4 ? 2.0 : filter == ShadowFilter::Pcf2x2 ? 1.0 : 0.5;
      const double stretch = std::sqrt(1.0 + kSunRise * kSunRise);
      const double margin = reach * texel * stretch + rowM;
      const double bandLo = kStripLo - kSunRise, bandHi = kStripHi - kSunRise;  // wall y of the shadow
      uint64_t visible = 0, shadowed = 0, predicted = 0, edgeRows = 0;
      for (uint32_t row = 0; row < H; ++row) {
        const double ndcY = (row + 0.5) / H * 2.0 - 1.0;
        const double stripY = -ndcY * 3.0 * kTanHalfFov, wallY = -ndcY * 4.0 * kTanHalfFov;
        if (stripY >= kStripLo && stripY <= kStripHi) continue;  // the strip, not the wall
        const bool inBand = wallY > bandLo && wallY < bandHi;
        const bool nearEdge = std::abs(wallY - bandLo) < margin || std::abs(wallY - bandHi) < margin;
        if (nearEdge) ++edgeRows;
        uint64_t rowShadowed = 0;
        for (uint32_t x = 0; x < W; ++x) {
          int diff = 0;
          for (int c = 0; c < 3; ++c) {
            const size_t i = (size_t(row) * W + x) * 4 + c;
            diff = std::max(diff, std::abs(int(on.image[i]) - int(off.image[i])));
          }
          if (diff == 0) ++rowShadowed;
          if (!nearEdge && inBand) {
            EXPECT_EQ(diff, 0) << "row " << row << " x " << x;
          } else if (!nearEdge) {
            EXPECT_GE(diff, 16) << "row " << row << " x " << x;
          }
        }
        visible += W;
        shadowed += rowShadowed;
        if (inBand) predicted += W;
      }
      const double fraction = double(shadowed) / double(visible);
      const double expected = double(predicted) / double(visible);
      const double tolerance = double(edgeRows * W) / double(visible);
      std::printf("shadows=%-7s %4u: shadowed wall fraction %.4f, predicted %.4f +- %.4f\n",
                  std::string(toString(filter)).c_str(), size, fraction, expected, tolerance);
      EXPECT_GT(predicted, 10u * W);
      EXPECT_NEAR(fraction, expected, tolerance);
    }
  }
}

// Against pcf4x4 at 4096 (the smoothest, finest shadows): hard shadows from
// the 4096 map are closer than hard shadows from the 512 map, whose texels
// are 8x larger (their staircase edges move farther from the filtered
// edge); and pcf2x2's error against its own 4096 map falls from 512 to 2048.
TEST(Shadows, LargerMapsAreCloserToTheReference) {
  const VkExtent2D extent = {160, 90};
  const nlohmann::json spec = "atrium";
  auto at = [&](ShadowFilter f, uint32_t size) {
    Rendered r = render("forward", spec, extent, shadowsWith(f, size, false, false));
    EXPECT_TRUE(r.ok);
    return r.image;
  };
  auto err = [&](const std::vector<uint8_t>& a, const std::vector<uint8_t>& b) {
    auto e = analysis::compareImages(a, b, extent.width, extent.height);
    EXPECT_TRUE(e.ok());
    return e ? e->meanAbs : 0.0;
  };
  // Every filter: against its own 4096 map (the option's reference), the
  // 2048 map is closer than the 512 map.
  for (ShadowFilter f : testedFilters()) {
    const auto ref = at(f, 4096);
    const double e512 = err(at(f, 512), ref), e2048 = err(at(f, 2048), ref);
    std::printf("shadows=%s mean |error| vs 4096: 512 %.4f, 2048 %.4f\n", std::string(toString(f)).c_str(), e512,
                e2048);
    EXPECT_LT(e2048, e512) << toString(f);
  }
  if (!linearDepthFiltering()) return;
  const auto reference = at(ShadowFilter::Pcf4x4, 4096);
  const double e4096 = err(at(ShadowFilter::Hard, 4096), reference), e512 = err(at(ShadowFilter::Hard, 512), reference);
  std::printf("mean |error| vs pcf4x4@4096: hard@4096 %.4f, hard@512 %.4f\n", e4096, e512);
  EXPECT_LT(e4096, e512);
}

// Every renderer shades the sun with the same code: images agree with
// forward's with the same shadows as renderers_test.cpp requires without.
TEST(Shadows, EveryRendererAgreesWithForward) {
  const VkExtent2D extent = {160, 90};
  for (const nlohmann::json& spec : {nlohmann::json("atrium")}) {
    Rendered reference = render("forward", spec, extent, shadowsWith(agreeFilter(), 1024, false, false));
    ASSERT_TRUE(reference.ok);
    for (const auto& name : rendererNames()) {
      if (name == "forward") continue;
      Rendered r = render(name, spec, extent, shadowsWith(agreeFilter(), 1024, false, false));
      const double db = analysis::psnr(reference.image, r.image);
      std::printf("%-16s shadows (pcf2x2, else hard) PSNR vs forward %.1f dB\n", name.c_str(), db);
      EXPECT_GE(db, kMinPsnrDb) << name;
    }
  }
  auto strip = makeShadowScene();
  Rendered reference = renderStrip(*strip, "forward", extent, shadowsWith(agreeFilter(), 1024, true, false));
  for (const auto& name : rendererNames()) {
    if (name == "forward") continue;
    Rendered r = renderStrip(*strip, name, extent, shadowsWith(agreeFilter(), 1024, true, false));
    EXPECT_GE(analysis::psnr(reference.image, r.image), kMinPsnrDb) << name << " on the strip scene";
  }
}

}  // namespace
}  // namespace tally::renderers
