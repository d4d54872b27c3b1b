// What footprint marks skip (InstrumentOptions::footprintDedup): the names,
// the environment's choice, and the code each choice adds to tally_fp_mark.
// That the choices change no count is footprint_dedup_test.cpp's, on a device.
#include <algorithm>
#include <cstdlib>
#include <optional>
#include <string>

#include "spirv_test_util.hpp"

namespace tally::spirv {
namespace {

using test::compileGlsl;
using test::disassemble;
using test::instrumentOk;

const char* kLoop = R"(#version 450
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0) readonly buffer In { uint data[]; } src;
layout(set = 0, binding = 1) writeonly buffer Out { uint data[]; } dst;
void main() {
  uint sum = 0u;
  for (uint k = 0u; k < 64u; ++k) sum += src.data[k % 8u];
  dst.data[gl_LocalInvocationIndex] = sum;
}
)";

bool contains(const std::string& text, const std::string& what) { return text.find(what) != std::string::npos; }

// Sets TALLY_FOOTPRINT_DEDUP for one scope, and puts back what was there.
class DedupEnvironment {
 public:
  explicit DedupEnvironment(const char* value) {
    if (const char* old = std::getenv(kName)) old_ = old;
    if (value != nullptr) setenv(kName, value, 1); else unsetenv(kName);
  }
  ~DedupEnvironment() {
    if (old_) setenv(kName, old_->c_str(), 1); else unsetenv(kName);
  }

 private:
  static constexpr const char* kName = "TALLY_FOOTPRINT_DEDUP";
  std::optional<std::string> old_;
};

InstrumentOptions withFootprint(std::optional<FootprintDedup> dedup) {
  InstrumentOptions options;
  options.mode = *parseMode("accumulate");
  options.footprintBlockBytes = 64;
  options.footprintDedup = dedup;
  return options;
}

TEST(FootprintDedup, NamesReadBack) {
  for (const char* name : {"none", "subgroup", "cache", "loops", "lanes", "subgroup,cache", "subgroup,loops", "cache,loops",
                           "loops,lanes", "subgroup,cache,loops", "all"}) {
    auto d = parseFootprintDedup(name);
    ASSERT_TRUE(d.ok()) << name << ": " << d.error();
    EXPECT_EQ(toString(*d), name);
  }
  EXPECT_EQ(*parseFootprintDedup("all"), (FootprintDedup{true, true, true, true}));
  EXPECT_EQ(*parseFootprintDedup("none"), (FootprintDedup{false, false, false, false}));
  EXPECT_EQ(*parseFootprintDedup("loops,subgroup"), (FootprintDedup{true, false, true, false}));
  EXPECT_EQ(*parseFootprintDedup("lanes,cache"), (FootprintDedup{false, true, false, true}));
  EXPECT_EQ(toString(FootprintDedup{}), "loops,lanes") << "the default";
  for (const char* bad : {"both", "", "loops,", ",loops", "loops,loops", "subgroup,none", "all,cache", "lanes,lanes"}) {
    auto r = parseFootprintDedup(bad);
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_EQ(r.error(), "unknown footprint dedup '" + std::string(bad) +
                             "' (expected none, all, or a list of subgroup, cache, loops and lanes, each once, joined by commas)");
  }
}

// Each choice's code in tally_fp_mark: the cache's registers, the
// subgroup's reduction; none keeps the load and the atomic only.
TEST(FootprintDedup, EachChoiceAddsItsCode) {
  const auto words = compileGlsl(kLoop, Stage::Compute);
  for (const char* name : {"none", "subgroup", "cache", "all"}) {
    SCOPED_TRACE(name);
    const FootprintDedup dedup = *parseFootprintDedup(name);
    auto r = instrumentOk(words, withFootprint(dedup));
    ASSERT_TRUE(r.footprintDedup.has_value());
    EXPECT_EQ(toString(*r.footprintDedup), name);
    std::string dis = disassemble(r.words);
    EXPECT_EQ(contains(dis, "OpGroupNonUniformBitwiseOr"), dedup.subgroup) << dis;
    EXPECT_EQ(contains(dis, "%tally_fp_word0 = OpVariable"), dedup.cache) << dis;
    EXPECT_TRUE(contains(dis, "OpAtomicOr")) << dis;
  }
}

