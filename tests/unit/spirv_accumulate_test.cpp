// The accumulate mode's choices, read off the instrumented module: which
// sites accumulate and which are counted per access, and how compute
// counters are striped over copies. Its counts are checked on a device in
// tests/integration (accumulate_test, exactness_test, overflow_test).
#include <string>

#include "spirv/cfg.hpp"
#include "spirv/inject.hpp"
#include "spirv_test_util.hpp"

namespace tally::spirv {
namespace {

using test::compileGlsl;
using test::disassemble;
using test::instrumentOk;

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// The index of the function with OpName `name` in m.functions, or -1.
int functionNamed(const Module& m, const DefIndex& defs, const std::string& name) {
  for (size_t f = 0; f < m.functions.size(); ++f) {
    if (defs.name(m.functions[f].id()) == name) return int(f);
  }
  return -1;
}

InstrumentOptions accumulate(const char* mode) {
  InstrumentOptions o;
  auto m = parseMode(mode);
  EXPECT_TRUE(m.ok());
  o.mode = *m;
  return o;
}

// A texture sample on every path (runs exactly once), one on a branch (at
// most once), a buffer read in a loop, and the output written at the return.
const char* kOnceAndLoop = R"(#version 450
layout(set = 0, binding = 0) uniform sampler2D tex;
layout(set = 0, binding = 1) readonly buffer Lights { vec4 light[]; };
layout(set = 0, binding = 2) uniform sampler2D shadow;
layout(push_constant) uniform Push { int count; };
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;
void main() {
  vec4 c = texture(tex, uv);
  if (uv.x > 0.5) c *= texture(shadow, uv);
  for (int i = 0; i < count; ++i) c += light[i];
  color = c;
}
)";

size_t countOf(const std::string& text, const std::string& part) {
  size_t n = 0;
  for (size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + 1)) ++n;
  return n;
}

TEST(Accumulate, PerLaneFlushCountsSitesThatRunOncePerAccess) {
  auto r = instrumentOk(compileGlsl(kOnceAndLoop, Stage::Fragment), accumulate("accumulate:lane"));
  std::string dis = disassemble(r.words);
  // The branch's sample runs at most once: its flush would be one atomic per
  // lane, as the access is. So is the invocation counter's.
  EXPECT_EQ(countOf(dis, "OpFunctionCall %void %tally_count_exact"), 2u) << dis;
  EXPECT_EQ(test::sitesOf(r, SiteKind::BufferRead).size(), 1u);
  EXPECT_TRUE(contains(dis, "%tally_flush_fragment")) << dis;
  bool noted = false;
  for (const auto& n : r.notes) noted = noted || contains(n, "2 fragment sites that run at most once per invocation counted per access");
  EXPECT_TRUE(noted);
}

TEST(Accumulate, SubgroupFlushAccumulatesSitesThatRunOnce) {
  // A reduction turns a subgroup's once-per-lane atomics into one: worth it.
  auto r = instrumentOk(compileGlsl(kOnceAndLoop, Stage::Fragment), accumulate("accumulate:subgroup"));
  std::string dis = disassemble(r.words);
  EXPECT_FALSE(contains(dis, "%tally_count_exact")) << dis;
  EXPECT_TRUE(contains(dis, "OpGroupNonUniformIAdd")) << dis;
}

TEST(Accumulate, SitesOnEveryPathAreDerivedFromTheInvocationCount) {
  for (const char* mode : {"accumulate:lane", "accumulate:subgroup"}) {
    auto r = instrumentOk(compileGlsl(kOnceAndLoop, Stage::Fragment), accumulate(mode));
    auto invocation = test::sitesOf(r, SiteKind::Invocation);
    auto reads = test::sitesOf(r, SiteKind::TextureRead);
    auto outputs = test::sitesOf(r, SiteKind::OutputWrite);
    ASSERT_EQ(invocation.size(), 1u);
    ASSERT_EQ(reads.size(), 2u);
    ASSERT_EQ(outputs.size(), 1u);
    // tex (the first sample) and the output; not shadow. The loop's read
    // comes from its trip counter, the slot after the sites'.
    auto lights = test::sitesOf(r, SiteKind::BufferRead);
    ASSERT_EQ(lights.size(), 1u);
    std::vector<DerivedCount> expected = {{r.slotCount - 1, lights[0]->slot, 1},
                                          {invocation[0]->slot, reads[0]->slot, 1},
                                          {invocation[0]->slot, outputs[0]->slot, 1}};
    EXPECT_EQ(r.derived, expected) << mode;
    EXPECT_EQ(r.layout().derived, expected) << mode;
    EXPECT_TRUE(r.layout().needsSettling()) << mode;
    // Off, every site adds in the shader.
    auto options = accumulate(mode);
    options.deriveOnceSites = false;
    auto counted = instrumentOk(compileGlsl(kOnceAndLoop, Stage::Fragment), options);
    EXPECT_TRUE(counted.derived.empty()) << mode;
    EXPECT_EQ(counted.sites.size(), r.sites.size()) << mode;
  }
}

