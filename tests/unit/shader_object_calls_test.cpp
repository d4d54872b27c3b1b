// The layer's shader-object calls (layer/shader_objects.cpp) against a
// recording stand-in for the driver below it, since no device Tally's CI has
// offers VK_EXT_shader_object: what vkCreateShadersEXT creates (the
// application's shaders as asked, then instrumented twins with the counter
// set appended; linked shaders' twins in one call; none for binary code),
// what vkCmdBindShadersEXT binds in command buffers that count and in those
// that do not, the early-tests twin swapped in while alpha to coverage is
// off, and what vkDestroyShaderEXT and the device's end destroy.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "layer/intercepts.hpp"
#include "layer/shader_objects.hpp"
#include "spirv_test_util.hpp"

namespace tally::layer {

// The layer's handle lookups (layer.cpp), over the one device of these tests.
DeviceState* g_device = nullptr;
DeviceState* deviceOf(const void*) { return g_device; }
CommandBufferState* commandBufferOf(DeviceState& dev, VkCommandBuffer cb) {
  auto it = dev.commandBuffers.find(cb);
  return it == dev.commandBuffers.end() ? nullptr : it->second.get();
}

namespace {

// What the stand-in driver was asked.
struct Created {
  VkShaderCreateInfoEXT info;
  std::vector<uint32_t> code;
  std::vector<VkDescriptorSetLayout> sets;
  VkShaderEXT handle;
};
struct Driver {
  uint64_t next = 0x100;
  std::vector<std::vector<Created>> createCalls;
  std::vector<uint64_t> destroyed;
  std::vector<std::vector<uint64_t>> bound;  // per vkCmdBindShadersEXT call, 0 for null
  std::vector<std::pair<uint64_t, uint32_t>> counterBinds;  // (layout, dynamic offset)
  std::vector<uint64_t> layoutsDestroyed;
} g_driver;

template <class T>
T handle(uint64_t value) {
  return reinterpret_cast<T>(uintptr_t(value));
}

VKAPI_ATTR VkResult VKAPI_CALL CreateShaders(VkDevice, uint32_t count, const VkShaderCreateInfoEXT* infos,
                                             const VkAllocationCallbacks*, VkShaderEXT* shaders) {
  std::vector<Created> call;
  for (uint32_t i = 0; i < count; ++i) {
    shaders[i] = handle<VkShaderEXT>(g_driver.next++);
    const auto* words = static_cast<const uint32_t*>(infos[i].pCode);
    call.push_back({infos[i], std::vector<uint32_t>(words, words + infos[i].codeSize / 4),
                    std::vector<VkDescriptorSetLayout>(infos[i].pSetLayouts,
                                                       infos[i].pSetLayouts + infos[i].setLayoutCount),
                    shaders[i]});
  }
  g_driver.createCalls.push_back(std::move(call));
  return VK_SUCCESS;
}
VKAPI_ATTR void VKAPI_CALL DestroyShader(VkDevice, VkShaderEXT shader, const VkAllocationCallbacks*) {
  g_driver.destroyed.push_back(reinterpret_cast<uint64_t>(shader));
}
VKAPI_ATTR void VKAPI_CALL BindShaders(VkCommandBuffer, uint32_t count, const VkShaderStageFlagBits*,
                                       const VkShaderEXT* shaders) {
  std::vector<uint64_t> call;
  for (uint32_t i = 0; i < count; ++i) call.push_back(shaders == nullptr ? 0 : reinterpret_cast<uint64_t>(shaders[i]));
  g_driver.bound.push_back(call);
}
VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL ProcAddr(VkDevice, const char* name) {
  const std::string n = name;
  if (n == "vkCreateShadersEXT") return reinterpret_cast<PFN_vkVoidFunction>(CreateShaders);
  if (n == "vkDestroyShaderEXT") return reinterpret_cast<PFN_vkVoidFunction>(DestroyShader);
  if (n == "vkCmdBindShadersEXT") return reinterpret_cast<PFN_vkVoidFunction>(BindShaders);
  return nullptr;
}
VKAPI_ATTR VkResult VKAPI_CALL CreateLayout(VkDevice, const VkPipelineLayoutCreateInfo*, const VkAllocationCallbacks*,
                                            VkPipelineLayout* layout) {
  *layout = handle<VkPipelineLayout>(g_driver.next++);
  return VK_SUCCESS;
}
VKAPI_ATTR void VKAPI_CALL DestroyLayout(VkDevice, VkPipelineLayout layout, const VkAllocationCallbacks*) {
  g_driver.layoutsDestroyed.push_back(reinterpret_cast<uint64_t>(layout));
}
VKAPI_ATTR void VKAPI_CALL BindSets(VkCommandBuffer, VkPipelineBindPoint, VkPipelineLayout layout, uint32_t first,
                                    uint32_t, const VkDescriptorSet*, uint32_t, const uint32_t* offsets) {
  EXPECT_EQ(first, 7u);
  g_driver.counterBinds.push_back({reinterpret_cast<uint64_t>(layout), offsets[0]});
}

const char* kVertex = R"(#version 450
layout(std430, set = 0, binding = 0) readonly buffer Positions { vec2 p[]; };
void main() { gl_Position = vec4(p[gl_VertexIndex], 0.0, 1.0); }
)";
const char* kFragment = R"(#version 450
layout(set = 0, binding = 1) uniform Tint { vec4 tint; };
layout(location = 0) out vec4 color;
void main() { color = tint; }
)";

