// Footprint of buffer reads in loops (FootprintDedup::loops: a read in a
// counted loop marks the range of its iterations once where the loop is
// entered). Each case's blocks are derived here by enumerating, on the CPU,
// every byte range the shader reads (its data is the pass's fixed pattern,
// so data-dependent bounds and branches are enumerated too), and the
// instrumented pass must give those blocks with ranges on and with every
// iteration marking, at each block size. Whether the read was marked as a
// range is checked from the module's note: a case that should not qualify
// (a stride beyond a block, a conditional read) must not be.
#include <gtest/gtest.h>

#include "strict.hpp"

#include <functional>
#include <set>
#include <string>

#include "footprint_pass.hpp"
#include "gpu_fixture.hpp"

namespace tally::test {
namespace {

constexpr uint32_t kInvocations = 64 * 64;
constexpr uint32_t kRowWords = 40;  // src.data[][40]: rows of 160 bytes

// The pass's buffer pattern (footprint_pass.cpp): byte b holds b * 13 + 5.
uint32_t word(uint32_t w) {
  uint32_t v = 0;
  for (uint32_t k = 0; k < 4; ++k) v |= uint32_t(uint8_t((4 * w + k) * 13 + 5)) << (8 * k);
  return v;
}

using Reads = std::function<void(uint32_t invocation, const std::function<void(uint64_t offset, uint64_t bytes)>&)>;

uint64_t blocksOf(const Reads& reads, uint32_t invocations, uint32_t blockBytes, uint64_t* accesses = nullptr) {
  std::set<uint64_t> blocks;
  uint64_t n = 0;
  for (uint32_t i = 0; i < invocations; ++i) {
    reads(i, [&](uint64_t offset, uint64_t bytes) {
      ++n;
      for (uint64_t b = offset / blockBytes; b <= (offset + bytes - 1) / blockBytes; ++b) blocks.insert(b);
    });
  }
  if (accesses != nullptr) *accesses = n;
  return blocks.size();
}

// A dispatch of 64 x 64 invocations, i its index and row = i % 64: `body`
// adds to sum from src (binding 0, `declaration`), and dst.data[i] = sum.
std::string computeShader(const std::string& body,
                          const std::string& declaration = "uint data[][" + std::to_string(kRowWords) + "];") {
  return "#version 450\nlayout(local_size_x = 8, local_size_y = 8) in;\n"
         "struct Item { uvec4 a; uvec4 b; };\n"
         "struct Tri { uint a; uint b; uint c; };\n"
         "struct TriRow { Tri tris[10]; uint pad[2]; };\n"
         "layout(set = 0, binding = 0) readonly buffer In { " + declaration + " } src;\n"
         "layout(set = 0, binding = 1) writeonly buffer Out { uint data[]; } dst;\n"
         "void main() {\n"
         "  uint i = gl_GlobalInvocationID.y * 64u + gl_GlobalInvocationID.x;\n"
         "  uint row = i % 64u;\n"
         "  uint sum = 0u;\n" + body +
         "  dst.data[i] = sum;\n"
         "}\n";
}

struct Case {
  const char* name;
  std::string source;
  Reads reads;
  bool range;            // the read is marked as a range
  bool compute = true;
  uint64_t bytes = 64 * kRowWords * 4;  // src's size
  bool countsAccesses = true;           // src's requested bytes are 4 x the accesses
};

std::vector<Case> cases() {
  auto rowRead = [](uint32_t row, int64_t k, const std::function<void(uint64_t, uint64_t)>& read) {
    read(uint64_t(row) * kRowWords * 4 + uint64_t(k) * 4, 4);
  };
  std::vector<Case> out;
  out.push_back({"UpByOne", computeShader("  for (uint k = 0u; k < 16u; ++k) sum += src.data[row][k];\n"),
                 [=](uint32_t i, auto read) {
                   for (int k = 0; k < 16; ++k) rowRead(i % 64, k, read);
                 },
                 true});
  out.push_back({"DownByThreeSigned", computeShader("  for (int k = 39; k >= 8; k -= 3) sum += src.data[row][k];\n"),
                 [=](uint32_t i, auto read) {
                   for (int k = 39; k >= 8; k -= 3) rowRead(i % 64, k, read);
                 },
                 true});
  out.push_back({"UpByTwoInclusive", computeShader("  for (uint k = 1u; k <= 33u; k += 2u) sum += src.data[row][k];\n"),
                 [=](uint32_t i, auto read) {
                   for (int k = 1; k <= 33; k += 2) rowRead(i % 64, k, read);
                 },
                 true});
  // The bound is read from the buffer: 0 to 6 trips.
  out.push_back({"RunTimeBoundSometimesZero",
                 computeShader("  uint n = (src.data[row][39] + i) % 7u;\n"
                               "  for (uint k = 0u; k < n; ++k) sum += src.data[row][k];\n"),
                 [=](uint32_t i, auto read) {
                   uint32_t row = i % 64;
                   rowRead(row, 39, read);
                   uint32_t n = (word(row * kRowWords + 39) + i) % 7;
                   for (uint32_t k = 0; k < n; ++k) rowRead(row, k, read);
                 },
                 true});
  // 32-byte elements, one per trip: a block or less per step at every size.
  out.push_back({"ThirtyTwoByteElements",
                 computeShader("  uint start = i % 29u;\n  uint end = start + 3u + i % 5u;\n"
                               "  for (uint k = start; k < end; ++k) { Item it = src.items[k]; sum += it.a.x ^ it.b.w; }\n",
                               "Item items[];"),
                 [=](uint32_t i, auto read) {
                   uint32_t start = i % 29, end = start + 3 + i % 5;
                   for (uint32_t k = start; k < end; ++k) read(uint64_t(k) * 32, 32);
                 },
                 true, true, 64 * 32, false});
  // 12-byte elements, row r reading its first 1 + r % 10 of them: reads
  // straddle blocks, and the last one's end is the only read in its block.
  out.push_back({"TwelveByteElementsStraddleBlocks",
                 computeShader("  uint n = 1u + row % 10u;\n"
                               "  for (uint k = 0u; k < n; ++k) { Tri t = src.rows[row].tris[k]; sum += t.a ^ t.c; }\n",
                               "TriRow rows[];"),
                 [=](uint32_t i, auto read) {
                   uint32_t row = i % 64, n = 1 + row % 10;
                   for (uint32_t k = 0; k < n; ++k) read(uint64_t(row) * 128 + uint64_t(k) * 12, 12);
                 },
                 true, true, 64 * 128, false});
  // The same element every trip (step 0): marked once.
  out.push_back({"InvariantIndex", computeShader("  for (uint k = 0u; k < 8u; ++k) sum += src.data[row][3] * k;\n"),
                 [=](uint32_t i, auto read) {
                   for (int k = 0; k < 8; ++k) rowRead(i % 64, 3, read);
                 },
                 true});
  // Rows of 256 bytes, one per trip: more than a block apart, marked per trip.
  out.push_back({"StrideBeyondABlock", computeShader("  for (uint k = 0u; k < 8u; ++k) sum += src.rows[k][row];\n",
                                                     "uint rows[][64];"),
                 [=](uint32_t i, auto read) {
                   for (uint32_t k = 0; k < 8; ++k) read(uint64_t(k) * 256 + (i % 64) * 4, 4);
                 },
                 false, true, 8 * 256});
  out.push_back({"ConditionalRead",
                 computeShader("  for (uint k = 0u; k < 16u; ++k) { if (((k ^ row) & 3u) == 0u) sum += src.data[row][k]; }\n"),
                 [=](uint32_t i, auto read) {
                   for (uint32_t k = 0; k < 16; ++k) {
                     if (((k ^ (i % 64)) & 3u) == 0u) rowRead(i % 64, k, read);
                   }
                 },
                 false});
  // The inner loop's range, once per outer trip, at a row the outer trip picks.
  out.push_back({"NestedLoops",
                 computeShader("  for (uint j = 0u; j < 3u; ++j) {\n"
                               "    uint r = (row * 5u + j * 7u) % 64u;\n"
                               "    uint e = j + 9u;\n"
                               "    for (uint k = j; k < e; ++k) sum += src.data[r][k];\n"
                               "  }\n"),
                 [=](uint32_t i, auto read) {
                   for (uint32_t j = 0; j < 3; ++j) {
                     uint32_t r = ((i % 64) * 5 + j * 7) % 64;
                     for (uint32_t k = j; k < j + 9; ++k) rowRead(r, k, read);
                   }
                 },
                 true});
  // A light loop as the renderers' shading has it: a whole element per
  // trip, and a `continue` after the read.
  out.push_back({"FragmentLoopWithContinue",
                 "#version 450\n"
                 "struct Item { uvec4 a; uvec4 b; };\n"
                 "layout(set = 0, binding = 0) readonly buffer In { Item items[]; } src;\n"
                 "layout(location = 0) out vec4 color;\n"
                 "void main() {\n"
                 "  uint count = 20u + uint(gl_FragCoord.x) % 5u;\n"
                 "  float c = 0.0;\n"
                 "  for (uint k = 0u; k < count; ++k) {\n"
                 "    Item it = src.items[k];\n"
                 "    if ((it.a.x & 3u) == 0u) continue;\n"
                 "    c += float(it.b.y & 255u);\n"
                 "  }\n"
                 "  color = vec4(c);\n"
                 "}\n",
                 [=](uint32_t i, auto read) {
                   uint32_t count = 20 + (i % 64) % 5;
                   for (uint32_t k = 0; k < count; ++k) read(uint64_t(k) * 32, 32);
                 },
                 true, false, 32 * 32, false});
  return out;
}

struct Choice {
  const char* mode;
  bool optimize;  // the module through SPIRV-Tools' performance passes: loops in SSA form (OpPhi)
};

class FootprintLoops : public ::testing::TestWithParam<uint32_t> {
 protected:
  void SetUp() override {
    std::string error;
    ctx_ = testContext(&error);
    if (ctx_ == nullptr) TALLY_SKIP_UNLESS_STRICT("no Vulkan device: " << error);
  }