TEST(Accumulate, NothingIsDerivedWhereAnInvocationCanEndEarly) {
  const char* source = R"(#version 450
layout(set = 0, binding = 0) uniform sampler2D tex;
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;
void main() {
  vec4 c = texture(tex, uv);
  if (c.a < 0.5) discard;
  color = c;
}
)";
  auto r = instrumentOk(compileGlsl(source, Stage::Fragment), accumulate("accumulate"));
  EXPECT_TRUE(r.derived.empty());
  EXPECT_FALSE(r.layout().needsSettling());
}

TEST(Accumulate, SettlingFoldsCopiesThenAddsDerivedCounts) {
  // Slots 10..12, two copies 16 apart; slot 10 counts invocations.
  CopyLayout l{10, 3, 2, 16, {{10, 11, 2}, {10, 12, 1}}};
  std::vector<uint64_t> counters(48, 0);
  counters[10] = 5;       // invocations, copy 0
  counters[26] = 2;       // invocations, copy 1
  counters[11] = 1;       // counted in the shader as well
  counters[28] = 4;       // slot 12, copy 1
  settleCounters(counters, l);
  EXPECT_EQ(counters[10], 7u);
  EXPECT_EQ(counters[11], 1u + 2u * 7u);
  EXPECT_EQ(counters[12], 4u + 7u);
  EXPECT_EQ(counters[26] + counters[28], 0u);
}

TEST(Accumulate, FunctionsCalledTwiceOrInALoopDoNotRunOnce) {
  const char* source = R"(#version 450
layout(set = 0, binding = 0) readonly buffer A { float a[]; };
layout(set = 0, binding = 1) readonly buffer B { float b[]; };
layout(set = 0, binding = 2) readonly buffer C { float c[]; };
layout(set = 0, binding = 3) writeonly buffer Out { float o[]; };
layout(local_size_x = 64) in;
float twice(uint i) { return a[i]; }
float inLoop(uint i) { return b[i]; }
float once(uint i) { return c[i]; }
void main() {
  uint i = gl_GlobalInvocationID.x;
  float s = twice(i) + twice(i + 1u) + once(i);
  for (uint k = 0u; k < 4u; ++k) s += inLoop(i + k);
  o[i] = s;
}
)";
  auto words = compileGlsl(source, Stage::Compute);
  auto module = Module::parse(words);
  ASSERT_TRUE(module.ok()) << module.error();
  DefIndex defs(*module);
  const int entry = functionNamed(*module, defs, "main");
  ASSERT_GE(entry, 0);
  auto once = functionsRunOnce(*module, defs, entry);
  for (size_t f = 0; f < module->functions.size(); ++f) {
    std::string name = defs.name(module->functions[f].id());
    bool expected = name == "main" || name.rfind("once(", 0) == 0;
    EXPECT_EQ(once[f], expected) << name;
  }
}

TEST(Accumulate, FunctionsRunExactlyOnceOnlyWhereEveryReturnPathCallsThem) {
  const char* source = R"(#version 450
layout(set = 0, binding = 0) readonly buffer A { float a[]; };
layout(set = 0, binding = 1) writeonly buffer Out { float o[]; };
layout(local_size_x = 64) in;
float always(uint i) { return a[i]; }
float onBranch(uint i) { return a[i + 1u]; }
float afterReturn(uint i) { return a[i + 2u]; }
void main() {
  uint i = gl_GlobalInvocationID.x;
  float s = always(i);
  if (i % 2u == 0u) s += onBranch(i);
  if (i > 1000u) return;
  o[i] = s + afterReturn(i);
}
)";
  auto words = compileGlsl(source, Stage::Compute);
  auto module = Module::parse(words);
  ASSERT_TRUE(module.ok()) << module.error();
  DefIndex defs(*module);
  const int entry = functionNamed(*module, defs, "main");
  ASSERT_GE(entry, 0);
  auto exactly = functionsRunExactlyOnce(*module, defs, entry);
  auto once = functionsRunOnce(*module, defs, entry);
  for (size_t f = 0; f < module->functions.size(); ++f) {
    std::string name = defs.name(module->functions[f].id());
    EXPECT_TRUE(once[f]) << name;
    EXPECT_EQ(exactly[f], name == "main" || name.rfind("always(", 0) == 0) << name;
  }
  EXPECT_FALSE(endsOtherThanByReturn(*module, entry));
  // In main, the call of always() lies on every return path; the store after the early return does not.
  const auto& insts = module->functions[entry].insts;
  auto onEvery = instructionsOnEveryReturnPath(module->functions[entry], defs);
  int calls = 0;
  for (size_t at = 0; at < insts.size(); ++at) {
    if (insts[at].opcode() != spv::Op::OpFunctionCall) continue;
    std::string callee = defs.name(insts[at].word(3));
    EXPECT_EQ(onEvery[at], callee.rfind("always(", 0) == 0) << callee;
    ++calls;
  }
  EXPECT_EQ(calls, 3);
}

