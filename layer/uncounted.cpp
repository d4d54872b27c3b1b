#include "uncounted.hpp"

#include <cstdio>

#include "descriptor_buffers_layer.hpp"
#include "names.hpp"

namespace tally::layer {
namespace {

template <class F>
F next(DeviceState& dev, const char* name) {
  return reinterpret_cast<F>(dev.d.GetDeviceProcAddr(dev.device, name));
}

void note(DeviceState& dev, const std::string& line) {
  std::lock_guard lock(dev.mutex);
  if (dev.notes.insert(line).second) std::fprintf(stderr, "tally layer: %s\n", line.c_str());
}

void report(DeviceState& dev, const std::string& stage, const std::string& name, const std::string& why) {
  std::lock_guard lock(dev.mutex);
  dev.shaderReports.push_back(
      {{"name", name}, {"stage", stage}, {"instrumented", false}, {"sites", 0}, {"reason", why}});
}

// ---------------------------------------------------------------- descriptor buffers

VKAPI_ATTR VkResult VKAPI_CALL CreateDescriptorSetLayout(VkDevice device, const VkDescriptorSetLayoutCreateInfo* info,
                                                         const VkAllocationCallbacks* alloc,
                                                         VkDescriptorSetLayout* layout) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.CreateDescriptorSetLayout(device, info, alloc, layout);
  if (result == VK_SUCCESS) noteDescriptorSetLayout(*dev, *layout, *info);
  if (result == VK_SUCCESS && (info->flags & VK_DESCRIPTOR_SET_LAYOUT_CREATE_DESCRIPTOR_BUFFER_BIT_EXT) != 0) {
    std::lock_guard lock(dev->mutex);
    dev->descriptorBufferLayouts.insert(u64(*layout));
  }
  return result;
}

VKAPI_ATTR void VKAPI_CALL DestroyDescriptorSetLayout(VkDevice device, VkDescriptorSetLayout layout,
                                                      const VkAllocationCallbacks* alloc) {
  DeviceState* dev = deviceOf(device);
  {
    std::lock_guard lock(dev->mutex);
    dev->descriptorBufferLayouts.erase(u64(layout));  // a later layout may reuse the handle
  }
  dev->d.DestroyDescriptorSetLayout(device, layout, alloc);
}

// ---------------------------------------------------------------- ray tracing

VKAPI_ATTR VkResult VKAPI_CALL CreateRayTracingPipelinesKHR(VkDevice device, VkDeferredOperationKHR deferred,
                                                            VkPipelineCache cache, uint32_t count,
                                                            const VkRayTracingPipelineCreateInfoKHR* infos,
                                                            const VkAllocationCallbacks* alloc,
                                                            VkPipeline* pipelines) {
  DeviceState* dev = deviceOf(device);
  auto down = next<PFN_vkCreateRayTracingPipelinesKHR>(*dev, "vkCreateRayTracingPipelinesKHR");
  VkResult result = down(device, deferred, cache, count, infos, alloc, pipelines);
  const std::string why = "ray-tracing pipelines are not instrumented by the layer: vkCmdTraceRays runs uncounted";
  note(*dev, why);
  for (uint32_t i = 0; i < count; ++i) {
    if (pipelines[i] != VK_NULL_HANDLE) {
      note(*dev, "ray-tracing pipeline " + hexHandle(u64(pipelines[i])) + " (" +
                     std::to_string(infos[i].stageCount) + " stages): not instrumented, uncounted");
    }
    for (uint32_t s = 0; s < infos[i].stageCount; ++s) {
      report(*dev, "ray tracing", "shader " + hexHandle(u64(infos[i].pStages[s].module)), why);
    }
  }
  return result;
}

}  // namespace

std::string layoutRefusal(const DeviceState& dev, const VkPipelineLayoutCreateInfo& info) {
  if (countsDescriptorBuffers(dev)) return "";  // the counter set in the layer's descriptor buffer
  for (uint32_t i = 0; i < info.setLayoutCount; ++i) {
    if (dev.descriptorBufferLayouts.count(u64(info.pSetLayouts[i])) > 0) {
      return "a pipeline layout uses descriptor buffers (VK_EXT_descriptor_buffer): the layer's counter set is "
             "an ordinary descriptor set, which such a layout cannot hold, so its pipelines run unchanged, "
             "uncounted";
    }
  }
  return "";
}

PFN_vkVoidFunction interceptedUncounted(std::string_view n) {
  if (n == "vkCreateDescriptorSetLayout") return reinterpret_cast<PFN_vkVoidFunction>(CreateDescriptorSetLayout);
  if (n == "vkDestroyDescriptorSetLayout") return reinterpret_cast<PFN_vkVoidFunction>(DestroyDescriptorSetLayout);
  if (n == "vkCreateRayTracingPipelinesKHR") {
    return reinterpret_cast<PFN_vkVoidFunction>(CreateRayTracingPipelinesKHR);
  }
  return nullptr;
}

}  // namespace tally::layer
