#include "renderers/techniques/tile_memory.hpp"

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
  VkMemoryPropertyFlags flags = 0;
  gpu::Image image = gpu::createImage(ctx, width, height, format, usage, VK_SAMPLE_COUNT_1_BIT,
                                      gpu::MemoryUse::Transient, &flags);
  memoryKind = memoryKindName(flags);
  return image;
}

}  // namespace tally::renderers