const char* kComputeLoop = R"(#version 450
layout(set = 0, binding = 0) readonly buffer In { float v[]; };
layout(set = 0, binding = 1) writeonly buffer Out { float o[]; };
layout(local_size_x = 8, local_size_y = 8) in;
void main() {
  uint i = gl_GlobalInvocationID.y * 1024u + gl_GlobalInvocationID.x;
  float s = 0.0;
  for (uint k = 0u; k < 16u; ++k) {
    s += v[i + k];
    if (s > 100.0) break;  // the trip count is not known at the entry: the load adds in the shader
  }
  o[i] = s;
}
)";

TEST(Accumulate, ComputeCountersAreStripedOverCopiesOnTheirOwnCacheLines) {
  auto r = instrumentOk(compileGlsl(kComputeLoop, Stage::Compute), accumulate("accumulate"));
  EXPECT_EQ(r.copies, 16u);
  EXPECT_GE(r.copyStride, r.slotCount);
  EXPECT_EQ(r.copyStride % kCopyAlignSlots, 0u);
  EXPECT_EQ(r.layout().reserved(), r.copyStride * 16);
  std::string dis = disassemble(r.words);
  EXPECT_TRUE(contains(dis, "BuiltIn WorkgroupId")) << dis;
  EXPECT_TRUE(contains(dis, "BuiltIn SubgroupId")) << dis;  // the reduced flush: one copy per subgroup
  auto lane = instrumentOk(compileGlsl(kComputeLoop, Stage::Compute), accumulate("accumulate:lane"));
  EXPECT_TRUE(contains(disassemble(lane.words), "BuiltIn LocalInvocationIndex"));

  InstrumentOptions one = accumulate("accumulate");
  one.computeCopies = 1;
  auto single = instrumentOk(compileGlsl(kComputeLoop, Stage::Compute), one);
  EXPECT_EQ(single.copies, 1u);
  EXPECT_EQ(single.layout().reserved(), single.slotCount);
  // Other modes and other stages keep one copy.
  EXPECT_EQ(instrumentOk(compileGlsl(kComputeLoop, Stage::Compute), accumulate("exact")).copies, 1u);
  EXPECT_EQ(instrumentOk(compileGlsl(kOnceAndLoop, Stage::Fragment), accumulate("accumulate")).copies, 1u);
}

TEST(Accumulate, CopiesMustBeAPowerOfTwo) {
  for (uint32_t bad : {0u, 3u, 24u, 512u}) {
    InstrumentOptions o = accumulate("accumulate");
    o.computeCopies = bad;
    auto r = instrument(compileGlsl(kComputeLoop, Stage::Compute), o);
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_TRUE(contains(r.error(), "power of two")) << r.error();
  }
}

TEST(Accumulate, FoldSumsEveryCopyIntoItsSlot) {
  CopyLayout l{2, 3, 4, 16};
  std::vector<uint64_t> counters(2 + 16 * 4, 0);
  counters[0] = 7;  // another module's slot: untouched
  for (uint32_t k = 0; k < 4; ++k) {
    for (uint32_t s = 0; s < 3; ++s) counters[2 + k * 16 + s] = (k + 1) * 100 + s;
  }
  foldCopies(counters, l);
  EXPECT_EQ(counters[0], 7u);
  for (uint32_t s = 0; s < 3; ++s) EXPECT_EQ(counters[2 + s], 1000u + 4 * s) << s;  // 100+200+300+400, +s each
  for (uint32_t k = 1; k < 4; ++k) {
    for (uint32_t s = 0; s < 3; ++s) EXPECT_EQ(counters[2 + k * 16 + s], 0u);
  }
}

