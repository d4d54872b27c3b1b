// RendererBase: drawing the scene (per draw, per subset, each with its cull
// mode), the shared depth pre-pass and the full-screen shading pass.
#include "renderers/renderer_base.hpp"

#include "gpu/vk_check.hpp"
#include "renderers/techniques/msaa.hpp"
#include "shared.h"

namespace tally::renderers {

Result<bool> RendererBase::addDepthPrepass() {
  const VkImageLayout depthAttachment = VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
  uint32_t p = addPass("zprepass");
  VkRenderPass rp = ownRenderPass(createPassRenderPass(
      *ctx_, {}, AttachmentSpec{kDepthFormat, true, VK_IMAGE_LAYOUT_UNDEFINED, depthAttachment, depthAttachment}));
  VkFramebuffer fb = framebuffer(rp, {depth_->view});
  auto depthOnly = depthOnlyPipeline(p, "zprepass.vert.glsl", rp);
  if (!depthOnly) return makeError(depthOnly.error());
  gpu::GraphicsPipelineDesc desc = *depthOnly;
  geometryState(desc, true);
  VkPipeline pipe = pipeline(desc);
  VkPipelineLayout layout = desc.layout;
  pass(p).indexFetches = true;
  pass(p).depthWrite = "depth";
  auto masked = maskedDraws(p, desc, "zprepass.vert.glsl", "zprepass.frag.glsl");
  if (!masked) return makeError(masked.error());
  pass(p).record = [=, this, masked = *masked](VkCommandBuffer cmd) {
    beginRenderPass(cmd, p, rp, fb, {depthClear()});
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipe);
    bindSets(cmd, layout, VK_NULL_HANDLE, VK_NULL_HANDLE);
    drawScene(cmd, p, layout, false);
    if (masked) masked(cmd);
    endRenderPass(cmd, p);
  };
  return true;
}

void RendererBase::drawScene(VkCommandBuffer cmd, uint32_t passIndex, VkPipelineLayout layout,
                             bool materialSets, DrawSubset subset) {
  VkDeviceSize offsets[2] = {0, 0};
  VkBuffer vbs[2] = {vertexBuffer().buffer, scene_->attributeBuffer().buffer};
  const auto& f = scene_->features();
  vkCmdBindVertexBuffers(cmd, 0, f.vertexColors || f.uv1 ? 2 : 1, vbs, offsets);
  vkCmdBindIndexBuffer(cmd, indexBuffer().buffer, 0, VK_INDEX_TYPE_UINT32);
  const auto& draws = scene_->draws();
  std::vector<uint32_t> order;
  for (uint32_t i = 0; i < draws.size(); ++i)
    if (inSubset(draws[i], subset)) order.push_back(i);
  if (subset == DrawSubset::Blend) {  // back to front from this frame's eye, by the draws' centres
    const glm::vec3 eye(frameCamera_.position);
    std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
      return glm::length(draws[a].center - eye) > glm::length(draws[b].center - eye);
    });
  }
  for (uint32_t i : order) {
    GpuDraw d = draws[i];
    if (dynamicCull_) vkCmdSetCullMode(cmd, d.doubleSided ? VK_CULL_MODE_NONE : VK_CULL_MODE_BACK_BIT);
    if (lod_) {  // the level chosen for this frame (LodSelection::select)
      d.firstIndex = lod_->chosen(i).firstIndex;
      d.indexCount = lod_->chosen(i).indexCount;
    }
    if (materialSets) {
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout, shaders::kSetMaterial, 1,
                              &materialSets_[d.material], 0, nullptr);
      // the draw's maps: its own bank of the footprint table
      if (footprintOn()) boundSets_[0][shaders::kSetMaterial] = materialSets_[d.material];
    }
    if (countsDraws()) {  // the draw's own counter region (base_draw_counts.cpp)
      counterRegion_ = drawRegion(i);
      passes_[passIndex].drawsRecorded.push_back(i);
    }
    if (countsDraws() || (materialSets && footprintOn())) bindCounterSet(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout);
    shaders::DrawPush push = {i, d.material};
    vkCmdPushConstants(cmd, layout, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof push,
                       &push);
    vkCmdDrawIndexed(cmd, d.indexCount, 1, d.firstIndex, d.vertexOffset, 0);
    passes_[passIndex].indicesDrawn += d.indexCount;
    passes_[passIndex].indexRanges.emplace_back(d.firstIndex, d.indexCount);
  }
  if (countsDraws() && !order.empty()) {  // later work of the pass counts outside draws
    counterRegion_ = 0;
    bindCounterSet(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout);
  }
}

const gpu::Buffer& RendererBase::vertexBuffer() const {
  return packedVertices_ ? packedVertices_->buffer : scene_->vertices();
}

const gpu::Buffer& RendererBase::indexBuffer() const { return lod_ ? lod_->indexBuffer() : scene_->indices(); }

const gpu::Buffer& RendererBase::drawsBuffer() const { return lod_ ? lod_->drawBuffer() : scene_->drawBuffer(); }

Result<bool> RendererBase::addFullScreenShading(uint32_t passIndex, const std::string& fragment,
                                                VkDescriptorSetLayout material, VkDescriptorSet materialSet,
                                                VkDescriptorSetLayout inputLayout, VkDescriptorSet input,
                                                VkDescriptorSet geometry, std::vector<std::string> defines) {
  const uint32_t p = passIndex;
  const bool msaa = options_.msaa > 1;
  if (msaa) defines.push_back("TALLY_MSAA " + std::to_string(options_.msaa));
  const VkImageLayout depthReadOnly = VK_IMAGE_LAYOUT_DEPTH_STENCIL_READ_ONLY_OPTIMAL;
  // msaa: the 1-sample "depth" is cleared here and gets the stencil mask (msaa.hpp).
  const AttachmentSpec depth =
      msaa ? AttachmentSpec{kDepthFormat, true, VK_IMAGE_LAYOUT_UNDEFINED,
                            VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL, depthReadOnly}
           : AttachmentSpec{kDepthFormat, false, depthReadOnly, depthReadOnly, depthReadOnly};
  VkRenderPass rp = ownRenderPass(createPassRenderPass(*ctx_, {{kHdrFormat}}, depth));
  VkFramebuffer fb = framebuffer(rp, {hdr_->view, depth_->view});
  auto shaders =
      shaderPipeline(p, "fullscreen.vert.glsl", fragment, pipelineLayout(material, inputLayout), rp, defines);
  if (!shaders) return makeError(shaders.error());
  gpu::GraphicsPipelineDesc desc = *shaders;
  if (msaa) {
    msaaResolveState(desc);
  } else {
    geometryPixelsOnly(desc);
  }
  VkPipeline pipe = pipeline(desc);
  VkPipelineLayout layout = desc.layout;
  pass(p).bindings.outputs[shaders::kOutColor] = "hdr";
  pass(p).record = [=, this](VkCommandBuffer cmd) {
    beginRenderPass(cmd, p, rp, fb, {VkClearValue{}, depthClear()});
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipe);
    bindSets(cmd, layout, materialSet, input, geometry);
    drawFullScreen(cmd);
    endRenderPass(cmd, p);
  };
  return true;
}

}  // namespace tally::renderers
