// Shader objects (VK_EXT_shader_object) in the layer, without a device that
// offers them: each stage's slot band, what is refused and why, the twin's
// set layouts with the counter set appended, a stage's SPIR-V instrumented
// into its band with the counter set's index, and the combination bound at a
// draw (slots relative to its region, regionShift, dynamic state).
#include <cstdint>

#include <gtest/gtest.h>

#include "layer/shader_objects.hpp"
#include "spirv_test_util.hpp"

namespace tally::layer {
namespace {

constexpr uint32_t kMaxSlots = 131072;  // a 1 MiB region of 8-byte slots, as on lavapipe and the H200
constexpr uint32_t kCounterSet = 7;

const char* kVertex = R"(#version 450
layout(std430, set = 0, binding = 0) readonly buffer Positions { vec2 p[]; };
void main() { gl_Position = vec4(p[gl_VertexIndex], 0.0, 1.0); }
)";
const char* kFragment = R"(#version 450
layout(set = 0, binding = 1) uniform Tint { vec4 tint; };
layout(location = 0) out vec4 color;
void main() { color = tint; }
)";

VkShaderCreateInfoEXT spirvInfo(VkShaderStageFlagBits stage, const std::vector<uint32_t>& words) {
  VkShaderCreateInfoEXT info = {VK_STRUCTURE_TYPE_SHADER_CREATE_INFO_EXT};
  info.stage = stage;
  info.codeType = VK_SHADER_CODE_TYPE_SPIRV_EXT;
  info.codeSize = words.size() * 4;
  info.pCode = words.data();
  info.pName = "main";
  return info;
}

// A shader object as vkCreateShadersEXT leaves it: instrumented, with a twin.
ShaderObject instrumented(VkShaderStageFlagBits stage, const char* source, spirv::Stage glslStage) {
  ShaderObject object;
  object.stage = stage;
  object.handle = 0x2000 + stage;
  object.twin = reinterpret_cast<VkShaderEXT>(uintptr_t(0x1000 + stage));
  std::vector<uint32_t> out;
  std::vector<std::string> notes;
  spirv::InstrumentOptions options;
  options.set = kCounterSet;
  const std::string why =
      instrumentShaderObject(test::compileGlsl(source, glslStage), options, kMaxSlots, "s", object, out, notes);
  EXPECT_EQ(why, "");
  EXPECT_FALSE(out.empty());
  return object;
}

TEST(ShaderObjects, StagesThatMayBeBoundTogetherCountInBandsThatDoNotOverlap) {
  const VkShaderStageFlagBits classic[] = {VK_SHADER_STAGE_VERTEX_BIT, VK_SHADER_STAGE_TESSELLATION_CONTROL_BIT,
                                           VK_SHADER_STAGE_TESSELLATION_EVALUATION_BIT, VK_SHADER_STAGE_GEOMETRY_BIT,
                                           VK_SHADER_STAGE_FRAGMENT_BIT};
  const VkShaderStageFlagBits mesh[] = {VK_SHADER_STAGE_TASK_BIT_EXT, VK_SHADER_STAGE_MESH_BIT_EXT,
                                        VK_SHADER_STAGE_FRAGMENT_BIT};
  for (const auto& stages : {std::vector<VkShaderStageFlagBits>(std::begin(classic), std::end(classic)),
                             std::vector<VkShaderStageFlagBits>(std::begin(mesh), std::end(mesh))}) {
    for (size_t a = 0; a < stages.size(); ++a) {
      for (size_t b = a + 1; b < stages.size(); ++b) {
        const SlotBand x = slotBand(stages[a], kMaxSlots), y = slotBand(stages[b], kMaxSlots);
        EXPECT_TRUE(x.limit <= y.first || y.limit <= x.first) << stages[a] << " and " << stages[b];
      }
    }
  }
  // The usual pair: the vertex band right below the fragment shader's, which runs to the region's end.
  EXPECT_EQ(slotBand(VK_SHADER_STAGE_VERTEX_BIT, kMaxSlots).limit, slotBand(VK_SHADER_STAGE_FRAGMENT_BIT, kMaxSlots).first);
  EXPECT_EQ(slotBand(VK_SHADER_STAGE_FRAGMENT_BIT, kMaxSlots).limit, kMaxSlots);
  EXPECT_EQ(slotBand(VK_SHADER_STAGE_COMPUTE_BIT, kMaxSlots).first, 0u);
  EXPECT_EQ(slotBand(VK_SHADER_STAGE_COMPUTE_BIT, kMaxSlots).limit, kMaxSlots);
  EXPECT_EQ(shaderStageIndex(VK_SHADER_STAGE_COMPUTE_BIT), int(kComputeShaderIndex));
  EXPECT_EQ(shaderStageIndex(VK_SHADER_STAGE_RAYGEN_BIT_KHR), -1);
}

