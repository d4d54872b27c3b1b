// Footprint on analytic cases: distinct blocks touched, against predictions
// derived here from the geometry of each case (texture levels, strides,
// buffer sizes), at every block size. Each case is a small pass built here:
// a full-screen fragment pass or a compute dispatch (footprint_pass.hpp).
#include <gtest/gtest.h>

#include "strict.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <string>

#include "footprint_pass.hpp"
#include "gpu_fixture.hpp"

namespace tally::test {
namespace {

class Footprint : public ::testing::TestWithParam<uint32_t> {
 protected:
  void SetUp() override {
    std::string error;
    ctx_ = testContext(&error);
    if (ctx_ == nullptr) TALLY_SKIP_UNLESS_STRICT("no Vulkan device: " << error);
  }
  Result<PassResult> run(PassDesc d) {
    d.blockBytes = GetParam();
    return FootprintPass(*ctx_).run(d);
  }
  // Every line: footprint bytes (blocks x block bytes) do not exceed requested bytes.
  void expectBounded(const PassResult& r) {
    for (const auto& [key, line] : r.lines) {
      EXPECT_LE(line.blocks * GetParam(), line.requestedBytes) << key;
    }
  }
  const gpu::Context* ctx_ = nullptr;
};

// A full-screen pass: uv = pixel centre / target size x scale + offset.
std::string sampleShader(double scale, double offset = 0.0) {
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "#version 450\n"
                "layout(set = 0, binding = 0) uniform sampler2D tex;\n"
                "layout(location = 0) out vec4 color;\n"
                "void main() {\n"
                "  vec2 uv = gl_FragCoord.xy / vec2(64.0) * %.9f + %.9f;\n"
                "  color = texture(tex, uv);\n"
                "}\n",
                scale, offset);
  return buf;
}

TEST_P(Footprint, TextureAtOneToOneIsLevelZero) {
  PassDesc d;
  d.source = sampleShader(1.0);
  d.textures = {{64}};
  auto r = run(d);
  ASSERT_TRUE(r.ok()) << r.error();
  // lambda = 0: magnification, level 0 (64 x 64), every texel.
  EXPECT_EQ(r->lines["binding 0 read"].blocks, rgba8Blocks(64, 64, GetParam()));
  EXPECT_EQ(r->lines["binding 0 read"].requestedBytes, 64u * 64u * 4u);
  EXPECT_EQ(r->lines["target write"].blocks, rgba8Blocks(64, 64, GetParam()));
  expectBounded(*r);
}

TEST_P(Footprint, MagnifiedTextureIsItsBaseLevel) {
  PassDesc d;
  d.source = sampleShader(1.0);
  d.textures = {{32}};  // 32 x 32 over 64 x 64 pixels: lambda = -1
  auto r = run(d);
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->lines["binding 0 read"].blocks, rgba8Blocks(32, 32, GetParam()));
  expectBounded(*r);
}

TEST_P(Footprint, MinifiedTextureIsBothTrilinearLevels) {
  PassDesc d;
  // 128 x 128 at 2^1.5 texels per pixel: lambda = 1.5, levels 1 (64^2) and 2 (32^2), each covered
  // entirely (the uvs span 1.41 repeats).
  d.source = sampleShader(std::pow(2.0, 1.5) * 64.0 / 128.0);
  d.textures = {{128}};
  auto r = run(d);
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->lines["binding 0 read"].blocks, rgba8Blocks(64, 64, GetParam()) + rgba8Blocks(32, 32, GetParam()));
  // Here the blocks hold more bytes (20480) than were requested (one 4-byte
  // texel per sample, 16384): trilinear filtering reads 8 texels a sample.
  // A line reports the smaller of the two (docs/measurement.md).
  EXPECT_GT(r->lines["binding 0 read"].blocks * GetParam(), r->lines["binding 0 read"].requestedBytes);
}

