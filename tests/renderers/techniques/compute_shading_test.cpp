// Shading in compute (docs/techniques.md, "Shading in compute"): the option
// table's checks, the refused combinations, and on the test device (lavapipe
// in CI) for deferred, visbuffer and visbuffer-lean, shading=compute against
// shading=fragment of the same frame:
// - invocations: the counted compute invocations (the entry point's site,
//   before the shader's bounds check) are the dispatched ones,
//   ceil(W/8)*8 x ceil(H/8)*8, equal to the pipeline statistic where the
//   device has it; the pass has no fragment invocations;
// - per-resource counts, derived from the covered pixels C (the fragment
//   variant's counted invocations of the same pass, itself checked against
//   the analytic scene's coverage) and the pixel count P = W x H: the
//   per-pixel input (deferred's depth, the visibility ids) is read P times
//   (every in-image invocation, to find the sky) against C in the fragment
//   pass; "hdr" is written P times (sky pixels get the cleared value) against
//   C; everything else (G-buffer texels, derivatives, draws, vertices, maps,
//   lights, camera) is read exactly as often as by the fragment pass, i.e.
//   only for covered pixels;
// - images: compute against fragment within a PSNR bound (the same shader
//   code, no implicit derivatives anywhere: only the compilers' instruction
//   selection for the two stages may round differently), also with bloom on
//   and after several frames (the "hdr" layout transitions of the compute
//   pass: tonemap and bloom sample it in SHADER_READ_ONLY_OPTIMAL).
#include <cmath>
#include <cstdio>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "analytic.hpp"
#include "analysis/image.hpp"
#include "render_fixture.hpp"
#include "renderers/options.hpp"

