// Forward rendering: one geometry pass samples the draw's five maps and
// shades every light per fragment that passes the early depth test.
// "forward-zprepass" first lays depth down with a position-only pass, so the
// forward pass (depth EQUAL, no depth write) shades each covered pixel once.
#include "renderers/renderers.hpp"
#include "shared.h"

namespace tally::renderers {
namespace {

class ForwardRenderer final : public RendererBase {
 public:
  explicit ForwardRenderer(bool prepass) : prepass_(prepass) {}
  std::string_view name() const override { return prepass_ ? "forward-zprepass" : "forward"; }
  nlohmann::json notes() const override {
    if (!prepass_) return nlohmann::json::object();
    // Instrumented runs give the pre-pass an empty fragment shader
    // (zprepass.frag) so that its depth writes are counted; the timing twin
    // stays depth-only.
    return {{"zprepass_fragment_shader", options_.instrumented ? "counting_only" : "none"}};
  }

 protected:
  std::vector<std::string> ownPassNames() const override {
    if (prepass_) return {"zprepass", "forward"};
    return {"forward"};
  }

  Result<bool> setupPasses() override {
    for (auto& r : scene_->materialMapResources()) resources_.push_back(r);
    const VkImageLayout depthAttachment = VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
    const VkImageLayout depthReadOnly = VK_IMAGE_LAYOUT_DEPTH_STENCIL_READ_ONLY_OPTIMAL;
    if (prepass_) {
      uint32_t p = addPass("zprepass");
      VkRenderPass rp = ownRenderPass(createPassRenderPass(
          *ctx_, {},
          AttachmentSpec{kDepthFormat, true, VK_IMAGE_LAYOUT_UNDEFINED, depthAttachment, depthAttachment}));
      VkFramebuffer fb = framebuffer(rp, {depth_->view});
      auto vs = shader(p, "zprepass.vert.glsl");
      if (!vs) return makeError(vs.error());
      gpu::GraphicsPipelineDesc desc;
      desc.vertex = *vs;
      if (options_.instrumented) {
        auto fs = shader(p, "zprepass.frag.glsl");
        if (!fs) return makeError(fs.error());
        desc.fragment = *fs;
      }
      desc.layout = pipelineLayout(VK_NULL_HANDLE, VK_NULL_HANDLE);
      desc.renderPass = rp;
      desc.colorAttachmentCount = 0;
      meshVertexInput(desc);
      geometryState(desc, true);
      VkPipeline pipe = pipeline(desc);
      VkPipelineLayout layout = desc.layout;
      pass(p).indexFetches = true;
      pass(p).depthWrite = "depth";
      pass(p).record = [=, this](VkCommandBuffer cmd) {
        beginRenderPass(cmd, p, rp, fb, {depthClear()});
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipe);
        bindSets(cmd, layout, VK_NULL_HANDLE, VK_NULL_HANDLE);
        drawScene(cmd, p, layout, false);
        endRenderPass(cmd, p);
      };
    }
    uint32_t p = addPass("forward");
    AttachmentSpec depth{kDepthFormat, true, VK_IMAGE_LAYOUT_UNDEFINED, depthAttachment, depthReadOnly};
    if (prepass_) depth = {kDepthFormat, false, depthAttachment, depthAttachment, depthReadOnly};
    VkRenderPass rp = ownRenderPass(createPassRenderPass(*ctx_, {{kHdrFormat}}, depth));
    VkFramebuffer fb = framebuffer(rp, {hdr_->view, depth_->view});
    auto shaders = shaderPipeline(p, "forward.vert.glsl", "forward.frag.glsl",
                                  pipelineLayout(materialLayout_, VK_NULL_HANDLE), rp);
    if (!shaders) return makeError(shaders.error());
    gpu::GraphicsPipelineDesc desc = *shaders;
    meshVertexInput(desc);
    geometryState(desc, !prepass_);
    if (prepass_) desc.depthCompare = VK_COMPARE_OP_EQUAL;  // bit-identical depth (`invariant`)
    VkPipeline pipe = pipeline(desc);
    VkPipelineLayout layout = desc.layout;
    for (uint32_t k = 0; k < scenes::kMapSlotCount; ++k) {
      pass(p).bindings.bind(shaders::kSetMaterial, k, std::string("material_maps.") + mapKindName(k));
    }
    pass(p).bindings.outputs[shaders::kOutColor] = "hdr";
    pass(p).indexFetches = true;
    if (!prepass_) pass(p).depthWrite = "depth";
    pass(p).record = [=, this](VkCommandBuffer cmd) {
      std::vector<VkClearValue> clears(2);
      clears[1] = depthClear();
      beginRenderPass(cmd, p, rp, fb, clears);
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipe);
      bindSets(cmd, layout, VK_NULL_HANDLE, VK_NULL_HANDLE);
      drawScene(cmd, p, layout, true);
      endRenderPass(cmd, p);
    };
    return true;
  }

 private:
  bool prepass_;
};

}  // namespace

std::unique_ptr<Renderer> makeForward(bool prepass) { return std::make_unique<ForwardRenderer>(prepass); }

}  // namespace tally::renderers
