#include "gpu/resources.hpp"

#include <cstring>

#include "gpu/vk_check.hpp"

namespace tally::gpu {
namespace {

bool isDepthFormat(VkFormat format) {
  switch (format) {
    case VK_FORMAT_D16_UNORM:
    case VK_FORMAT_X8_D24_UNORM_PACK32:
    case VK_FORMAT_D32_SFLOAT:
    case VK_FORMAT_D16_UNORM_S8_UINT:
    case VK_FORMAT_D24_UNORM_S8_UINT:
    case VK_FORMAT_D32_SFLOAT_S8_UINT: return true;
    default: return false;
  }
}

bool hasStencil(VkFormat format) {
  return format == VK_FORMAT_D16_UNORM_S8_UINT || format == VK_FORMAT_D24_UNORM_S8_UINT ||
         format == VK_FORMAT_D32_SFLOAT_S8_UINT || format == VK_FORMAT_S8_UINT;
}

VkImageAspectFlags aspectOf(VkFormat format) {
  if (format == VK_FORMAT_S8_UINT) return VK_IMAGE_ASPECT_STENCIL_BIT;
  if (!isDepthFormat(format)) return VK_IMAGE_ASPECT_COLOR_BIT;
  return hasStencil(format) ? (VK_IMAGE_ASPECT_DEPTH_BIT | VK_IMAGE_ASPECT_STENCIL_BIT)
                            : VK_IMAGE_ASPECT_DEPTH_BIT;
}

VkDeviceMemory allocate(const Context& ctx, const VkMemoryRequirements& requirements, MemoryUse use,
                        bool deviceAddress, bool* coherent, VkMemoryPropertyFlags* memoryFlags = nullptr) {
  VkMemoryPropertyFlags required = 0;
  VkMemoryPropertyFlags preferred = 0;
  uint32_t lazy = ~0u;
  switch (use) {
    case MemoryUse::DeviceLocal: preferred = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT; break;
    case MemoryUse::Transient:
      preferred = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
      for (uint32_t i = 0; i < ctx.memoryProperties.memoryTypeCount && lazy == ~0u; ++i) {
        if ((requirements.memoryTypeBits & (1u << i)) != 0 &&
            (ctx.memoryProperties.memoryTypes[i].propertyFlags & VK_MEMORY_PROPERTY_LAZILY_ALLOCATED_BIT) != 0) {
          lazy = i;
        }
      }
      break;
    case MemoryUse::Upload:
      required = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
      break;
    case MemoryUse::Readback:
      required = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT;
      preferred = VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
      break;
  }
  uint32_t type = lazy != ~0u ? lazy
                              : selectMemoryType(ctx.memoryProperties, requirements.memoryTypeBits, required, preferred);
  if (memoryFlags != nullptr) *memoryFlags = ctx.memoryProperties.memoryTypes[type].propertyFlags;
  if (coherent != nullptr) {
    *coherent =
        (ctx.memoryProperties.memoryTypes[type].propertyFlags & VK_MEMORY_PROPERTY_HOST_COHERENT_BIT) != 0;
  }
  VkMemoryAllocateInfo info = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  info.allocationSize = requirements.size;
  info.memoryTypeIndex = type;
  VkMemoryAllocateFlagsInfo flags = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_FLAGS_INFO};
  if (deviceAddress) {
    flags.flags = VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT;
    info.pNext = &flags;
  }
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VK_CHECK(vkAllocateMemory(ctx.device, &info, nullptr, &memory));
  return memory;
}

void invalidate(const Context& ctx, const Buffer& buffer) {
  if (buffer.coherent || buffer.mapped == nullptr) return;
  VkMappedMemoryRange range = {VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE};
  range.memory = buffer.memory;
  range.size = VK_WHOLE_SIZE;
  VK_CHECK(vkInvalidateMappedMemoryRanges(ctx.device, 1, &range));
}

void flush(const Context& ctx, const Buffer& buffer) {
  if (buffer.coherent || buffer.mapped == nullptr) return;
  VkMappedMemoryRange range = {VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE};
  range.memory = buffer.memory;
  range.size = VK_WHOLE_SIZE;
  VK_CHECK(vkFlushMappedMemoryRanges(ctx.device, 1, &range));
}

// Everything before is visible to everything after; fine for setup and readback.
// Buffer<->image copies of depth/stencil images move the depth aspect only.
VkImageAspectFlags copyAspect(const Image& image) {
  if (image.aspect & VK_IMAGE_ASPECT_DEPTH_BIT) return VK_IMAGE_ASPECT_DEPTH_BIT;
  return image.aspect;
}

// Bytes per texel of a buffer<->image copy of the aspect readImage/uploadImage use.
VkDeviceSize copyTexelBytes(const Image& image) {
  uint32_t bytes = formatBytes(image.format);
  if (image.aspect & VK_IMAGE_ASPECT_DEPTH_BIT) {
    bytes = (image.format == VK_FORMAT_D16_UNORM || image.format == VK_FORMAT_D16_UNORM_S8_UINT) ? 2 : 4;
  }
  if (bytes == 0) {
    throwVulkanError(VK_ERROR_FORMAT_NOT_SUPPORTED, "image copy (texel size of this format unknown)",
                     __FILE__, __LINE__);
  }
  return bytes;
}

void fullBarrier(VkCommandBuffer cmd) {
  VkMemoryBarrier barrier = {VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  barrier.srcAccessMask = VK_ACCESS_MEMORY_WRITE_BIT;
  barrier.dstAccessMask = VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT;
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, 0, 1,
                       &barrier, 0, nullptr, 0, nullptr);
}

}  // namespace