class ShaderObjectCalls : public ::testing::Test {
 protected:
  void SetUp() override {
    g_driver = Driver{};
    dev.device = handle<VkDevice>(0x1);
    dev.counting = true;
    dev.config.output = "unused.json";  // a window ahead
    dev.fragmentStores = dev.vertexStores = true;
    dev.counterSet = 7;
    dev.instrumentOptions.set = 7;
    dev.regionRange = 1u << 20;
    dev.emptySetLayout = handle<VkDescriptorSetLayout>(0xE);
    dev.counterSetLayout = handle<VkDescriptorSetLayout>(0xC);
    dev.counterDescriptorSet = handle<VkDescriptorSet>(0xD);
    dev.d.GetDeviceProcAddr = ProcAddr;
    dev.d.CreatePipelineLayout = CreateLayout;
    dev.d.DestroyPipelineLayout = DestroyLayout;
    dev.d.CmdBindDescriptorSets = BindSets;
    g_device = &dev;
    create = reinterpret_cast<PFN_vkCreateShadersEXT>(interceptedShaderObjects("vkCreateShadersEXT"));
    destroy = reinterpret_cast<PFN_vkDestroyShaderEXT>(interceptedShaderObjects("vkDestroyShaderEXT"));
    bind = reinterpret_cast<PFN_vkCmdBindShadersEXT>(interceptedShaderObjects("vkCmdBindShadersEXT"));
    vertexWords = test::compileGlsl(kVertex, spirv::Stage::Vertex);
    fragmentWords = test::compileGlsl(kFragment, spirv::Stage::Fragment);
  }
  void TearDown() override { g_device = nullptr; }

