// The instrumentation pass: SPIR-V in, expected disassembly lines and site
// tables out.
#include <algorithm>
#include <set>

#include "spirv/inject.hpp"
#include "spirv/validate.hpp"
#include "spirv_test_util.hpp"

namespace tally::spirv {
namespace {

using test::compileGlsl;
using test::disassemble;
using test::instrumentOk;
using test::sitesOf;

const char* kTextured = R"(#version 450
layout(set = 0, binding = 0) uniform sampler2D tex;
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;
void main() { color = texture(tex, uv); }
)";

bool contains(const std::string& text, const std::string& line) { return text.find(line) != std::string::npos; }

// The line after the first one containing `first`.
std::string lineAfter(const std::string& text, const std::string& first) {
  auto at = text.find(first);
  if (at == std::string::npos) return {};
  auto start = text.find('\n', at) + 1;
  auto end = text.find('\n', start);
  return text.substr(start, end - start);
}

TEST(Instrument, ExactModeAddsBufferCapabilitiesAndACallAfterEachAccess) {
  auto r = instrumentOk(compileGlsl(kTextured, Stage::Fragment));
  std::string dis = disassemble(r.words);
  EXPECT_TRUE(contains(dis, "OpCapability Int64Atomics")) << dis;
  EXPECT_TRUE(contains(dis, "OpDecorate %tally_counters DescriptorSet 7"));
  EXPECT_TRUE(contains(dis, "OpDecorate %tally_counters Binding 0"));
  EXPECT_TRUE(contains(dis, "OpAtomicIAdd %ulong"));
  EXPECT_TRUE(contains(lineAfter(dis, "OpImageSampleImplicitLod"), "OpFunctionCall %void %tally_count_exact"))
      << dis;
  // SPIR-V 1.4+: the entry point lists every global it uses, counters included.
  auto ep = dis.substr(dis.find("OpEntryPoint"));
  EXPECT_TRUE(contains(ep.substr(0, ep.find('\n')), "%tally_counters"));
  ASSERT_EQ(r.sites.size(), 3u);  // invocation, texture_read, output_write
  EXPECT_EQ(sitesOf(r, SiteKind::TextureRead).size(), 1u);
  EXPECT_EQ(sitesOf(r, SiteKind::OutputWrite)[0]->location, 0u);
  EXPECT_EQ(r.slotCount, 3u);
}

TEST(Instrument, SetBindingAndFirstSlotAreTheCallers) {
  InstrumentOptions options;
  options.set = 3;
  options.binding = 5;
  options.firstSlot = 40;
  auto r = instrumentOk(compileGlsl(kTextured, Stage::Fragment), options);
  std::string dis = disassemble(r.words);
  EXPECT_TRUE(contains(dis, "OpDecorate %tally_counters DescriptorSet 3"));
  EXPECT_TRUE(contains(dis, "OpDecorate %tally_counters Binding 5"));
  for (const auto& s : r.sites) {
    EXPECT_GE(s.slot, 40u);
    EXPECT_LT(s.slot, 40u + r.slotCount);
  }
}

TEST(Instrument, OldModulesGetAUniformBufferBlockAndNoInterfaceEntry) {
  auto r = instrumentOk(compileGlsl(kTextured, Stage::Fragment, glsl::Target::Vulkan10));
  std::string dis = disassemble(r.words);
  EXPECT_EQ(r.versionOut, kVersion10);
  EXPECT_TRUE(contains(dis, "OpDecorate %TallyCounters BufferBlock"));
  auto ep = dis.substr(dis.find("OpEntryPoint"));
  EXPECT_FALSE(contains(ep.substr(0, ep.find('\n')), "%tally_counters"));
}

TEST(Instrument, Uint32PairWidthNeedsNoInt64) {
  InstrumentOptions options;
  options.width = CounterWidth::Uint32Pair;
  auto r = instrumentOk(compileGlsl(kTextured, Stage::Fragment, glsl::Target::Vulkan10), options);
  std::string dis = disassemble(r.words);
  EXPECT_FALSE(contains(dis, "Int64"));
  EXPECT_TRUE(contains(dis, "OpULessThan"));  // the carry test
  EXPECT_TRUE(contains(dis, "OpAtomicIAdd %uint"));
}

TEST(Instrument, SubgroupModeRaisesOldModulesTo13AndSkipsHelperLanes) {
  InstrumentOptions options;
  options.mode = {CountMode::Subgroup, 1};
  auto r = instrumentOk(compileGlsl(kTextured, Stage::Fragment, glsl::Target::Vulkan10), options);
  EXPECT_EQ(r.versionIn, kVersion10);
  EXPECT_EQ(r.versionOut, kVersion13);
  EXPECT_TRUE(std::any_of(r.notes.begin(), r.notes.end(), [](auto& n) { return contains(n, "raised"); }));
  std::string dis = disassemble(r.words);
  EXPECT_TRUE(contains(dis, "OpGroupNonUniformIAdd %uint %uint_3 Reduce"));
  EXPECT_TRUE(contains(dis, "OpGroupNonUniformElect"));
  EXPECT_TRUE(contains(dis, "BuiltIn HelperInvocation"));
  EXPECT_FALSE(contains(dis, "Volatile"));    // no demotion: a plain read
  EXPECT_FALSE(contains(dis, "OpLoopMerge"));  // constant slots: one reduction
}

TEST(Instrument, SubgroupModeLoopsOverDistinctSlotsForDynamicIndices) {
  const char* fs = R"(#version 450
layout(set = 0, binding = 0) uniform sampler2D maps[4];
layout(location = 0) flat in int material;
layout(location = 0) out vec4 color;
void main() { color = texture(maps[material & 3], vec2(0.5)); }
)";
  InstrumentOptions options;
  options.mode = {CountMode::Subgroup, 1};
  auto r = instrumentOk(compileGlsl(fs, Stage::Fragment), options);
  std::string dis = disassemble(r.words);
  EXPECT_TRUE(contains(dis, "OpGroupNonUniformBroadcastFirst"));
  EXPECT_TRUE(contains(dis, "OpLoopMerge"));  // the waterfall
  EXPECT_TRUE(contains(dis, "%tally_count_subgroup_uniform_fragment"));  // and constant-slot sites
}

