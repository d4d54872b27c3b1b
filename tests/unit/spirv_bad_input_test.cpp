// Bad input of every kind gets a one-line error naming the problem, never a
// crash. The sanitizer build (scripts/test.sh) runs these under ASan/UBSan.
#include <cstring>
#include <random>

#include "spirv/module.hpp"
#include "spirv/validate.hpp"
#include "spirv_test_util.hpp"

namespace tally::spirv {
namespace {

const char* kShader = R"(#version 450
layout(set = 0, binding = 0) uniform sampler2D tex;
layout(set = 0, binding = 1) buffer Data { vec4 values[]; } data;
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;
void main() {
  vec4 c = texture(tex, uv);
  for (int i = 0; i < 4; ++i) { if (c.x > 0.5) c += data.values[i]; }
  color = c;
}
)";

std::string instrumentError(std::span<const uint32_t> words, const InstrumentOptions& options = {}) {
  auto r = instrument(words, options);
  if (r.ok()) return "";
  EXPECT_EQ(r.error().find('\n'), std::string::npos) << "error is not one line: " << r.error();
  return r.error();
}

std::string bytesError(const std::vector<uint8_t>& bytes) {
  auto words = wordsFromBytes(bytes);
  if (!words.ok()) return words.error();
  return instrumentError(*words);
}

class BadInput : public ::testing::Test {
 protected:
  void SetUp() override { good_ = test::compileGlsl(kShader, Stage::Fragment); }
  std::vector<uint8_t> goodBytes() const {
    std::vector<uint8_t> bytes(good_.size() * 4);
    std::memcpy(bytes.data(), good_.data(), bytes.size());
    return bytes;
  }
  std::vector<uint32_t> good_;
};

TEST_F(BadInput, EmptyFile) { EXPECT_NE(bytesError({}).find("empty"), std::string::npos); }

TEST_F(BadInput, NotAWholeNumberOfWords) {
  auto bytes = goodBytes();
  bytes.resize(bytes.size() - 3);
  EXPECT_NE(bytesError(bytes).find("not a whole number of 32-bit words"), std::string::npos);
}

TEST_F(BadInput, ShorterThanTheHeader) {
  std::vector<uint32_t> words(good_.begin(), good_.begin() + 3);
  EXPECT_NE(instrumentError(words).find("truncated"), std::string::npos);
}

TEST_F(BadInput, WrongMagic) {
  auto words = good_;
  words[0] = 0xdeadbeef;
  EXPECT_NE(instrumentError(words).find("wrong magic number 0xdeadbeef"), std::string::npos);
  auto text = std::string("#version 450\nvoid main() {}\n");
  std::vector<uint8_t> glslBytes(text.begin(), text.end());
  glslBytes.resize(glslBytes.size() / 4 * 4);
  EXPECT_NE(bytesError(glslBytes).find("wrong magic"), std::string::npos);
}

TEST_F(BadInput, UnsupportedVersion) {
  auto words = good_;
  words[1] = 0x00020000;
  EXPECT_NE(instrumentError(words).find("unsupported SPIR-V version 2.0"), std::string::npos);
  words[1] = 0x00010700;
  EXPECT_NE(instrumentError(words).find("unsupported SPIR-V version 1.7"), std::string::npos);
}

TEST_F(BadInput, TruncatedAtEveryWord) {
  for (size_t size = 5; size < good_.size(); ++size) {
    std::vector<uint32_t> cut(good_.begin(), good_.begin() + static_cast<long>(size));
    std::string error = instrumentError(cut);
    EXPECT_FALSE(error.empty()) << "a module cut to " << size << " words was accepted";
  }
}

TEST_F(BadInput, ZeroWordCount) {
  auto words = good_;
  words[5] = 0;  // the first instruction's header
  EXPECT_NE(instrumentError(words).find("word count 0"), std::string::npos);
}

TEST_F(BadInput, SemanticallyInvalidModuleIsRejectedByTheValidator) {
  auto words = good_;
  // Point the entry point at an id that is not a function.
  auto module = Module::parse(words);
  ASSERT_TRUE(module.ok());
  module->entryPoints[0].words[2] = module->bound - 1 + 1000;
  module->bound += 1000;
  std::string error = instrumentError(module->serialize());
  EXPECT_NE(error.find("invalid SPIR-V"), std::string::npos) << error;
}

TEST_F(BadInput, ModuleAlreadyUsingTheCounterBinding) {
  InstrumentOptions options;
  options.set = 0;
  options.binding = 1;  // the shader's own 'data' buffer
  std::string error = instrumentError(good_, options);
  EXPECT_NE(error.find("already uses descriptor set 0 binding 1 ('data')"), std::string::npos) << error;
  // Instrumenting twice with the same binding is refused too.
  auto once = test::instrumentOk(good_);
  EXPECT_NE(instrumentError(once.words).find("already uses descriptor set 7 binding 0"), std::string::npos);
  // With another binding the second pass is accepted.
  InstrumentOptions other;
  other.binding = 1;
  EXPECT_EQ(instrumentError(once.words, other), "");
}

TEST_F(BadInput, KernelModules) {
  const char* text = R"(
    OpCapability Kernel
    OpCapability Addresses
    OpMemoryModel Physical32 OpenCL
    OpEntryPoint Kernel %k "k"
    %void = OpTypeVoid
    %fn = OpTypeFunction %void
    %k = OpFunction %void None %fn
    %l = OpLabel
    OpReturn
    OpFunctionEnd
  )";
  auto words = test::assemble(text, SPV_ENV_UNIVERSAL_1_0);
  InstrumentOptions options;
  options.validate = false;  // reach the kernel check itself
  EXPECT_NE(instrumentError(words, options).find("OpenCL kernel"), std::string::npos);
  EXPECT_NE(instrumentError(words).find("invalid SPIR-V"), std::string::npos);
}