TEST_P(Footprint, NearestMinificationIsOneLevel) {
  PassDesc d;
  d.source = sampleShader(std::pow(2.0, 1.25) * 64.0 / 128.0);  // lambda = 1.25: nearest level 1
  d.textures = {{128, VK_FILTER_NEAREST}};
  auto r = run(d);
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->lines["binding 0 read"].blocks, rgba8Blocks(64, 64, GetParam()));
  expectBounded(*r);
}

TEST_P(Footprint, VisiblePartOfAMagnifiedTexture) {
  PassDesc d;
  // A quarter of a 64 x 64 texture over the target (lambda = -2), clamped at
  // the edges: bilinear reads texels 0..16 in x and y (u * 64 - 0.5 spans
  // -0.375 .. 15.375: the pairs (i, i + 1) cover -1..16, -1 clamps to 0).
  d.source = sampleShader(0.25);
  d.textures = {{64, VK_FILTER_LINEAR, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE}};
  auto r = run(d);
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->lines["binding 0 read"].blocks, rgba8Blocks(17, 17, GetParam()));
  expectBounded(*r);
}

// Bilinear magnification across the texture's edges in every address mode
// (mirror clamp to edge needs a feature: left out), on a power-of-two and a
// non-power-of-two texture: the blocks of the 2 x 2 texels each pixel reads,
// derived here from u = pixel centre / 64 x scale + offset (and v alike), the
// texel pairs floor(u x size - 0.5) + {0, 1}, and the mode's wrapping. Over
// u in [-0.6, 2.1] every mode but the border reaches every texel; over
// [-0.3, 0.2] each mode reaches texels of its own.
TEST_P(Footprint, AddressModesWrapTheBilinearTexels) {
  const uint32_t block = GetParam();
  const TileDims tile = rgba8Tile(block);
  for (auto [scale, offset] : {std::pair{2.7, -0.6}, std::pair{0.5, -0.3}})
  for (uint32_t size : {16u, 12u}) {
    for (VkSamplerAddressMode mode : {VK_SAMPLER_ADDRESS_MODE_REPEAT, VK_SAMPLER_ADDRESS_MODE_MIRRORED_REPEAT,
                                      VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_BORDER}) {
      SCOPED_TRACE("u from " + std::to_string(offset) + ", size " + std::to_string(size) + ", address mode " +
                   std::to_string(int(mode)));
      const int n = int(size);
      auto wrapped = [&](int c) {  // the texel, or -1 for none (the border)
        switch (mode) {
          case VK_SAMPLER_ADDRESS_MODE_REPEAT: return ((c % n) + n) % n;
          case VK_SAMPLER_ADDRESS_MODE_MIRRORED_REPEAT: {
            int m = ((c % (2 * n)) + 2 * n) % (2 * n);
            return m < n ? m : 2 * n - 1 - m;
          }
          case VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE: return std::clamp(c, 0, n - 1);
          default: return c >= 0 && c < n ? c : -1;
        }
      };
      std::set<std::pair<int, int>> blocks;  // (tile column, tile row)
      for (int p = 0; p < 64; ++p) {
        for (int q = 0; q < 64; ++q) {
          double x = ((p + 0.5) / 64.0 * scale + offset) * n - 0.5, y = ((q + 0.5) / 64.0 * scale + offset) * n - 0.5;
          ASSERT_GT(std::abs(x - std::round(x)), 1e-3) << "a texel boundary: float rounding could go either way";
          ASSERT_GT(std::abs(y - std::round(y)), 1e-3) << "a texel boundary: float rounding could go either way";
          int x0 = int(std::floor(x)), y0 = int(std::floor(y));
          for (int tx : {wrapped(x0), wrapped(x0 + 1)}) {
            for (int ty : {wrapped(y0), wrapped(y0 + 1)}) {
              if (tx >= 0 && ty >= 0) blocks.insert({tx / int(tile.w), ty / int(tile.h)});
            }
          }
        }
      }
      PassDesc d;
      d.source = sampleShader(scale, offset);
      d.textures = {{size, VK_FILTER_LINEAR, mode}};
      auto r = run(d);
      ASSERT_TRUE(r.ok()) << r.error();
      EXPECT_EQ(r->lines["binding 0 read"].blocks, blocks.size());
    }
  }
}

