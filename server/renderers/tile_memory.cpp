#include "renderers/tile_memory.hpp"

#include "gpu/vk_check.hpp"

namespace tally::renderers {

std::string memoryKindName(VkMemoryPropertyFlags flags) {
  if (flags & VK_MEMORY_PROPERTY_LAZILY_ALLOCATED_BIT) return "lazily_allocated";
  if (flags & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT) return "device_local";
  return "host_visible";
}

std::string imageMemoryKind(const gpu::Context& ctx, const VkMemoryRequirements& requirements) {
  uint32_t type = gpu::selectMemoryType(ctx.memoryProperties, requirements.memoryTypeBits, 0,
                                        VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  return memoryKindName(ctx.memoryProperties.memoryTypes[type].propertyFlags);
}

nlohmann::json tileMemorySummary(const FrameResult& frame) {
  uint64_t total = 0, dram = 0;
  nlohmann::json passes = nlohmann::json::object();
  nlohmann::json lines = nlohmann::json::array();
  for (const auto& p : frame.passes) {
    uint64_t passTotal = 0, passDram = 0;
    for (const auto& a : p.accesses) {
      passTotal += a.bytes;
      if (a.onChip) {
        lines.push_back(p.name + "/" + a.resource + (a.write ? "/write" : "/read"));
      } else {
        passDram += a.bytes;
      }
    }
    passes[p.name] = {{"bytes", passTotal}, {"bytes_dram", passDram}};
    total += passTotal;
    dram += passDram;
  }
  return {{"bytes", total},
          {"bytes_dram", dram},
          {"bytes_on_chip", total - dram},
          {"passes", std::move(passes)},
          {"on_chip_lines", std::move(lines)}};
}

gpu::Image createTransientImage(const gpu::Context& ctx, uint32_t width, uint32_t height, VkFormat format,
                                VkImageUsageFlags usage, std::string& memoryKind) {
  gpu::Image result;
  result.format = format;
  result.extent = {width, height};
  result.aspect = VK_IMAGE_ASPECT_COLOR_BIT;
  VkImageCreateInfo info = {VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  info.imageType = VK_IMAGE_TYPE_2D;
  info.format = format;
  info.extent = {width, height, 1};
  info.mipLevels = 1;
  info.arrayLayers = 1;
  info.samples = VK_SAMPLE_COUNT_1_BIT;
  info.tiling = VK_IMAGE_TILING_OPTIMAL;
  info.usage = usage;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  VK_CHECK(vkCreateImage(ctx.device, &info, nullptr, &result.image));
  try {
    VkMemoryRequirements requirements;
    vkGetImageMemoryRequirements(ctx.device, result.image, &requirements);
    uint32_t type = gpu::selectMemoryType(ctx.memoryProperties, requirements.memoryTypeBits, 0,
                                          VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    for (uint32_t i = 0; i < ctx.memoryProperties.memoryTypeCount; ++i) {
      if ((requirements.memoryTypeBits & (1u << i)) == 0) continue;
      if (ctx.memoryProperties.memoryTypes[i].propertyFlags & VK_MEMORY_PROPERTY_LAZILY_ALLOCATED_BIT) {
        type = i;
        break;
      }
    }
    memoryKind = memoryKindName(ctx.memoryProperties.memoryTypes[type].propertyFlags);
    VkMemoryAllocateInfo alloc = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
    alloc.allocationSize = requirements.size;
    alloc.memoryTypeIndex = type;
    VK_CHECK(vkAllocateMemory(ctx.device, &alloc, nullptr, &result.memory));
    VK_CHECK(vkBindImageMemory(ctx.device, result.image, result.memory, 0));
    VkImageViewCreateInfo view = {VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    view.image = result.image;
    view.viewType = VK_IMAGE_VIEW_TYPE_2D;
    view.format = format;
    view.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    VK_CHECK(vkCreateImageView(ctx.device, &view, nullptr, &result.view));
  } catch (...) {
    gpu::destroyImage(ctx, result);
    throw;
  }
  return result;
}

}  // namespace tally::renderers
