// Shading in compute (docs/techniques.md, "Shading in compute";
// RendererOptions::computeShading): the full-screen shading pass of deferred
// ("lighting") and the visibility buffers ("shading") as a compute dispatch.
// One invocation per pixel in 8x8 workgroups over the extent rounded up to
// whole groups; the shader returns past the edge, so the counted invocations
// (the entry point's site, before that check) and the pipeline statistic are
// both ceil(W/8)*8 x ceil(H/8)*8. Every in-image invocation stores "hdr" (the
// cleared value on sky pixels), so the target needs no clear and starts each
// frame from UNDEFINED.
#include "renderers/renderer_base.hpp"

namespace tally::renderers {

VkDescriptorSetLayout RendererBase::computeShadingInputLayout(uint32_t inputs) {
  // Bindings [inputs, kBindingHdrImage) are left out, not padded: a binding
  // the layout has must be written (lavapipe reads every one when binding).
  std::vector<VkDescriptorSetLayoutBinding> bindings;
  for (uint32_t i = 0; i <= inputs && i <= shaders::kBindingHdrImage; ++i) {
    VkDescriptorSetLayoutBinding b = {};
    b.binding = i < inputs ? i : shaders::kBindingHdrImage;
    b.descriptorType = i < inputs ? VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER : VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
    b.descriptorCount = 1;
    b.stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
    bindings.push_back(b);
  }
  ownedSetLayouts_.push_back(gpu::createDescriptorSetLayout(*ctx_, bindings));
  return ownedSetLayouts_.back();
}

VkImageUsageFlags RendererBase::computeShadingUsage() const {
  return options_.computeShading ? VkImageUsageFlags(VK_IMAGE_USAGE_STORAGE_BIT) : VkImageUsageFlags(0);
}

void RendererBase::computeShadingNotes(nlohmann::json& notes) const {
  if (!options_.computeShading) return;
  notes["shading"] = "compute";
  notes["workgroup"] = {kComputeShadingGroup, kComputeShadingGroup};
}

Result<bool> RendererBase::addComputeShading(uint32_t p, const std::string& file, VkDescriptorSetLayout material,
                                             VkDescriptorSet materialSet, VkDescriptorSetLayout inputLayout,
                                             VkDescriptorSet input, VkDescriptorSet geometry,
                                             const std::vector<std::string>& defines) {
  VkFormatProperties props = {};
  vkGetPhysicalDeviceFormatProperties(ctx_->physicalDevice, kHdrFormat, &props);
  if ((props.optimalTilingFeatures & VK_FORMAT_FEATURE_STORAGE_IMAGE_BIT) == 0) {
    return makeError(std::string(name()) + ": shading=compute needs R16G16B16A16_SFLOAT storage images " +
                     "(VK_FORMAT_FEATURE_STORAGE_IMAGE_BIT), which this device lacks");
  }
  writeStorageImage(input, shaders::kBindingHdrImage, hdr_->view);
  pass(p).bindings.bind(shaders::kSetPassInput, shaders::kBindingHdrImage, "hdr");
  VkPipelineLayout layout = computePipelineLayout(material, inputLayout);
  auto pipe = computePipeline(p, file, layout, defines);
  if (!pipe) return makeError(pipe.error());
  const VkPipeline pipeline = *pipe;
  const uint32_t groupsX = (extent_.width + kComputeShadingGroup - 1) / kComputeShadingGroup;
  const uint32_t groupsY = (extent_.height + kComputeShadingGroup - 1) / kComputeShadingGroup;
  const gpu::Image* hdr = hdr_;
  pass(p).record = [=, this](VkCommandBuffer cmd) {
    // Every pixel is stored: the old contents need not survive.
    gpu::transitionImage(cmd, *hdr, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL);
    beginComputePass(cmd, p);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
    bindComputeSets(cmd, layout, materialSet, input, geometry);
    vkCmdDispatch(cmd, groupsX, groupsY, 1);
    endComputePass(cmd, p);
    // Tonemap and bloom sample it there.
    gpu::transitionImage(cmd, *hdr, VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  };
  return true;
}

}  // namespace tally::renderers