TEST(ShaderObjects, BinaryCodeIsRefusedWithTheReason) {
  const auto words = test::compileGlsl(kVertex, spirv::Stage::Vertex);
  VkShaderCreateInfoEXT info = spirvInfo(VK_SHADER_STAGE_VERTEX_BIT, words);
  EXPECT_EQ(shaderRefusal(info, kCounterSet, true, true), "");
  info.codeType = VK_SHADER_CODE_TYPE_BINARY_EXT;
  const std::string why = shaderRefusal(info, kCounterSet, true, true);
  EXPECT_NE(why.find("VK_SHADER_CODE_TYPE_BINARY_EXT"), std::string::npos) << why;
  EXPECT_NE(why.find("uncounted"), std::string::npos) << why;
}

TEST(ShaderObjects, WhatTheDeviceOrTheSetLayoutsForbidIsRefusedWithTheReason) {
  const auto words = test::compileGlsl(kFragment, spirv::Stage::Fragment);
  VkShaderCreateInfoEXT info = spirvInfo(VK_SHADER_STAGE_FRAGMENT_BIT, words);
  EXPECT_EQ(shaderRefusal(info, kCounterSet, false, true), "the device has no fragmentStoresAndAtomics");
  info.stage = VK_SHADER_STAGE_VERTEX_BIT;
  EXPECT_EQ(shaderRefusal(info, kCounterSet, true, false), "the device has no vertexPipelineStoresAndAtomics");
  std::vector<VkDescriptorSetLayout> sets(kCounterSet + 1, VK_NULL_HANDLE);
  info.setLayoutCount = uint32_t(sets.size());
  info.pSetLayouts = sets.data();
  EXPECT_EQ(shaderRefusal(info, kCounterSet, true, true),
            "the shader object uses 8 descriptor sets and the layer needs set 7: it runs unchanged, uncounted");
  info.setLayoutCount = 0;
  info.codeSize = 6;
  EXPECT_EQ(shaderRefusal(info, kCounterSet, true, true),
            "codeSize 6 is not a SPIR-V module's (a multiple of 4, at least 20)");
}

TEST(ShaderObjects, TheTwinsSetLayoutsEndWithTheCounterSet) {
  auto handle = [](uintptr_t h) { return reinterpret_cast<VkDescriptorSetLayout>(h); };
  const VkDescriptorSetLayout app[2] = {handle(1), handle(2)};
  VkShaderCreateInfoEXT info = {VK_STRUCTURE_TYPE_SHADER_CREATE_INFO_EXT};
  info.setLayoutCount = 2;
  info.pSetLayouts = app;
  const auto sets = twinSetLayouts(info, 5, handle(9), handle(7));
  EXPECT_EQ(sets, (std::vector<VkDescriptorSetLayout>{handle(1), handle(2), handle(9), handle(9), handle(9), handle(7)}));
}