TEST(Instrument, SubgroupHelperReadIsVolatileOnlyWhenTheModuleDemotes) {
  const char* fs = R"(#version 450
#extension GL_EXT_demote_to_helper_invocation : require
layout(set = 0, binding = 0) uniform sampler2D tex;
layout(location = 0) out vec4 color;
void main() {
  vec4 c = texture(tex, vec2(0.5));
  if (c.a < 0.5) demote;
  color = c;
}
)";
  InstrumentOptions options;
  options.mode = {CountMode::Subgroup, 1};
  auto r = instrumentOk(compileGlsl(fs, Stage::Fragment), options);
  EXPECT_TRUE(contains(disassemble(r.words), "OpDecorate %gl_HelperInvocation Volatile"));
}

TEST(Instrument, SubgroupModeFallsBackToExactWhereTheStageLacksSubgroups) {
  const char* vs = R"(#version 450
layout(set = 0, binding = 0) uniform Camera { mat4 mvp; } camera;
layout(location = 0) in vec3 position;
void main() { gl_Position = camera.mvp * vec4(position, 1.0); }
)";
  InstrumentOptions options;
  options.mode = {CountMode::Subgroup, 1};
  options.subgroupStages = stageBit(Stage::Fragment) | stageBit(Stage::Compute);  // lavapipe
  auto r = instrumentOk(compileGlsl(vs, Stage::Vertex), options);
  EXPECT_FALSE(contains(disassemble(r.words), "OpGroupNonUniform"));
  EXPECT_TRUE(std::any_of(r.notes.begin(), r.notes.end(), [](auto& n) { return contains(n, "vertex"); }));
  auto reads = sitesOf(r, SiteKind::BufferRead);
  ASSERT_EQ(reads.size(), 2u);
  // The vertex attribute: fetched once per vertex invocation, counted on entry.
  EXPECT_EQ(reads[0]->location, 0u);
  EXPECT_EQ(reads[0]->set, -1);
  EXPECT_EQ(reads[0]->resource, "vertex_input position");
  EXPECT_EQ(reads[0]->elementBytes, 12u);  // vec3
  // The uniform block.
  EXPECT_EQ(reads[1]->set, 0);
  EXPECT_EQ(reads[1]->resource, "camera");
  EXPECT_EQ(reads[1]->elementBytes, 64u);  // mat4
  EXPECT_EQ(reads[1]->elementType, "mat4x4<f32>");
}

TEST(Instrument, NotesFragmentShadersWithoutEarlyFragmentTests) {
  auto late = instrumentOk(compileGlsl(kTextured, Stage::Fragment));
  EXPECT_TRUE(std::any_of(late.notes.begin(), late.notes.end(),
                          [](auto& n) { return contains(n, "no early_fragment_tests"); }));
  std::string early = std::string(kTextured).replace(13, 0, "layout(early_fragment_tests) in;\n");
  auto r = instrumentOk(compileGlsl(early, Stage::Fragment));
  EXPECT_TRUE(std::none_of(r.notes.begin(), r.notes.end(),
                           [](auto& n) { return contains(n, "early_fragment_tests"); }));
}

