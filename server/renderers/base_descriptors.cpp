// RendererBase: descriptor set layouts, sets, their writes and binding them.
#include "renderers/renderer_base.hpp"

#include "gpu/vk_check.hpp"
#include "shared.h"

namespace tally::renderers {

VkDescriptorSetLayout RendererBase::setLayout(const std::vector<VkDescriptorType>& types,
                                              const std::vector<uint32_t>& counts) {
  std::vector<VkDescriptorSetLayoutBinding> bindings;
  for (uint32_t i = 0; i < types.size(); ++i) {
    VkDescriptorSetLayoutBinding b = {};
    b.binding = i;
    b.descriptorType = types[i];
    b.descriptorCount = i < counts.size() ? counts[i] : 1;
    b.stageFlags = VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT | VK_SHADER_STAGE_COMPUTE_BIT;
    bindings.push_back(b);
  }
  ownedSetLayouts_.push_back(gpu::createDescriptorSetLayout(*ctx_, bindings));
  return ownedSetLayouts_.back();
}

VkDescriptorSet RendererBase::allocateSet(VkDescriptorSetLayout layout) {
  return gpu::allocateDescriptorSet(*ctx_, pool_, layout);
}

void RendererBase::writeImage(VkDescriptorSet set, uint32_t binding, VkImageView view, VkSampler sampler,
                              VkImageLayout layout) {
  gpu::DescriptorWrite w;
  w.binding = binding;
  w.type = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  w.image = {sampler, view, layout};
  gpu::updateDescriptorSet(*ctx_, set, {&w, 1});
}

void RendererBase::bindSets(VkCommandBuffer cmd, VkPipelineLayout layout, VkDescriptorSet material,
                            VkDescriptorSet passInput, VkDescriptorSet geometry) {
  bindSetsAt(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout, material, passInput, geometry);
}

void RendererBase::bindComputeSets(VkCommandBuffer cmd, VkPipelineLayout layout, VkDescriptorSet material,
                                   VkDescriptorSet passInput, VkDescriptorSet geometry) {
  bindSetsAt(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, material, passInput, geometry);
}

void RendererBase::writeStorageImage(VkDescriptorSet set, uint32_t binding, VkImageView view) {
  gpu::DescriptorWrite w;
  w.binding = binding;
  w.type = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
  w.image = {VK_NULL_HANDLE, view, VK_IMAGE_LAYOUT_GENERAL};
  gpu::updateDescriptorSet(*ctx_, set, {&w, 1});
}

void RendererBase::bindSetsAt(VkCommandBuffer cmd, VkPipelineBindPoint point, VkPipelineLayout layout,
                              VkDescriptorSet material, VkDescriptorSet passInput, VkDescriptorSet geometry) {
  auto& bound = boundSets_[point == VK_PIPELINE_BIND_POINT_COMPUTE ? 1 : 0];
  auto bind = [&](uint32_t index, VkDescriptorSet set) {
    if (set == VK_NULL_HANDLE) return;
    vkCmdBindDescriptorSets(cmd, point, layout, index, 1, &set, 0, nullptr);
    if (index < bound.size()) bound[index] = set;
  };
  bind(shaders::kSetFrame, frameSet_);
  bind(shaders::kSetMaterial, material);
  bind(shaders::kSetGeometry, geometry != VK_NULL_HANDLE ? geometry : geometrySet_);
  bind(shaders::kSetPassInput, passInput);
  bindCounterSet(cmd, point, layout);
}

void RendererBase::bindCounterSet(VkCommandBuffer cmd, VkPipelineBindPoint point, VkPipelineLayout layout) {
  if (counterDescriptorSet_ == VK_NULL_HANDLE) return;
  // Dynamic offsets in binding order: the draw's counter region, the footprint bank.
  uint32_t offsets[2] = {};
  uint32_t dynamic = 0;
  if (countsDraws()) offsets[dynamic++] = uint32_t(uint64_t(counterRegion_) * regionSlots_ * sizeof(uint64_t));
  if (footprintOn()) offsets[dynamic++] = footprint_.bankOffset(footprintBank(point));
  vkCmdBindDescriptorSets(cmd, point, layout, counterSet_, 1, &counterDescriptorSet_, dynamic, offsets);
}

VkDescriptorSet RendererBase::geometrySetWith(const gpu::Buffer& materials, const gpu::Buffer& materialExtras) {
  VkDescriptorSet set = allocateSet(geometryLayout_);
  const gpu::Buffer* buffers[] = {&drawsBuffer(),  &materials, &vertexBuffer(), &indexBuffer(),
                                  &scene_->attributeBuffer(), &materialExtras};
  gpu::DescriptorWrite writes[6];
  for (uint32_t i = 0; i < 6; ++i) {
    writes[i].binding = i;
    writes[i].type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[i].buffer = {buffers[i]->buffer, 0, VK_WHOLE_SIZE};
  }
  gpu::updateDescriptorSet(*ctx_, set, writes);
  return set;
}

}  // namespace tally::renderers
