// Footprint through the renderers, on the planes scene whose coverage is
// known analytically (analytic.hpp): every G-buffer target is written and
// read once per covered pixel whatever the overdraw, the light buffer is
// read once whatever the pixel count, no line marks more blocks than its
// accesses can touch, and where blocks x block size exceed the requested
// bytes the clamp is reported.
#include <gtest/gtest.h>

#include <cinttypes>
#include <cstdio>

#include "analytic.hpp"
#include "render_fixture.hpp"
#include "renderers/renderers.hpp"
#include "shared.h"

namespace tally::renderers {
namespace {

using fixture::planes;
using fixture::render;
using fixture::Rendered;

// The tile of one block for a texel size, as docs/measurement.md states it
// (blockBytes / texelBytes texels, as square as powers of two allow, wider
// than tall), written out.
std::pair<uint32_t, uint32_t> tileOf(uint32_t texels) {
  switch (texels) {
    case 1: return {1, 1};
    case 2: return {2, 1};
    case 4: return {2, 2};
    case 8: return {4, 2};
    case 16: return {4, 4};
    case 32: return {8, 4};
    case 64: return {8, 8};
    case 128: return {16, 8};
  }
  return {0, 0};
}

// Blocks of the full-width rows [first, first + count) of a W-wide image.
uint64_t rowBlocks(uint32_t width, uint32_t first, uint32_t count, uint32_t texelBytes, uint32_t blockBytes) {
  auto [tw, th] = tileOf(blockBytes / texelBytes);
  if (count == 0) return 0;
  uint64_t tileRows = (first + count - 1) / th - first / th + 1;
  return tileRows * ((width + tw - 1) / tw);
}

const Access* line(const PassResult& p, const std::string& resource, bool write) {
  for (const auto& a : p.accesses)
    if (a.resource == resource && a.write == write && a.source == "counter") return &a;
  return nullptr;
}

const ResourceInfo* resource(const Rendered& r, const std::string& name) {
  for (const auto& info : r.resources)
    if (info.name == name) return &info;
  return nullptr;
}

class RendererFootprint : public ::testing::TestWithParam<uint32_t> {};

TEST_P(RendererFootprint, GBufferIsTheCoveredAreaWhateverTheOverdraw) {
  const uint32_t block = GetParam();
  const VkExtent2D extent = {157, 91};
  for (const char* order : {"back-to-front", "front-to-back"}) {
    for (double coverage : {1.0, 0.5}) {
      const nlohmann::json spec = planes(4, order, coverage);
      const analytic::Geometry g = analytic::geometryOf(spec, extent);
      ASSERT_FALSE(g.rows.ambiguous);
      Rendered r = render("deferred", spec, extent, [&](RendererOptions& o) { o.footprintBlockBytes = block; });
      ASSERT_TRUE(r.ok) << r.error;
      const PassResult& gbuffer = fixture::passNamed(r, "gbuffer");
      const PassResult& lighting = fixture::passNamed(r, "lighting");
      for (const char* target : {"gbuffer.normal", "gbuffer.diffuse", "gbuffer.specular"}) {
        SCOPED_TRACE(std::string(order) + " coverage " + std::to_string(coverage) + " " + target);
        const ResourceInfo* info = resource(r, target);
        ASSERT_NE(info, nullptr);
        const uint64_t blocks = rowBlocks(extent.width, g.rows.first, g.rows.count, info->elementBytes, block);
        const Access* written = line(gbuffer, target, true);
        ASSERT_NE(written, nullptr);
        EXPECT_EQ(written->footprintBlocks, int64_t(blocks));
        EXPECT_EQ(written->footprintBytes, int64_t(std::min<uint64_t>(blocks * block, written->bytes)));
        // Back to front, every layer writes every covered pixel: 4x the requests, the same footprint.
        if (std::string(order) == "back-to-front") {
          EXPECT_EQ(written->bytes, 4 * g.covered * info->elementBytes);
        }
        const Access* read = line(lighting, target, false);
        ASSERT_NE(read, nullptr);
        EXPECT_EQ(read->footprintBlocks, int64_t(blocks)) << "lighting reads each covered pixel once";
      }
      // The light buffer: every shaded pixel reads every light; its footprint is the lights once.
      const Access* lights = line(lighting, "lights", false);
      ASSERT_NE(lights, nullptr);
      const uint64_t lightBytes = uint64_t(fixture::kTestLights) * sizeof(shaders::PointLight);
      EXPECT_EQ(lights->footprintBlocks, int64_t((lightBytes + block - 1) / block));
      EXPECT_EQ(lights->bytes, g.covered * lightBytes);
    }
  }
}

// The model's own bound, with the clamp taken off (docs/measurement.md,
// "The bound"): each access of e bytes marks the blocks its element spans,
// at most ceil(e / B) + 1 (one more where it straddles a boundary), and a
// line marks at least one block once it made any access. footprint_bytes is the smaller of blocks x B and
// the requested bytes, and footprint_clamped says when the clamp fired.
TEST_P(RendererFootprint, BlocksWithinWhatTheAccessesCanTouchAndTheClampIsReported) {
  const uint32_t block = GetParam();
  const VkExtent2D extent = {97, 131};
  for (const auto& name : rendererNames()) {
    Rendered r = render(name, planes(3, "front-to-back", 0.5), extent,
                        [&](RendererOptions& o) { o.footprintBlockBytes = block; });
    ASSERT_TRUE(r.ok) << name << ": " << r.error;
    size_t measured = 0, counted = 0, clamped = 0;
    for (const auto& p : r.frame.passes) {
      for (const auto& a : p.accesses) {
        if (a.source != "counter") {
          if (a.resource == "indices") {
            // Derived from the index ranges drawn: the planes' quads, 6 indices
            // each, one after another from index 0 of the buffer.
            EXPECT_EQ(a.footprintBlocks, int64_t((a.bytes + block - 1) / block)) << name << " " << p.name;
            EXPECT_EQ(a.footprintBytes, int64_t(a.bytes)) << name << " " << p.name;
          } else {
            EXPECT_EQ(a.footprintBytes, -1) << name << " " << p.name << " " << a.resource << ": derived lines have none";
          }
          continue;
        }
        ++counted;
        if (a.footprintBytes < 0) continue;
        ++measured;
        const std::string what = name + " " + p.name + " " + a.resource;
        ASSERT_GE(a.footprintBlocks, 0) << what;
        const uint64_t blocks = uint64_t(a.footprintBlocks);
        if (a.count == 0) {
          EXPECT_EQ(blocks, 0u) << what << ": blocks marked without an access";
          continue;
        }
        // Summed over accesses of e_i bytes (a line may mix sizes):
        // sum(ceil(e_i / B) + 1) < bytes / B + 2 x count.
        EXPECT_GE(blocks, 1u) << what;
        EXPECT_LE(blocks * block, a.bytes + 2 * uint64_t(block) * a.count)
            << what << ": " << blocks << " blocks for " << a.count << " accesses, " << a.bytes << " bytes";
        EXPECT_EQ(a.footprintClamped, blocks * block > a.bytes) << what;
        EXPECT_EQ(uint64_t(a.footprintBytes), a.footprintClamped ? a.bytes : blocks * block) << what;
        clamped += a.footprintClamped ? 1 : 0;
      }
    }
    std::printf("%s, %u-byte blocks: footprint on %zu of %zu counted lines, %zu clamped to the requested bytes\n",
                name.c_str(), block, measured, counted, clamped);
    EXPECT_GT(measured, 0u) << name;
  }
}

// The clamp fires, and is reported, where accesses are sparser than a block:
// the 97-pixel rows of an RGBA8 target end in a partial block at 128 bytes.
TEST(RendererFootprintClamp, APartialLastBlockIsReportedAsClamped) {
  const uint32_t block = 128;
  Rendered r = render("forward", planes(1, "front-to-back", 1.0), {97, 131},
                      [&](RendererOptions& o) { o.footprintBlockBytes = block; });
  ASSERT_TRUE(r.ok) << r.error;
  size_t clamped = 0, measured = 0;
  for (const auto& p : r.frame.passes) {
    for (const auto& a : p.accesses) {
      if (a.footprintBytes < 0) continue;
      ++measured;
      if (!a.footprintClamped) continue;
      ++clamped;
      EXPECT_EQ(uint64_t(a.footprintBytes), a.bytes) << p.name << " " << a.resource;
      EXPECT_GT(uint64_t(a.footprintBlocks) * block, a.bytes) << p.name << " " << a.resource;
    }
  }
  EXPECT_GT(measured, 0u);
  EXPECT_GT(clamped, 0u) << "no line of a 97-pixel-wide frame at 128-byte blocks was clamped";
}

INSTANTIATE_TEST_SUITE_P(BlockBytes, RendererFootprint, ::testing::Values(32u, 64u, 128u),
                         [](const ::testing::TestParamInfo<uint32_t>& block) {
                           return std::to_string(block.param) + "B";
                         });

}  // namespace
}  // namespace tally::renderers