// The flush as read off the module: reduced first, one vote for whole sums,
// adds in rounds (a ballot's rank and count) and no elected lane; the
// study's words take each part back, or leave adds and flushes out (then
// the notes say the counts are not the mode's).
TEST(Accumulate, FlushReducesFirstAndAddsInRoundsUnlessStudied) {
  const auto words = compileGlsl(kComputeLoop, Stage::Compute);
  std::string now = disassemble(instrumentOk(words, accumulate("accumulate")).words);
  EXPECT_TRUE(contains(now, "OpGroupNonUniformAll")) << now;
  EXPECT_TRUE(contains(now, "OpGroupNonUniformBallotBitCount")) << now;
  EXPECT_FALSE(contains(now, "OpGroupNonUniformElect")) << now;
  InstrumentOptions before = accumulate("accumulate");
  before.study = kStudyElectedAdds | kStudySplitReductions | kStudyWaterfallEach;
  std::string was = disassemble(instrumentOk(words, before).words);
  EXPECT_TRUE(contains(was, "OpGroupNonUniformElect")) << was;
  EXPECT_FALSE(contains(was, "OpGroupNonUniformAll")) << was;
  EXPECT_FALSE(contains(was, "OpGroupNonUniformBallotBitCount")) << was;

  InstrumentOptions noFlush = accumulate("accumulate");
  noFlush.study = kStudyNoFlush;
  auto quiet = instrumentOk(words, noFlush);
  EXPECT_FALSE(contains(disassemble(quiet.words), "OpFunctionCall %void %tally_flush"));
  bool said = false;
  for (const auto& note : quiet.notes) said = said || contains(note, "not the mode's");
  EXPECT_TRUE(said);
  EXPECT_TRUE(contains(now, "OpFunctionCall %void %tally_flush")) << now;
}

TEST(Accumulate, StudyWordsParseOrNameTheBadOne) {
  auto both = parseStudy("no-adds,no-flush");
  ASSERT_TRUE(both.ok()) << both.error();
  EXPECT_EQ(*both, kStudyNoAdds | kStudyNoFlush);
  EXPECT_EQ(*parseStudy("elected-adds,split-reductions,waterfall-each"),
            kStudyElectedAdds | kStudySplitReductions | kStudyWaterfallEach);
  EXPECT_EQ(*parseStudy("inline-flush"), kStudyInlineFlush);
  EXPECT_EQ(*parseStudy("partitioned"), kStudyPartitioned);
  EXPECT_EQ(*parseStudy("evict-always,partitioned"), kStudyEvictAlways | kStudyPartitioned);
  for (const char* bad : {"no-add", "no-adds,,no-flush", "fast"}) {
    auto r = parseStudy(bad);
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_TRUE(contains(r.error(), "unknown variant")) << r.error();
  }
}

// Two runtime-sized arrays read with indices that differ between lanes:
// each site's cache flushes per element, in a waterfall or, where the
// device partitions a subgroup by value and the study asks, in one
// partition of the lanes.
const char* kMaterialMaps = R"(#version 450
#extension GL_EXT_nonuniform_qualifier : require
layout(local_size_x = 64) in;
layout(set = 0, binding = 0) uniform sampler2D albedo[];
layout(set = 0, binding = 1) uniform sampler2D normals[];
layout(set = 0, binding = 2) readonly buffer Ids { uint material[]; };
layout(set = 0, binding = 3) writeonly buffer Out { vec4 o[]; };
void main() {
  uint i = gl_GlobalInvocationID.x;
  uint m = material[i];
  vec2 uv = vec2(i) / 64.0;
  o[i] = texture(albedo[nonuniformEXT(m)], uv) + texture(normals[nonuniformEXT(m / 2u)], uv);
}
)";