uint32_t selectMemoryType(const VkPhysicalDeviceMemoryProperties& properties, uint32_t typeBits,
                          VkMemoryPropertyFlags required, VkMemoryPropertyFlags preferred) {
  int fallback = -1;
  for (uint32_t i = 0; i < properties.memoryTypeCount; ++i) {
    if ((typeBits & (1u << i)) == 0) continue;
    VkMemoryPropertyFlags flags = properties.memoryTypes[i].propertyFlags;
    if ((flags & required) != required) continue;
    if ((flags & preferred) == preferred) return i;
    if (fallback < 0) fallback = static_cast<int>(i);
  }
  if (fallback < 0) {
    throwVulkanError(VK_ERROR_OUT_OF_DEVICE_MEMORY,
                     "selectMemoryType (no memory type with the required flags)", __FILE__, __LINE__);
  }
  return static_cast<uint32_t>(fallback);
}

Buffer createBuffer(const Context& ctx, VkDeviceSize size, VkBufferUsageFlags usage, MemoryUse use) {
  if (size == 0) {
    // Vulkan forbids empty buffers; some drivers crash instead of failing.
    throwVulkanError(VK_ERROR_UNKNOWN, "createBuffer (size 0)", __FILE__, __LINE__);
  }
  Buffer result;
  result.size = size;
  VkBufferCreateInfo info = {VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  info.size = size;
  info.usage = usage;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  VK_CHECK(vkCreateBuffer(ctx.device, &info, nullptr, &result.buffer));
  ctx.log->buffer(result.buffer, size);
  try {
    VkMemoryRequirements requirements;
    vkGetBufferMemoryRequirements(ctx.device, result.buffer, &requirements);
    bool deviceAddress = (usage & VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT) != 0;
    result.memory = allocate(ctx, requirements, use, deviceAddress, &result.coherent);
    VK_CHECK(vkBindBufferMemory(ctx.device, result.buffer, result.memory, 0));
    if (use != MemoryUse::DeviceLocal)
      VK_CHECK(vkMapMemory(ctx.device, result.memory, 0, VK_WHOLE_SIZE, 0, &result.mapped));
  } catch (...) {
    destroyBuffer(ctx, result);
    throw;
  }
  return result;
}

void destroyBuffer(const Context& ctx, Buffer& buffer) {
  if (buffer.buffer != VK_NULL_HANDLE) vkDestroyBuffer(ctx.device, buffer.buffer, nullptr);
  if (buffer.memory != VK_NULL_HANDLE) vkFreeMemory(ctx.device, buffer.memory, nullptr);  // unmaps too
  buffer = Buffer{};
}

Image createImage(const Context& ctx, uint32_t width, uint32_t height, VkFormat format,
                  VkImageUsageFlags usage, VkSampleCountFlagBits samples, MemoryUse use,
                  VkMemoryPropertyFlags* memoryFlags) {
  Image result;
  result.format = format;
  result.extent = {width, height};
  result.aspect = aspectOf(format);
  VkImageCreateInfo info = {VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  info.imageType = VK_IMAGE_TYPE_2D;
  info.format = format;
  info.extent = {width, height, 1};
  info.mipLevels = 1;
  info.arrayLayers = 1;
  info.samples = samples;
  info.tiling = VK_IMAGE_TILING_OPTIMAL;
  info.usage = usage;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  VK_CHECK(vkCreateImage(ctx.device, &info, nullptr, &result.image));
  try {
    VkMemoryRequirements requirements;
    vkGetImageMemoryRequirements(ctx.device, result.image, &requirements);
    result.memory = allocate(ctx, requirements, use, false, nullptr, memoryFlags);
    VK_CHECK(vkBindImageMemory(ctx.device, result.image, result.memory, 0));

    VkImageViewCreateInfo viewInfo = {VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    viewInfo.image = result.image;
    viewInfo.viewType = VK_IMAGE_VIEW_TYPE_2D;
    viewInfo.format = format;
    viewInfo.subresourceRange = {result.aspect, 0, 1, 0, 1};
    VK_CHECK(vkCreateImageView(ctx.device, &viewInfo, nullptr, &result.view));
    ctx.log->view(result.view, info, viewInfo);
  } catch (...) {
    destroyImage(ctx, result);
    throw;
  }
  return result;
}

void destroyImage(const Context& ctx, Image& image) {
  if (image.view != VK_NULL_HANDLE) vkDestroyImageView(ctx.device, image.view, nullptr);
  if (image.image != VK_NULL_HANDLE) vkDestroyImage(ctx.device, image.image, nullptr);
  if (image.memory != VK_NULL_HANDLE) vkFreeMemory(ctx.device, image.memory, nullptr);
  image = Image{};
}

void submitAndWait(const Context& ctx, const std::function<void(VkCommandBuffer)>& record) {
  VkCommandBufferAllocateInfo allocInfo = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  allocInfo.commandPool = ctx.commandPool;
  allocInfo.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  allocInfo.commandBufferCount = 1;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  VK_CHECK(vkAllocateCommandBuffers(ctx.device, &allocInfo, &cmd));
  VkFence fence = VK_NULL_HANDLE;
  try {
    VkCommandBufferBeginInfo begin = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    VK_CHECK(vkBeginCommandBuffer(cmd, &begin));
    record(cmd);
    VK_CHECK(vkEndCommandBuffer(cmd));

    VkFenceCreateInfo fenceInfo = {VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    VK_CHECK(vkCreateFence(ctx.device, &fenceInfo, nullptr, &fence));
    VkSubmitInfo submit = {VK_STRUCTURE_TYPE_SUBMIT_INFO};
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &cmd;
    VK_CHECK(vkQueueSubmit(ctx.queue, 1, &submit, fence));
    VK_CHECK(vkWaitForFences(ctx.device, 1, &fence, VK_TRUE, UINT64_MAX));
  } catch (...) {
    // Never free a command buffer the device may still run.
    if (fence != VK_NULL_HANDLE) {
      vkDeviceWaitIdle(ctx.device);
      vkDestroyFence(ctx.device, fence, nullptr);
    }
    vkFreeCommandBuffers(ctx.device, ctx.commandPool, 1, &cmd);
    throw;
  }
  vkDestroyFence(ctx.device, fence, nullptr);
  vkFreeCommandBuffers(ctx.device, ctx.commandPool, 1, &cmd);
}

void transitionImage(VkCommandBuffer cmd, const Image& image, VkImageLayout from, VkImageLayout to) {
  VkImageMemoryBarrier barrier = {VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER};
  barrier.srcAccessMask = VK_ACCESS_MEMORY_WRITE_BIT;
  barrier.dstAccessMask = VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT;
  barrier.oldLayout = from;
  barrier.newLayout = to;
  barrier.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  barrier.image = image.image;
  barrier.subresourceRange = {image.aspect, 0, 1, 0, 1};
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, 0, 0,
                       nullptr, 0, nullptr, 1, &barrier);
}

namespace {

// A temporary host-visible buffer, freed however the work that uses it ends.
struct StagingBuffer {
  const Context& ctx;
  Buffer buffer;
  StagingBuffer(const Context& c, VkDeviceSize size, VkBufferUsageFlags usage, MemoryUse use)
      : ctx(c), buffer(createBuffer(c, size, usage, use)) {}
  ~StagingBuffer() { destroyBuffer(ctx, buffer); }
  StagingBuffer(const StagingBuffer&) = delete;
  StagingBuffer& operator=(const StagingBuffer&) = delete;
};

}  // namespace

void submitFromStaging(const Context& ctx, std::span<const uint8_t> data,
                       const std::function<void(VkCommandBuffer, VkBuffer)>& record) {
  StagingBuffer staging(ctx, data.size(), VK_BUFFER_USAGE_TRANSFER_SRC_BIT, MemoryUse::Upload);
  std::memcpy(staging.buffer.mapped, data.data(), data.size());
  flush(ctx, staging.buffer);
  submitAndWait(ctx, [&](VkCommandBuffer cmd) { record(cmd, staging.buffer.buffer); });
}

std::vector<uint8_t> submitToStaging(const Context& ctx, VkDeviceSize size,
                                     const std::function<void(VkCommandBuffer, VkBuffer)>& record) {
  StagingBuffer staging(ctx, size, VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUse::Readback);
  submitAndWait(ctx, [&](VkCommandBuffer cmd) { record(cmd, staging.buffer.buffer); });
  invalidate(ctx, staging.buffer);
  std::vector<uint8_t> out(size);
  std::memcpy(out.data(), staging.buffer.mapped, size);
  return out;
}

void uploadBuffer(const Context& ctx, const Buffer& buffer, std::span<const uint8_t> data,
                  VkDeviceSize offset) {
  if (data.empty()) return;
  if (offset + data.size() > buffer.size) {
    throwVulkanError(VK_ERROR_UNKNOWN, "uploadBuffer (data past the end of the buffer)", __FILE__, __LINE__);
  }
  if (buffer.mapped != nullptr) {
    std::memcpy(static_cast<uint8_t*>(buffer.mapped) + offset, data.data(), data.size());
    flush(ctx, buffer);
    return;
  }
  submitFromStaging(ctx, data, [&](VkCommandBuffer cmd, VkBuffer staging) {
    VkBufferCopy region = {0, offset, data.size()};
    vkCmdCopyBuffer(cmd, staging, buffer.buffer, 1, &region);
    fullBarrier(cmd);
  });
}

std::vector<uint8_t> readBuffer(const Context& ctx, const Buffer& buffer, VkDeviceSize offset,
                                VkDeviceSize size) {
  if (size == VK_WHOLE_SIZE) size = buffer.size - offset;
  if (offset + size > buffer.size) {
    throwVulkanError(VK_ERROR_UNKNOWN, "readBuffer (range past the end of the buffer)", __FILE__, __LINE__);
  }
  std::vector<uint8_t> out(size);
  if (size == 0) return out;
  if (buffer.mapped != nullptr) {
    invalidate(ctx, buffer);
    std::memcpy(out.data(), static_cast<const uint8_t*>(buffer.mapped) + offset, size);
    return out;
  }
  return submitToStaging(ctx, size, [&](VkCommandBuffer cmd, VkBuffer staging) {
    fullBarrier(cmd);
    VkBufferCopy region = {offset, 0, size};
    vkCmdCopyBuffer(cmd, buffer.buffer, staging, 1, &region);
    fullBarrier(cmd);
  });
}

void fillBuffer(const Context& ctx, const Buffer& buffer, uint32_t word, VkDeviceSize offset, VkDeviceSize size) {
  submitAndWait(ctx, [&](VkCommandBuffer cmd) {
    fullBarrier(cmd);
    vkCmdFillBuffer(cmd, buffer.buffer, offset, size, word);
    fullBarrier(cmd);
  });
}

void zeroBuffer(const Context& ctx, const Buffer& buffer, VkDeviceSize offset, VkDeviceSize size) {
  fillBuffer(ctx, buffer, 0, offset, size);
}

void uploadImage(const Context& ctx, const Image& image, std::span<const uint8_t> texels,
                 VkImageLayout finalLayout) {
  VkDeviceSize expected = VkDeviceSize(image.extent.width) * image.extent.height * copyTexelBytes(image);
  if (texels.size() != expected) {
    throwVulkanError(VK_ERROR_UNKNOWN, "uploadImage (texel data size does not match the image)", __FILE__,
                     __LINE__);
  }
  submitFromStaging(ctx, texels, [&](VkCommandBuffer cmd, VkBuffer staging) {
    transitionImage(cmd, image, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
    VkBufferImageCopy region = {};
    region.imageSubresource = {copyAspect(image), 0, 0, 1};
    region.imageExtent = {image.extent.width, image.extent.height, 1};
    vkCmdCopyBufferToImage(cmd, staging, image.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    transitionImage(cmd, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, finalLayout);
  });
}

std::vector<uint8_t> readImage(const Context& ctx, const Image& image, VkImageLayout currentLayout) {
  VkDeviceSize size = VkDeviceSize(image.extent.width) * image.extent.height * copyTexelBytes(image);
  return submitToStaging(ctx, size, [&](VkCommandBuffer cmd, VkBuffer staging) {
    transitionImage(cmd, image, currentLayout, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    VkBufferImageCopy region = {};
    region.imageSubresource = {copyAspect(image), 0, 0, 1};
    region.imageExtent = {image.extent.width, image.extent.height, 1};
    vkCmdCopyImageToBuffer(cmd, image.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, staging, 1, &region);
    transitionImage(cmd, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, currentLayout);
    fullBarrier(cmd);
  });
}

uint32_t formatBytes(VkFormat format) {
  switch (format) {
    case VK_FORMAT_R8_UNORM:
    case VK_FORMAT_R8_SNORM:
    case VK_FORMAT_R8_UINT:
    case VK_FORMAT_R8_SINT:
    case VK_FORMAT_R8_SRGB:
    case VK_FORMAT_S8_UINT: return 1;
    case VK_FORMAT_R8G8_UNORM:
    case VK_FORMAT_R8G8_SNORM:
    case VK_FORMAT_R8G8_UINT:
    case VK_FORMAT_R8G8_SINT:
    case VK_FORMAT_R16_UNORM:
    case VK_FORMAT_R16_SFLOAT:
    case VK_FORMAT_R16_UINT:
    case VK_FORMAT_R16_SINT:
    case VK_FORMAT_D16_UNORM:
    case VK_FORMAT_R5G6B5_UNORM_PACK16: return 2;
    case VK_FORMAT_R8G8B8_UNORM:
    case VK_FORMAT_R8G8B8_SRGB:
    case VK_FORMAT_D16_UNORM_S8_UINT: return 3;  // D16_S8: copies are per aspect; 3 is the packed size
    case VK_FORMAT_R8G8B8A8_UNORM:
    case VK_FORMAT_R8G8B8A8_SNORM:
    case VK_FORMAT_R8G8B8A8_UINT:
    case VK_FORMAT_R8G8B8A8_SINT:
    case VK_FORMAT_R8G8B8A8_SRGB:
    case VK_FORMAT_B8G8R8A8_UNORM:
    case VK_FORMAT_B8G8R8A8_SRGB:
    case VK_FORMAT_A2B10G10R10_UNORM_PACK32:
    case VK_FORMAT_A2R10G10B10_UNORM_PACK32:
    case VK_FORMAT_B10G11R11_UFLOAT_PACK32:
    case VK_FORMAT_E5B9G9R9_UFLOAT_PACK32:
    case VK_FORMAT_R16G16_UNORM:
    case VK_FORMAT_R16G16_SFLOAT:
    case VK_FORMAT_R16G16_UINT:
    case VK_FORMAT_R16G16_SINT:
    case VK_FORMAT_R32_SFLOAT:
    case VK_FORMAT_R32_UINT:
    case VK_FORMAT_R32_SINT:
    case VK_FORMAT_D32_SFLOAT:
    case VK_FORMAT_X8_D24_UNORM_PACK32:
    case VK_FORMAT_D24_UNORM_S8_UINT: return 4;
    case VK_FORMAT_D32_SFLOAT_S8_UINT: return 5;  // 4 depth + 1 stencil, copied per aspect
    case VK_FORMAT_R16G16B16A16_UNORM:
    case VK_FORMAT_R16G16B16A16_SFLOAT:
    case VK_FORMAT_R16G16B16A16_UINT:
    case VK_FORMAT_R16G16B16A16_SINT:
    case VK_FORMAT_R32G32_SFLOAT:
    case VK_FORMAT_R32G32_UINT:
    case VK_FORMAT_R32G32_SINT: return 8;
    case VK_FORMAT_R32G32B32_SFLOAT:
    case VK_FORMAT_R32G32B32_UINT: return 12;
    case VK_FORMAT_R32G32B32A32_SFLOAT:
    case VK_FORMAT_R32G32B32A32_UINT:
    case VK_FORMAT_R32G32B32A32_SINT: return 16;
    default: return 0;
  }
}

}  // namespace tally::gpu
