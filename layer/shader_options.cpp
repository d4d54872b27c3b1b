#include "shader_options.hpp"

#include <algorithm>
#include <cstring>

namespace tally::layer {

spirv::ValidationTarget validationTarget(const VkDeviceCreateInfo& info, uint32_t instanceVersion,
                                         uint32_t deviceVersion) {
  spirv::ValidationTarget target;
  // The patch number plays no part in what SPIR-V is valid.
  target.vulkanVersion = std::min(VK_MAKE_API_VERSION(0, VK_API_VERSION_MAJOR(instanceVersion),
                                                      VK_API_VERSION_MINOR(instanceVersion), 0),
                                  VK_MAKE_API_VERSION(0, VK_API_VERSION_MAJOR(deviceVersion),
                                                      VK_API_VERSION_MINOR(deviceVersion), 0));
  target.relaxedBlockLayout = target.vulkanVersion >= VK_API_VERSION_1_1;
  for (uint32_t i = 0; i < info.enabledExtensionCount; ++i) {
    if (std::strcmp(info.ppEnabledExtensionNames[i], VK_KHR_RELAXED_BLOCK_LAYOUT_EXTENSION_NAME) == 0) {
      target.relaxedBlockLayout = true;
    }
  }
  for (auto* p = static_cast<const VkBaseInStructure*>(info.pNext); p != nullptr; p = p->pNext) {
    switch (p->sType) {
      case VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES: {
        auto* f = reinterpret_cast<const VkPhysicalDeviceVulkan12Features*>(p);
        target.scalarBlockLayout |= f->scalarBlockLayout == VK_TRUE;
        target.uniformBufferStandardLayout |= f->uniformBufferStandardLayout == VK_TRUE;
        break;
      }
      case VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SCALAR_BLOCK_LAYOUT_FEATURES:
        target.scalarBlockLayout |=
            reinterpret_cast<const VkPhysicalDeviceScalarBlockLayoutFeatures*>(p)->scalarBlockLayout == VK_TRUE;
        break;
      case VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_UNIFORM_BUFFER_STANDARD_LAYOUT_FEATURES:
        target.uniformBufferStandardLayout |=
            reinterpret_cast<const VkPhysicalDeviceUniformBufferStandardLayoutFeatures*>(p)
                ->uniformBufferStandardLayout == VK_TRUE;
        break;
      case VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES:
        target.localSizeId |= reinterpret_cast<const VkPhysicalDeviceVulkan13Features*>(p)->maintenance4 == VK_TRUE;
        break;
      case VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_4_FEATURES:
        target.localSizeId |= reinterpret_cast<const VkPhysicalDeviceMaintenance4Features*>(p)->maintenance4 == VK_TRUE;
        break;
      case VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_WORKGROUP_MEMORY_EXPLICIT_LAYOUT_FEATURES_KHR:
        target.workgroupScalarBlockLayout |=
            reinterpret_cast<const VkPhysicalDeviceWorkgroupMemoryExplicitLayoutFeaturesKHR*>(p)
                ->workgroupMemoryExplicitLayoutScalarBlockLayout == VK_TRUE;
        break;
      default: break;
    }
  }
  return target;
}

AlphaToCoverage alphaToCoverage(const VkGraphicsPipelineCreateInfo& info) {
  if (info.pDynamicState != nullptr) {
    for (uint32_t i = 0; i < info.pDynamicState->dynamicStateCount; ++i) {
      if (info.pDynamicState->pDynamicStates[i] == VK_DYNAMIC_STATE_ALPHA_TO_COVERAGE_ENABLE_EXT) {
        return AlphaToCoverage::Dynamic;
      }
    }
  }
  // pMultisampleState may dangle where rasterization is discarded, and then no fragment runs anyway.
  const bool discarded = info.pRasterizationState != nullptr && info.pRasterizationState->rasterizerDiscardEnable;
  if (!discarded && info.pMultisampleState != nullptr && info.pMultisampleState->alphaToCoverageEnable == VK_TRUE) {
    return AlphaToCoverage::On;
  }
  return AlphaToCoverage::Off;
}

}  // namespace tally::layer
