// Descriptor layouts, sets, samplers, render passes and pipelines: the small
// amount of boilerplate every pass shares. Plain create/destroy functions.
#pragma once

#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

#include "gpu/context.hpp"

namespace tally::gpu {

VkDescriptorSetLayout createDescriptorSetLayout(const Context& ctx,
                                                std::span<const VkDescriptorSetLayoutBinding> bindings);
// Every set up to the counter set needs a layout: pass an empty layout
// (createDescriptorSetLayout with no bindings) for the unused ones.
VkPipelineLayout createPipelineLayout(const Context& ctx, std::span<const VkDescriptorSetLayout> setLayouts,
                                      uint32_t pushConstantBytes = 0,
                                      VkShaderStageFlags pushConstantStages = VK_SHADER_STAGE_ALL);

// A pool sized for `maxSets` sets holding the given descriptor counts in total.
VkDescriptorPool createDescriptorPool(const Context& ctx, uint32_t maxSets,
                                      std::span<const VkDescriptorPoolSize> sizes);
VkDescriptorSet allocateDescriptorSet(const Context& ctx, VkDescriptorPool pool,
                                      VkDescriptorSetLayout layout);

// One descriptor to write: an image (sampled, storage, combined) or a buffer.
struct DescriptorWrite {
  uint32_t binding = 0;
  VkDescriptorType type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  VkDescriptorImageInfo image = {};
  VkDescriptorBufferInfo buffer = {};
  uint32_t arrayElement = 0;
};
void updateDescriptorSet(const Context& ctx, VkDescriptorSet set, std::span<const DescriptorWrite> writes);

VkSampler createSampler(const Context& ctx, VkFilter filter = VK_FILTER_LINEAR,
                        VkSamplerAddressMode addressMode = VK_SAMPLER_ADDRESS_MODE_REPEAT);

// One subpass writing colour attachments (cleared on load, stored) and an
// optional depth/stencil attachment (VK_FORMAT_UNDEFINED: none). Colour
// attachments end in `colorFinalLayout`.
VkRenderPass createRenderPass(const Context& ctx, std::span<const VkFormat> colorFormats,
                              VkFormat depthFormat = VK_FORMAT_UNDEFINED,
                              VkImageLayout colorFinalLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
VkFramebuffer createFramebuffer(const Context& ctx, VkRenderPass renderPass,
                                std::span<const VkImageView> views, VkExtent2D extent);

struct GraphicsPipelineDesc {
  VkShaderModule vertex = VK_NULL_HANDLE;
  VkShaderModule fragment = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkRenderPass renderPass = VK_NULL_HANDLE;
  uint32_t subpass = 0;
  uint32_t colorAttachmentCount = 1;
  std::vector<VkVertexInputBindingDescription> vertexBindings;  // empty: no vertex buffers
  std::vector<VkVertexInputAttributeDescription> vertexAttributes;
  VkPrimitiveTopology topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  VkCullModeFlags cullMode = VK_CULL_MODE_NONE;
  // Cull mode as dynamic state (Vulkan 1.3 vkCmdSetCullMode): set per draw
  // (glTF doubleSided) while recording; cullMode is then only the initial value.
  bool dynamicCullMode = false;
  VkFrontFace frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
  bool depthTest = false;
  bool depthWrite = false;
  VkCompareOp depthCompare = VK_COMPARE_OP_GREATER_OR_EQUAL;  // reversed Z
  bool blend = false;  // premultiplied-alpha style src*1 + dst*(1-srcA) when true
  // Stencil, the same state for front and back faces. Off by default.
  bool stencilTest = false;
  VkCompareOp stencilCompare = VK_COMPARE_OP_ALWAYS;
  VkStencilOp stencilPassOp = VK_STENCIL_OP_KEEP;  // on stencil and depth pass
  uint32_t stencilReference = 0;
  uint32_t stencilWriteMask = 0;  // 0: the stencil is only tested
  VkSampleCountFlagBits samples = VK_SAMPLE_COUNT_1_BIT;  // rasterization samples (the render pass's)
};

// Viewport and scissor are dynamic state (set them when recording).
VkPipeline createGraphicsPipeline(const Context& ctx, const GraphicsPipelineDesc& desc);
VkPipeline createComputePipeline(const Context& ctx, VkShaderModule module, VkPipelineLayout layout);

// What the driver reports of one executable of a pipeline (a shader stage,
// as compiled) through VK_KHR_pipeline_executable_properties: its statistics
// by the driver's own names ("Register Count", ...), as numbers. Empty where
// the context has no pipelineExecutableInfo.
struct ExecutableStatistics {
  std::string stages;  // "vertex", "fragment", "compute", "vertex|fragment"
  std::string name;    // the driver's name for the executable
  std::map<std::string, double> values;
};
std::vector<ExecutableStatistics> executableStatistics(const Context& ctx, VkPipeline pipeline);

// Viewport and scissor covering `extent`.
void setViewportAndScissor(VkCommandBuffer cmd, VkExtent2D extent);

}  // namespace tally::gpu