TEST(ShaderObjects, AStageIsInstrumentedInItsBandWithTheCounterSet) {
  const ShaderObject vertex = instrumented(VK_SHADER_STAGE_VERTEX_BIT, kVertex, spirv::Stage::Vertex);
  const SlotBand band = slotBand(VK_SHADER_STAGE_VERTEX_BIT, kMaxSlots);
  EXPECT_EQ(vertex.firstSlot, band.first);
  EXPECT_TRUE(vertex.counted.counted);
  ASSERT_FALSE(vertex.counted.sites.empty());
  for (const auto& site : vertex.counted.sites) {
    EXPECT_GE(site.slot, band.first);
    EXPECT_LT(site.slot, vertex.counted.slots);
    EXPECT_EQ(site.shader, "s");
  }
  EXPECT_LE(vertex.counted.slots, band.limit);
  // The twin's code binds the counters at the layer's set.
  std::vector<uint32_t> out;
  std::vector<std::string> notes;
  ShaderObject again;
  again.stage = VK_SHADER_STAGE_VERTEX_BIT;
  spirv::InstrumentOptions options;
  options.set = kCounterSet;
  ASSERT_EQ(instrumentShaderObject(test::compileGlsl(kVertex, spirv::Stage::Vertex), options, kMaxSlots, "s", again,
                                   out, notes),
            "");
  EXPECT_NE(test::disassemble(out).find("DescriptorSet 7"), std::string::npos);
}

TEST(ShaderObjects, AFragmentShaderGetsACopyWithEarlyTestsCountingInTheSameSlots) {
  ShaderObject late;
  late.stage = VK_SHADER_STAGE_FRAGMENT_BIT;
  std::vector<uint32_t> out, early;
  std::vector<std::string> notes;
  const auto words = test::compileGlsl(kFragment, spirv::Stage::Fragment);
  ASSERT_EQ(instrumentShaderObject(words, {}, kMaxSlots, "f", late, out, notes, &early), "");
  EXPECT_EQ(test::disassemble(out).find("EarlyFragmentTests"), std::string::npos);
  EXPECT_NE(test::disassemble(early).find("EarlyFragmentTests"), std::string::npos);
  // The late twin's note (rejected fragments counted) is the early copy's to drop.
  for (const auto& note : notes) EXPECT_EQ(note.find("early_fragment_tests"), std::string::npos) << note;
  // A shader that discards keeps late tests only.
  const auto discards = test::compileGlsl(R"(#version 450
layout(set = 0, binding = 1) uniform Tint { vec4 tint; };
layout(location = 0) out vec4 color;
void main() { if (tint.a < 0.5) discard; color = tint; }
)", spirv::Stage::Fragment);
  ShaderObject other;
  other.stage = VK_SHADER_STAGE_FRAGMENT_BIT;
  std::vector<uint32_t> none;
  ASSERT_EQ(instrumentShaderObject(discards, {}, kMaxSlots, "d", other, out, notes, &none), "");
  EXPECT_TRUE(none.empty());
}

TEST(ShaderObjects, AStageThatNeedsMoreThanItsBandIsRefused) {
  const SlotBand vertex = slotBand(VK_SHADER_STAGE_VERTEX_BIT, kMaxSlots);
  EXPECT_EQ(vertex.limit - vertex.first, kShaderBandSlots);
  // A region that leaves the fragment band one slot.
  ShaderObject fragment;
  fragment.stage = VK_SHADER_STAGE_FRAGMENT_BIT;
  std::vector<uint32_t> out;
  std::vector<std::string> notes;
  const uint32_t tight = slotBand(VK_SHADER_STAGE_FRAGMENT_BIT, kMaxSlots).first + 1;
  const std::string why = instrumentShaderObject(test::compileGlsl(kFragment, spirv::Stage::Fragment), {}, tight, "f",
                                                 fragment, out, notes);
  EXPECT_NE(why.find("counter slots; a shader object of its stage holds 1"), std::string::npos) << why;
  EXPECT_FALSE(fragment.counted.counted);
  EXPECT_TRUE(out.empty());
}

