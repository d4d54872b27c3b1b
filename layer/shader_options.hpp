// What the application's device and pipelines allow the instrumented
// shaders: the rules its SPIR-V is validated by, and whether a pipeline's
// fragment shader may be given early fragment tests (docs/layer.md).
#pragma once

#include <string>

#include <vulkan/vulkan.h>

#include "spirv/validate.hpp"

namespace tally::layer {

// The Vulkan version the device runs at (the lower of the instance's and
// the device's) and the block layouts and LocalSizeId the application
// enabled in VkDeviceCreateInfo (its features chain and extensions): a
// module the driver accepts is valid for this target.
spirv::ValidationTarget validationTarget(const VkDeviceCreateInfo& info, uint32_t instanceVersion,
                                         uint32_t deviceVersion);

// Why early fragment tests would change what this pipeline does, whatever
// its fragment shader: alpha to coverage (set or dynamic) removes samples
// after the shader, and early tests would already have written their depth
// and stencil. "" when nothing in the pipeline's state stands against them.
std::string earlyTestsPipelineBlocker(const VkGraphicsPipelineCreateInfo& info);

}  // namespace tally::layer
