// Names the layer gives what it reports: formats as the result schema spells
// them ("R16G16B16A16_SFLOAT"), usage flags, and the bytes of one element.
#pragma once

#include <cstdint>
#include <string>

#include <vulkan/vulkan.h>

namespace tally::layer {

// "R8G8B8A8_UNORM" (Vulkan-Hpp's name, in the enum's own spelling).
std::string formatName(VkFormat format);
// Bytes of one texel (of one block for compressed formats); 0 where unknown.
// `aspect`: the depth or stencil aspect alone of a combined format (a view's).
uint32_t formatBytes(VkFormat format, VkImageAspectFlags aspect = 0);
std::string imageUsageName(VkImageUsageFlags usage);
std::string bufferUsageName(VkBufferUsageFlags usage);
std::string hexHandle(uint64_t handle);

}  // namespace tally::layer
