// What both compute workloads share: "hdr" written by one compute pass, read
// back for the per-pixel figures the pass leaves in its alpha channel. Only the
// workloads (volume_fog.cpp, raytrace.cpp) include it.
#pragma once

#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include <glm/gtc/packing.hpp>

#include "gpu/vk_check.hpp"
#include "renderers/renderer_base.hpp"
#include "renderers/workloads/workloads.hpp"

namespace tally::renderers {

class WorkloadBase : public RendererBase {
 public:
  std::vector<float> depthImage() override { return {}; }  // no depth is written

 protected:
  VkImageUsageFlags hdrExtraUsage() const override {
    // transfer_src: frameExtras reads the alpha channel's per-pixel figures.
    return VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  }
  bool drawsSky() const override { return false; }
  void destroyPasses() override {
    if (ctx_ == nullptr) return;
    for (auto* b : {&params_, &data_}) gpu::destroyBuffer(*ctx_, *b);
    if (sampler_ != VK_NULL_HANDLE) vkDestroySampler(ctx_->device, sampler_, nullptr);
    sampler_ = VK_NULL_HANDLE;
    if (volumeView_ != VK_NULL_HANDLE) vkDestroyImageView(ctx_->device, volumeView_, nullptr);
    if (volume_ != VK_NULL_HANDLE) vkDestroyImage(ctx_->device, volume_, nullptr);
    if (volumeMemory_ != VK_NULL_HANDLE) vkFreeMemory(ctx_->device, volumeMemory_, nullptr);
    volumeView_ = VK_NULL_HANDLE;
    volume_ = VK_NULL_HANDLE;
    volumeMemory_ = VK_NULL_HANDLE;
  }

  // A host-visible uniform or storage buffer with `bytes`, recorded as a resource.
  gpu::Buffer& buffer(gpu::Buffer& b, const std::string& name, const void* data, size_t size, uint32_t element,
                      bool storage) {
    b = gpu::createBuffer(*ctx_, size,
                          storage ? VK_BUFFER_USAGE_STORAGE_BUFFER_BIT : VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                          gpu::MemoryUse::Upload);
    gpu::uploadBuffer(*ctx_, b, {static_cast<const uint8_t*>(data), size});
    ResourceInfo info;
    info.name = name;
    info.kind = ResourceKind::Buffer;
    info.elementBytes = element;
    info.allocationBytes = b.size;
    info.usage = storage ? "storage" : "uniform";
    info.objects = {gpu::objectOf(b.buffer)};
    resources_.push_back(info);
    return b;
  }

  void writeBuffer(VkDescriptorSet set, uint32_t binding, VkDescriptorType type, const gpu::Buffer& b) {
    gpu::DescriptorWrite w;
    w.binding = binding;
    w.type = type;
    w.buffer = {b.buffer, 0, VK_WHOLE_SIZE};
    gpu::updateDescriptorSet(*ctx_, set, {&w, 1});
  }

  // The one compute pass: `file` with `defines`, set 3 = `layout`/`set`
  // (binding 0 the "hdr" storage image), one invocation per pixel in 8x8 groups.
  Result<bool> addComputePass(const std::string& name, const std::string& file,
                              const std::vector<std::string>& defines, VkDescriptorSetLayout layout,
                              VkDescriptorSet set) {
    uint32_t p = addPass(name);
    writeStorageImage(set, 0, hdr_->view);
    pass(p).bindings.bind(shaders::kSetPassInput, 0, "hdr");
    for (const auto& [binding, resource] : inputs_) pass(p).bindings.bind(shaders::kSetPassInput, binding, resource);
    VkPipelineLayout pipelineLayout = computePipelineLayout(VK_NULL_HANDLE, layout);
    auto pipe = computePipeline(p, file, pipelineLayout, defines);
    if (!pipe) return makeError(pipe.error());
    VkPipeline pipeline = *pipe;
    const uint32_t gx = (extent_.width + 7) / 8, gy = (extent_.height + 7) / 8;
    pass(p).record = [=, this](VkCommandBuffer cmd) {
      gpu::transitionImage(cmd, *hdr_, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL);
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
      bindComputeSets(cmd, pipelineLayout, VK_NULL_HANDLE, set);
      beginComputePass(cmd, p);
      vkCmdDispatch(cmd, gx, gy, 1);
      endComputePass(cmd, p);
      gpu::transitionImage(cmd, *hdr_, VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    };
    return true;
  }

  // The alpha channel of "hdr" after the last frame, one float per pixel.
  std::vector<float> hdrAlpha() {
    std::vector<uint8_t> bytes = targetBytes("hdr");
    std::vector<float> out(bytes.size() / 8);
    for (size_t i = 0; i < out.size(); ++i) {
      uint16_t half;
      std::memcpy(&half, bytes.data() + i * 8 + 6, 2);
      out[i] = glm::unpackHalf1x16(half);
    }
    return out;
  }

  std::vector<std::pair<uint32_t, std::string>> inputs_;  // set-3 bindings besides "hdr"
  gpu::Buffer params_, data_;
  VkImage volume_ = VK_NULL_HANDLE;
  VkDeviceMemory volumeMemory_ = VK_NULL_HANDLE;
  VkImageView volumeView_ = VK_NULL_HANDLE;
  VkSampler sampler_ = VK_NULL_HANDLE;
};

}  // namespace tally::renderers