TEST_P(Footprint, BufferReadAtAStride) {
  for (uint32_t strideWords : {1u, 3u, 16u, 40u}) {
    SCOPED_TRACE("stride " + std::to_string(strideWords * 4) + " bytes");
    const uint32_t n = 32 * 32;  // invocations, one read each
    PassDesc d;
    d.compute = true;
    d.width = 32;
    d.height = 32;
    d.buffers = {VkDeviceSize(n) * strideWords * 4, VkDeviceSize(n) * 4};
    d.source = "#version 450\nlayout(local_size_x = 8, local_size_y = 8) in;\n"
               "layout(set = 0, binding = 0) readonly buffer In { uint data[]; } src;\n"
               "layout(set = 0, binding = 1) writeonly buffer Out { uint data[]; } dst;\n"
               "void main() {\n"
               "  uint i = gl_GlobalInvocationID.y * 32u + gl_GlobalInvocationID.x;\n"
               "  dst.data[i] = src.data[i * " + std::to_string(strideWords) + "u];\n"
               "}\n";
    auto r = run(d);
    ASSERT_TRUE(r.ok()) << r.error();
    std::set<uint64_t> blocks;
    for (uint64_t i = 0; i < n; ++i) blocks.insert(i * strideWords * 4 / GetParam());
    EXPECT_EQ(r->lines["binding 0 read"].blocks, blocks.size());
    EXPECT_EQ(r->lines["binding 0 read"].requestedBytes, uint64_t(n) * 4);
    EXPECT_EQ(r->lines["binding 1 write"].blocks, uint64_t(n) * 4 / GetParam());
    // A stride wider than the element touches more block bytes than it
    // requests (a line reports the smaller: docs/measurement.md); dense, never.
    if (strideWords == 1) expectBounded(*r);
  }
}

TEST_P(Footprint, LightBufferReadByEveryPixelCountsOnce) {
  PassDesc d;
  const uint32_t lights = 40;  // 32 bytes each: two vec4
  d.buffers = {VkDeviceSize(lights) * 32};
  d.textures = {};
  d.source = "#version 450\n"
             "layout(set = 0, binding = 0) readonly buffer Lights { vec4 v[]; } lights;\n"
             "layout(location = 0) out vec4 color;\n"
             "void main() {\n"
             "  vec4 sum = vec4(0.0);\n"
             "  for (int i = 0; i < " + std::to_string(lights) + "; ++i) sum += lights.v[2 * i] * lights.v[2 * i + 1];\n"
             "  color = sum;\n"
             "}\n";
  auto r = run(d);
  ASSERT_TRUE(r.ok()) << r.error();
  const Line& l = r->lines["binding 0 read"];
  EXPECT_EQ(l.blocks, uint64_t(lights) * 32 / GetParam());
  EXPECT_EQ(l.requestedBytes, uint64_t(64) * 64 * lights * 32);
  expectBounded(*r);
}

