// What the layer lets pass without counting, and says so: descriptor
// buffers and ray-tracing pipelines (shader objects are counted:
// shader_objects.hpp). Each is noted in the output (`notes`, and `shaders`
// for the shaders it could not instrument); none may be half-handled,
// because a pipeline layout extended with the counter set is invalid for
// descriptor-buffer pipelines.
#pragma once

#include <string>
#include <string_view>

#include "state.hpp"

namespace tally::layer {

// The entry points below, by name ("vkCreateRayTracingPipelinesKHR"); null for others.
PFN_vkVoidFunction interceptedUncounted(std::string_view name);

// Why a pipeline layout must be created as the application asked, or "" when
// the layer may extend it: a layout with a descriptor-buffer set layout
// cannot take the layer's ordinary counter set. Called under dev.mutex.
std::string layoutRefusal(const DeviceState& dev, const VkPipelineLayoutCreateInfo& info);

}  // namespace tally::layer
