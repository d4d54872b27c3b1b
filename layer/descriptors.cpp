// The layer's intercepts for descriptors: sets, their writes and templates,
// and the sets bound or pushed in command buffers (docs/layer.md).
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string_view>
#include <utility>

#include "early_tests_twin.hpp"
#include "intercepts.hpp"
#include "libraries.hpp"
#include "names.hpp"
#include "shader_options.hpp"
#include "state.hpp"
#include "uncounted.hpp"

namespace tally::layer {
namespace {

VKAPI_ATTR VkResult VKAPI_CALL AllocateDescriptorSets(VkDevice device, const VkDescriptorSetAllocateInfo* info,
                                                      VkDescriptorSet* sets) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.AllocateDescriptorSets(device, info, sets);
  if (result != VK_SUCCESS) return result;
  std::lock_guard lock(dev->mutex);
  for (uint32_t i = 0; i < info->descriptorSetCount; ++i) {
    dev->sets[u64(sets[i])] = DescriptorSetState{};
    dev->poolSets[u64(info->descriptorPool)].insert(u64(sets[i]));
  }
  return result;
}

VKAPI_ATTR VkResult VKAPI_CALL FreeDescriptorSets(VkDevice device, VkDescriptorPool pool, uint32_t count,
                                                  const VkDescriptorSet* sets) {
  DeviceState* dev = deviceOf(device);
  {
    std::lock_guard lock(dev->mutex);
    for (uint32_t i = 0; i < count; ++i) {
      dev->sets.erase(u64(sets[i]));
      dev->poolSets[u64(pool)].erase(u64(sets[i]));
    }
  }
  return dev->d.FreeDescriptorSets(device, pool, count, sets);
}

void forgetPoolSets(DeviceState& dev, VkDescriptorPool pool) {
  std::lock_guard lock(dev.mutex);
  for (uint64_t s : dev.poolSets[u64(pool)]) dev.sets.erase(s);
  dev.poolSets.erase(u64(pool));
}

VKAPI_ATTR VkResult VKAPI_CALL ResetDescriptorPool(VkDevice device, VkDescriptorPool pool,
                                                   VkDescriptorPoolResetFlags flags) {
  DeviceState* dev = deviceOf(device);
  forgetPoolSets(*dev, pool);
  return dev->d.ResetDescriptorPool(device, pool, flags);
}

VKAPI_ATTR void VKAPI_CALL DestroyDescriptorPool(VkDevice device, VkDescriptorPool pool,
                                                 const VkAllocationCallbacks* alloc) {
  DeviceState* dev = deviceOf(device);
  forgetPoolSets(*dev, pool);
  dev->d.DestroyDescriptorPool(device, pool, alloc);
}

}  // namespace

// What one descriptor of `type` refers to.
Bound boundImage(DeviceState& dev, VkImageView view) {
  auto it = dev.views.find(u64(view));
  if (it == dev.views.end()) return {};
  return {it->second.image, it->second.format, it->second.aspect};
}

