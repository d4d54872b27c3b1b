#include "gpu/resource_log.hpp"

#include <algorithm>

#include "gpu/footprint.hpp"
#include "gpu/resources.hpp"

namespace tally::gpu {

void ResourceLog::view(VkImageView v, const VkImageCreateInfo& image, const VkImageViewCreateInfo& view) {
  ViewInfo info;
  info.width = image.extent.width;
  info.height = image.extent.height;
  info.imageLevels = image.mipLevels;
  info.baseLevel = view.subresourceRange.baseMipLevel;
  info.levels = view.subresourceRange.levelCount == VK_REMAINING_MIP_LEVELS
                    ? image.mipLevels - info.baseLevel
                    : view.subresourceRange.levelCount;
  info.layers = view.subresourceRange.layerCount == VK_REMAINING_ARRAY_LAYERS
                    ? image.arrayLayers - view.subresourceRange.baseArrayLayer
                    : view.subresourceRange.layerCount;
  // The view's aspect decides the texel: the depth of D32_S8 is 4 bytes.
  uint32_t bytes = formatBytes(view.format);
  if (view.subresourceRange.aspectMask == VK_IMAGE_ASPECT_DEPTH_BIT &&
      (view.format == VK_FORMAT_D32_SFLOAT_S8_UINT || view.format == VK_FORMAT_D32_SFLOAT)) {
    bytes = 4;
  }
  info.texelBytes = bytes * std::max<uint32_t>(uint32_t(image.samples), 1u);
  info.viewType = view.viewType;
  views_[v] = info;
}

void ResourceLog::sampler(VkSampler s, const VkSamplerCreateInfo& info) {
  samplers_[s] = {samplerBits(info), info.anisotropyEnable == VK_TRUE && info.maxAnisotropy > 1.0f};
}

const ViewInfo* ResourceLog::view(VkImageView v) const {
  auto it = views_.find(v);
  return it == views_.end() ? nullptr : &it->second;
}

const SamplerInfo* ResourceLog::sampler(VkSampler s) const {
  auto it = samplers_.find(s);
  return it == samplers_.end() ? nullptr : &it->second;
}

std::optional<VkDeviceSize> ResourceLog::buffer(VkBuffer b) const {
  auto it = buffers_.find(b);
  if (it == buffers_.end()) return std::nullopt;
  return it->second;
}

const LoggedDescriptor* ResourceLog::written(VkDescriptorSet set, uint32_t binding, uint32_t element) const {
  auto it = writes_.find({set, binding, element});
  return it == writes_.end() ? nullptr : &it->second;
}

}  // namespace tally::gpu