TEST(Accumulate, CachedArraysPartitionTheSubgroupWhereTheDeviceCan) {
  const auto words = compileGlsl(kMaterialMaps, Stage::Compute);
  InstrumentOptions options = accumulate("accumulate");
  std::string waterfall = disassemble(instrumentOk(words, options).words);
  EXPECT_TRUE(contains(waterfall, "OpGroupNonUniformBroadcastFirst")) << waterfall;
  EXPECT_FALSE(contains(waterfall, "OpGroupNonUniformPartitionNV")) << waterfall;

  options.partitionedStages = stageBit(Stage::Compute);
  EXPECT_EQ(disassemble(instrumentOk(words, options).words), waterfall);  // the device can: not enough
  options.study = kStudyPartitioned;
  std::string parts = disassemble(instrumentOk(words, options).words);
  EXPECT_TRUE(contains(parts, "OpCapability GroupNonUniformPartitionedNV")) << parts;
  EXPECT_TRUE(contains(parts, "OpExtension \"SPV_NV_shader_subgroup_partitioned\"")) << parts;
  // One partition per cache, intersected; each count reduced within a part,
  // and the parts' first lanes found by a partitioned scan. No waterfall.
  EXPECT_EQ(countOf(parts, "OpGroupNonUniformPartitionNV"), 2u) << parts;
  EXPECT_TRUE(contains(parts, "PartitionedReduceNV")) << parts;
  EXPECT_TRUE(contains(parts, "PartitionedExclusiveScanNV")) << parts;
  EXPECT_FALSE(contains(parts, "OpGroupNonUniformBroadcastFirst")) << parts;

  // Not in a stage the device has no subgroup operations in.
  options.subgroupStages = stageBit(Stage::Fragment);
  EXPECT_FALSE(contains(disassemble(instrumentOk(words, options).words), "OpGroupNonUniformPartitionNV"));
}

// A cached site that runs at most once per invocation never finds its cache
// holding another element: it stores the element and a count of 1, with no
// eviction (a branch and an atomic) beside the access. In a loop it keeps
// the eviction: an atomic per cache beside the flush's.
TEST(Accumulate, CachedArraysThatRunOnceNeverEvict) {
  std::string looped = kMaterialMaps;
  looped.replace(looped.find("void main() {"), std::string::npos,
                 "void main() {\n  uint i = gl_GlobalInvocationID.x;\n  vec4 sum = vec4(0.0);\n"
                 "  for (uint k = 0u; k < material[0]; ++k) {\n    uint m = material[i + k];\n"
                 "    sum += texture(albedo[nonuniformEXT(m)], vec2(0.5)) + texture(normals[nonuniformEXT(m / 2u)], "
                 "vec2(0.5));\n  }\n  o[i] = sum;\n}\n");
  InstrumentOptions options = accumulate("accumulate");
  std::string once = disassemble(instrumentOk(compileGlsl(kMaterialMaps, Stage::Compute), options).words);
  std::string loop = disassemble(instrumentOk(compileGlsl(looped.c_str(), Stage::Compute), options).words);
  // Both flush the two caches in one waterfall; only the loop's sites evict.
  EXPECT_TRUE(contains(once, "OpGroupNonUniformBroadcastFirst")) << once;
  EXPECT_EQ(countOf(loop, "OpAtomicIAdd"), countOf(once, "OpAtomicIAdd") + 2) << once << loop;
  // The study word that keeps the eviction where it cannot happen (for timing it).
  options.study = kStudyEvictAlways;
  std::string evicting = disassemble(instrumentOk(compileGlsl(kMaterialMaps, Stage::Compute), options).words);
  EXPECT_EQ(countOf(evicting, "OpAtomicIAdd"), countOf(once, "OpAtomicIAdd") + 2) << evicting;
}

TEST(Accumulate, PerLaneFragmentCachesPartitionToo) {
  std::string fragment = kMaterialMaps;
  fragment.replace(fragment.find("layout(local_size_x = 64) in;"), 29,
                   "layout(location = 0) flat in uint m;\nlayout(location = 0) out vec4 color;");
  fragment.replace(fragment.find("void main() {"), std::string::npos,
                   "void main() {\n  vec2 uv = gl_FragCoord.xy;\n  color = texture(albedo[nonuniformEXT(m)], uv);\n}\n");
  const auto words = compileGlsl(fragment.c_str(), Stage::Fragment);
  InstrumentOptions options = accumulate("accumulate:lane");
  options.partitionedStages = kAllStages;
  options.study = kStudyPartitioned;
  std::string parts = disassemble(instrumentOk(words, options).words);
  EXPECT_EQ(countOf(parts, "OpGroupNonUniformPartitionNV"), 1u) << parts;
  EXPECT_FALSE(contains(parts, "OpGroupNonUniformBroadcastFirst")) << parts;
  // Helper lanes stay out of the flush, as in the waterfall.
  EXPECT_TRUE(contains(parts, "HelperInvocation")) << parts;
}

}  // namespace
}  // namespace tally::spirv
