// The layer's own Vulkan objects (device_objects.cpp).
#pragma once

#include "state.hpp"

namespace tally::layer {

// A memory type among `bits` with `required`, `preferred` too where one has it; UINT32_MAX if none.
uint32_t memoryType(const DeviceState& dev, uint32_t bits, VkMemoryPropertyFlags required,
                    VkMemoryPropertyFlags preferred);
bool createBuffer(DeviceState& dev, VkDeviceSize size, VkBufferUsageFlags usage, VkMemoryPropertyFlags required,
                  VkMemoryPropertyFlags preferred, VkBuffer& buffer, VkDeviceMemory& memory);
VkCommandPool ownPool(DeviceState& dev, uint32_t family);  // the layer's pool on a queue family, made once
VkCommandBuffer ownCommandBuffer(DeviceState& dev, VkCommandPool pool);
void memoryBarrier(DeviceState& dev, VkCommandBuffer cmd, VkPipelineStageFlags src, VkAccessFlags srcAccess,
                   VkPipelineStageFlags dst, VkAccessFlags dstAccess);

}  // namespace tally::layer
