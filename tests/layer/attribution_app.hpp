// The Vulkan objects of attribution_app.cpp, made plainly: one device with
// dynamic rendering, multiview, dynamic vertex input, colour write enable and
// dynamic colour write masks; W x H images in GENERAL layout; one-subpass
// render passes; graphics pipelines drawing a triangle that covers the
// viewport.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include <vulkan/vulkan.h>

#include "spirv/sites.hpp"

namespace attribution {

constexpr uint32_t kWidth = 64, kHeight = 48;
constexpr VkImageLayout kGeneral = VK_IMAGE_LAYOUT_GENERAL;

void check(VkResult r, const char* what);

struct Image {
  VkImage image = VK_NULL_HANDLE;
  VkImageView view = VK_NULL_HANDLE;
};

struct App {
  VkInstance instance = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  VkQueue queue = VK_NULL_HANDLE;
  uint32_t family = 0;
  VkPhysicalDeviceMemoryProperties memory{};
  VkShaderModule vertex = VK_NULL_HANDLE;  // position (Location 0) and shade (Location 1), both R32G32_SFLOAT
  std::vector<std::pair<VkImage, VkImageAspectFlags>> images;  // every image, to move to GENERAL once
  PFN_vkSetDebugUtilsObjectNameEXT setName = nullptr;
  PFN_vkCmdBeginDebugUtilsLabelEXT beginLabel = nullptr;
  PFN_vkCmdEndDebugUtilsLabelEXT endLabel = nullptr;
  PFN_vkCmdSetVertexInputEXT setVertexInput = nullptr;
  PFN_vkCmdSetColorWriteEnableEXT setColorWriteEnable = nullptr;
  PFN_vkCmdSetColorWriteMaskEXT setColorWriteMask = nullptr;

  void name(VkObjectType type, uint64_t handle, const char* text) const;
  VkDeviceMemory allocate(VkMemoryRequirements req, VkMemoryPropertyFlags want) const;
  VkShaderModule shader(const char* source, tally::spirv::Stage stage) const;
  Image image(const char* label, VkFormat format, VkImageUsageFlags usage, uint32_t layers = 1);
  // Three vertices (position.xy, shade, padding: 16 bytes) of a triangle covering the viewport.
  VkBuffer vertexBuffer(const char* label) const;
  void label(VkCommandBuffer cmd, const char* text) const;
};

// Exits naming what the device lacks.
void createDevice(App& app);

// One subpass: `colors` by Location (VK_ATTACHMENT_UNUSED allowed) into the
// first formats, the last format the depth attachment where `depth`.
VkRenderPass renderPass(const App& app, const std::vector<VkFormat>& formats, const std::vector<uint32_t>& colors,
                        bool depth, uint32_t viewMask = 0);
VkFramebuffer framebuffer(const App& app, VkRenderPass pass, const std::vector<VkImageView>& views);

struct PipelineDesc {
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkRenderPass renderPass = VK_NULL_HANDLE;  // else dynamic rendering with `formats`
  std::vector<VkFormat> formats;             // dynamic rendering's colour formats
  std::vector<VkColorComponentFlags> masks;  // one per colour attachment
  bool depth = false;
  std::vector<VkDynamicState> dynamic;  // besides viewport and scissor
  VkShaderModule fragment = VK_NULL_HANDLE;
};
VkPipeline pipeline(const App& app, const PipelineDesc& desc);

// A resettable command pool of the app's queue family, a command buffer from it, an unsignalled fence.
VkCommandPool commandPool(const App& app);
VkCommandBuffer commandBuffer(const App& app, VkCommandPool pool, VkCommandBufferLevel level);
VkFence fence(const App& app);
// Submits `cmd` and waits for it.
void submit(const App& app, VkCommandBuffer cmd, VkFence fence);
// Every image to GENERAL, once (recorded into `cmd`, submitted, waited for).
void prepareImages(const App& app, VkCommandBuffer cmd, VkFence fence);

}  // namespace attribution