namespace {
Bound boundOf(DeviceState& dev, VkDescriptorType type, const void* element) {
  switch (type) {
    case VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER:
    case VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE:
    case VK_DESCRIPTOR_TYPE_STORAGE_IMAGE:
    case VK_DESCRIPTOR_TYPE_INPUT_ATTACHMENT:
      return boundImage(dev, static_cast<const VkDescriptorImageInfo*>(element)->imageView);
    case VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER:
    case VK_DESCRIPTOR_TYPE_STORAGE_BUFFER:
    case VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER_DYNAMIC:
    case VK_DESCRIPTOR_TYPE_STORAGE_BUFFER_DYNAMIC:
      return {u64(static_cast<const VkDescriptorBufferInfo*>(element)->buffer)};
    case VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER:
    case VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER: {
      auto it = dev.bufferViews.find(u64(*static_cast<const VkBufferView*>(element)));
      return {it == dev.bufferViews.end() ? 0 : it->second};
    }
    default: return {};  // samplers, inline uniform blocks, acceleration structures
  }
}

void writeElement(DescriptorSetState& set, uint32_t binding, uint32_t element, Bound bound) {
  auto& elements = set.bindings[binding];
  if (elements.size() <= element) elements.resize(element + 1);
  elements[element] = bound;
}

// One write of vkUpdateDescriptorSets or vkCmdPushDescriptorSetKHR.
void applyWrite(DeviceState& dev, DescriptorSetState& set, const VkWriteDescriptorSet& write) {
  for (uint32_t i = 0; i < write.descriptorCount; ++i) {
    const void* element = nullptr;
    if (write.pImageInfo != nullptr &&
        (write.descriptorType == VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER ||
         write.descriptorType == VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE ||
         write.descriptorType == VK_DESCRIPTOR_TYPE_STORAGE_IMAGE ||
         write.descriptorType == VK_DESCRIPTOR_TYPE_INPUT_ATTACHMENT)) {
      element = &write.pImageInfo[i];
    } else if (write.pBufferInfo != nullptr &&
               (write.descriptorType == VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER ||
                write.descriptorType == VK_DESCRIPTOR_TYPE_STORAGE_BUFFER ||
                write.descriptorType == VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER_DYNAMIC ||
                write.descriptorType == VK_DESCRIPTOR_TYPE_STORAGE_BUFFER_DYNAMIC)) {
      element = &write.pBufferInfo[i];
    } else if (write.pTexelBufferView != nullptr &&
               (write.descriptorType == VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER ||
                write.descriptorType == VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER)) {
      element = &write.pTexelBufferView[i];
    }
    if (element == nullptr) continue;
    writeElement(set, write.dstBinding, write.dstArrayElement + i, boundOf(dev, write.descriptorType, element));
  }
}

// A descriptor update template's entries applied to `data`.
void applyTemplate(DeviceState& dev, DescriptorSetState& set, const std::vector<VkDescriptorUpdateTemplateEntry>& entries,
                   const void* data) {
  for (const auto& entry : entries) {
    if (entry.descriptorType == VK_DESCRIPTOR_TYPE_INLINE_UNIFORM_BLOCK) continue;
    for (uint32_t i = 0; i < entry.descriptorCount; ++i) {
      const void* element = static_cast<const uint8_t*>(data) + entry.offset + size_t(i) * entry.stride;
      writeElement(set, entry.dstBinding, entry.dstArrayElement + i, boundOf(dev, entry.descriptorType, element));
    }
  }
}

VKAPI_ATTR void VKAPI_CALL UpdateDescriptorSets(VkDevice device, uint32_t writeCount, const VkWriteDescriptorSet* writes,
                                                uint32_t copyCount, const VkCopyDescriptorSet* copies) {
  DeviceState* dev = deviceOf(device);
  {
    std::lock_guard lock(dev->mutex);
    for (uint32_t w = 0; w < writeCount; ++w) {
      auto it = dev->sets.find(u64(writes[w].dstSet));
      if (it != dev->sets.end()) applyWrite(*dev, it->second, writes[w]);
    }
    for (uint32_t c = 0; c < copyCount; ++c) {
      const auto& copy = copies[c];
      auto src = dev->sets.find(u64(copy.srcSet));
      auto dst = dev->sets.find(u64(copy.dstSet));
      if (src == dev->sets.end() || dst == dev->sets.end()) continue;
      const auto& from = src->second.bindings[copy.srcBinding];
      for (uint32_t i = 0; i < copy.descriptorCount; ++i) {
        uint32_t e = copy.srcArrayElement + i;
        writeElement(dst->second, copy.dstBinding, copy.dstArrayElement + i, e < from.size() ? from[e] : Bound{});
      }
    }
  }
  dev->d.UpdateDescriptorSets(device, writeCount, writes, copyCount, copies);
}

VKAPI_ATTR VkResult VKAPI_CALL CreateDescriptorUpdateTemplate(VkDevice device,
                                                              const VkDescriptorUpdateTemplateCreateInfo* info,
                                                              const VkAllocationCallbacks* alloc,
                                                              VkDescriptorUpdateTemplate* handle) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.CreateDescriptorUpdateTemplate(device, info, alloc, handle);
  if (result != VK_SUCCESS) return result;
  std::lock_guard lock(dev->mutex);
  if (info->templateType == VK_DESCRIPTOR_UPDATE_TEMPLATE_TYPE_DESCRIPTOR_SET) {
    dev->templates[u64(*handle)].assign(info->pDescriptorUpdateEntries,
                                         info->pDescriptorUpdateEntries + info->descriptorUpdateEntryCount);
  } else if (info->templateType == VK_DESCRIPTOR_UPDATE_TEMPLATE_TYPE_PUSH_DESCRIPTORS_KHR) {
    dev->pushTemplates[u64(*handle)] = {info->pipelineBindPoint,
                                        {info->pDescriptorUpdateEntries,
                                         info->pDescriptorUpdateEntries + info->descriptorUpdateEntryCount}};
  }
  return result;
}

VKAPI_ATTR void VKAPI_CALL UpdateDescriptorSetWithTemplate(VkDevice device, VkDescriptorSet set,
                                                           VkDescriptorUpdateTemplate handle, const void* data) {
  DeviceState* dev = deviceOf(device);
  {
    std::lock_guard lock(dev->mutex);
    auto t = dev->templates.find(u64(handle));
    auto s = dev->sets.find(u64(set));
    if (t != dev->templates.end() && s != dev->sets.end()) applyTemplate(*dev, s->second, t->second, data);
  }
  dev->d.UpdateDescriptorSetWithTemplate(device, set, handle, data);
}