  VkShaderCreateInfoEXT info(VkShaderStageFlagBits stage, const std::vector<uint32_t>& words) {
    VkShaderCreateInfoEXT i = {VK_STRUCTURE_TYPE_SHADER_CREATE_INFO_EXT};
    i.stage = stage;
    i.codeType = VK_SHADER_CODE_TYPE_SPIRV_EXT;
    i.codeSize = words.size() * 4;
    i.pCode = words.data();
    i.pName = "main";
    i.setLayoutCount = 1;
    i.pSetLayouts = &appSet;
    return i;
  }
  CommandBufferState& commandBuffer(uint64_t value, bool counted) {
    auto cb = std::make_unique<CommandBufferState>();
    cb->handle = handle<VkCommandBuffer>(value);
    cb->counted = counted;
    auto& out = *cb;
    dev.commandBuffers[cb->handle] = std::move(cb);
    return out;
  }
  // The application's vertex and fragment shaders, created apart.
  std::pair<VkShaderEXT, VkShaderEXT> vertexAndFragment() {
    VkShaderEXT v = VK_NULL_HANDLE, f = VK_NULL_HANDLE;
    const VkShaderCreateInfoEXT vi = info(VK_SHADER_STAGE_VERTEX_BIT, vertexWords);
    const VkShaderCreateInfoEXT fi = info(VK_SHADER_STAGE_FRAGMENT_BIT, fragmentWords);
    EXPECT_EQ(create(dev.device, 1, &vi, nullptr, &v), VK_SUCCESS);
    EXPECT_EQ(create(dev.device, 1, &fi, nullptr, &f), VK_SUCCESS);
    return {v, f};
  }
  const ShaderObject& object(VkShaderEXT shader) { return *dev.shaderObjects->shaders.at(u64(shader)); }

  DeviceState dev;
  VkDescriptorSetLayout appSet = handle<VkDescriptorSetLayout>(0xA);
  PFN_vkCreateShadersEXT create = nullptr;
  PFN_vkDestroyShaderEXT destroy = nullptr;
  PFN_vkCmdBindShadersEXT bind = nullptr;
  std::vector<uint32_t> vertexWords, fragmentWords;
};

TEST_F(ShaderObjectCalls, TheApplicationGetsItsOwnShaderAndATwinIsInstrumentedWithTheCounterSet) {
  VkShaderEXT v = VK_NULL_HANDLE;
  const VkShaderCreateInfoEXT vi = info(VK_SHADER_STAGE_VERTEX_BIT, vertexWords);
  ASSERT_EQ(create(dev.device, 1, &vi, nullptr, &v), VK_SUCCESS);
  ASSERT_EQ(g_driver.createCalls.size(), 2u);
  const Created& own = g_driver.createCalls[0][0];
  EXPECT_EQ(own.handle, v);
  EXPECT_EQ(own.code, vertexWords);
  EXPECT_EQ(own.sets, std::vector<VkDescriptorSetLayout>{appSet});
  const Created& twin = g_driver.createCalls[1][0];
  EXPECT_NE(twin.code, vertexWords);
  EXPECT_NE(test::disassemble(twin.code).find("DescriptorSet 7"), std::string::npos);
  EXPECT_EQ(twin.sets, (std::vector<VkDescriptorSetLayout>{appSet, dev.emptySetLayout, dev.emptySetLayout,
                                                           dev.emptySetLayout, dev.emptySetLayout, dev.emptySetLayout,
                                                           dev.emptySetLayout, dev.counterSetLayout}));
  EXPECT_EQ(object(v).twin, twin.handle);
  EXPECT_TRUE(object(v).counted.counted);
  EXPECT_NE(object(v).counted.layout, VkPipelineLayout(VK_NULL_HANDLE));
  ASSERT_EQ(dev.shaderReports.size(), 1u);
  EXPECT_EQ(dev.shaderReports[0]["instrumented"], true);
  EXPECT_EQ(dev.shaderReports[0]["stage"], "vertex");
}

TEST_F(ShaderObjectCalls, ABinaryShaderGetsNoTwinAndIsNoted) {
  VkShaderEXT b = VK_NULL_HANDLE;
  VkShaderCreateInfoEXT bi = info(VK_SHADER_STAGE_VERTEX_BIT, vertexWords);
  bi.codeType = VK_SHADER_CODE_TYPE_BINARY_EXT;
  ASSERT_EQ(create(dev.device, 1, &bi, nullptr, &b), VK_SUCCESS);
  EXPECT_EQ(g_driver.createCalls.size(), 1u);  // the application's only
  EXPECT_EQ(object(b).twin, VkShaderEXT(VK_NULL_HANDLE));
  ASSERT_EQ(dev.shaderReports.size(), 1u);
  EXPECT_EQ(dev.shaderReports[0]["instrumented"], false);
  EXPECT_NE(dev.shaderReports[0]["reason"].get<std::string>().find("VK_SHADER_CODE_TYPE_BINARY_EXT"),
            std::string::npos);
  ASSERT_EQ(dev.notes.size(), 1u);
  EXPECT_NE(dev.notes.begin()->find("VK_SHADER_CODE_TYPE_BINARY_EXT"), std::string::npos);
}

