// MSAA footprint (docs/techniques.md, "MSAA footprint"): the option table's
// checks, the refusal of sample counts the device lacks, and on the test
// device (lavapipe in CI: 1 and 4 samples) for deferred, visbuffer and
// visbuffer-lean at every supported count:
// - footprint: every target's real allocation holds width x height x samples
//   x element bytes, and the per-sample targets' bytes at N over those at 1
//   are N within allocation padding;
// - counts, derived on a full-screen plane (every sample covered): geometry
//   pass writes = pixels x N per target, shading-pass reads of the per-sample
//   targets = pixels x N, visibility-buffer triangle shadings between one per
//   pixel and one more per pixel the quad's diagonal splits;
// - image: msaa=N against msaa=1 differs only next to the plane's edges, and
//   deferred and visbuffer at N agree as they do at 1.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "analytic.hpp"
#include "render_fixture.hpp"
#include "renderers/techniques/msaa.hpp"
#include "renderers/options.hpp"

namespace tally::renderers {
using namespace fixture;
namespace {

constexpr VkExtent2D kExtent = {64, 36};
const std::vector<std::string> kRenderers = {"deferred", "visbuffer", "visbuffer-lean"};

// The counts > 1 the test device renders to (framebufferColorSampleCounts).
std::vector<uint32_t> supportedCounts() {
  std::vector<uint32_t> out;
  gpu::Context* ctx = context();
  if (ctx == nullptr) return out;
  VkPhysicalDeviceProperties props;
  vkGetPhysicalDeviceProperties(ctx->physicalDevice, &props);
  for (uint32_t n : {2u, 4u, 8u}) {
    if (props.limits.framebufferColorSampleCounts & n) out.push_back(n);
  }
  return out;
}

std::function<void(RendererOptions&)> withMsaa(uint32_t n) {
  return [n](RendererOptions& o) { o.msaa = n; };
}

const ResourceInfo* resourceNamed(const Rendered& r, const std::string& name) {
  for (const auto& info : r.resources) {
    if (info.name == name) return &info;
  }
  return nullptr;
}

// The geometry pass's targets: multisampled at N > 1 (the N-sample depth is
// "depth.msaa"; at 1 sample the geometry pass renders "depth").
std::vector<std::string> perSampleTargets(const std::string& renderer, bool msaa) {
  std::vector<std::string> out;
  if (renderer == "deferred") out = {"gbuffer.normal", "gbuffer.diffuse", "gbuffer.specular"};
  if (renderer == "visbuffer") out = {"visibility.id", "visibility.uv_derivatives"};
  if (renderer == "visbuffer-lean") out = {"visibility.id"};
  out.push_back(msaa ? kMsaaDepthName : "depth");
  return out;
}

uint64_t countedOn(const PassResult& p, const std::string& name, bool write, const std::string& source) {
  uint64_t n = 0;
  for (const auto& a : p.accesses) {
    if (a.write == write && a.source == source && a.resource == name) n += a.count;
  }
  return n;
}

TEST(MsaaOptions, TableChecksValues) {
  for (const auto& name : kRenderers) {
    auto ok = canonicalOptions(name, {{"msaa", 4}});
    ASSERT_TRUE(ok.ok()) << ok.error();
    EXPECT_EQ(variantLabel(name, *ok), name + " msaa=4");
    auto plain = canonicalOptions(name, {{"msaa", 1}});
    ASSERT_TRUE(plain.ok());
    EXPECT_EQ(*plain, nlohmann::json::object()) << "1 is the default";
    for (const nlohmann::json& bad : {nlohmann::json(3), nlohmann::json(16), nlohmann::json("4"), nlohmann::json(4.0)}) {
      auto refused = canonicalOptions(name, {{"msaa", bad}});
      ASSERT_FALSE(refused.ok()) << bad.dump();
      EXPECT_EQ(refused.error().rfind("msaa: ", 0), 0u) << refused.error();
    }
  }
  auto forward = canonicalOptions("forward", {{"msaa", 4}});
  ASSERT_FALSE(forward.ok());
  EXPECT_EQ(forward.error().rfind("msaa: forward takes no option msaa", 0), 0u) << forward.error();
}

// Counts the device lacks are refused at setup with the limit and the count
// named; zprepass (a 1-sample pre-pass) with msaa too.
TEST(MsaaOptions, UnsupportedCountsRefused) {
  gpu::Context* ctx = context();
  ASSERT_NE(ctx, nullptr);
  VkPhysicalDeviceProperties props;
  vkGetPhysicalDeviceProperties(ctx->physicalDevice, &props);
  const nlohmann::json spec = planes(1, "front-to-back", 1.0);
  bool refusedOne = false;
  for (uint32_t n : {2u, 8u}) {
    if (props.limits.framebufferColorSampleCounts & n) continue;
    for (const auto& name : kRenderers) {
      Rendered r = render(name, spec, kExtent, withMsaa(n), 1, true);
      EXPECT_FALSE(r.ok);
      const std::string bit = "VK_SAMPLE_COUNT_" + std::to_string(n) + "_BIT";
      EXPECT_NE(r.error.find("msaa " + std::to_string(n) + " is not supported"), std::string::npos) << r.error;
      EXPECT_NE(r.error.find("framebufferColorSampleCounts lacks " + bit), std::string::npos) << r.error;
      EXPECT_NE(r.error.find(name), std::string::npos) << r.error;
      refusedOne = true;
    }
  }
  if (!refusedOne) GTEST_LOG_(INFO) << "the device has 2 and 8 samples: nothing to refuse";
  EXPECT_NE(msaaUnsupported(*ctx, 3, {}, false).find("must be 1, 2, 4 or 8"), std::string::npos);
  Rendered both = render("deferred", spec, kExtent,
                         [](RendererOptions& o) {
                           o.msaa = 4;
                           o.zprepass = true;
                         },
                         1, true);
  EXPECT_NE(both.error.find("zprepass"), std::string::npos) << both.error;
}

TEST(MsaaFootprint, AllocationsHoldEverySampleAndScaleWithN) {
  const auto counts = supportedCounts();
  ASSERT_FALSE(counts.empty()) << "the device renders to no multisampled target";
  const nlohmann::json spec = planes(1, "front-to-back", 1.0);
  for (const auto& name : kRenderers) {
    Rendered one = render(name, spec, kExtent);
    ASSERT_TRUE(one.ok) << one.error;
    EXPECT_EQ(one.extras.value("msaa", nlohmann::json()), nlohmann::json()) << "no msaa extras at 1 sample";
    uint64_t sumOne = 0, formatOne = 0;
    for (const auto& t : perSampleTargets(name, false)) {
      const ResourceInfo* r = resourceNamed(one, t);
      ASSERT_NE(r, nullptr) << name << " " << t;
      EXPECT_EQ(r->samples, 1u);
      sumOne += r->allocationBytes;
      formatOne += uint64_t(r->width) * r->height * r->elementBytes;
    }
    for (uint32_t n : counts) {
      const std::string label = name + " msaa=" + std::to_string(n);
      Rendered many = render(name, spec, kExtent, withMsaa(n));
      ASSERT_TRUE(many.ok) << label << ": " << many.error;
      uint64_t sumN = 0, perSample = 0, perPixel = 0;
      for (const auto& r : many.resources) {
        if (r.kind != ResourceKind::Attachment && r.kind != ResourceKind::Depth) continue;
        EXPECT_GE(r.allocationBytes, uint64_t(r.width) * r.height * r.samples * r.elementBytes) << label << " " << r.name;
        (r.samples > 1 ? perSample : perPixel) += r.allocationBytes;
      }
      for (const auto& t : perSampleTargets(name, true)) {
        const ResourceInfo* r = resourceNamed(many, t);
        ASSERT_NE(r, nullptr) << label << " " << t;
        EXPECT_EQ(r->samples, n) << label << " " << t;
        sumN += r->allocationBytes;
      }
      // N x within padding: at most one 64 KiB alignment per target either way.
      const double padding = 65536.0 * double(perSampleTargets(name, true).size());
      EXPECT_GE(double(sumN), double(n) * double(formatOne)) << label;
      EXPECT_NEAR(double(sumN), double(n) * double(sumOne), padding * n) << label;
      // The 1-sample targets ("hdr", "final", the stencil mask "depth") stay.
      const ResourceInfo* hdr = resourceNamed(many, "hdr");
      ASSERT_NE(hdr, nullptr);
      EXPECT_EQ(hdr->samples, 1u);
      const ResourceInfo* depth = resourceNamed(many, "depth");
      ASSERT_NE(depth, nullptr);
      EXPECT_EQ(depth->samples, 1u);
      const nlohmann::json& e = many.extras["msaa"];
      EXPECT_EQ(e["samples"], n) << many.extras.dump();
      EXPECT_EQ(e["per_sample_bytes"], perSample);
      EXPECT_EQ(e["per_sample_bytes"], sumN) << label << ": exactly the geometry pass's targets are multisampled";
      EXPECT_EQ(e["per_pixel_bytes"], perPixel);
      EXPECT_EQ(e["render_target_bytes"], perSample + perPixel);
    }
  }
}

// A full-screen plane: every sample of every pixel is covered, so the
// geometry pass writes pixels x N per target and the shading pass fetches
// pixels x N texels of each per-sample target.
TEST(MsaaCounts, ScaleWithSamplesOnAFullScreenPlane) {
  const auto counts = supportedCounts();
  ASSERT_FALSE(counts.empty());
  const nlohmann::json spec = planes(1, "front-to-back", 1.0);
  const analytic::Geometry g = analytic::geometryOf(spec, kExtent);
  ASSERT_EQ(g.covered, g.pixels) << "the plane covers the screen";
  const uint64_t pixels = g.pixels;
  for (uint32_t n : counts) {
    // Deferred: per sample.
    {
      Rendered r = render("deferred", spec, kExtent, withMsaa(n));
      ASSERT_TRUE(r.ok) << r.error;
      // One fragment per pixel and triangle covering any of its samples: the
      // quad has two triangles, so between one and two per pixel.
      const PassResult& gb = passNamed(r, "gbuffer");
      EXPECT_GE(gb.fragmentInvocations, pixels);
      EXPECT_LE(gb.fragmentInvocations, 2 * pixels);
      for (const char* t : {"gbuffer.normal", "gbuffer.diffuse", "gbuffer.specular", kMsaaDepthName}) {
        // fragments x N: pixels x N (every sample written once) plus the split pixels' extra fragments.
        EXPECT_EQ(countedOn(gb, t, true, "derived"), gb.fragmentInvocations * n) << t;
        EXPECT_GE(countedOn(gb, t, true, "derived"), pixels * n) << t;
        EXPECT_EQ(countedOn(gb, t, true, "counter"), 0u) << t;
      }
      const PassResult& light = passNamed(r, "lighting");
      EXPECT_EQ(light.fragmentInvocations, pixels);
      for (const char* t : {kMsaaDepthName, "gbuffer.normal", "gbuffer.diffuse", "gbuffer.specular"}) {
        EXPECT_EQ(countedOn(light, t, false, "counter"), pixels * n) << t << ": N x G-buffer texels per pixel";
      }
    }
    // Visibility buffers: N ids per pixel; each distinct triangle shaded
    // once: one or two per pixel (the quad's two triangles).
    for (const std::string name : {"visbuffer", "visbuffer-lean"}) {
      Rendered r = render(name, spec, kExtent, withMsaa(n));
      ASSERT_TRUE(r.ok) << r.error;
      const PassResult& vis = passNamed(r, "visibility");
      EXPECT_GE(vis.fragmentInvocations, pixels) << name;
      EXPECT_LE(vis.fragmentInvocations, 2 * pixels) << name;
      EXPECT_EQ(countedOn(vis, "visibility.id", true, "derived"), vis.fragmentInvocations * n) << name;
      EXPECT_EQ(countedOn(vis, kMsaaDepthName, true, "derived"), vis.fragmentInvocations * n) << name;
      const PassResult& shading = passNamed(r, "shading");
      EXPECT_EQ(shading.fragmentInvocations, pixels) << name;
      EXPECT_EQ(countedOn(shading, "visibility.id", false, "counter"), pixels * n) << name;
      const uint64_t maps = counted(shading, "material_maps.", false);
      EXPECT_EQ(maps % 5, 0u) << name << ": five maps per shaded triangle";
      const uint64_t shaded = maps / 5;
      EXPECT_GE(shaded, pixels) << name;
      EXPECT_LE(shaded, 2 * pixels) << name;
      EXPECT_LE(shaded, vis.fragmentInvocations) << name << ": a triangle is shaded only where it has a fragment";
      if (name == "visbuffer") {
        EXPECT_EQ(countedOn(shading, "visibility.uv_derivatives", false, "counter"), shaded)
            << "one derivative texel per shaded triangle";
      }
    }
  }
}

int maxChannelDifference(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, size_t pixel) {
  int d = 0;
  for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(int(a[pixel * 4 + c]) - int(b[pixel * 4 + c])));
  return d;
}

// Half the screen covered: the plane's edges are rows (the quads span the
// full width). MSAA changes the pixels those edges cross and their
// neighbours, nothing else beyond rounding (kInterior); deferred and
// visbuffer at N differ by no more than at 1 plus that rounding.
TEST(MsaaImage, DiffersOnlyNearEdgesAndRenderersAgree) {
  constexpr int kInterior = 3;  // 8-bit steps: per-sample depth at the pixel centre, averaging
  const auto counts = supportedCounts();
  ASSERT_FALSE(counts.empty());
  const nlohmann::json spec = planes(1, "front-to-back", 0.5);
  const analytic::Geometry g = analytic::geometryOf(spec, kExtent);
  ASSERT_GT(g.rows.count, 0u);
  ASSERT_LT(g.covered, g.pixels);
  auto nearEdge = [&](uint32_t row) {
    const int64_t top = g.rows.first, bottom = int64_t(g.rows.first) + g.rows.count;  // first uncovered row below
    return std::llabs(int64_t(row) - top) <= 1 || std::llabs(int64_t(row) - (top - 1)) <= 1 ||
           std::llabs(int64_t(row) - bottom) <= 1 || std::llabs(int64_t(row) - (bottom - 1)) <= 1;
  };
  for (uint32_t n : counts) {
    std::map<std::string, std::vector<uint8_t>> images, plain;
    for (const auto& name : kRenderers) {
      Rendered one = render(name, spec, kExtent);
      Rendered many = render(name, spec, kExtent, withMsaa(n));
      ASSERT_TRUE(one.ok && many.ok) << name;
      uint64_t changedNearEdge = 0, changedInside = 0;
      for (uint32_t y = 0; y < kExtent.height; ++y) {
        for (uint32_t x = 0; x < kExtent.width; ++x) {
          const int d = maxChannelDifference(one.image, many.image, size_t(y) * kExtent.width + x);
          if (nearEdge(y)) {
            changedNearEdge += d > kInterior;
          } else {
            changedInside += d > kInterior;
          }
        }
      }
      // Inside the plane the only geometric edge is the quad's diagonal, shared
      // by its two triangles: it crosses at most W + H pixels. (The fat
      // visibility buffer's unorm16 barycentrics clamp the negative ones a
      // pixel centre outside the triangle gets: visible there.)
      EXPECT_LE(changedInside, uint64_t(kExtent.width + kExtent.height)) << name << " msaa=" << n;
      GTEST_LOG_(INFO) << name << " msaa=" << n << ": " << changedInside << " pixels on the diagonal changed";
      GTEST_LOG_(INFO) << name << " msaa=" << n << ": " << changedNearEdge << " edge pixels changed";
      images[name] = many.image;
      plain[name] = one.image;
    }
    // Mean 8-bit difference: deferred vs each visibility buffer at N within
    // that at 1 plus kInterior / 4 (the diagonal's pixels are < 5% here).
    for (const std::string other : {"visbuffer", "visbuffer-lean"}) {
      double sumOne = 0, sumMany = 0;
      for (size_t p = 0; p < g.pixels; ++p) {
        sumOne += maxChannelDifference(plain["deferred"], plain[other], p);
        sumMany += maxChannelDifference(images["deferred"], images[other], p);
      }
      EXPECT_LE(sumMany / double(g.pixels), sumOne / double(g.pixels) + kInterior / 4.0)
          << "deferred vs " << other << " msaa=" << n;
      GTEST_LOG_(INFO) << "deferred vs " << other << " mean difference at 1: " << sumOne / double(g.pixels)
                       << ", at " << n << ": " << sumMany / double(g.pixels);
    }
  }
}

}  // namespace
}  // namespace tally::renderers