VKAPI_ATTR void VKAPI_CALL CmdBindDescriptorSets(VkCommandBuffer cmd, VkPipelineBindPoint point, VkPipelineLayout layout,
                                                 uint32_t first, uint32_t count, const VkDescriptorSet* sets,
                                                 uint32_t dynamicCount, const uint32_t* dynamicOffsets) {
  DeviceState* dev = deviceOf(cmd);
  dev->d.CmdBindDescriptorSets(cmd, point, layout, first, count, sets, dynamicCount, dynamicOffsets);
  if (point != VK_PIPELINE_BIND_POINT_GRAPHICS && point != VK_PIPELINE_BIND_POINT_COMPUTE) return;
  std::lock_guard lock(dev->mutex);
  CommandBufferState* cb = cbState(*dev, cmd);
  if (cb == nullptr) return;
  auto& bp = cb->bind[point == VK_PIPELINE_BIND_POINT_COMPUTE ? 1 : 0];
  for (uint32_t i = 0; i < count && first + i < bp.sets.size(); ++i) {
    bp.sets[first + i] = u64(sets[i]);
    bp.pushed.erase(first + i);
  }
  bp.dirty = true;
}

// Push descriptors resolve as bound sets do: the command buffer holds the
// pushed set's descriptors, updated incrementally, until a bind replaces it.
template <class Update>
void pushDescriptors(VkCommandBuffer cmd, VkPipelineBindPoint point, uint32_t set, Update update) {
  if (point != VK_PIPELINE_BIND_POINT_GRAPHICS && point != VK_PIPELINE_BIND_POINT_COMPUTE) return;
  DeviceState* dev = deviceOf(cmd);
  std::lock_guard lock(dev->mutex);
  CommandBufferState* cb = cbState(*dev, cmd);
  if (cb == nullptr) return;
  auto& bp = cb->bind[point == VK_PIPELINE_BIND_POINT_COMPUTE ? 1 : 0];
  if (set >= bp.sets.size()) return;
  update(*dev, bp.pushed[set]);
  bp.sets[set] = 0;
  bp.dirty = true;
}

VKAPI_ATTR void VKAPI_CALL CmdPushDescriptorSetKHR(VkCommandBuffer cmd, VkPipelineBindPoint point,
                                                   VkPipelineLayout layout, uint32_t set, uint32_t count,
                                                   const VkWriteDescriptorSet* writes) {
  deviceOf(cmd)->d.CmdPushDescriptorSetKHR(cmd, point, layout, set, count, writes);
  pushDescriptors(cmd, point, set, [&](DeviceState& dev, DescriptorSetState& pushed) {
    for (uint32_t i = 0; i < count; ++i) applyWrite(dev, pushed, writes[i]);
  });
}

VKAPI_ATTR void VKAPI_CALL CmdPushDescriptorSetWithTemplateKHR(VkCommandBuffer cmd, VkDescriptorUpdateTemplate handle,
                                                               VkPipelineLayout layout, uint32_t set, const void* data) {
  DeviceState* dev = deviceOf(cmd);
  dev->d.CmdPushDescriptorSetWithTemplateKHR(cmd, handle, layout, set, data);
  VkPipelineBindPoint point = VK_PIPELINE_BIND_POINT_MAX_ENUM;
  {
    std::lock_guard lock(dev->mutex);
    if (auto t = dev->pushTemplates.find(u64(handle)); t != dev->pushTemplates.end()) point = t->second.first;
  }
  pushDescriptors(cmd, point, set, [&](DeviceState& device, DescriptorSetState& pushed) {
    applyTemplate(device, pushed, device.pushTemplates[u64(handle)].second, data);
  });
}

}  // namespace

PFN_vkVoidFunction interceptedDescriptors(std::string_view name) {
  TALLY_INTERCEPT(AllocateDescriptorSets)
  TALLY_INTERCEPT(FreeDescriptorSets)
  TALLY_INTERCEPT(ResetDescriptorPool)
  TALLY_INTERCEPT(DestroyDescriptorPool)
  TALLY_INTERCEPT(UpdateDescriptorSets)
  TALLY_INTERCEPT(CreateDescriptorUpdateTemplate)
  TALLY_INTERCEPT_ALIAS(CreateDescriptorUpdateTemplateKHR, CreateDescriptorUpdateTemplate)
  TALLY_INTERCEPT(UpdateDescriptorSetWithTemplate)
  TALLY_INTERCEPT_ALIAS(UpdateDescriptorSetWithTemplateKHR, UpdateDescriptorSetWithTemplate)
  TALLY_INTERCEPT(CmdBindDescriptorSets)
  TALLY_INTERCEPT(CmdPushDescriptorSetKHR)
  TALLY_INTERCEPT(CmdPushDescriptorSetWithTemplateKHR)
  return nullptr;
}

}  // namespace tally::layer