TEST(Instrument, AnonymousBlocksAreNamedByTheirType) {
  const char* fs = R"(#version 450
layout(set = 0, binding = 0) uniform CameraBlock { vec4 tint; };
layout(location = 0) out vec4 color;
void main() { color = tint; }
)";
  auto r = instrumentOk(compileGlsl(fs, Stage::Fragment));
  auto reads = sitesOf(r, SiteKind::BufferRead);
  ASSERT_EQ(reads.size(), 1u);
  EXPECT_EQ(reads[0]->resource, "CameraBlock");
}

TEST(Instrument, SampledModeCountsOneFragmentPerTileScaledByN) {
  InstrumentOptions options;
  options.mode = {CountMode::Sampled, 16};
  auto r = instrumentOk(compileGlsl(kTextured, Stage::Fragment), options);
  std::string dis = disassemble(r.words);
  EXPECT_TRUE(contains(dis, "BuiltIn FragCoord"));
  EXPECT_TRUE(contains(dis, "OpUMod"));
  EXPECT_TRUE(contains(dis, "%uint_16"));
}

TEST(Instrument, SampledTileShapeIsAsSquareAsNAllows) {
  EXPECT_EQ(sampledTileShape(4).width, 2u);
  EXPECT_EQ(sampledTileShape(4).height, 2u);
  EXPECT_EQ(sampledTileShape(8).width, 4u);
  EXPECT_EQ(sampledTileShape(8).height, 2u);
  EXPECT_EQ(sampledTileShape(64).width, 8u);
  EXPECT_EQ(sampledTileShape(7).width, 7u);
  EXPECT_EQ(sampledTileShape(7).height, 1u);
  for (uint32_t n = 2; n < 300; ++n) EXPECT_EQ(sampledTileShape(n).width * sampledTileShape(n).height, n);
}

TEST(Instrument, ParseMode) {
  EXPECT_EQ(parseMode("exact")->kind, CountMode::Exact);
  EXPECT_EQ(parseMode("subgroup")->kind, CountMode::Subgroup);
  EXPECT_EQ(parseMode("sampled:64")->sampleRate, 64u);
  EXPECT_EQ(toString(*parseMode("sampled:4")), "sampled:4");
  for (const char* bad : {"", "fast", "sampled", "sampled:", "sampled:1", "sampled:0", "sampled:-4", "sampled:4x",
                          "sampled:99999999999", "sampled:65537"}) {
    auto m = parseMode(bad);
    ASSERT_FALSE(m.ok()) << bad;
    EXPECT_FALSE(m.error().empty());
  }
}

TEST(Instrument, SamplerParameterResolvesToTheCallersVariable) {
  const char* fs = R"(#version 450
layout(set = 1, binding = 4) uniform sampler2D only;
layout(location = 0) out vec4 color;
vec4 shade(sampler2D s) { return texture(s, vec2(0.5)); }
void main() { color = shade(only); }
)";
  auto r = instrumentOk(compileGlsl(fs, Stage::Fragment));
  EXPECT_FALSE(r.inlined);
  auto reads = sitesOf(r, SiteKind::TextureRead);
  ASSERT_EQ(reads.size(), 1u);
  EXPECT_EQ(reads[0]->set, 1);
  EXPECT_EQ(reads[0]->binding, 4);
  EXPECT_EQ(reads[0]->resource, "only");
}

TEST(Instrument, FunctionCalledWithDifferentSamplersIsInlined) {
  const char* fs = R"(#version 450
layout(set = 0, binding = 0) uniform sampler2D a;
layout(set = 0, binding = 1) uniform sampler2D b;
layout(location = 0) out vec4 color;
vec4 shade(sampler2D s) { return texture(s, vec2(0.5)); }
void main() { color = shade(a) + shade(b); }
)";
  auto r = instrumentOk(compileGlsl(fs, Stage::Fragment));
  EXPECT_TRUE(r.inlined);
  auto reads = sitesOf(r, SiteKind::TextureRead);
  ASSERT_EQ(reads.size(), 2u);
  std::vector<int64_t> bindings = {reads[0]->binding, reads[1]->binding};
  std::sort(bindings.begin(), bindings.end());
  EXPECT_EQ(bindings, (std::vector<int64_t>{0, 1}));
  EXPECT_NE(reads[0]->slot, reads[1]->slot);
}

