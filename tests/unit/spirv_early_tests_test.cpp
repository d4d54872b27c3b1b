// Early fragment tests kept (InstrumentOptions::earlyFragmentTests): a
// fragment shader whose tests may run early without changing what it does
// is given EarlyFragmentTests; one that discards, demotes, writes depth,
// stencil or sample mask, or has stores or atomics of its own keeps its late
// tests and a note naming why. Every output validates.
#include <algorithm>

#include "spirv/validate.hpp"
#include "spirv_test_util.hpp"

namespace tally::spirv {
namespace {

using test::compileGlsl;
using test::disassemble;

size_t countOf(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

struct Outcome {
  size_t earlyModes = 0;  // OpExecutionMode ... EarlyFragmentTests in the output
  std::string note;       // the early-tests note, "" for none
};

Outcome instrumentFragment(const std::string& source, bool preserve = true,
                           glsl::Target target = glsl::Target::Vulkan13) {
  InstrumentOptions options;
  options.earlyFragmentTests = preserve;
  options.mode = Mode{CountMode::Accumulate};
  auto r = instrument(compileGlsl(source, Stage::Fragment, target), options);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error());
  if (!r.ok()) return {};
  EXPECT_EQ(validate(r->words), std::nullopt);
  Outcome out;
  out.earlyModes = countOf(disassemble(r->words), "EarlyFragmentTests");
  for (const auto& n : r->notes) {
    if (n.find("early_fragment_tests") != std::string::npos) out.note = n;
  }
  return out;
}

const char* kSafe = R"(#version 450
layout(set = 0, binding = 0) uniform sampler2D tex;
layout(set = 0, binding = 1) uniform Tint { vec4 tint; };
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;
vec4 shade(vec2 at) { return texture(tex, at) * tint; }
void main() { color = shade(uv); }
)";

TEST(EarlyTests, ASafeShaderIsGivenThemAndNoNote) {
  auto o = instrumentFragment(kSafe);
  EXPECT_EQ(o.earlyModes, 1u);
  EXPECT_EQ(o.note, "");
}

TEST(EarlyTests, WithoutTheOptionTheShaderKeepsLateTestsAndTheNote) {
  auto o = instrumentFragment(kSafe, false);
  EXPECT_EQ(o.earlyModes, 0u);
  EXPECT_NE(o.note.find("fragment entry point 'main' has no early_fragment_tests: its counters are side effects"),
            std::string::npos)
      << o.note;
}

TEST(EarlyTests, AShaderThatDeclaresThemIsLeftAlone) {
  auto o = instrumentFragment(std::string(kSafe).replace(13, 0, "layout(early_fragment_tests) in;\n"));
  EXPECT_EQ(o.earlyModes, 1u);
  EXPECT_EQ(o.note, "");
}

TEST(EarlyTests, PostDepthCoverageDoesNotStandAgainstThem) {
  auto o = instrumentFragment(std::string(kSafe).replace(
      13, 0, "#extension GL_ARB_post_depth_coverage : require\nlayout(post_depth_coverage) in;\n"));
  EXPECT_EQ(o.earlyModes, 1u);
  EXPECT_EQ(o.note, "");
}

void expectKept(const std::string& source, const std::string& why, glsl::Target target = glsl::Target::Vulkan13) {
  auto o = instrumentFragment(source, true, target);
  EXPECT_EQ(o.earlyModes, 0u) << source;
  EXPECT_NE(o.note.find("has no early_fragment_tests and cannot be given them (" + why), std::string::npos) << o.note;
}

TEST(EarlyTests, DiscardKeepsLateTests) {
  const char* discard = R"(#version 450
layout(set = 0, binding = 0) uniform sampler2D tex;
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;
void main() { color = texture(tex, uv); if (color.a < 0.5) discard; }
)";
  expectKept(discard, "it discards (OpTerminateInvocation)");  // SPIR-V 1.6
  expectKept(discard, "it discards (OpKill)", glsl::Target::Vulkan10);
}

TEST(EarlyTests, DiscardInACalledFunctionKeepsLateTests) {
  expectKept(R"(#version 450
layout(set = 0, binding = 0) uniform sampler2D tex;
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;
void alphaTest(float a) { if (a < 0.5) discard; }
void main() { color = texture(tex, uv); alphaTest(color.a); }
)", "it discards");
}

TEST(EarlyTests, DemoteKeepsLateTests) {
  expectKept(R"(#version 450
#extension GL_EXT_demote_to_helper_invocation : require
layout(set = 0, binding = 0) uniform sampler2D tex;
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;
void main() { color = texture(tex, uv); if (color.a < 0.5) demote; }
)", "it demotes to a helper invocation");
}

TEST(EarlyTests, ADepthWriteKeepsLateTests) {
  expectKept(R"(#version 450
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;
void main() { color = vec4(uv, 0, 1); gl_FragDepth = uv.x; }
)", "it replaces its depth");
}

TEST(EarlyTests, ASampleMaskWriteKeepsLateTests) {
  expectKept(R"(#version 450
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;
void main() { color = vec4(uv, 0, 1); gl_SampleMask[0] = 1; }
)", "it writes SampleMask");
}

TEST(EarlyTests, AStencilExportKeepsLateTests) {
  expectKept(R"(#version 450
#extension GL_ARB_shader_stencil_export : require
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;
void main() { color = vec4(uv, 0, 1); gl_FragStencilRefARB = 3; }
)", "it replaces its stencil reference");
}

TEST(EarlyTests, AStorageBufferStoreKeepsLateTests) {
  expectKept(R"(#version 450
layout(set = 0, binding = 0) buffer Out { vec4 values[]; };
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;
void main() { color = vec4(uv, 0, 1); values[int(gl_FragCoord.x)] = color; }
)", "it stores to a storage buffer");
}

TEST(EarlyTests, AStorageImageWriteKeepsLateTests) {
  expectKept(R"(#version 450
layout(set = 0, binding = 0, rgba8) uniform writeonly image2D target;
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;
void main() { color = vec4(uv, 0, 1); imageStore(target, ivec2(gl_FragCoord.xy), color); }
)", "it writes a storage image (OpImageWrite)");
}

TEST(EarlyTests, AnAtomicKeepsLateTests) {
  expectKept(R"(#version 450
layout(set = 0, binding = 0) buffer Counter { uint fragments; };
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;
void main() { color = vec4(uv, 0, 1); atomicAdd(fragments, 1u); }
)", "it uses atomics");
}

TEST(EarlyTests, AnalysisOnlyNeverAddsThem) {
  InstrumentOptions options;
  options.earlyFragmentTests = true;
  auto words = compileGlsl(kSafe, Stage::Fragment);
  auto r = analyze(words, options);
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->words, words);
  EXPECT_TRUE(std::any_of(r->notes.begin(), r->notes.end(),
                          [](auto& n) { return n.find("no early_fragment_tests") != std::string::npos; }));
}

}  // namespace
}  // namespace tally::spirv
