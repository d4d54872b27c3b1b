// The layer's intercepted calls, one file per area, and what the areas share.
// Each area's file defines its calls and answers for them by name (the
// table sits beside the functions it names); layer.cpp asks each in turn.
#pragma once

#include <string>
#include <string_view>

#include "state.hpp"

// In an area's table (a function of `std::string_view name`): answers
// for vk<fn>, or vk<alias>, with the area's function.
#define TALLY_INTERCEPT(fn) \
  if (name == "vk" #fn) return reinterpret_cast<PFN_vkVoidFunction>(fn);
#define TALLY_INTERCEPT_ALIAS(alias, fn) \
  if (name == "vk" #alias) return reinterpret_cast<PFN_vkVoidFunction>(fn);

namespace tally::layer {

PFN_vkVoidFunction interceptedResources(std::string_view name);    // resources.cpp
PFN_vkVoidFunction interceptedDescriptors(std::string_view name);  // descriptors.cpp
PFN_vkVoidFunction interceptedPipelines(std::string_view name);    // pipelines.cpp
PFN_vkVoidFunction interceptedCommands(std::string_view name);     // commands.cpp
PFN_vkVoidFunction interceptedDraws(std::string_view name);        // draws.cpp
PFN_vkVoidFunction interceptedShaderObjects(std::string_view name);  // shader_objects.cpp

// Shared between areas.
Bound boundImage(DeviceState& dev, VkImageView view);        // descriptors.cpp: what a view names
bool tracked(DeviceState& dev, CommandBufferState* cb);      // commands.cpp: the layer records its scopes
void openPass(DeviceState& dev, CommandBufferState& cb, const char* kind);
void closePass(DeviceState& dev, CommandBufferState& cb);
inline CommandBufferState* cbState(DeviceState& dev, VkCommandBuffer cb) { return commandBufferOf(dev, cb); }

}  // namespace tally::layer
