// What footprint marks skip (InstrumentOptions::footprintDedup: the
// subgroup's combined marks, each invocation's cache of the words it
// marked, a loop's range, texel marks left to the lane that marks the same
// block) changes no count: on passes whose blocks are derived here by
// hand, every choice gives those blocks, in every counting mode and at
// every block size; on a trilinear pass, every choice gives what marking
// without either gives.
#include <gtest/gtest.h>

#include "strict.hpp"

#include <set>
#include <string>
#include <utility>
#include <vector>

#include "footprint_pass.hpp"
#include "gpu_fixture.hpp"

namespace tally::test {
namespace {

const spirv::FootprintDedup kNone{false, false, false, false}, kSubgroup{true, false, false, false},
    kCache{false, true, false, false}, kLoops{false, false, true, false}, kLanes{false, false, false, true},
    kAll{true, true, true, true};

struct Choice {
  const char* mode;
  spirv::FootprintDedup dedup;
};

std::vector<Choice> everyChoice() {
  std::vector<Choice> out;
  for (const char* mode : {"exact", "subgroup", "accumulate"}) {
    for (const auto& dedup : {kNone, kSubgroup, kCache, kLoops, kLanes, kAll}) out.push_back({mode, dedup});
  }
  return out;
}

// A compute dispatch of 64 x 64 invocations (8 x 8 workgroups), i its
// index: reads `read` (an expression of i and of k, the loop counter, in
// uint words of binding 0) `trips` times, writes dst.data[i] once.
std::string computeShader(const std::string& read, int trips) {
  return "#version 450\nlayout(local_size_x = 8, local_size_y = 8) in;\n"
         "layout(set = 0, binding = 0) readonly buffer In { uint data[]; } src;\n"
         "layout(set = 0, binding = 1) writeonly buffer Out { uint data[]; } dst;\n"
         "void main() {\n"
         "  uint i = gl_GlobalInvocationID.y * 64u + gl_GlobalInvocationID.x;\n"
         "  uint sum = 0u;\n"
         "  for (uint k = 0u; k < " + std::to_string(trips) + "u; ++k) sum += src.data[" + read + "];\n"
         "  dst.data[i] = sum;\n"
         "}\n";
}

// A full-screen fragment pass over 64 x 64 pixels, i the pixel's index:
// reads src.data[`read`] and writes the target.
std::string fragmentShader(const std::string& read) {
  return "#version 450\n"
         "layout(set = 0, binding = 0) readonly buffer In { uint data[]; } src;\n"
         "layout(location = 0) out vec4 color;\n"
         "void main() {\n"
         "  uint i = uint(gl_FragCoord.y) * 64u + uint(gl_FragCoord.x);\n"
         "  color = vec4(float(src.data[" + read + "]));\n"
         "}\n";
}

class FootprintDedup : public ::testing::TestWithParam<uint32_t> {
 protected:
  void SetUp() override {
    std::string error;
    ctx_ = testContext(&error);
    if (ctx_ == nullptr) TALLY_SKIP_UNLESS_STRICT("no Vulkan device: " << error);
  }

  // Runs `d` with the choice; the marks of its own stage's module skip what
  // was asked (the subgroup's only where the stage has subgroup arithmetic).
  Result<PassResult> run(PassDesc d, const Choice& c) {
    d.blockBytes = GetParam();
    auto mode = spirv::parseMode(c.mode);
    if (!mode) return makeError(mode.error());
    d.mode = *mode;
    d.dedup = c.dedup;
    auto r = FootprintPass(*ctx_).run(d);
    if (!r) return r;
    spirv::FootprintDedup expected = c.dedup;
    const spirv::Stage stage = d.compute ? spirv::Stage::Compute : spirv::Stage::Fragment;
    expected.subgroup = expected.subgroup && (ctx_->subgroupStages & spirv::stageBit(stage)) != 0;
    expected.lanes = expected.lanes && (ctx_->subgroupStages & spirv::stageBit(stage)) != 0;
    EXPECT_FALSE(r->dedup.empty()) << "no module says what its marks skip";
    if (!r->dedup.empty()) {
      EXPECT_EQ(spirv::toString(r->dedup.front()), spirv::toString(expected)) << "the marks skip another choice";
    }
    return r;
  }

  static std::string name(const Choice& c) { return std::string(c.mode) + ", dedup " + spirv::toString(c.dedup); }