TEST_F(BadInput, RandomCorruptionNeverCrashes) {
  std::mt19937 rng(1234);  // fixed seed: the same 3000 mutants every run
  int accepted = 0;
  for (int i = 0; i < 3000; ++i) {
    auto words = good_;
    int edits = 1 + static_cast<int>(rng() % 4);
    for (int e = 0; e < edits; ++e) {
      size_t at = 5 + rng() % (words.size() - 5);
      switch (rng() % 3) {
        case 0: words[at] ^= 1u << (rng() % 32); break;
        case 1: words[at] = rng(); break;
        case 2: words[at] = (words[at] & 0xffffu) | ((rng() % 8) << 16); break;  // word counts
      }
    }
    auto r = instrument(words, {});
    if (r.ok()) {
      ++accepted;
      EXPECT_EQ(validate(r->words), std::nullopt);
    } else {
      EXPECT_FALSE(r.error().empty());
    }
  }
  // Most single-bit edits still make a valid module (names, constants); the
  // point is that none crashed and every accepted one validated.
  RecordProperty("accepted_mutants", accepted);
}

// Found by fuzzing: integer coordinates, gather components and offsets may be
// unsigned (GLSL always makes them signed). The footprint's texel helpers take
// i32: the instrumentation must convert them, in every mode and block size.
TEST_F(BadInput, UnsignedCoordinatesAndOffsetsInstrumentWithFootprint) {
  const char* text = R"(
    OpCapability Shader
    %1 = OpExtInstImport "GLSL.std.450"
    OpMemoryModel Logical GLSL450
    OpEntryPoint Fragment %main "main" %gl_FragCoord %inUv %outColor
    OpExecutionMode %main OriginUpperLeft
    OpSource GLSL 450
    OpName %main "main"
    OpName %texel "texel"
    OpName %gbuffer "gbuffer"
    OpName %gl_FragCoord "gl_FragCoord"
    OpName %reds "reds"
    OpName %ao "ao"
    OpName %inUv "inUv"
    OpName %greens "greens"
    OpName %outColor "outColor"
    OpDecorate %gbuffer DescriptorSet 0
    OpDecorate %gbuffer Binding 3
    OpDecorate %gl_FragCoord BuiltIn FragCoord
    OpDecorate %ao DescriptorSet 2
    OpDecorate %ao Binding 2
    OpDecorate %inUv Location 0
    OpDecorate %outColor Location 0
    %void = OpTypeVoid
    %3 = OpTypeFunction %void
    %float = OpTypeFloat 32
    %v4float = OpTypeVector %float 4
    %_ptr_Function_v4float = OpTypePointer Function %v4float
    %10 = OpTypeImage %float 2D 0 0 0 1 Unknown
    %11 = OpTypeSampledImage %10
    %_ptr_UniformConstant_11 = OpTypePointer UniformConstant %11
    %gbuffer = OpVariable %_ptr_UniformConstant_11 UniformConstant
    %_ptr_Input_v4float = OpTypePointer Input %v4float
    %gl_FragCoord = OpVariable %_ptr_Input_v4float Input
    %v2float = OpTypeVector %float 2
    %uint = OpTypeInt 32 0
    %v2uint = OpTypeVector %uint 2
    %uint_0 = OpConstant %uint 0
    %ao = OpVariable %_ptr_UniformConstant_11 UniformConstant
    %_ptr_Input_v2float = OpTypePointer Input %v2float
    %inUv = OpVariable %_ptr_Input_v2float Input
    %uint_1 = OpConstant %uint 1
    %37 = OpConstantComposite %v2uint %uint_1 %uint_0
    %_ptr_Output_v4float = OpTypePointer Output %v4float
    %outColor = OpVariable %_ptr_Output_v4float Output
    %main = OpFunction %void None %3
    %5 = OpLabel
    %texel = OpVariable %_ptr_Function_v4float Function
    %reds = OpVariable %_ptr_Function_v4float Function
    %greens = OpVariable %_ptr_Function_v4float Function
    %14 = OpLoad %11 %gbuffer
    %18 = OpLoad %v4float %gl_FragCoord
    %19 = OpVectorShuffle %v2float %18 %18 0 1
    %22 = OpConvertFToS %v2uint %19
    %24 = OpImage %10 %14
    %25 = OpImageFetch %v4float %24 %22 Lod %uint_0
    OpStore %texel %25
    %28 = OpLoad %11 %ao
    %31 = OpLoad %v2float %inUv
    %32 = OpImageGather %v4float %28 %31 %uint_0
    OpStore %reds %32
    %34 = OpLoad %11 %ao
    %35 = OpLoad %v2float %inUv
    %38 = OpImageGather %v4float %34 %35 %uint_1 ConstOffset %37
    OpStore %greens %38
    %41 = OpLoad %v4float %texel
    %42 = OpLoad %v4float %reds
    %43 = OpFAdd %v4float %41 %42
    %44 = OpLoad %v4float %greens
    %45 = OpFAdd %v4float %43 %44
    OpStore %outColor %45
    OpReturn
    OpFunctionEnd
  )";
  const auto words = test::assemble(text, SPV_ENV_VULKAN_1_0);
  for (const char* mode : {"exact", "subgroup", "sampled:4", "accumulate", "accumulate:subgroup", "accumulate:lane"}) {
    for (uint32_t block : {32u, 64u, 128u}) {
      InstrumentOptions options;
      options.mode = *parseMode(mode);
      options.footprintBlockBytes = block;
      auto r = instrument(words, options);
      ASSERT_TRUE(r.ok()) << mode << ", " << block << " B blocks: " << r.error();
      // The fetch and both gathers are marked, not noted as unsupported.
      int marked = 0;
      for (const Site& site : r->sites) marked += site.kind == SiteKind::TextureRead && site.footprint;
      EXPECT_EQ(marked, 3) << mode << ", " << block << " B blocks";
    }
  }
}

TEST_F(BadInput, NoEntryPoints) {
  const char* text = R"(
    OpCapability Shader
    OpCapability Linkage
    OpMemoryModel Logical GLSL450
    %void = OpTypeVoid
  )";
  InstrumentOptions options;
  options.validate = false;
  EXPECT_NE(instrumentError(test::assemble(text, SPV_ENV_UNIVERSAL_1_0), options).find("no entry points"),
            std::string::npos);
}

}  // namespace
}  // namespace tally::spirv