TEST(Instrument, DynamicIndexGetsOneSlotPerArrayElement) {
  const char* fs = R"(#version 450
#extension GL_EXT_nonuniform_qualifier : require
layout(set = 0, binding = 0) uniform sampler2D fixedMaps[4];
layout(set = 0, binding = 1) uniform sampler2D allMaps[];
layout(location = 0) flat in int material;
layout(location = 0) out vec4 color;
void main() {
  color = texture(fixedMaps[material & 3], vec2(0.5)) + texture(allMaps[nonuniformEXT(material)], vec2(0.5))
        + texture(fixedMaps[2], vec2(0.5));
}
)";
  auto r = instrumentOk(compileGlsl(fs, Stage::Fragment));
  auto reads = sitesOf(r, SiteKind::TextureRead);
  ASSERT_EQ(reads.size(), 3u);
  int dynamicSites = 0;
  for (const auto* s : reads) {
    if (s->binding == 0 && s->dynamicIndex) {
      EXPECT_EQ(s->slotCount, 4u);
      ++dynamicSites;
    } else if (s->binding == 1) {
      EXPECT_TRUE(s->dynamicIndex);
      EXPECT_EQ(s->slotCount, kRuntimeArraySlots);
      ++dynamicSites;
    } else {
      EXPECT_EQ(s->index, 2u);
      EXPECT_EQ(s->slotCount, 1u);
    }
  }
  EXPECT_EQ(dynamicSites, 2);
  // Slot ranges never overlap.
  std::vector<std::pair<uint32_t, uint32_t>> ranges;
  for (const auto& s : r.sites) ranges.emplace_back(s.slot, s.slot + s.slotCount);
  std::sort(ranges.begin(), ranges.end());
  ranges.erase(std::unique(ranges.begin(), ranges.end()), ranges.end());
  for (size_t i = 1; i < ranges.size(); ++i) EXPECT_LE(ranges[i - 1].second, ranges[i].first);
  EXPECT_TRUE(contains(disassemble(r.words), "OpSelect %uint"));  // the clamp
}

TEST(Instrument, FollowsCopyObjectAndImageChainsInHandWrittenAssembly) {
  const char* text = R"(
               OpCapability Shader
               OpMemoryModel Logical GLSL450
               OpEntryPoint Fragment %main "main" %out
               OpExecutionMode %main OriginUpperLeft
               OpDecorate %tex DescriptorSet 2
               OpDecorate %tex Binding 3
               OpDecorate %out Location 0
       %void = OpTypeVoid
         %fn = OpTypeFunction %void
      %float = OpTypeFloat 32
        %int = OpTypeInt 32 1
         %v4 = OpTypeVector %float 4
         %v2 = OpTypeVector %float 2
       %v2i = OpTypeVector %int 2
        %img = OpTypeImage %float 2D 0 0 0 1 Unknown
         %si = OpTypeSampledImage %img
     %ptr_si = OpTypePointer UniformConstant %si
        %tex = OpVariable %ptr_si UniformConstant
    %ptr_out = OpTypePointer Output %v4
        %out = OpVariable %ptr_out Output
       %half = OpConstant %float 0.5
       %zero = OpConstant %int 0
      %coord = OpConstantComposite %v2 %half %half
     %icoord = OpConstantComposite %v2i %zero %zero
       %main = OpFunction %void None %fn
      %label = OpLabel
         %ld = OpLoad %si %tex
         %cp = OpCopyObject %si %ld
         %im = OpImage %img %cp
      %fetch = OpImageFetch %v4 %im %icoord Lod %zero
     %sample = OpImageSampleImplicitLod %v4 %cp %coord
        %sum = OpFAdd %v4 %fetch %sample
               OpStore %out %sum
               OpReturn
               OpFunctionEnd
)";
  auto words = test::assemble(text, SPV_ENV_VULKAN_1_0);
  auto r = instrumentOk(words);
  auto reads = sitesOf(r, SiteKind::TextureRead);
  ASSERT_EQ(reads.size(), 2u);
  for (const auto* s : reads) {
    EXPECT_EQ(s->set, 2);
    EXPECT_EQ(s->binding, 3);
    EXPECT_EQ(s->slot, reads[0]->slot);  // same kind and resource: one slot
  }
  EXPECT_EQ(reads[0]->opcode, "OpImageFetch");
  EXPECT_EQ(reads[1]->opcode, "OpImageSampleImplicitLod");
}