  const gpu::Context* ctx_ = nullptr;
};

// Every invocation reads word 0 (bytes 0..3): one block, whichever its
// size; the writes cover dst's 64 x 64 x 4 bytes, 16384 / B blocks.
TEST_P(FootprintDedup, EveryLaneMarksTheSameBlock) {
  PassDesc d;
  d.compute = true;
  d.buffers = {256, 64 * 64 * 4};
  d.source = computeShader("0u", 1);
  for (const Choice& c : everyChoice()) {
    SCOPED_TRACE(name(c));
    auto r = run(d, c);
    ASSERT_TRUE(r.ok()) << r.error();
    EXPECT_EQ(r->lines["binding 0 read"].blocks, 1u);
    EXPECT_EQ(r->lines["binding 0 read"].requestedBytes, 64u * 64 * 4);
    EXPECT_EQ(r->lines["binding 1 write"].blocks, 64u * 64 * 4 / GetParam());
  }
}

// The same in a fragment shader, where helper lanes must not mark for
// others: every pixel reads word 0, one block; the target's 64 x 64 RGBA8
// texels are all written.
TEST_P(FootprintDedup, EveryPixelMarksTheSameBlock) {
  PassDesc d;
  d.buffers = {256};
  d.source = fragmentShader("0u");
  for (const Choice& c : everyChoice()) {
    SCOPED_TRACE(name(c));
    auto r = run(d, c);
    ASSERT_TRUE(r.ok()) << r.error();
    EXPECT_EQ(r->lines["binding 0 read"].blocks, 1u);
    EXPECT_EQ(r->lines["target write"].blocks, rgba8Blocks(64, 64, GetParam()));
  }
}

// Invocation i reads word 32 i: bytes 128 i .. 128 i + 3, in a block of
// its own at every block size up to 128 bytes: 4096 blocks.
TEST_P(FootprintDedup, EveryLaneMarksABlockOfItsOwn) {
  PassDesc d;
  d.compute = true;
  d.buffers = {64 * 64 * 128, 64 * 64 * 4};
  d.source = computeShader("i * 32u", 1);
  for (const Choice& c : everyChoice()) {
    SCOPED_TRACE(name(c));
    auto r = run(d, c);
    ASSERT_TRUE(r.ok()) << r.error();
    EXPECT_EQ(r->lines["binding 0 read"].blocks, 64u * 64);
  }
}

// The same per pixel: 4096 blocks.
TEST_P(FootprintDedup, EveryPixelMarksABlockOfItsOwn) {
  PassDesc d;
  d.buffers = {64 * 64 * 128};
  d.source = fragmentShader("i * 32u");
  for (const Choice& c : everyChoice()) {
    SCOPED_TRACE(name(c));
    auto r = run(d, c);
    ASSERT_TRUE(r.ok()) << r.error();
    EXPECT_EQ(r->lines["binding 0 read"].blocks, 64u * 64);
  }
}

// A loop of 64 trips reads words 8 (i % 64) + k % 8: the 32 bytes from
// 32 (i % 64), one block at every block size, marked again each trip.
// Together the invocations cover bytes 0..2047: 2048 / B blocks.
TEST_P(FootprintDedup, ALoopMarksOneBlockAgainAndAgain) {
  PassDesc d;
  d.compute = true;
  d.buffers = {4096, 64 * 64 * 4};
  d.source = computeShader("(i % 64u) * 8u + k % 8u", 64);
  for (const Choice& c : everyChoice()) {
    SCOPED_TRACE(name(c));
    auto r = run(d, c);
    ASSERT_TRUE(r.ok()) << r.error();
    EXPECT_EQ(r->lines["binding 0 read"].blocks, 2048u / GetParam());
    EXPECT_EQ(r->lines["binding 0 read"].requestedBytes, 64u * 64 * 64 * 4);
  }
}

// Trilinear minification (both levels, a 2 x 2 filter on each), every
// choice against marks that skip nothing.
TEST_P(FootprintDedup, TrilinearReadsAsWithoutDedup) {
  PassDesc d;
  d.source = "#version 450\n"
             "layout(set = 0, binding = 0) uniform sampler2D tex;\n"
             "layout(location = 0) out vec4 color;\n"
             "void main() { color = texture(tex, gl_FragCoord.xy / vec2(64.0) * 2.7 + 0.13); }\n";
  d.textures = {{128}};
  std::vector<Choice> choices = everyChoice();
  auto reference = run(d, choices.front());
  ASSERT_TRUE(reference.ok()) << reference.error();
  const Line& want = reference->lines["binding 0 read"];
  ASSERT_GT(want.blocks, 0u);
  for (const Choice& c : choices) {
    SCOPED_TRACE(name(c));
    auto r = run(d, c);
    ASSERT_TRUE(r.ok()) << r.error();
    EXPECT_EQ(r->lines["binding 0 read"].blocks, want.blocks);
    EXPECT_EQ(r->lines["target write"].blocks, rgba8Blocks(64, 64, GetParam()));
  }
}

// Texel fetches and fragment outputs, the marks FootprintDedup::lanes
// combines: each pixel (x, y) of 64 x 64 that is not discarded fetches texel
// t(x, y) of level 0 of a 64 x 64 RGBA8 texture and writes its own texel of
// the RGBA8 target; the blocks are those of the texels, enumerated here. The
// lanes of a subgroup share blocks (every pixel its own texel, or 3 x 3
// pixels one texel), share none (texels 5 apart), or hold holes where pixels
// were discarded, so that a lane's quad or partition is missing lanes; in a
// fragment shader and in a compute dispatch.
TEST_P(FootprintDedup, FetchedTexelsAsEnumerated) {
  struct Case {
    const char* name;
    const char* texel;    // GLSL of x and y
    const char* discard;  // GLSL condition
    uint32_t (*tx)(uint32_t, uint32_t);
    uint32_t (*ty)(uint32_t, uint32_t);
    bool (*gone)(uint32_t, uint32_t);
  };
  const Case cases[] = {
      {"each pixel its texel", "ivec2(x, y)", "false", [](uint32_t x, uint32_t) { return x; },
       [](uint32_t, uint32_t y) { return y; }, [](uint32_t, uint32_t) { return false; }},
      {"3 x 3 pixels a texel", "ivec2(x / 3, y / 3)", "false", [](uint32_t x, uint32_t) { return x / 3; },
       [](uint32_t, uint32_t y) { return y / 3; }, [](uint32_t, uint32_t) { return false; }},
      {"texels 5 apart", "ivec2((x * 5) % 64, (y * 7) % 64)", "false", [](uint32_t x, uint32_t) { return x * 5 % 64; },
       [](uint32_t, uint32_t y) { return y * 7 % 64; }, [](uint32_t, uint32_t) { return false; }},
      {"holes", "ivec2(x, (y + x / 8) % 64)", "((x ^ y) % 3) == 1 || (x * y) % 7 == 2",
       [](uint32_t x, uint32_t) { return x; }, [](uint32_t x, uint32_t y) { return (y + x / 8) % 64; },
       [](uint32_t x, uint32_t y) { return (x ^ y) % 3 == 1 || (x * y) % 7 == 2; }},
  };
  const TileDims tile = rgba8Tile(GetParam());
  for (const Case& k : cases) for (bool compute : {false, true}) {
    SCOPED_TRACE(std::string(k.name) + (compute ? ", compute" : ", fragment"));
    PassDesc d;
    d.compute = compute;
    d.textures = {{64, VK_FILTER_NEAREST}};
    if (compute) {
      // The same fetches from a dispatch of 64 x 64 (x, y) invocations; a
      // discarded pixel's invocation returns first. Writes go to a buffer.
      d.buffers = {64 * 64 * 16};
      d.source = std::string("#version 450\nlayout(local_size_x = 8, local_size_y = 8) in;\n"
                             "layout(set = 0, binding = 0) uniform sampler2D tex;\n"
                             "layout(set = 0, binding = 1) writeonly buffer Out { vec4 data[]; } dst;\n"
                             "void main() {\n"
                             "  int x = int(gl_GlobalInvocationID.x), y = int(gl_GlobalInvocationID.y);\n"
                             "  if (") + k.discard + ") return;\n"
                             "  dst.data[y * 64 + x] = texelFetch(tex, " + k.texel + ", 0);\n"
                             "}\n";
    } else {
      d.source = std::string("#version 450\n"
                             "layout(set = 0, binding = 0) uniform sampler2D tex;\n"
                             "layout(location = 0) out vec4 color;\n"
                             "void main() {\n"
                             "  int x = int(gl_FragCoord.x), y = int(gl_FragCoord.y);\n"
                             "  if (") + k.discard + ") discard;\n"
                             "  color = texelFetch(tex, " + k.texel + ", 0);\n"
                             "}\n";
    }
    std::set<std::pair<uint32_t, uint32_t>> blocks, written;
    uint64_t pixels = 0;
    for (uint32_t y = 0; y < 64; ++y) {
      for (uint32_t x = 0; x < 64; ++x) {
        if (k.gone(x, y)) continue;
        ++pixels;
        blocks.insert({k.tx(x, y) / tile.w, k.ty(x, y) / tile.h});
        written.insert({x / tile.w, y / tile.h});
      }
    }
    for (const Choice& c : everyChoice()) {
      SCOPED_TRACE(name(c));
      auto r = run(d, c);
      ASSERT_TRUE(r.ok()) << r.error();
      EXPECT_EQ(r->lines["binding 0 read"].blocks, blocks.size());
      EXPECT_EQ(r->lines["binding 0 read"].requestedBytes, pixels * 4);
      if (!compute) {
        EXPECT_EQ(r->lines["target write"].blocks, written.size());
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(BlockBytes, FootprintDedup, ::testing::Values(32u, 64u, 128u),
                         [](const ::testing::TestParamInfo<uint32_t>& block) {
                           return std::to_string(block.param) + "B";
                         });

}  // namespace
}  // namespace tally::test
