#include "names.hpp"

#include <cctype>
#include <cstdio>

#define VULKAN_HPP_NO_EXCEPTIONS
#define VULKAN_HPP_DISPATCH_LOADER_DYNAMIC 0
#include <vulkan/vulkan.hpp>
#include <vulkan/vulkan_format_traits.hpp>
#include <vulkan/vulkan_to_string.hpp>

namespace tally::layer {

std::string formatName(VkFormat format) {
  // Vulkan-Hpp spells eR16G16B16A16Sfloat "R16G16B16A16Sfloat": a word starts
  // at an upper-case letter followed by a lower-case one, or after a lower-case
  // letter (S8 in D32SfloatS8Uint, 32 in Pack32).
  const std::string camel = vk::to_string(static_cast<vk::Format>(format));
  if (camel.find("invalid") != std::string::npos) return "VkFormat " + std::to_string(int(format));
  std::string out;
  for (size_t i = 0; i < camel.size(); ++i) {
    const char c = camel[i];
    const bool afterLower = i > 0 && std::islower(static_cast<unsigned char>(camel[i - 1]));
    const bool wordStart = std::isupper(static_cast<unsigned char>(c)) && i + 1 < camel.size() &&
                           std::islower(static_cast<unsigned char>(camel[i + 1]));
    if (i > 0 && (wordStart || afterLower) && !std::islower(static_cast<unsigned char>(c))) out += '_';
    out += char(std::toupper(static_cast<unsigned char>(c)));
  }
  return out;
}

uint32_t formatBytes(VkFormat format, VkImageAspectFlags aspect) {
  const bool depthOnly = aspect == VK_IMAGE_ASPECT_DEPTH_BIT, stencilOnly = aspect == VK_IMAGE_ASPECT_STENCIL_BIT;
  switch (format) {
    case VK_FORMAT_D32_SFLOAT_S8_UINT: return depthOnly ? 4 : stencilOnly ? 1 : 5;
    case VK_FORMAT_D24_UNORM_S8_UINT: return depthOnly ? 4 : stencilOnly ? 1 : 4;
    case VK_FORMAT_D16_UNORM_S8_UINT: return depthOnly ? 2 : stencilOnly ? 1 : 3;
    default: break;
  }
  if (format == VK_FORMAT_UNDEFINED) return 0;
  return vk::blockSize(static_cast<vk::Format>(format));
}

namespace {
template <class Flags>
std::string flagNames(Flags flags, std::initializer_list<std::pair<Flags, const char*>> names) {
  std::string out;
  for (const auto& [bit, name] : names) {
    if (flags & bit) out += (out.empty() ? "" : "|") + std::string(name);
  }
  return out;
}
}  // namespace

std::string imageUsageName(VkImageUsageFlags usage) {
  return flagNames<VkImageUsageFlags>(usage, {{VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT, "color_attachment"},
                                              {VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, "depth_stencil_attachment"},
                                              {VK_IMAGE_USAGE_SAMPLED_BIT, "sampled"},
                                              {VK_IMAGE_USAGE_STORAGE_BIT, "storage"},
                                              {VK_IMAGE_USAGE_INPUT_ATTACHMENT_BIT, "input_attachment"},
                                              {VK_IMAGE_USAGE_TRANSIENT_ATTACHMENT_BIT, "transient_attachment"},
                                              {VK_IMAGE_USAGE_TRANSFER_SRC_BIT, "transfer_src"},
                                              {VK_IMAGE_USAGE_TRANSFER_DST_BIT, "transfer_dst"}});
}

std::string bufferUsageName(VkBufferUsageFlags usage) {
  return flagNames<VkBufferUsageFlags>(usage, {{VK_BUFFER_USAGE_VERTEX_BUFFER_BIT, "vertex_buffer"},
                                               {VK_BUFFER_USAGE_INDEX_BUFFER_BIT, "index_buffer"},
                                               {VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, "uniform_buffer"},
                                               {VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "storage_buffer"},
                                               {VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT, "uniform_texel_buffer"},
                                               {VK_BUFFER_USAGE_STORAGE_TEXEL_BUFFER_BIT, "storage_texel_buffer"},
                                               {VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT, "indirect_buffer"},
                                               {VK_BUFFER_USAGE_TRANSFER_SRC_BIT, "transfer_src"},
                                               {VK_BUFFER_USAGE_TRANSFER_DST_BIT, "transfer_dst"}});
}

std::string hexHandle(uint64_t handle) {
  char text[24];
  std::snprintf(text, sizeof text, "0x%llx", static_cast<unsigned long long>(handle));
  return text;
}

}  // namespace tally::layer
