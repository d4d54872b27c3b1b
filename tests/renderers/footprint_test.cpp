// Footprint through the renderers, on the planes scene whose coverage is
// known analytically (analytic.hpp): every G-buffer target is written and
// read once per covered pixel whatever the overdraw, the light buffer is
// read once whatever the pixel count, and no line reports more footprint
// than requested bytes.
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
        if (std::string(order) == "back-to-front") EXPECT_EQ(written->bytes, 4 * g.covered * info->elementBytes);
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

TEST_P(RendererFootprint, NoLineReportsMoreThanItRequested) {
  const uint32_t block = GetParam();
  const VkExtent2D extent = {97, 131};
  for (const auto& name : rendererNames()) {
    Rendered r = render(name, planes(3, "front-to-back", 0.5), extent,
                        [&](RendererOptions& o) { o.footprintBlockBytes = block; });
    ASSERT_TRUE(r.ok) << name << ": " << r.error;
    size_t measured = 0, counted = 0;
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
        EXPECT_LE(uint64_t(a.footprintBytes), a.bytes) << name << " " << p.name << " " << a.resource;
        EXPECT_EQ(a.footprintBytes, int64_t(std::min<uint64_t>(uint64_t(a.footprintBlocks) * block, a.bytes)));
        if (a.count > 0) EXPECT_GT(a.footprintBlocks, 0) << name << " " << p.name << " " << a.resource;
      }
    }
    std::printf("%s, %u-byte blocks: footprint on %zu of %zu counted lines\n", name.c_str(), block, measured, counted);
    EXPECT_GT(measured, 0u) << name;
  }
}

INSTANTIATE_TEST_SUITE_P(BlockBytes, RendererFootprint, ::testing::Values(32u, 64u, 128u),
                         [](const ::testing::TestParamInfo<uint32_t>& info) {
                           return std::to_string(info.param) + "B";
                         });

}  // namespace
}  // namespace tally::renderers