TEST_F(ShaderObjectCalls, LinkedShadersGetTheirTwinsInOneLinkedCall) {
  VkShaderCreateInfoEXT infos[2] = {info(VK_SHADER_STAGE_VERTEX_BIT, vertexWords),
                                    info(VK_SHADER_STAGE_FRAGMENT_BIT, fragmentWords)};
  for (auto& i : infos) i.flags = VK_SHADER_CREATE_LINK_STAGE_BIT_EXT;
  VkShaderEXT shaders[2] = {};
  ASSERT_EQ(create(dev.device, 2, infos, nullptr, shaders), VK_SUCCESS);
  ASSERT_EQ(g_driver.createCalls.size(), 2u);
  const auto& twins = g_driver.createCalls[1];
  ASSERT_EQ(twins.size(), 2u);
  for (const auto& t : twins) EXPECT_EQ(t.info.flags, VK_SHADER_CREATE_LINK_STAGE_BIT_EXT);
  EXPECT_EQ(object(shaders[0]).twin, twins[0].handle);
  EXPECT_EQ(object(shaders[1]).twin, twins[1].handle);
  EXPECT_EQ(object(shaders[0]).linkGroup, object(shaders[1]).linkGroup);
  EXPECT_EQ(object(shaders[1]).earlyTwin, VkShaderEXT(VK_NULL_HANDLE));  // bound with the others, never swapped
}

TEST_F(ShaderObjectCalls, CountingCommandBuffersBindTheTwinsAndTheCounterSetAtTheLowestBand) {
  const auto [v, f] = vertexAndFragment();
  EXPECT_NE(object(f).earlyTwin, VkShaderEXT(VK_NULL_HANDLE));
  CommandBufferState& cb = commandBuffer(0x50, true);
  const VkShaderStageFlagBits stages[5] = {VK_SHADER_STAGE_VERTEX_BIT, VK_SHADER_STAGE_TESSELLATION_CONTROL_BIT,
                                           VK_SHADER_STAGE_TESSELLATION_EVALUATION_BIT, VK_SHADER_STAGE_GEOMETRY_BIT,
                                           VK_SHADER_STAGE_FRAGMENT_BIT};
  const VkShaderEXT shaders[5] = {v, VK_NULL_HANDLE, VK_NULL_HANDLE, VK_NULL_HANDLE, f};
  bind(cb.handle, 5, stages, shaders);
  ASSERT_EQ(g_driver.bound.size(), 1u);
  EXPECT_EQ(g_driver.bound[0], (std::vector<uint64_t>{u64(object(v).twin), 0, 0, 0, u64(object(f).twin)}));
  EXPECT_EQ(cb.shaders[0], u64(v));
  EXPECT_EQ(cb.shaders[kFragmentShaderIndex], u64(f));
  const auto& pipeline = cb.bind[0].pipeline;
  ASSERT_TRUE(pipeline);
  EXPECT_EQ(pipeline->regionShift, VkDeviceSize(object(v).firstSlot) * 8);
  EXPECT_EQ(pipeline->sites.size(), object(v).counted.sites.size() + object(f).counted.sites.size());
  EXPECT_EQ(pipeline->layout, object(v).counted.layout);
  ASSERT_EQ(g_driver.counterBinds.size(), 1u);  // at the sink until a draw binds its region
  EXPECT_EQ(g_driver.counterBinds[0], std::make_pair(u64(object(v).counted.layout), 0u));
  // Binding the same shaders again gives the same combination (draws share regions).
  bind(cb.handle, 5, stages, shaders);
  EXPECT_EQ(cb.bind[0].pipeline, pipeline);
  // Alpha to coverage off: the early-tests twin; on again: the late one.
  cb.coverage.known = true;
  bindShadersForCoverage(dev, cb);
  EXPECT_EQ(g_driver.bound.back(), std::vector<uint64_t>{u64(object(f).earlyTwin)});
  cb.coverage.alphaToCoverage = true;
  bindShadersForCoverage(dev, cb);
  EXPECT_EQ(g_driver.bound.back(), std::vector<uint64_t>{u64(object(f).twin)});
  // A pipeline bound unbinds them; null shaders unbind their stages.
  unbindShaderObjects(cb, false);
  EXPECT_EQ(cb.shaders[0], 0u);
  bind(cb.handle, 5, stages, nullptr);
  EXPECT_EQ(cb.bind[0].pipeline, nullptr);
}