// Lanes: a texel fetch's mark is left to the lane that marks the same
// block, by a partition of the subgroup where the device has one, else by
// the subgroup's first lane, and so is a fragment output's; the filtered
// read keeps the plain mark. Without lanes, or without subgroup operations in the
// stage, no mark combines.
TEST(FootprintDedup, LanesCombineTexelMarks) {
  const auto words = compileGlsl(R"(#version 450
layout(set = 0, binding = 0) uniform sampler2D fetched;
layout(set = 0, binding = 1) uniform sampler2D filtered;
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;
void main() { color = texelFetch(fetched, ivec2(gl_FragCoord.xy), 0) + texture(filtered, uv); }
)", Stage::Fragment);
  struct Want {
    const char* dedup;
    uint32_t partitioned, subgroupStages;
    bool match, first;
  };
  for (const Want& w : {Want{"loops,lanes", kAllStages, kAllStages, true, false}, Want{"lanes", 0, kAllStages, false, true},
                        Want{"loops", kAllStages, kAllStages, false, false},
                        Want{"lanes", kAllStages, stageBit(Stage::Compute), false, false}}) {
    SCOPED_TRACE(std::string(w.dedup) + (w.partitioned ? ", partitioned" : ""));
    InstrumentOptions options = withFootprint(*parseFootprintDedup(w.dedup));
    options.partitionedStages = w.partitioned;
    options.subgroupStages = w.subgroupStages;
    auto r = instrumentOk(words, options);
    std::string dis = disassemble(r.words);
    EXPECT_EQ(contains(dis, "OpName %tally_fp_mark_match"), w.match) << dis;
    EXPECT_EQ(contains(dis, "OpGroupNonUniformPartitionNV"), w.match);
    EXPECT_EQ(contains(dis, "OpName %tally_fp_mark_first"), w.first);
    EXPECT_TRUE(contains(dis, "OpName %tally_fp_mark \"tally_fp_mark\"")) << "filtered reads: the plain mark";
    EXPECT_EQ(r.footprintDedup->lanes, w.match || w.first);
  }
}

// Without subgroup arithmetic in the stage the marks do not combine, and a
// note says why; the cache still applies.
TEST(FootprintDedup, NoSubgroupArithmeticNoCombining) {
  InstrumentOptions options = withFootprint(*parseFootprintDedup("all"));
  options.subgroupStages = stageBit(Stage::Fragment);
  auto r = instrumentOk(compileGlsl(kLoop, Stage::Compute), options);
  ASSERT_TRUE(r.footprintDedup.has_value());
  EXPECT_EQ(toString(*r.footprintDedup), "cache,loops");
  EXPECT_FALSE(contains(disassemble(r.words), "OpGroupNonUniformBitwiseOr"));
  bool noted = false;
  for (const auto& n : r.notes) noted |= n == "footprint: marks not combined across the subgroup: no subgroup arithmetic in the compute stage";
  EXPECT_TRUE(noted);
}

// Unset in the options, the environment chooses; a bad value names the
// variable; set in the options, the environment is not read.
TEST(FootprintDedup, TheEnvironmentChoosesWhereTheOptionsDoNot) {
  const auto words = compileGlsl(kLoop, Stage::Compute);
  {
    DedupEnvironment env(nullptr);
    auto r = instrumentOk(words, withFootprint(std::nullopt));
    EXPECT_EQ(r.footprintDedup, FootprintDedup{});
  }
  {
    DedupEnvironment env("subgroup");
    auto r = instrumentOk(words, withFootprint(std::nullopt));
    EXPECT_EQ(toString(*r.footprintDedup), "subgroup");
    EXPECT_NE(std::find(r.notes.begin(), r.notes.end(), "footprint: marks dedup 'subgroup', from TALLY_FOOTPRINT_DEDUP"),
              r.notes.end());
    EXPECT_EQ(toString(*instrumentOk(words, withFootprint(*parseFootprintDedup("none"))).footprintDedup), "none");
  }
  {
    DedupEnvironment env("fast");
    auto r = instrument(words, withFootprint(std::nullopt));
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error(), "TALLY_FOOTPRINT_DEDUP: unknown footprint dedup 'fast' (expected none, all, or a list of "
                         "subgroup, cache, loops and lanes, each once, joined by commas)");
    InstrumentOptions off;
    EXPECT_TRUE(instrument(words, off).ok()) << "read with footprint off";
  }
}

// In a fragment shader helper lanes stay out of the combined marks.
TEST(FootprintDedup, FragmentMarksSkipHelperLanes) {
  const char* fs = R"(#version 450
layout(set = 0, binding = 0) uniform sampler2D tex;
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;
void main() { color = texture(tex, uv); }
)";
  const auto words = compileGlsl(fs, Stage::Fragment);
  std::string plain = disassemble(instrumentOk(words, withFootprint(*parseFootprintDedup("none"))).words);
  EXPECT_FALSE(contains(plain, "BuiltIn HelperInvocation")) << plain;
  std::string dis = disassemble(instrumentOk(words, withFootprint(*parseFootprintDedup("subgroup"))).words);
  EXPECT_TRUE(contains(dis, "BuiltIn HelperInvocation")) << dis;
  EXPECT_TRUE(contains(dis, "OpGroupNonUniformBitwiseOr")) << dis;
}

}  // namespace
}  // namespace tally::spirv