TEST(Instrument, FunctionSharedByTwoStagesIsInlinedPerEntryPoint) {
  const char* text = R"(
               OpCapability Shader
               OpMemoryModel Logical GLSL450
               OpEntryPoint Vertex %vs "vs"
               OpEntryPoint Fragment %fs "fs" %out
               OpExecutionMode %fs OriginUpperLeft
               OpMemberDecorate %S 0 Offset 0
               OpDecorate %S Block
               OpDecorate %u DescriptorSet 0
               OpDecorate %u Binding 0
               OpDecorate %out Location 0
       %void = OpTypeVoid
         %fn = OpTypeFunction %void
      %float = OpTypeFloat 32
         %v4 = OpTypeVector %float 4
       %fnv4 = OpTypeFunction %v4
          %S = OpTypeStruct %v4
       %ptrS = OpTypePointer Uniform %S
          %u = OpVariable %ptrS Uniform
        %int = OpTypeInt 32 1
       %zero = OpConstant %int 0
      %ptrV4 = OpTypePointer Uniform %v4
    %ptr_out = OpTypePointer Output %v4
        %out = OpVariable %ptr_out Output
        %get = OpFunction %v4 None %fnv4
         %gl = OpLabel
         %ac = OpAccessChain %ptrV4 %u %zero
          %v = OpLoad %v4 %ac
               OpReturnValue %v
               OpFunctionEnd
         %vs = OpFunction %void None %fn
         %vl = OpLabel
          %x = OpFunctionCall %v4 %get
               OpReturn
               OpFunctionEnd
         %fs = OpFunction %void None %fn
         %fl = OpLabel
          %y = OpFunctionCall %v4 %get
               OpStore %out %y
               OpReturn
               OpFunctionEnd
)";
  InstrumentOptions options;
  options.mode = {CountMode::Sampled, 4};  // stage-specific helpers
  auto r = instrumentOk(test::assemble(text, SPV_ENV_VULKAN_1_0), options);
  EXPECT_TRUE(r.inlined);
  auto reads = sitesOf(r, SiteKind::BufferRead);
  ASSERT_EQ(reads.size(), 2u);
  std::set<Stage> stages = {reads[0]->stage, reads[1]->stage};
  EXPECT_EQ(stages, (std::set<Stage>{Stage::Vertex, Stage::Fragment}));
  EXPECT_NE(reads[0]->slot, reads[1]->slot);
  auto invocations = sitesOf(r, SiteKind::Invocation);
  ASSERT_EQ(invocations.size(), 2u);
  EXPECT_NE(invocations[0]->slot, invocations[1]->slot);
  std::string dis = disassemble(r.words);
  EXPECT_TRUE(contains(dis, "BuiltIn VertexIndex"));
  EXPECT_TRUE(contains(dis, "BuiltIn FragCoord"));
}

TEST(Instrument, SiteTableJsonHasTheDocumentedFields) {
  glsl::CompileOptions co;
  co.debugInfo = true;
  co.fileName = "textured.frag.glsl";
  auto words = glsl::compile(kTextured, Stage::Fragment, co);
  ASSERT_TRUE(words.ok());
  InstrumentOptions options;
  auto r = instrumentOk(*words, options);
  auto j = toJson(r, options);
  ASSERT_TRUE(j.contains("sites"));
  bool sawTexture = false;
  for (const auto& s : j["sites"]) {
    for (const char* field : {"slot", "stage", "kind", "set", "binding", "index", "element_type", "element_bytes"}) {
      EXPECT_TRUE(s.contains(field)) << field;
    }
    if (s["kind"] == "texture_read") {
      sawTexture = true;
      EXPECT_EQ(s["stage"], "fragment");
      EXPECT_EQ(s["file"], "textured.frag.glsl");
      EXPECT_EQ(s["line"], 5);
    }
  }
  EXPECT_TRUE(sawTexture);
  EXPECT_EQ(j["counters"]["set"], 7);
  EXPECT_EQ(j["slot_count"], 3);
}

TEST(Instrument, AnalyzeReportsTheSameSitesWithoutRewriting) {
  auto words = compileGlsl(kTextured, Stage::Fragment);
  auto analyzed = analyze(words, {});
  ASSERT_TRUE(analyzed.ok());
  EXPECT_EQ(analyzed->words, words);
  auto r = instrumentOk(words);
  ASSERT_EQ(analyzed->sites.size(), r.sites.size());
  for (size_t i = 0; i < r.sites.size(); ++i) EXPECT_EQ(analyzed->sites[i].slot, r.sites[i].slot);
}

}  // namespace
}  // namespace tally::spirv
