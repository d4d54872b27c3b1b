#include "gpu/debug_names.hpp"

#include "gpu/vk_check.hpp"

namespace tally::gpu {

void nameObject(const Context& ctx, VkObjectType type, uint64_t handle, const std::string& name) {
  if (handle == 0) return;
  if (ctx.debugUtilsHook) ctx.debugUtilsHook({DebugUtilsEvent::Kind::ObjectName, type, handle, VK_NULL_HANDLE, name});
  if (ctx.setDebugUtilsObjectName == nullptr) return;
  VkDebugUtilsObjectNameInfoEXT info = {VK_STRUCTURE_TYPE_DEBUG_UTILS_OBJECT_NAME_INFO_EXT};
  info.objectType = type;
  info.objectHandle = handle;
  info.pObjectName = name.c_str();
  VK_CHECK(ctx.setDebugUtilsObjectName(ctx.device, &info));
}

void beginLabel(const Context& ctx, VkCommandBuffer cmd, const std::string& name) {
  if (ctx.debugUtilsHook) {
    ctx.debugUtilsHook({DebugUtilsEvent::Kind::BeginLabel, VK_OBJECT_TYPE_UNKNOWN, 0, cmd, name});
  }
  if (ctx.cmdBeginDebugUtilsLabel == nullptr) return;
  VkDebugUtilsLabelEXT label = {VK_STRUCTURE_TYPE_DEBUG_UTILS_LABEL_EXT};
  label.pLabelName = name.c_str();
  ctx.cmdBeginDebugUtilsLabel(cmd, &label);
}

void endLabel(const Context& ctx, VkCommandBuffer cmd) {
  if (ctx.debugUtilsHook) ctx.debugUtilsHook({DebugUtilsEvent::Kind::EndLabel, VK_OBJECT_TYPE_UNKNOWN, 0, cmd, ""});
  if (ctx.cmdEndDebugUtilsLabel == nullptr) return;
  ctx.cmdEndDebugUtilsLabel(cmd);
}

}  // namespace tally::gpu
