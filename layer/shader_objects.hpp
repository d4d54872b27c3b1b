// Shader objects (VK_EXT_shader_object), counted as shader modules are
// (docs/layer.md, "Shader objects"). Each SPIR-V shader the application
// creates gets a twin: the same create info with the stage instrumented and
// the counter set appended to its set layouts. The application's handle is
// its own shader; the twin is bound in its place only in command buffers
// recorded for counting. The shaders bound at a draw make up its
// "pipeline": their sites, in one region of the counter buffer.
//
// Slots: unlinked shaders of different stages may be bound in any
// combination, so a shader's slots cannot depend on the others'. Each stage
// counts in a band of its own (slotBand), fragment shaders last and without a
// bound of their own; a draw's region spans the bands of the stages bound,
// and the counter set is bound that many bytes before it (regionShift).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

#include "shader_object_api.hpp"
#include "state.hpp"

namespace tally::layer {

// CommandBufferState::shaders, by stage: vertex, tessellation control and
// evaluation, geometry, fragment, task, mesh, compute. -1: not a shader stage.
int shaderStageIndex(VkShaderStageFlagBits stage);
constexpr size_t kFragmentShaderIndex = 4, kComputeShaderIndex = 7;
spirv::Stage shaderStage(VkShaderStageFlagBits stage);

// The slots a stage's shader objects count in: [first, limit).
struct SlotBand {
  uint32_t first = 0, limit = 0;
};
// Pre-rasterization stages hold 512 slots each (4 KiB of a region): a
// vertex shader and a fragment shader, the usual pair, span 4 KiB more than
// their slots. Vertex and mesh shaders share a band (they are never bound
// together), as do tessellation control and task shaders.
constexpr uint32_t kShaderBandSlots = 512;
SlotBand slotBand(VkShaderStageFlagBits stage, uint32_t maxSlots);

// Why a shader object cannot be instrumented ("" where it can): binary code,
// a stage the device cannot store from, or set layouts that reach the
// layer's counter set.
std::string shaderRefusal(const VkShaderCreateInfoEXT& info, uint32_t counterSet, bool fragmentStores,
                          bool vertexStores);

// The twin's set layouts: the application's, then `empty` up to the counter
// set, then `counter` (as pipeline layouts are extended, pipelines.cpp).
std::vector<VkDescriptorSetLayout> twinSetLayouts(const VkShaderCreateInfoEXT& info, uint32_t counterSet,
                                                  VkDescriptorSetLayout empty, VkDescriptorSetLayout counter);

struct ShaderObject {
  uint64_t handle = 0;           // the application's shader, created as it asked
  VkShaderEXT twin = VK_NULL_HANDLE;  // instrumented; null where the shader is not counted
  // Fragment shaders: the twin with early tests, bound in its place while
  // alpha to coverage is off (bindShadersForCoverage). Null where the
  // shader cannot have them, or was created linked.
  VkShaderEXT earlyTwin = VK_NULL_HANDLE;
  VkShaderStageFlagBits stage = VK_SHADER_STAGE_VERTEX_BIT;
  // Its sites and fold layouts, slots absolute (in the stage's band), and
  // the layout through which the counter set is bound (the twin's set
  // layouts and the application's push constant ranges).
  PipelineInfo counted;
  uint32_t firstSlot = 0;
  uint64_t linkGroup = 0;  // shaders created linked (VK_SHADER_CREATE_LINK_STAGE_BIT_EXT): their call's number
};

// Instruments a shader object's SPIR-V with the device's `options` in its
// stage's band, filling `object` (sites named `name`) and `out` (the twin's
// code, late fragment tests), or gives the reason it cannot be counted (""
// where it can). `early`, where given, gets a fragment shader's copy with
// early tests (same sites, same slots) where the shader may have them.
std::string instrumentShaderObject(const std::vector<uint32_t>& words, spirv::InstrumentOptions options,
                                   uint32_t maxSlots, const std::string& name, ShaderObject& object,
                                   std::vector<uint32_t>& out, std::vector<std::string>& notes,
                                   std::vector<uint32_t>* early = nullptr);

// The "pipeline" of the shaders bound at one bind point: the counted ones'
// sites with slots relative to the region (shifted by the lowest band
// bound), the regionShift that undoes it, every state a shader object
// leaves to dynamic state read from the command buffer, and the layout of
// the first counted shader. Null when none is counted.
std::shared_ptr<PipelineInfo> combineShaders(const std::vector<const ShaderObject*>& bound);

// The device's shader objects.
struct ShaderObjects {
  PFN_vkCreateShadersEXT create = nullptr;
  PFN_vkDestroyShaderEXT destroy = nullptr;
  PFN_vkCmdBindShadersEXT bind = nullptr;
  std::map<uint64_t, std::shared_ptr<ShaderObject>> shaders;
  // Combinations seen bound, by their shaders (0 where a stage has none):
  // the same combination keeps one identity, so draws share regions.
  std::map<std::array<uint64_t, kComputeShaderIndex + 1>, std::shared_ptr<PipelineInfo>> combinations;
  uint64_t nextLinkGroup = 1;
  uint32_t created = 0, counted = 0;
};

// vkCmdBindPipeline: a pipeline replaces the shader objects bound at its bind
// point (graphics: every graphics stage).
void unbindShaderObjects(CommandBufferState& cb, bool compute);

// Before a draw, and where alpha to coverage is set: the bound fragment
// shader's early-tests twin while alpha to coverage is off, its late-tests
// twin otherwise. Under the device's mutex.
void bindShadersForCoverage(DeviceState& dev, CommandBufferState& cb);

// vkDestroyDevice: the twins and layouts of shader objects the application
// left undestroyed, so that the layer leaks nothing of its own.
void destroyShaderObjects(DeviceState& dev);

}  // namespace tally::layer
