// Tile memory (docs/techniques.md, "Tile memory"; docs/measurement.md, "Byte
// models"): deferred gbuffer=subpass reads the G-buffer with subpassLoad in
// the lighting subpass of one render pass. The counts equal the analytic
// prediction and the sampled variant's (now attachment reads), the images
// agree, the tile-memory model removes exactly the on-chip lines derived by
// hand from the counts and formats, transient targets report the memory the
// device offers, and the option table refuses bad values.
#include <cstdio>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "analytic.hpp"
#include "analysis/image.hpp"
#include "gpu/shaders.hpp"
#include "render_fixture.hpp"
#include "renderers/options.hpp"
#include "renderers/renderer_base.hpp"
#include "renderers/techniques/tile_memory.hpp"
#include "shared.h"

namespace tally::renderers {
using namespace fixture;
namespace {

constexpr VkExtent2D kExtent = {96, 54};
// Bytes per event, from the formats (renderers/deferred.cpp, renderer_base.hpp).
constexpr uint64_t kNormalBytes = 8;    // R16G16B16A16_SFLOAT
constexpr uint64_t kDiffuseBytes = 4;   // R8G8B8A8_UNORM
constexpr uint64_t kSpecularBytes = 4;  // R8G8B8A8_UNORM
constexpr uint64_t kDepthAspectBytes = 4;  // the D32 depth aspect of D32_SFLOAT_S8_UINT

std::function<void(RendererOptions&)> gbuffer(const std::string& mode, bool zprepass = false) {
  nlohmann::json options = {{"gbuffer", mode}};
  if (zprepass) options["zprepass"] = true;
  auto canonical = canonicalOptions("deferred", options);
  EXPECT_TRUE(canonical.ok()) << (canonical ? "" : canonical.error());
  const nlohmann::json c = canonical ? *canonical : nlohmann::json::object();
  return [c](RendererOptions& o) { applyOptions(c, o); };
}

const Access* line(const PassResult& p, const std::string& resource, bool write) {
  for (const auto& a : p.accesses) {
    if (a.resource == resource && a.write == write) return &a;
  }
  return nullptr;
}

uint64_t allBytes(const FrameResult& f) {
  uint64_t n = 0;
  for (const auto& p : f.passes) {
    for (const auto& a : p.accesses) n += a.bytes;
  }
  return n;
}

const ResourceInfo* resource(const Rendered& r, const std::string& name) {
  for (const auto& info : r.resources) {
    if (info.name == name) return &info;
  }
  return nullptr;
}

TEST(TileMemoryOptions, TableAndBadValues) {
  const OptionDef* def = nullptr;
  for (const auto& d : optionDefs()) {
    if (d.name == "gbuffer") def = &d;
  }
  ASSERT_NE(def, nullptr);
  EXPECT_EQ(def->renderers, std::vector<std::string>({"deferred"}));
  EXPECT_EQ(def->values, std::vector<nlohmann::json>({"sampled", "subpass"}));
  EXPECT_EQ(def->defaultValue(), "sampled");
  EXPECT_FALSE(def->parameter);

  auto bad = [](const std::string& renderer, const nlohmann::json& options) {
    auto r = canonicalOptions(renderer, options);
    ASSERT_FALSE(r.ok()) << options.dump();
    EXPECT_EQ(r.error().rfind("gbuffer:", 0), 0u) << r.error();
  };
  bad("deferred", {{"gbuffer", "tiled"}});
  bad("deferred", {{"gbuffer", true}});
  bad("forward", {{"gbuffer", "subpass"}});  // forward has no G-buffer
  bad("visbuffer", {{"gbuffer", "subpass"}});

  auto ok = canonicalOptions("deferred", {{"gbuffer", "subpass"}, {"zprepass", false}});
  ASSERT_TRUE(ok.ok()) << ok.error();
  EXPECT_EQ(*ok, nlohmann::json({{"gbuffer", "subpass"}}));
  EXPECT_EQ(variantLabel("deferred", *ok), "deferred gbuffer=subpass");
  EXPECT_EQ(*canonicalOptions("deferred", {{"gbuffer", "sampled"}}), nlohmann::json::object());
  RendererOptions o;
  applyOptions(*ok, o);
  EXPECT_TRUE(o.gbufferSubpass);

  // Set directly: MSAA G-buffers are not combined with subpasses.
  Rendered r = render("deferred", planes(1, "front-to-back"), {32, 24},
                      [](RendererOptions& ro) {
                        ro.gbufferSubpass = true;
                        ro.msaa = 4;
                      },
                      1, true);
  EXPECT_NE(r.error.find("gbuffer=subpass"), std::string::npos) << r.error;
}

// The lighting subpass's shader: every G-buffer read is a subpassLoad, the
// attribute "attachment_read" in the site table, at the sampled variant's
// bindings.
TEST(TileMemory, LightingSubpassReadsAreAttachmentReads) {
  gpu::Context* ctx = context();
  ASSERT_NE(ctx, nullptr);
  auto source = gpu::loadShaderSource(*ctx, shaderDirectory().value(), "lighting_subpass.frag.glsl");
  ASSERT_TRUE(source.ok()) << source.error();
  auto compiled = gpu::compileAndInstrument(*ctx, *source, gpu::instrumentOptionsFor(*ctx, spirv::Mode{}));
  ASSERT_TRUE(compiled.ok()) << compiled.error();
  std::set<int64_t> attachmentBindings, textureBindings;
  for (const auto& site : compiled->result.sites) {
    if (site.kind == spirv::SiteKind::AttachmentRead) {
      EXPECT_EQ(site.set, int64_t(shaders::kSetPassInput));
      attachmentBindings.insert(site.binding);
    }
    if (site.kind == spirv::SiteKind::TextureRead) {
      EXPECT_EQ(site.set, int64_t(shaders::kSetPassInput));
      textureBindings.insert(site.binding);
    }
  }
  EXPECT_EQ(attachmentBindings, std::set<int64_t>({shaders::kBindingNormalTarget, shaders::kBindingDiffuseTarget,
                                                   shaders::kBindingSpecularTarget}));
  // Depth through the sampled depth view, as the sampled variant reads it.
  EXPECT_EQ(textureBindings, std::set<int64_t>({shaders::kBindingDepthTarget}));
}

// Counts: the subpass variant's lighting reads covered pixels x 4 attachments,
// the sampled variant's texture reads of the same G-buffer; every pass
// equals the sampled variant's counts; the images agree.
TEST(TileMemory, SubpassCountsAndImageMatchSampled) {
  for (bool zprepass : {false, true}) {
    const auto spec = planes(3, "back-to-front", 0.6);
    const analytic::Geometry g = analytic::geometryOf(spec, kExtent);
    ASSERT_FALSE(g.rows.ambiguous);
    Rendered sampled = render("deferred", spec, kExtent, gbuffer("sampled", zprepass));
    Rendered subpass = render("deferred", spec, kExtent, gbuffer("subpass", zprepass));
    ASSERT_TRUE(sampled.ok) << sampled.error;
    ASSERT_TRUE(subpass.ok) << subpass.error;
    const std::string label = zprepass ? "zprepass" : "plain";
    ASSERT_EQ(sampled.frame.passes.size(), subpass.frame.passes.size()) << label;

    const PassResult& lighting = passNamed(subpass, "lighting");
    EXPECT_EQ(lighting.fragmentInvocations, g.covered) << label;
    for (const std::string name : {"depth", "gbuffer.normal", "gbuffer.diffuse", "gbuffer.specular"}) {
      const Access* got = line(lighting, name, false);
      ASSERT_NE(got, nullptr) << label << " " << name;
      EXPECT_EQ(got->count, g.covered) << label << " " << name;
      const Access* want = line(passNamed(sampled, "lighting"), name, false);
      ASSERT_NE(want, nullptr) << label << " " << name;
      EXPECT_EQ(got->count, want->count) << label << " " << name;
      EXPECT_EQ(got->bytes, want->bytes) << label << " " << name;
    }
    // Every pass, every line: as the sampled variant (the instrumented
    // shaders differ only in how the lighting pass reads).
    for (size_t i = 0; i < subpass.frame.passes.size(); ++i) {
      const PassResult& a = sampled.frame.passes[i];
      const PassResult& b = subpass.frame.passes[i];
      EXPECT_EQ(a.name, b.name);
      EXPECT_EQ(a.fragmentInvocations, b.fragmentInvocations) << label << " " << a.name;
      EXPECT_EQ(a.accesses.size(), b.accesses.size()) << label << " " << a.name;
      for (const auto& x : a.accesses) {
        const Access* y = line(b, x.resource, x.write);
        ASSERT_NE(y, nullptr) << label << " " << a.name << " " << x.resource;
        EXPECT_EQ(x.count, y->count) << label << " " << a.name << " " << x.resource;
      }
      if (a.fragmentInvocationsStatistic >= 0) {
        // Statistics queries per subpass (RendererBase::nextSubpass): the
        // lighting subpass's fragment shader invocations are its own.
        EXPECT_GE(b.fragmentInvocationsStatistic, int64_t(b.fragmentInvocations)) << label << " " << a.name;
      }
    }
    // The same texel values reach the same shading code: identical images.
    // Bound: 0 (lavapipe measured 0); a driver that compiles the two
    // fragment shaders with different float contraction could differ by one
    // 8-bit step, which would fail this test and be worth knowing.
    auto e = analysis::compareImages(sampled.image, subpass.image, kExtent.width, kExtent.height);
    ASSERT_TRUE(e.ok());
    std::printf("%s: subpass vs sampled max %d mean %.5f\n", label.c_str(), e->maxAbs, e->meanAbs);
    EXPECT_EQ(e->maxAbs, 0) << label;

    // One render pass: "gbuffer" carries both subpasses' time, lighting 0.
    EXPECT_EQ(lighting.gpuMs, 0.0) << label;
    EXPECT_EQ(subpass.notes.value("gbuffer", ""), "subpass") << subpass.notes.dump();
    EXPECT_TRUE(subpass.notes.contains("timing")) << subpass.notes.dump();
  }
}

// The tile-memory model on the planes scene: the subpass variant's DRAM
// bytes are the immediate bytes less the G-buffer writes (gbuffer fragments x
// 8 + 4 + 4 bytes) and the input-attachment reads (covered pixels x 8 + 4 +
// 4 bytes); depth is sampled from its stored target (DRAM); the sampled
// variant and forward keep everything in DRAM.
TEST(TileMemory, ByteModelRemovesExactlyTheOnChipLines) {
  const auto spec = planes(2, "back-to-front", 0.8);
  const analytic::Geometry g = analytic::geometryOf(spec, kExtent);
  ASSERT_FALSE(g.rows.ambiguous);
  const uint64_t gbufferFragments = uint64_t(g.layers) * g.covered;  // back to front: every layer shaded
  const uint64_t onChip = gbufferFragments * (kNormalBytes + kDiffuseBytes + kSpecularBytes) +
                          g.covered * (kNormalBytes + kDiffuseBytes + kSpecularBytes);

  Rendered subpass = render("deferred", spec, kExtent, gbuffer("subpass"));
  ASSERT_TRUE(subpass.ok) << subpass.error;
  ASSERT_TRUE(subpass.extras.contains("tile_memory")) << subpass.extras.dump();
  const nlohmann::json& t = subpass.extras["tile_memory"];
  const uint64_t immediate = allBytes(subpass.frame);
  std::printf("planes 2 layers %ux%u: immediate %llu bytes, tile model %llu (on chip %llu)\n", kExtent.width,
              kExtent.height, (unsigned long long)immediate, (unsigned long long)(immediate - onChip),
              (unsigned long long)onChip);
  EXPECT_EQ(t.at("bytes").get<uint64_t>(), immediate);
  EXPECT_EQ(t.at("bytes_on_chip").get<uint64_t>(), onChip) << t.dump();
  EXPECT_EQ(t.at("bytes_dram").get<uint64_t>(), immediate - onChip) << t.dump();
  EXPECT_EQ(t.at("on_chip_lines"),
            nlohmann::json({"gbuffer/gbuffer.normal/write", "gbuffer/gbuffer.diffuse/write",
                            "gbuffer/gbuffer.specular/write", "lighting/gbuffer.normal/read",
                            "lighting/gbuffer.diffuse/read", "lighting/gbuffer.specular/read"}))
      << t.dump();
  // Per pass: lighting's DRAM bytes are its hdr writes and buffer reads.
  const PassResult& lighting = passNamed(subpass, "lighting");
  uint64_t lightingDram = 0;
  for (const auto& a : lighting.accesses) {
    const bool attachmentInput = !a.write && a.resource.rfind("gbuffer.", 0) == 0;
    EXPECT_EQ(a.onChip, attachmentInput) << a.resource;
    if (!attachmentInput) lightingDram += a.bytes;
  }
  EXPECT_EQ(t["passes"]["lighting"]["bytes_dram"].get<uint64_t>(), lightingDram);
  const Access* hdr = line(lighting, "hdr", true);
  ASSERT_NE(hdr, nullptr);
  EXPECT_FALSE(hdr->onChip);  // stored for tonemap
  const Access* depthRead = line(lighting, "depth", false);
  ASSERT_NE(depthRead, nullptr);
  EXPECT_EQ(depthRead->bytes, g.covered * kDepthAspectBytes);
  EXPECT_FALSE(depthRead->onChip);  // sampled from the stored depth target
  const Access* depth = line(passNamed(subpass, "gbuffer"), "depth", true);
  ASSERT_NE(depth, nullptr);
  EXPECT_FALSE(depth->onChip);  // stored: the skybox tests its stencil

  // The sampled G-buffer is stored and sampled later: all in DRAM, the same
  // G-buffer write bytes as the subpass variant's on-chip ones.
  // Extras only where something is on chip (the sampled variant has none).
  Rendered sampled = render("deferred", spec, kExtent, gbuffer("sampled"));
  ASSERT_TRUE(sampled.ok) << sampled.error;
  EXPECT_FALSE(sampled.extras.contains("tile_memory")) << sampled.extras.dump();
  const nlohmann::json s = tileMemorySummary(sampled.frame);
  EXPECT_EQ(s.at("bytes_dram"), s.at("bytes"));
  EXPECT_EQ(s.at("bytes_on_chip").get<uint64_t>(), 0u);
  EXPECT_EQ(s.at("bytes").get<uint64_t>(), immediate);  // the same lines, counted alike
  EXPECT_EQ(bytes(passNamed(sampled, "gbuffer"), "gbuffer.normal", true), gbufferFragments * kNormalBytes);

  // Every other renderer stores every attachment it writes: no line on chip.
  for (const std::string name : {"forward", "visbuffer-lean"}) {
    Rendered r = render(name, spec, kExtent);
    ASSERT_TRUE(r.ok) << name << ": " << r.error;
    EXPECT_FALSE(r.extras.contains("tile_memory")) << name;
    EXPECT_GT(allBytes(r.frame), 0u) << name;
    for (const auto& p : r.frame.passes) {
      for (const auto& a : p.accesses) EXPECT_FALSE(a.onChip) << name << " " << p.name << " " << a.resource;
    }
  }
}

// Transient G-buffer targets: lazily allocated memory exactly where the
// device offers a LAZILY_ALLOCATED type (lavapipe does not).
TEST(TileMemory, TransientTargetsReportTheDeviceMemory) {
  gpu::Context* ctx = context();
  ASSERT_NE(ctx, nullptr);
  bool lazy = false;
  for (uint32_t i = 0; i < ctx->memoryProperties.memoryTypeCount; ++i) {
    if (ctx->memoryProperties.memoryTypes[i].propertyFlags & VK_MEMORY_PROPERTY_LAZILY_ALLOCATED_BIT) lazy = true;
  }
  std::printf("device lazily allocated memory: %s\n", lazy ? "yes" : "no");
  const auto spec = planes(1, "front-to-back");
  Rendered subpass = render("deferred", spec, {32, 24}, gbuffer("subpass"));
  Rendered sampled = render("deferred", spec, {32, 24}, gbuffer("sampled"));
  ASSERT_TRUE(subpass.ok && sampled.ok) << subpass.error << sampled.error;
  for (const std::string name : {"gbuffer.normal", "gbuffer.diffuse", "gbuffer.specular"}) {
    const ResourceInfo* t = resource(subpass, name);
    ASSERT_NE(t, nullptr) << name;
    EXPECT_EQ(t->memory, lazy ? "lazily_allocated" : "device_local") << name;
    EXPECT_EQ(subpass.notes["gbuffer_memory"].value(name, ""), t->memory) << name;
    EXPECT_NE(t->usage.find("transient_attachment"), std::string::npos) << t->usage;
    EXPECT_NE(t->usage.find("input_attachment"), std::string::npos) << t->usage;
    EXPECT_EQ(t->usage.find("sampled"), std::string::npos) << t->usage;
    EXPECT_GT(t->allocationBytes, 0u) << name;
    const ResourceInfo* s = resource(sampled, name);
    ASSERT_NE(s, nullptr) << name;
    EXPECT_NE(s->memory, "lazily_allocated") << name;
    EXPECT_FALSE(s->memory.empty()) << name;
  }
}

}  // namespace
}  // namespace tally::renderers