TEST_F(ShaderObjectCalls, OtherCommandBuffersBindTheApplicationsShaders) {
  const auto [v, f] = vertexAndFragment();
  CommandBufferState& cb = commandBuffer(0x60, false);
  const VkShaderStageFlagBits stages[2] = {VK_SHADER_STAGE_VERTEX_BIT, VK_SHADER_STAGE_FRAGMENT_BIT};
  const VkShaderEXT shaders[2] = {v, f};
  bind(cb.handle, 2, stages, shaders);
  EXPECT_EQ(g_driver.bound.back(), (std::vector<uint64_t>{u64(v), u64(f)}));
  EXPECT_EQ(cb.bind[0].pipeline, nullptr);
  EXPECT_TRUE(g_driver.counterBinds.empty());
  // Counting off (TALLY_LAYER_COUNTING=off): a counting command buffer runs them too.
  dev.config.counts = false;
  CommandBufferState& timed = commandBuffer(0x61, true);
  bind(timed.handle, 2, stages, shaders);
  EXPECT_EQ(g_driver.bound.back(), (std::vector<uint64_t>{u64(v), u64(f)}));
  EXPECT_EQ(timed.bind[0].pipeline, nullptr);
}

TEST_F(ShaderObjectCalls, DestroyingAShaderDestroysItsTwinsAndTheDeviceTheRest) {
  const auto [v, f] = vertexAndFragment();
  const ShaderObject fragment = object(f);
  const ShaderObject vertex = object(v);
  destroy(dev.device, f, nullptr);
  EXPECT_EQ(g_driver.destroyed, (std::vector<uint64_t>{u64(fragment.twin), u64(fragment.earlyTwin), u64(f)}));
  EXPECT_EQ(g_driver.layoutsDestroyed, std::vector<uint64_t>{u64(fragment.counted.layout)});
  EXPECT_EQ(dev.shaderObjects->shaders.count(u64(f)), 0u);
  destroyShaderObjects(dev);  // the application left the vertex shader
  EXPECT_EQ(g_driver.destroyed.back(), u64(vertex.twin));
  EXPECT_EQ(g_driver.layoutsDestroyed.back(), u64(vertex.counted.layout));
}

TEST_F(ShaderObjectCalls, NothingIsInstrumentedWithoutAWindowAhead) {
  dev.config.output.clear();
  VkShaderEXT v = VK_NULL_HANDLE;
  const VkShaderCreateInfoEXT vi = info(VK_SHADER_STAGE_VERTEX_BIT, vertexWords);
  ASSERT_EQ(create(dev.device, 1, &vi, nullptr, &v), VK_SUCCESS);
  EXPECT_EQ(g_driver.createCalls.size(), 1u);
  EXPECT_EQ(object(v).twin, VkShaderEXT(VK_NULL_HANDLE));
  EXPECT_TRUE(dev.shaderReports.empty());
}

}  // namespace
}  // namespace tally::layer
