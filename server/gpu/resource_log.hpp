// What the renderers created and wrote into descriptor sets, as the
// footprint table needs it: each image view's geometry, each sampler's
// filters and address modes, each buffer's size, and every descriptor
// written. Kept per context; the gpu:: creation and update functions (and
// the renderers' own vkCreate* calls) record into it.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <tuple>

#include <vulkan/vulkan.h>

namespace tally::gpu {

struct ViewInfo {
  uint32_t width = 0, height = 0;  // the image's level 0
  uint32_t imageLevels = 1;
  uint32_t baseLevel = 0, levels = 1;  // the view's
  uint32_t layers = 1;                 // the view's (6 per cube)
  uint32_t texelBytes = 0;             // the view's format x samples
  VkImageViewType viewType = VK_IMAGE_VIEW_TYPE_2D;
};

struct SamplerInfo {
  uint32_t bits = 0;         // spirv::footprint sampler bits
  bool anisotropic = false;  // anisotropyEnable: footprints along the axis of anisotropy are not modelled
};

struct LoggedDescriptor {
  VkDescriptorType type = VK_DESCRIPTOR_TYPE_MAX_ENUM;
  VkImageView view = VK_NULL_HANDLE;
  VkSampler sampler = VK_NULL_HANDLE;
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceSize offset = 0, range = 0;
};

class ResourceLog {
 public:
  void view(VkImageView v, const ViewInfo& info) { views_[v] = info; }
  void view(VkImageView v, const VkImageCreateInfo& image, const VkImageViewCreateInfo& view);
  void sampler(VkSampler s, const VkSamplerCreateInfo& info);
  void buffer(VkBuffer b, VkDeviceSize size) { buffers_[b] = size; }
  void write(VkDescriptorSet set, uint32_t binding, uint32_t element, const LoggedDescriptor& d) {
    writes_[{set, binding, element}] = d;
  }

  const ViewInfo* view(VkImageView v) const;
  const SamplerInfo* sampler(VkSampler s) const;
  std::optional<VkDeviceSize> buffer(VkBuffer b) const;
  const LoggedDescriptor* written(VkDescriptorSet set, uint32_t binding, uint32_t element) const;

 private:
  std::map<VkImageView, ViewInfo> views_;
  std::map<VkSampler, SamplerInfo> samplers_;
  std::map<VkBuffer, VkDeviceSize> buffers_;
  std::map<std::tuple<VkDescriptorSet, uint32_t, uint32_t>, LoggedDescriptor> writes_;
};

}  // namespace tally::gpu
