// Buffers, images, one-shot command submission, upload and readback.
// Plain structs + free functions (niagara resources.h). Every Vulkan call is
// checked with VK_CHECK (throws VulkanError).
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include <vulkan/vulkan.h>

#include "gpu/context.hpp"

namespace tally::gpu {

struct Buffer {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkDeviceSize size = 0;
  void* mapped = nullptr;  // persistently mapped when host-visible, else null
  bool coherent = false;   // host-coherent memory: no flush/invalidate needed
};

struct Image {
  VkImage image = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkImageView view = VK_NULL_HANDLE;
  VkFormat format = VK_FORMAT_UNDEFINED;
  VkExtent2D extent = {};
  VkImageAspectFlags aspect = VK_IMAGE_ASPECT_COLOR_BIT;
};

enum class MemoryUse {
  DeviceLocal,  // GPU-only
  Upload,       // host-visible, written by the CPU (staging, uniforms)
  Readback,     // host-visible, read by the CPU (prefers host-cached)
  // Transient attachments: a LAZILY_ALLOCATED type where the image may take
  // one (tile-based GPUs back it with tile memory only), else device-local.
  Transient,
};

// A memory type allowed by typeBits with all `required` flags; `preferred`
// flags win ties. Throws VulkanError(VK_ERROR_OUT_OF_DEVICE_MEMORY) if none.
uint32_t selectMemoryType(const VkPhysicalDeviceMemoryProperties& properties, uint32_t typeBits,
                          VkMemoryPropertyFlags required, VkMemoryPropertyFlags preferred = 0);

Buffer createBuffer(const Context& ctx, VkDeviceSize size, VkBufferUsageFlags usage, MemoryUse use);
void destroyBuffer(const Context& ctx, Buffer& buffer);

// 2D, one mip level, one layer, optimal tiling, device-local, with a view
// (aspect derived from the format). Starts in VK_IMAGE_LAYOUT_UNDEFINED.
// `samples` > 1: a multisampled image (render targets; MSAA). `use`:
// DeviceLocal or Transient; `memoryFlags`, where given, gets the property
// flags of the memory type taken.
Image createImage(const Context& ctx, uint32_t width, uint32_t height, VkFormat format,
                  VkImageUsageFlags usage, VkSampleCountFlagBits samples = VK_SAMPLE_COUNT_1_BIT,
                  MemoryUse use = MemoryUse::DeviceLocal, VkMemoryPropertyFlags* memoryFlags = nullptr);
void destroyImage(const Context& ctx, Image& image);

// Records commands with `record`, submits them on ctx.queue and waits.
void submitAndWait(const Context& ctx, const std::function<void(VkCommandBuffer)>& record);

// Copies `data` into a temporary upload buffer, submits `record` (which copies
// from that buffer, passed in) and waits; the buffer is freed whatever happens.
void submitFromStaging(const Context& ctx, std::span<const uint8_t> data,
                       const std::function<void(VkCommandBuffer, VkBuffer)>& record);
// Submits `record` (which copies `size` bytes into a temporary readback
// buffer, passed in), waits and returns those bytes; the buffer is freed
// whatever happens.
std::vector<uint8_t> submitToStaging(const Context& ctx, VkDeviceSize size,
                                     const std::function<void(VkCommandBuffer, VkBuffer)>& record);

// A full-resource layout transition with conservative ALL_COMMANDS barriers;
// for setup and readback paths, not for per-pass synchronisation.
void transitionImage(VkCommandBuffer cmd, const Image& image, VkImageLayout from, VkImageLayout to);

// Host <-> buffer. Host-visible buffers are written/read through the mapping;
// device-local ones through a temporary staging buffer.
void uploadBuffer(const Context& ctx, const Buffer& buffer, std::span<const uint8_t> data,
                  VkDeviceSize offset = 0);
std::vector<uint8_t> readBuffer(const Context& ctx, const Buffer& buffer, VkDeviceSize offset = 0,
                                VkDeviceSize size = VK_WHOLE_SIZE);
// Fills `size` bytes from `offset` with the 32-bit `word` repeated
// (vkCmdFillBuffer), then waits; zeroBuffer fills with zero.
void fillBuffer(const Context& ctx, const Buffer& buffer, uint32_t word, VkDeviceSize offset = 0,
                VkDeviceSize size = VK_WHOLE_SIZE);
void zeroBuffer(const Context& ctx, const Buffer& buffer, VkDeviceSize offset = 0,
                VkDeviceSize size = VK_WHOLE_SIZE);

// Tightly packed texels of the whole image (width * height * texel bytes).
// Upload leaves the image in `finalLayout`; readback expects `currentLayout`
// and leaves it there.
void uploadImage(const Context& ctx, const Image& image, std::span<const uint8_t> texels,
                 VkImageLayout finalLayout);
std::vector<uint8_t> readImage(const Context& ctx, const Image& image, VkImageLayout currentLayout);

// Bytes per texel of an uncompressed colour or depth format; 0 for formats
// this table does not know (block-compressed, multi-planar).
uint32_t formatBytes(VkFormat format);

}  // namespace tally::gpu
