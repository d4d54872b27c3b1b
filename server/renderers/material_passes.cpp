// What glTF materials add to the shared passes (docs/scenes.md, "Rendering"):
// the alpha-tested twin of a geometry pipeline for alphaMode MASK draws, the
// transparent pass for alphaMode BLEND draws, and the configurations that
// refuse a scene's features (scene_limits.hpp).
#include <stdexcept>

#include "renderers/renderer_base.hpp"
#include "renderers/scene_limits.hpp"
#include "shared.h"

namespace tally::renderers {

Result<RendererBase::DrawRecorder> RendererBase::maskedDraws(uint32_t passIndex, gpu::GraphicsPipelineDesc desc,
                                                             const std::string& vertex, const std::string& fragment,
                                                             const std::vector<std::string>& defines) {
  if (!scene_->features().alphaMask) return DrawRecorder{};
  std::vector<std::string> masked = defines;
  // After an alpha-tested depth pre-pass (depth EQUAL, no write) the depth
  // already holds the test's outcome: the masked draws keep early tests and
  // shade only the fragments the pre-pass kept.
  const bool afterPrepass = desc.depthTest && !desc.depthWrite && desc.depthCompare == VK_COMPARE_OP_EQUAL;
  if (!afterPrepass) masked.push_back("TALLY_ALPHA_TEST");
  auto vs = shader(passIndex, vertex, masked);
  if (!vs) return makeError(vs.error());
  auto fs = shader(passIndex, fragment, masked);
  if (!fs) return makeError(fs.error());
  desc.vertex = *vs;
  desc.fragment = *fs;
  desc.layout = pipelineLayout(materialLayout_, VK_NULL_HANDLE);
  VkPipeline pipe = pipeline(desc);
  VkPipelineLayout layout = desc.layout;
  // The test's diffuse read (alpha_test.h; the per-draw passes bind all five already).
  pass(passIndex).bindings.bind(shaders::kSetMaterial, shaders::kMapDiffuse, "material_maps.diffuse");
  return DrawRecorder([=, this](VkCommandBuffer cmd) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipe);
    bindSets(cmd, layout, VK_NULL_HANDLE, VK_NULL_HANDLE);
    drawScene(cmd, passIndex, layout, true, DrawSubset::Masked);
  });
}

std::string RendererBase::featureRefusal() const {
  return renderers::featureRefusal(name(), scene_->features(), options_);  // scene_limits.hpp
}

bool RendererBase::hasTransparentPass() const {
  return scene_ != nullptr && scene_->features().alphaBlend && drawsSky();
}

void RendererBase::setupTransparentPass() {
  uint32_t p = addPass("transparent");
  const VkImageLayout readOnlyDepth = VK_IMAGE_LAYOUT_DEPTH_STENCIL_READ_ONLY_OPTIMAL;
  VkRenderPass rp = ownRenderPass(createPassRenderPass(
      *ctx_,
      {{kFinalFormat, false, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
        VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL}},
      AttachmentSpec{kDepthFormat, false, readOnlyDepth, readOnlyDepth, readOnlyDepth}));
  VkFramebuffer fb = framebuffer(rp, {final_->view, depth_->view});
  auto shaders = shaderPipeline(p, "forward.vert.glsl", "forward.frag.glsl", pipelineLayout(materialLayout_, VK_NULL_HANDLE),
                                rp, {"TALLY_TRANSPARENT"});
  if (!shaders) throw std::runtime_error(shaders.error());
  gpu::GraphicsPipelineDesc desc = *shaders;
  meshVertexInput(desc);
  desc.depthTest = true;
  desc.depthWrite = false;
  desc.depthCompare = VK_COMPARE_OP_LESS;
  desc.blend = true;  // premultiplied: src + dst x (1 - src alpha), in linear (final is sRGB)
  VkPipeline pipe = pipeline(desc);
  VkPipelineLayout layout = desc.layout;
  for (uint32_t k = 0; k < scenes::kMapSlotCount; ++k) {
    pass(p).bindings.bind(shaders::kSetMaterial, k, std::string("material_maps.") + mapKindName(k));
  }
  if (scene_->features().emissiveMaps) {
    pass(p).bindings.bind(shaders::kSetMaterial, shaders::kBindingEmissiveMap, "material_maps.emissive");
  }
  pass(p).bindings.outputs[shaders::kOutColor] = "final";
  pass(p).indexFetches = true;
  pass(p).record = [=, this](VkCommandBuffer cmd) {
    beginRenderPass(cmd, p, rp, fb, {});
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipe);
    bindSets(cmd, layout, VK_NULL_HANDLE, VK_NULL_HANDLE);
    drawScene(cmd, p, layout, true, DrawSubset::Blend);
    endRenderPass(cmd, p);
  };
}

}  // namespace tally::renderers