TEST(ShaderObjects, TheBoundCombinationCountsFromItsLowestBand) {
  const ShaderObject vertex = instrumented(VK_SHADER_STAGE_VERTEX_BIT, kVertex, spirv::Stage::Vertex);
  const ShaderObject fragment = instrumented(VK_SHADER_STAGE_FRAGMENT_BIT, kFragment, spirv::Stage::Fragment);
  const auto combined = combineShaders({&vertex, nullptr, &fragment});
  ASSERT_TRUE(combined);
  EXPECT_EQ(combined->regionShift, VkDeviceSize(vertex.firstSlot) * 8);
  EXPECT_EQ(combined->slots, fragment.counted.slots - vertex.firstSlot);
  EXPECT_EQ(combined->sites.size(), vertex.counted.sites.size() + fragment.counted.sites.size());
  EXPECT_EQ(combined->sites.front().slot, vertex.counted.sites.front().slot - vertex.firstSlot);
  EXPECT_EQ(combined->sites.back().slot, fragment.counted.sites.back().slot - vertex.firstSlot);
  EXPECT_TRUE(combined->hasFragment);
  EXPECT_EQ(combined->name, "shader objects 0x2001 0x2010");  // per-draw lines name the shaders
  EXPECT_EQ(combined->handle, reinterpret_cast<uint64_t>(combined.get()));
  const FixedFunction& fixed = combined->fixed;
  EXPECT_TRUE(fixed.dynamicWriteMask && fixed.dynamicWriteEnable && fixed.dynamicDiscard && fixed.dynamicVertexInput);

  // The fragment shader alone: its band starts the region.
  const auto alone = combineShaders({&fragment});
  ASSERT_TRUE(alone);
  EXPECT_EQ(alone->regionShift, VkDeviceSize(fragment.firstSlot) * 8);
  EXPECT_EQ(alone->sites.front().slot, fragment.counted.sites.front().slot - fragment.firstSlot);
}

TEST(ShaderObjects, ShadersWithoutATwinCountNothing) {
  ShaderObject vertex = instrumented(VK_SHADER_STAGE_VERTEX_BIT, kVertex, spirv::Stage::Vertex);
  vertex.twin = VK_NULL_HANDLE;  // the driver refused it
  ShaderObject binary;           // created from a binary: never instrumented
  binary.stage = VK_SHADER_STAGE_FRAGMENT_BIT;
  EXPECT_EQ(combineShaders({&vertex, &binary}), nullptr);
  EXPECT_EQ(combineShaders({}), nullptr);
}

TEST(ShaderObjects, FoldLayoutsMoveWithTheirSlots) {
  ShaderObject fragment;
  fragment.stage = VK_SHADER_STAGE_FRAGMENT_BIT;
  fragment.twin = reinterpret_cast<VkShaderEXT>(uintptr_t(1));
  fragment.firstSlot = 2048;
  fragment.counted.counted = true;
  fragment.counted.slots = 2048 + 8;
  spirv::Site site;
  site.slot = 2049;
  fragment.counted.sites.push_back(site);
  fragment.counted.foldLayouts.push_back({2048, 4, 2, 4, {{2049, 2050, 3}}});
  const auto combined = combineShaders({&fragment});
  ASSERT_TRUE(combined);
  ASSERT_EQ(combined->foldLayouts.size(), 1u);
  EXPECT_EQ(combined->foldLayouts[0].firstSlot, 0u);
  EXPECT_EQ(combined->foldLayouts[0].derived[0], (spirv::DerivedCount{1, 2, 3}));
  EXPECT_EQ(combined->sites[0].slot, 1u);
  EXPECT_EQ(combined->slots, 8u);
}

TEST(ShaderObjects, APipelineBoundUnbindsItsBindPointsShaders) {
  CommandBufferState cb;
  cb.shaders.fill(5);
  unbindShaderObjects(cb, false);
  for (size_t s = 0; s < kComputeShaderIndex; ++s) EXPECT_EQ(cb.shaders[s], 0u);
  EXPECT_EQ(cb.shaders[kComputeShaderIndex], 5u);
  unbindShaderObjects(cb, true);
  EXPECT_EQ(cb.shaders[kComputeShaderIndex], 0u);
}

}  // namespace
}  // namespace tally::layer