  void check(const Case& c, const Choice& choice) {
    SCOPED_TRACE(std::string(c.name) + ", " + choice.mode + (choice.optimize ? ", optimized" : ""));
    uint64_t accesses = 0;
    const uint64_t want = blocksOf(c.reads, kInvocations, GetParam(), &accesses);
    ASSERT_GT(want, 0u);
    PassDesc d;
    d.compute = c.compute;
    d.source = c.source;
    d.buffers = c.compute ? std::vector<VkDeviceSize>{c.bytes, kInvocations * 4} : std::vector<VkDeviceSize>{c.bytes};
    d.blockBytes = GetParam();
    d.mode = *spirv::parseMode(choice.mode);
    d.optimize = choice.optimize;
    for (bool ranges : {true, false}) {
      SCOPED_TRACE(ranges ? "ranges" : "a mark per trip");
      d.dedup = spirv::FootprintDedup{false, false, ranges};
      auto r = FootprintPass(*ctx_).run(d);
      ASSERT_TRUE(r.ok()) << r.error();
      EXPECT_EQ(r->lines["binding 0 read"].blocks, want);
      if (c.countsAccesses) {
        EXPECT_EQ(r->lines["binding 0 read"].requestedBytes, accesses * 4);
      }
      bool noted = false;
      for (const auto& n : r->notes) noted = noted || n.find("in counted loops marked once") != std::string::npos;
      EXPECT_EQ(noted, ranges && c.range) << "the read was " << (noted ? "" : "not ") << "marked as a range";
    }
  }

  const gpu::Context* ctx_ = nullptr;
};

TEST_P(FootprintLoops, EveryShapeMarksTheBlocksItsIterationsRead) {
  for (const Case& c : cases()) check(c, {"accumulate", false});
}

TEST_P(FootprintLoops, LoopsInSsaFormToo) {
  for (const Case& c : cases()) {
    if (c.compute && c.range) check(c, {"accumulate", true});
  }
}

TEST_P(FootprintLoops, ExactModeMarksTheSame) {
  for (const Case& c : cases()) {
    if (std::string(c.name) == "RunTimeBoundSometimesZero" || std::string(c.name) == "FragmentLoopWithContinue") {
      check(c, {"exact", false});
    }
  }
}

INSTANTIATE_TEST_SUITE_P(BlockBytes, FootprintLoops, ::testing::Values(32u, 64u, 128u),
                         [](const ::testing::TestParamInfo<uint32_t>& block) {
                           return std::to_string(block.param) + "B";
                         });

}  // namespace
}  // namespace tally::test
