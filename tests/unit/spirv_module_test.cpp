#include "spirv/module.hpp"

#include "spirv_test_util.hpp"

namespace tally::spirv {
namespace {

const char* kFragment = R"(#version 450
layout(set = 0, binding = 0) uniform sampler2D tex;
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;
void main() { color = texture(tex, uv); }
)";

TEST(SpirvModule, ParseSerializeRoundTripIsExact) {
  for (auto target : {glsl::Target::Vulkan10, glsl::Target::Vulkan13}) {
    auto words = test::compileGlsl(kFragment, Stage::Fragment, target);
    auto module = Module::parse(words);
    ASSERT_TRUE(module.ok()) << module.error();
    EXPECT_EQ(module->serialize(), words);
    EXPECT_EQ(module->functions.size(), 1u);
    EXPECT_EQ(module->entryPoints.size(), 1u);
  }
}

TEST(SpirvModule, ReadsByteSwappedModules) {
  auto words = test::compileGlsl(kFragment, Stage::Fragment);
  std::vector<uint32_t> swapped = words;
  for (auto& w : swapped) w = __builtin_bswap32(w);
  auto module = Module::parse(swapped);
  ASSERT_TRUE(module.ok()) << module.error();
  EXPECT_EQ(module->serialize(), words);
}

TEST(SpirvModule, SectionsFollowTheLogicalLayout) {
  auto words = test::compileGlsl(kFragment, Stage::Fragment);
  auto module = Module::parse(words);
  ASSERT_TRUE(module.ok());
  EXPECT_EQ(module->capabilities.front().opcode(), spv::Op::OpCapability);
  EXPECT_EQ(module->memoryModel.size(), 1u);
  for (const auto& inst : module->annotations) {
    EXPECT_TRUE(inst.opcode() == spv::Op::OpDecorate || inst.opcode() == spv::Op::OpMemberDecorate);
  }
  DefIndex defs(*module);
  bool foundTex = false;
  for (const auto& inst : module->globals) {
    if (inst.opcode() == spv::Op::OpVariable && defs.name(inst.resultId()) == "tex") {
      foundTex = true;
      EXPECT_EQ(defs.decorationValue(inst.resultId(), spv::Decoration::DescriptorSet), 0u);
      EXPECT_EQ(defs.decorationValue(inst.resultId(), spv::Decoration::Binding), 0u);
    }
  }
  EXPECT_TRUE(foundTex);
}

TEST(SpirvModule, StringWordsRoundTrip) {
  for (std::string text : {"", "a", "main", "abcd", "tally_counters"}) {
    std::vector<uint32_t> operands = stringWords(text);
    EXPECT_EQ(operands.size(), text.size() / 4 + 1) << text;
    Instruction inst(spv::Op::OpName, {});
    inst.words.insert(inst.words.end(), operands.begin(), operands.end());
    EXPECT_EQ(inst.literalString(1), text);
  }
}

TEST(SpirvModule, VersionString) {
  EXPECT_EQ(versionString(0x00010000), "1.0");
  EXPECT_EQ(versionString(0x00010600), "1.6");
}

}  // namespace
}  // namespace tally::spirv
