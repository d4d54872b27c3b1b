// Names and labels through VK_EXT_debug_utils, so that a tool that intercepts
// the application (a capture layer, a debugger) sees Tally's resources and
// passes by the names its results use. Each is a no-op where the extension is
// absent (Context's function pointers are null); Context::debugUtilsHook, if
// set, sees every call either way.
#pragma once

#include <cstdint>
#include <string>
#include <type_traits>

#include <vulkan/vulkan.h>

#include "gpu/context.hpp"

namespace tally::gpu {

// A Vulkan object as VkDebugUtilsObjectNameInfoEXT takes it.
struct DebugObject {
  VkObjectType type = VK_OBJECT_TYPE_UNKNOWN;
  uint64_t handle = 0;
  bool operator==(const DebugObject&) const = default;
};

// The 64-bit value of a non-dispatchable handle (a pointer on 64-bit hosts).
template <class Handle>
uint64_t handleValue(Handle h) {
  if constexpr (std::is_pointer_v<Handle>) {
    return static_cast<uint64_t>(reinterpret_cast<uintptr_t>(h));
  } else {
    return static_cast<uint64_t>(h);
  }
}
inline DebugObject objectOf(VkImage image) { return {VK_OBJECT_TYPE_IMAGE, handleValue(image)}; }
inline DebugObject objectOf(VkBuffer buffer) { return {VK_OBJECT_TYPE_BUFFER, handleValue(buffer)}; }

// vkSetDebugUtilsObjectNameEXT; a null handle is skipped.
void nameObject(const Context& ctx, VkObjectType type, uint64_t handle, const std::string& name);
inline void nameObject(const Context& ctx, const DebugObject& object, const std::string& name) {
  nameObject(ctx, object.type, object.handle, name);
}
// vkCmdBeginDebugUtilsLabelEXT / vkCmdEndDebugUtilsLabelEXT.
void beginLabel(const Context& ctx, VkCommandBuffer cmd, const std::string& name);
void endLabel(const Context& ctx, VkCommandBuffer cmd);

}  // namespace tally::gpu