// Executed arithmetic (the roofline's operations in the accumulate mode):
// two runs of a loop that differ only in their trip count differ by the
// extra iterations x the loop body's operations x the invocations. The body
// x = x * 1.0001 + 0.5; ++k is, read from the source, an OpFMul, an OpFAdd
// and an OpIAdd: 3 operations (the comparison k < N counts none).
TEST(ExecutedArithmetic, LoopTripsTimesTheBody) {
  std::string error;
  const gpu::Context* ctx = testContext(&error);
  if (ctx == nullptr) TALLY_SKIP_UNLESS_STRICT("no Vulkan device: " << error);
  auto shader = [](int trips) {
    return "#version 450\nlayout(local_size_x = 8, local_size_y = 8) in;\n"
           "layout(set = 0, binding = 0) writeonly buffer Out { float data[]; } dst;\n"
           "void main() {\n"
           "  uint i = gl_GlobalInvocationID.y * 32u + gl_GlobalInvocationID.x;\n"
           "  float x = float(i);\n"
           "  for (int k = 0; k < " + std::to_string(trips) + "; ++k) x = x * 1.0001 + 0.5;\n"
           "  dst.data[i] = x;\n"
           "}\n";
  };
  uint64_t counted[2] = {0, 0};
  const int trips[2] = {10, 47};
  for (int t = 0; t < 2; ++t) {
    PassDesc d;
    d.compute = true;
    d.width = d.height = 32;
    d.buffers = {32 * 32 * 4};
    d.source = shader(trips[t]);
    d.countArithmetic = true;
    auto r = FootprintPass(*ctx).run(d);
    ASSERT_TRUE(r.ok()) << r.error();
    counted[t] = r->arithmetic;
    EXPECT_GT(counted[t], uint64_t(trips[t]) * 3 * 32 * 32) << "at least the loop's operations";
  }
  EXPECT_EQ(counted[1] - counted[0], uint64_t(trips[1] - trips[0]) * 3 * 32 * 32);
}

// The blocks that run once in every invocation are derived from the
// invocation count, the rest counted by a register: the same total as
// counting every block, in a fragment shader and a compute one, with a
// branch taken by some invocations only, a loop, and a function called once.
TEST(ExecutedArithmetic, DerivedBlocksCountAsCountedOnes) {
  std::string error;
  const gpu::Context* ctx = testContext(&error);
  if (ctx == nullptr) TALLY_SKIP_UNLESS_STRICT("no Vulkan device: " << error);
  const std::string body =
      "float shade(float v) { return v * 0.25 + 1.0; }\n"
      "float work(uint i) {\n"
      "  float x = float(i) * 2.0 + 1.0;\n"
      "  if ((i % 3u) == 0u) x = x * x - 3.0;\n"
      "  for (uint k = 0u; k < (i % 5u); ++k) x = x * 1.5 + float(k);\n"
      "  return shade(x) / 7.0;\n"
      "}\n";
  for (bool compute : {false, true}) {
    PassDesc d;
    d.compute = compute;
    d.width = d.height = 32;
    d.buffers = {32 * 32 * 4};
    d.textures = {};
    d.source = compute ? "#version 450\nlayout(local_size_x = 8, local_size_y = 8) in;\n"
                         "layout(set = 0, binding = 0) writeonly buffer Out { float data[]; } dst;\n" + body +
                         "void main() {\n"
                         "  uint i = gl_GlobalInvocationID.y * 32u + gl_GlobalInvocationID.x;\n"
                         "  dst.data[i] = work(i);\n"
                         "}\n"
                       : "#version 450\n"
                         "layout(set = 0, binding = 0) writeonly buffer Out { float data[]; } dst;\n"
                         "layout(location = 0) out vec4 color;\n" + body +
                         "void main() {\n"
                         "  uint i = uint(gl_FragCoord.y) * 32u + uint(gl_FragCoord.x);\n"
                         "  color = vec4(work(i));\n"
                         "}\n";
    d.countArithmetic = true;
    uint64_t counted[2] = {0, 0};
    size_t derived[2] = {0, 0};
    for (int derive = 0; derive < 2; ++derive) {
      d.deriveOnceSites = derive == 1;
      auto r = FootprintPass(*ctx).run(d);
      ASSERT_TRUE(r.ok()) << r.error();
      counted[derive] = r->arithmetic;
      derived[derive] = r->derived;
    }
    SCOPED_TRACE(compute ? "compute" : "fragment");
    EXPECT_EQ(derived[0], 0u);
    EXPECT_GT(derived[1], 0u) << "the straight-line blocks are derived";
    EXPECT_GT(counted[0], uint64_t(32 * 32) * 4) << "at least the straight-line operations";
    EXPECT_EQ(counted[1], counted[0]);
  }
}

