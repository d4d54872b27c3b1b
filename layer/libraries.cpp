// Graphics pipeline libraries: their parts, and linking their counted sites
// into a pipeline (libraries.hpp).
#include "libraries.hpp"

#include <algorithm>

namespace tally::layer {

LibraryUse libraryUse(const VkGraphicsPipelineCreateInfo& info) {
  LibraryUse use;
  use.library = (info.flags & VK_PIPELINE_CREATE_LIBRARY_BIT_KHR) != 0;
  bool partsGiven = false;
  for (auto* p = static_cast<const VkBaseInStructure*>(info.pNext); p != nullptr; p = p->pNext) {
    if (p->sType == VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_LIBRARY_CREATE_INFO_EXT) {
      use.parts = reinterpret_cast<const VkGraphicsPipelineLibraryCreateInfoEXT*>(p)->flags;
      partsGiven = true;
    } else if (p->sType == VK_STRUCTURE_TYPE_PIPELINE_LIBRARY_CREATE_INFO_KHR) {
      const auto* libraries = reinterpret_cast<const VkPipelineLibraryCreateInfoKHR*>(p);
      for (uint32_t i = 0; i < libraries->libraryCount; ++i) use.linked.push_back(u64(libraries->pLibraries[i]));
    }
  }
  // Without VkGraphicsPipelineLibraryCreateInfoEXT, a library or a pipeline
  // linked from libraries defines no part itself (the extension's rule).
  if (!partsGiven && use.split()) use.parts = 0;
  return use;
}

bool stageInParts(VkShaderStageFlagBits stage, uint32_t parts) {
  if (stage == VK_SHADER_STAGE_COMPUTE_BIT) return true;
  if (stage == VK_SHADER_STAGE_FRAGMENT_BIT) return (parts & VK_GRAPHICS_PIPELINE_LIBRARY_FRAGMENT_SHADER_BIT_EXT) != 0;
  return (parts & VK_GRAPHICS_PIPELINE_LIBRARY_PRE_RASTERIZATION_SHADERS_BIT_EXT) != 0;
}

uint32_t mergeLibraries(const DeviceState& dev, const std::vector<uint64_t>& libraries, PipelineInfo& info) {
  uint32_t held = 0;
  for (uint64_t handle : libraries) {
    auto it = dev.libraries.find(handle);
    if (it == dev.libraries.end()) continue;
    const PipelineInfo& library = *it->second;
    held |= library.libraryParts;
    info.sites.insert(info.sites.end(), library.sites.begin(), library.sites.end());
    info.foldLayouts.insert(info.foldLayouts.end(), library.foldLayouts.begin(), library.foldLayouts.end());
    FixedFunction& fixed = info.fixed;  // each library holds its parts' state
    const FixedFunction& part = library.fixed;
    fixed.attributes.insert(part.attributes.begin(), part.attributes.end());
    if (fixed.writeMasks.empty()) fixed.writeMasks = part.writeMasks;
    if (fixed.writeEnables.empty()) fixed.writeEnables = part.writeEnables;
    fixed.rasterizerDiscard = fixed.rasterizerDiscard || part.rasterizerDiscard;
    fixed.dynamicWriteMask = fixed.dynamicWriteMask || part.dynamicWriteMask;
    fixed.dynamicWriteEnable = fixed.dynamicWriteEnable || part.dynamicWriteEnable;
    fixed.dynamicDiscard = fixed.dynamicDiscard || part.dynamicDiscard;
    fixed.dynamicVertexInput = fixed.dynamicVertexInput || part.dynamicVertexInput;
    info.slots = std::max(info.slots, library.slots);
    info.hasFragment = info.hasFragment || library.hasFragment;
    if (info.layout == VK_NULL_HANDLE) info.layout = library.layout;
  }
  info.counted = info.slots > 0;
  return held;
}

}  // namespace tally::layer
