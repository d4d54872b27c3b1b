// What the application's device and pipelines allow the instrumented
// shaders: the rules its SPIR-V is validated by, and whether a pipeline's
// fragment shader may be given early fragment tests (docs/layer.md).
#pragma once

#include <vulkan/vulkan.h>

#include "spirv/validate.hpp"

namespace tally::layer {

// The Vulkan version the device runs at (the lower of the instance's and
// the device's) and the block layouts and LocalSizeId the application
// enabled in VkDeviceCreateInfo (its features chain and extensions): a
// module the driver accepts is valid for this target.
spirv::ValidationTarget validationTarget(const VkDeviceCreateInfo& info, uint32_t instanceVersion,
                                         uint32_t deviceVersion);

// Alpha to coverage removes samples after the fragment shader; early tests
// would already have written their depth and stencil. Dynamic: set by
// vkCmdSetAlphaToCoverageEnableEXT at each draw.
enum class AlphaToCoverage { Off, On, Dynamic };
AlphaToCoverage alphaToCoverage(const VkGraphicsPipelineCreateInfo& info);

}  // namespace tally::layer