// Blocks in loops whose class has a trip counter (a counted loop's body,
// counted once where it is entered; an uncounted loop with two reads, its
// counter added each trip) are derived from that counter: the same total
// as a register add in every block, with a branch inside the loops too.
TEST(ExecutedArithmetic, LoopBlocksDerivedFromTripCountersCountAsCountedOnes) {
  std::string error;
  const gpu::Context* ctx = testContext(&error);
  if (ctx == nullptr) TALLY_SKIP_UNLESS_STRICT("no Vulkan device: " << error);
  for (bool compute : {false, true}) {
    PassDesc d;
    d.compute = compute;
    d.width = d.height = 32;
    d.buffers = {64 * 4, 32 * 32 * 4};
    const std::string body =
        "layout(set = 0, binding = 0) readonly buffer In { uint data[]; } src;\n"
        "float work(uint i) {\n"
        "  float x = float(i) * 2.0 + 1.0;\n"
        "  for (uint k = 0u; k < 16u; ++k) x = x * 1.0001 + float(src.data[k] & 7u);\n"
        "  uint n = i % 7u;\n"
        "  for (uint k = 0u; k < n; ++k) {\n"
        "    x += float(src.data[k] & 3u);\n"
        "    if ((k & 1u) == 0u) x = x * 0.5 + 1.0;\n"
        "  }\n"
        "  uint m = 0u;\n"
        "  while (x < 900.0 && m < 9u) { x = x * 1.7 + float(src.data[m] & 1u) + float(src.data[m + 1u] & 1u); ++m; }\n"
        "  return x;\n"
        "}\n";
    d.source = compute ? "#version 450\nlayout(local_size_x = 8, local_size_y = 8) in;\n" + body +
                             "layout(set = 0, binding = 1) writeonly buffer Out { float data[]; } dst;\n"
                             "void main() {\n"
                             "  uint i = gl_GlobalInvocationID.y * 32u + gl_GlobalInvocationID.x;\n"
                             "  dst.data[i] = work(i);\n"
                             "}\n"
                       : "#version 450\nlayout(location = 0) out vec4 color;\n" + body +
                             "void main() { color = vec4(work(uint(gl_FragCoord.y) * 32u + uint(gl_FragCoord.x))); }\n";
    if (!compute) d.buffers = {64 * 4};
    d.countArithmetic = true;
    uint64_t counted[2] = {0, 0};
    bool fromTrips[2] = {false, false};
    for (int derive = 0; derive < 2; ++derive) {
      d.deriveOnceSites = derive == 1;
      auto r = FootprintPass(*ctx).run(d);
      ASSERT_TRUE(r.ok()) << r.error();
      counted[derive] = r->arithmetic;
      for (const auto& n : r->notes) fromTrips[derive] = fromTrips[derive] || n.find("derived from their trip counters") != std::string::npos;
    }
    SCOPED_TRACE(compute ? "compute" : "fragment");
    EXPECT_FALSE(fromTrips[0]);
    EXPECT_TRUE(fromTrips[1]) << "blocks of the loops are derived from their trip counters";
    EXPECT_GT(counted[0], uint64_t(32 * 32) * 16 * 3) << "at least the counted loop's operations";
    EXPECT_EQ(counted[1], counted[0]);
  }
}

INSTANTIATE_TEST_SUITE_P(BlockBytes, Footprint, ::testing::Values(32u, 64u, 128u),
                         [](const ::testing::TestParamInfo<uint32_t>& block) {
                           return std::to_string(block.param) + "B";
                         });

}  // namespace
}  // namespace tally::test