namespace tally::renderers {
using namespace fixture;
namespace {

// Not multiples of 8: the dispatch covers 72 x 40, 432 invocations past the edge.
constexpr VkExtent2D kExtent = {68, 36};
const std::vector<std::string> kRenderers = {"deferred", "visbuffer", "visbuffer-lean"};
// Images of the two forms: identical where both stages compile the math
// alike; the bound allows 1-LSB rounding differences on a few pixels.
constexpr double kMinPsnr = 50.0;

std::function<void(RendererOptions&)> withCompute(bool compute, std::function<void(RendererOptions&)> more = {}) {
  return [compute, more](RendererOptions& o) {
    o.computeShading = compute;
    if (more) more(o);
  };
}

std::string shadingPass(const std::string& renderer) { return renderer == "deferred" ? "lighting" : "shading"; }
// The per-pixel input that tells geometry from sky.
std::string pixelInput(const std::string& renderer) { return renderer == "deferred" ? "depth" : "visibility.id"; }

const Access* line(const PassResult& p, const std::string& resource, bool write) {
  for (const auto& a : p.accesses) {
    if (a.resource == resource && a.write == write && a.source == "counter") return &a;
  }
  return nullptr;
}

uint32_t elementBytesOf(const Rendered& r, const std::string& name) {
  for (const auto& info : r.resources) {
    if (info.name == name) return info.elementBytes;
  }
  return 0;
}

TEST(ComputeShadingOptions, TableChecksValues) {
  for (const auto& name : kRenderers) {
    auto ok = canonicalOptions(name, {{"shading", "compute"}});
    ASSERT_TRUE(ok.ok()) << ok.error();
    EXPECT_EQ(variantLabel(name, *ok), name + " shading=compute");
    RendererOptions o;
    applyOptions(*ok, o);
    EXPECT_TRUE(o.computeShading);
    auto plain = canonicalOptions(name, {{"shading", "fragment"}});
    ASSERT_TRUE(plain.ok());
    EXPECT_EQ(*plain, nlohmann::json::object()) << "fragment is the default";
    for (const nlohmann::json& bad : {nlohmann::json("Compute"), nlohmann::json("mesh"), nlohmann::json(true),
                                      nlohmann::json(1)}) {
      auto refused = canonicalOptions(name, {{"shading", bad}});
      ASSERT_FALSE(refused.ok()) << bad.dump();
      EXPECT_EQ(refused.error().rfind("shading: ", 0), 0u) << refused.error();
      EXPECT_NE(refused.error().find("fragment, compute"), std::string::npos) << refused.error();
    }
  }
  for (const char* other : {"forward", "forward-zprepass"}) {
    auto refused = canonicalOptions(other, {{"shading", "compute"}});
    ASSERT_FALSE(refused.ok());
    EXPECT_EQ(refused.error().rfind(std::string("shading: ") + other + " takes no option shading", 0), 0u)
        << refused.error();
  }
  bool listed = false;
  for (const auto& d : optionDefsJson()) {
    if (d["name"] != "shading") continue;
    listed = true;
    EXPECT_EQ(d["default"], "fragment");
    EXPECT_EQ(d["reference"], "fragment");
    EXPECT_EQ(d["parameter"], false);
    EXPECT_EQ(d["renderers"], nlohmann::json(kRenderers));
  }
  EXPECT_TRUE(listed);
}

// msaa > 1 and gbuffer=subpass keep their fragment passes: refused, named.
TEST(ComputeShadingOptions, UnsupportedCombinationsRefused) {
  const nlohmann::json spec = planes(1, "front-to-back", 1.0);
  for (const auto& name : kRenderers) {
    Rendered r = render(name, spec, kExtent, withCompute(true, [](RendererOptions& o) { o.msaa = 4; }), 1, true);
    EXPECT_FALSE(r.ok) << name;
    EXPECT_NE(r.error.find("msaa 4"), std::string::npos) << r.error;
    EXPECT_NE(r.error.find(name), std::string::npos) << r.error;
  }
  Rendered sub =
      render("deferred", spec, kExtent, withCompute(true, [](RendererOptions& o) { o.gbufferSubpass = true; }), 1, true);
  EXPECT_FALSE(sub.ok);
  EXPECT_NE(sub.error.find("shading=compute with gbuffer=subpass"), std::string::npos) << sub.error;
}

// The sky scene: a quad over part of the screen, sky elsewhere.
TEST(ComputeShadingCounts, DerivedFromCoveredAndAllPixels) {
  const nlohmann::json spec = sky(0.5);
  const analytic::Geometry g = analytic::geometryOf(spec, kExtent);
  ASSERT_GT(g.covered, 0u);
  ASSERT_LT(g.covered, g.pixels) << "the scene must have sky pixels";
  const uint64_t pixels = uint64_t(kExtent.width) * kExtent.height;
  const uint32_t group = 8;
  const uint64_t dispatched = uint64_t((kExtent.width + group - 1) / group * group) *
                              ((kExtent.height + group - 1) / group * group);
  ASSERT_GT(dispatched, pixels);
  for (const auto& name : kRenderers) {
    SCOPED_TRACE(name);
    Rendered frag = render(name, spec, kExtent, withCompute(false));
    Rendered comp = render(name, spec, kExtent, withCompute(true));
    ASSERT_TRUE(frag.ok) << frag.error;
    ASSERT_TRUE(comp.ok) << comp.error;
    const std::string passName = shadingPass(name);
    const PassResult& f = passNamed(frag, passName);
    const PassResult& c = passNamed(comp, passName);
    const uint64_t covered = f.fragmentInvocations;
    if (!g.rows.ambiguous) {
      EXPECT_EQ(covered, g.covered) << "stencil-masked fragments = covered pixels";
    }

    // Invocations.
    EXPECT_EQ(c.computeInvocations, dispatched);
    EXPECT_EQ(c.fragmentInvocations, 0u);
    EXPECT_EQ(f.computeInvocations, 0u);
    if (c.computeInvocationsStatistic >= 0) {
      EXPECT_EQ(uint64_t(c.computeInvocationsStatistic), c.computeInvocations) << "pipeline statistic";
      EXPECT_EQ(c.fragmentInvocationsStatistic, 0);
    }

    // The per-pixel input: every pixel in compute, covered ones in fragment.
    const std::string input = pixelInput(name);
    const Access* fi = line(f, input, false);
    const Access* ci = line(c, input, false);
    ASSERT_NE(fi, nullptr);
    ASSERT_NE(ci, nullptr);
    EXPECT_EQ(fi->count, covered);
    EXPECT_EQ(ci->count, pixels);
    const uint32_t inputBytes = name == "deferred" ? 4u : elementBytesOf(comp, input);  // D32 aspect / id texel
    EXPECT_EQ(ci->bytes, pixels * inputBytes);

    // "hdr": every pixel stored in compute, covered ones written in fragment.
    const Access* fw = line(f, "hdr", true);
    const Access* cw = line(c, "hdr", true);
    ASSERT_NE(fw, nullptr);
    ASSERT_NE(cw, nullptr);
    EXPECT_EQ(fw->count, covered);
    EXPECT_EQ(cw->count, pixels);
    EXPECT_EQ(cw->bytes, pixels * elementBytesOf(comp, "hdr"));
    EXPECT_EQ(elementBytesOf(comp, "hdr"), 8u) << "RGBA16F";

    // Everything else: the same lines with the same counts (covered pixels only).
    std::set<std::string> seen;
    for (const auto& a : f.accesses) {
      if (a.source != "counter" || (a.resource == input && !a.write) || (a.resource == "hdr" && a.write)) continue;
      const Access* other = line(c, a.resource, a.write);
      ASSERT_NE(other, nullptr) << a.resource << (a.write ? " write" : " read") << " missing in compute";
      EXPECT_EQ(other->count, a.count) << a.resource << (a.write ? " write" : " read");
      EXPECT_EQ(other->bytes, a.bytes) << a.resource;
      seen.insert(a.resource + (a.write ? "/w" : "/r"));
    }
    for (const auto& a : c.accesses) {
      if (a.source != "counter" || (a.resource == input && !a.write) || (a.resource == "hdr" && a.write)) continue;
      EXPECT_TRUE(seen.count(a.resource + (a.write ? "/w" : "/r"))) << a.resource << " only in compute";
    }
    // The G-buffer texels / derivative texels: one per covered pixel.
    if (name == "deferred") {
      for (const char* t : {"gbuffer.normal", "gbuffer.diffuse", "gbuffer.specular"}) {
        const Access* a = line(c, t, false);
        ASSERT_NE(a, nullptr) << t;
        EXPECT_EQ(a->count, covered) << t;
      }
    }
    if (name == "visbuffer") {
      const Access* a = line(c, "visibility.uv_derivatives", false);
      ASSERT_NE(a, nullptr);
      EXPECT_EQ(a->count, covered);
    }
    // The other passes are untouched.
    for (const auto& p : frag.frame.passes) {
      if (p.name == passName) continue;
      EXPECT_EQ(passNamed(comp, p.name).fragmentInvocations, p.fragmentInvocations) << p.name;
    }
  }
}

TEST(ComputeShadingImages, MatchTheFragmentPass) {
  const VkExtent2D extent = {96, 54};
  for (const nlohmann::json& spec : {nlohmann::json("atrium"), sky(0.5)}) {
    for (const auto& name : kRenderers) {
      SCOPED_TRACE(name + " " + spec.dump());
      Rendered frag = render(name, spec, extent, withCompute(false));
      Rendered comp = render(name, spec, extent, withCompute(true));
      ASSERT_TRUE(frag.ok) << frag.error;
      ASSERT_TRUE(comp.ok) << comp.error;
      auto e = analysis::compareImages(frag.image, comp.image, extent.width, extent.height);
      ASSERT_TRUE(e.ok()) << e.error();
      std::printf("[compute shading] %s %s: psnr %.2f dB, max %d, mean %.5f\n", name.c_str(), spec.dump().c_str(),
                  e->psnr, e->maxAbs, e->meanAbs);
      EXPECT_GE(e->psnr, kMinPsnr);
      EXPECT_LE(e->maxAbs, 2);

      EXPECT_EQ(comp.notes.value("shading", ""), "compute") << comp.notes.dump();
      EXPECT_EQ(comp.notes.value("workgroup", nlohmann::json()), nlohmann::json({8, 8}));
      EXPECT_FALSE(frag.notes.contains("shading")) << "fragment: notes as before";
      EXPECT_FALSE(frag.notes.contains("workgroup"));
      std::string hdrUsage, fragUsage;
      for (const auto& r : comp.resources) {
        if (r.name == "hdr") hdrUsage = r.usage;
      }
      for (const auto& r : frag.resources) {
        if (r.name == "hdr") fragUsage = r.usage;
      }
      EXPECT_NE(hdrUsage.find("storage"), std::string::npos) << hdrUsage;
      EXPECT_EQ(fragUsage.find("storage"), std::string::npos) << "fragment: hdr without storage usage";
    }
  }
}

// The compute pass moves "hdr" UNDEFINED -> GENERAL -> SHADER_READ_ONLY_OPTIMAL
// every frame; bloom's bright pass and tonemap sample it after. Several
// frames, and bloom on, give the fragment pass's images.
TEST(ComputeShadingImages, HdrLayoutAcrossFramesAndBloom) {
  const VkExtent2D extent = {64, 36};
  for (const auto& name : kRenderers) {
    SCOPED_TRACE(name);
    auto bloom = [](RendererOptions& o) {
      o.bloom.blur = BloomBlur::Separable;
      o.bloom.threshold = 0.5f;
    };
    Rendered frag = render(name, "atrium", extent, withCompute(false, bloom), 3);
    Rendered comp = render(name, "atrium", extent, withCompute(true, bloom), 3);
    Rendered once = render(name, "atrium", extent, withCompute(true, bloom), 1);
    ASSERT_TRUE(frag.ok) << frag.error;
    ASSERT_TRUE(comp.ok) << comp.error;
    ASSERT_TRUE(once.ok) << once.error;
    EXPECT_EQ(comp.image, once.image) << "the third frame equals the first";
    auto e = analysis::compareImages(frag.image, comp.image, extent.width, extent.height);
    ASSERT_TRUE(e.ok());
    EXPECT_GE(e->psnr, kMinPsnr);
    EXPECT_NE(line(passNamed(comp, "bloom_bright"), "hdr", false), nullptr) << "bloom samples the stored hdr";
  }
}

}  // namespace
}  // namespace tally::renderers
