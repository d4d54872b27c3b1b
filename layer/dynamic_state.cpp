// The dynamic-state commands that decide what a draw writes and reads:
// vertex input (VK_EXT_vertex_input_dynamic_state), colour write enables
// (VK_EXT_color_write_enable), colour write masks
// (VK_EXT_extended_dynamic_state3) and rasterizer discard (Vulkan 1.3,
// VK_EXT_extended_dynamic_state2). Each is recorded into the command
// buffer's DynamicState after the call down; attribution.cpp reads it where
// the bound pipeline declares the state dynamic.
#include <mutex>

#include "state.hpp"

namespace tally::layer {
namespace {

CommandBufferState* recording(DeviceState& dev, VkCommandBuffer cmd) {
  auto it = dev.commandBuffers.find(cmd);
  return it == dev.commandBuffers.end() ? nullptr : it->second.get();
}

VKAPI_ATTR void VKAPI_CALL CmdSetVertexInputEXT(VkCommandBuffer cmd, uint32_t bindingCount,
                                                const VkVertexInputBindingDescription2EXT* bindings,
                                                uint32_t attributeCount,
                                                const VkVertexInputAttributeDescription2EXT* attributes) {
  DeviceState* dev = deviceOf(cmd);
  dev->d.CmdSetVertexInputEXT(cmd, bindingCount, bindings, attributeCount, attributes);
  std::lock_guard lock(dev->mutex);
  if (CommandBufferState* cb = recording(*dev, cmd)) {
    // The call replaces the whole vertex input state.
    cb->dynamic.attributes.clear();
    for (uint32_t a = 0; a < attributeCount; ++a) {
      cb->dynamic.attributes[attributes[a].location] = {attributes[a].binding, attributes[a].format};
    }
  }
}

VKAPI_ATTR void VKAPI_CALL CmdSetColorWriteEnableEXT(VkCommandBuffer cmd, uint32_t count, const VkBool32* enables) {
  DeviceState* dev = deviceOf(cmd);
  dev->d.CmdSetColorWriteEnableEXT(cmd, count, enables);
  std::lock_guard lock(dev->mutex);
  if (CommandBufferState* cb = recording(*dev, cmd)) cb->dynamic.writeEnables.assign(enables, enables + count);
}

VKAPI_ATTR void VKAPI_CALL CmdSetColorWriteMaskEXT(VkCommandBuffer cmd, uint32_t first, uint32_t count,
                                                   const VkColorComponentFlags* masks) {
  DeviceState* dev = deviceOf(cmd);
  dev->d.CmdSetColorWriteMaskEXT(cmd, first, count, masks);
  std::lock_guard lock(dev->mutex);
  if (CommandBufferState* cb = recording(*dev, cmd)) {
    auto& to = cb->dynamic.writeMasks;
    constexpr VkColorComponentFlags kAll = 0xF;  // attachments never set: written, as the pipeline would
    if (to.size() < first + count) to.resize(first + count, kAll);
    for (uint32_t i = 0; i < count; ++i) to[first + i] = masks[i];
  }
}

VKAPI_ATTR void VKAPI_CALL CmdSetRasterizerDiscardEnable(VkCommandBuffer cmd, VkBool32 enable) {
  DeviceState* dev = deviceOf(cmd);
  dev->d.CmdSetRasterizerDiscardEnable(cmd, enable);
  std::lock_guard lock(dev->mutex);
  if (CommandBufferState* cb = recording(*dev, cmd)) cb->dynamic.rasterizerDiscard = enable == VK_TRUE;
}

}  // namespace

PFN_vkVoidFunction interceptedDynamicState(std::string_view name) {
#define TALLY_DYNAMIC(alias, fn) \
  if (name == "vk" #alias) return reinterpret_cast<PFN_vkVoidFunction>(fn);
  TALLY_DYNAMIC(CmdSetVertexInputEXT, CmdSetVertexInputEXT)
  TALLY_DYNAMIC(CmdSetColorWriteEnableEXT, CmdSetColorWriteEnableEXT)
  TALLY_DYNAMIC(CmdSetColorWriteMaskEXT, CmdSetColorWriteMaskEXT)
  TALLY_DYNAMIC(CmdSetRasterizerDiscardEnable, CmdSetRasterizerDiscardEnable)
  TALLY_DYNAMIC(CmdSetRasterizerDiscardEnableEXT, CmdSetRasterizerDiscardEnable)
#undef TALLY_DYNAMIC
  return nullptr;
}

}  // namespace tally::layer
