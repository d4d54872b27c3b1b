// Deferred shading: the G-buffer pass samples the draw's five maps per
// fragment that passes the early depth test and writes normal (RGBA16F),
// diffuse and specular (RGBA8) plus D32_S8 depth/stencil; the lighting pass
// (full screen, stencil == 1) reads one texel of each per covered pixel,
// reconstructs position from depth and shades every light.
// zprepass=true: a depth-only "zprepass" pass (forward-zprepass's) first, then
// the G-buffer pass tests depth EQUAL without writing it: one G-buffer
// fragment per covered pixel.
#include "renderers/renderers.hpp"
#include "shared.h"

namespace tally::renderers {
namespace {

constexpr VkFormat kNormalFormat = VK_FORMAT_R16G16B16A16_SFLOAT;
constexpr VkFormat kDiffuseFormat = VK_FORMAT_R8G8B8A8_UNORM;
constexpr VkFormat kSpecularFormat = VK_FORMAT_R8G8B8A8_UNORM;

class DeferredRenderer final : public RendererBase {
 public:
  std::string_view name() const override { return "deferred"; }

 protected:
  std::vector<std::string> ownPassNames() const override {
    if (options_.zprepass) return {"zprepass", "gbuffer", "lighting"};
    return {"gbuffer", "lighting"};
  }
  nlohmann::json notes() const override {
    if (!options_.zprepass) return nlohmann::json::object();
    // As forward-zprepass: the counting-only fragment shader gives the pre-pass's depth writes.
    return {{"zprepass_fragment_shader", options_.instrumented ? "counting_only" : "none"}};
  }

  Result<bool> setupPasses() override {
    for (auto& r : scene_->materialMapResources()) resources_.push_back(r);
    const VkImageUsageFlags usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT;
    const gpu::Image* normal = createTarget("gbuffer.normal", kNormalFormat, usage, ResourceKind::Attachment);
    const gpu::Image* diffuse =
        createTarget("gbuffer.diffuse", kDiffuseFormat, usage, ResourceKind::Attachment);
    const gpu::Image* specular =
        createTarget("gbuffer.specular", kSpecularFormat, usage, ResourceKind::Attachment);
    const VkImageLayout depthAttachment = VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
    const VkImageLayout depthReadOnly = VK_IMAGE_LAYOUT_DEPTH_STENCIL_READ_ONLY_OPTIMAL;
    const VkImageLayout shaderRead = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;

    const bool prepass = options_.zprepass;
    // Depth pre-pass: position only, as forward-zprepass.
    if (prepass) {
      if (auto ok = addDepthPrepass(); !ok) return ok;
    }
    // G-buffer.
    {
      uint32_t p = addPass("gbuffer");
      AttachmentSpec depth{kDepthFormat, true, VK_IMAGE_LAYOUT_UNDEFINED, depthAttachment, depthReadOnly};
      if (prepass) depth = {kDepthFormat, false, depthAttachment, depthAttachment, depthReadOnly};
      VkRenderPass rp = ownRenderPass(createPassRenderPass(
          *ctx_, {{kNormalFormat}, {kDiffuseFormat}, {kSpecularFormat}}, depth));
      VkFramebuffer fb = framebuffer(rp, {normal->view, diffuse->view, specular->view, depth_->view});
      auto shaders = shaderPipeline(p, "gbuffer.vert.glsl", "gbuffer.frag.glsl",
                                    pipelineLayout(materialLayout_, VK_NULL_HANDLE), rp);
      if (!shaders) return makeError(shaders.error());
      gpu::GraphicsPipelineDesc desc = *shaders;
      desc.colorAttachmentCount = 3;
      meshVertexInput(desc);
      geometryState(desc, !prepass);
      if (prepass) desc.depthCompare = VK_COMPARE_OP_EQUAL;  // bit-identical depth (`invariant`)
      VkPipeline pipe = pipeline(desc);
      VkPipelineLayout layout = desc.layout;
      for (uint32_t k = 0; k < scenes::kMapSlotCount; ++k) {
        pass(p).bindings.bind(shaders::kSetMaterial, k, std::string("material_maps.") + mapKindName(k));
      }
      pass(p).bindings.outputs[shaders::kOutNormal] = "gbuffer.normal";
      pass(p).bindings.outputs[shaders::kOutDiffuse] = "gbuffer.diffuse";
      pass(p).bindings.outputs[shaders::kOutSpecular] = "gbuffer.specular";
      if (!prepass) pass(p).depthWrite = "depth";
      pass(p).indexFetches = true;
      pass(p).record = [=, this](VkCommandBuffer cmd) {
        std::vector<VkClearValue> clears(4);
        clears[3] = depthClear();
        beginRenderPass(cmd, p, rp, fb, clears);
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipe);
        bindSets(cmd, layout, VK_NULL_HANDLE, VK_NULL_HANDLE);
        drawScene(cmd, p, layout, true);
        endRenderPass(cmd, p);
      };
    }
    // Lighting: full screen, stencil == 1 (geometry), depth attached read-only.
    {
      uint32_t p = addPass("lighting");
      using T = VkDescriptorType;
      const T image = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
      VkDescriptorSetLayout inputLayout = setLayout({image, image, image, image});
      VkDescriptorSet input = allocateSet(inputLayout);
      writeImage(input, shaders::kBindingDepthTarget, depthOnlyView(), targetSampler_, depthReadOnly);
      writeImage(input, shaders::kBindingNormalTarget, normal->view, targetSampler_, shaderRead);
      writeImage(input, shaders::kBindingDiffuseTarget, diffuse->view, targetSampler_, shaderRead);
      writeImage(input, shaders::kBindingSpecularTarget, specular->view, targetSampler_, shaderRead);
      auto& b = pass(p).bindings;
      b.bind(shaders::kSetPassInput, shaders::kBindingDepthTarget, "depth");
      b.elementBytes[{shaders::kSetPassInput, shaders::kBindingDepthTarget}] = 4;  // the D32 depth aspect
      b.bind(shaders::kSetPassInput, shaders::kBindingNormalTarget, "gbuffer.normal");
      b.bind(shaders::kSetPassInput, shaders::kBindingDiffuseTarget, "gbuffer.diffuse");
      b.bind(shaders::kSetPassInput, shaders::kBindingSpecularTarget, "gbuffer.specular");
      b.outputs[shaders::kOutColor] = "hdr";
      VkRenderPass rp = ownRenderPass(createPassRenderPass(
          *ctx_, {{kHdrFormat}},
          AttachmentSpec{kDepthFormat, false, depthReadOnly, depthReadOnly, depthReadOnly}));
      VkFramebuffer fb = framebuffer(rp, {hdr_->view, depth_->view});
      auto shaders = shaderPipeline(p, "fullscreen.vert.glsl", "lighting.frag.glsl",
                                    pipelineLayout(VK_NULL_HANDLE, inputLayout), rp);
      if (!shaders) return makeError(shaders.error());
      gpu::GraphicsPipelineDesc desc = *shaders;
      geometryPixelsOnly(desc);
      VkPipeline pipe = pipeline(desc);
      VkPipelineLayout layout = desc.layout;
      pass(p).record = [=, this](VkCommandBuffer cmd) {
        beginRenderPass(cmd, p, rp, fb, {VkClearValue{}, depthClear()});
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipe);
        bindSets(cmd, layout, VK_NULL_HANDLE, input);
        drawFullScreen(cmd);
        endRenderPass(cmd, p);
      };
    }
    return true;
  }
};

}  // namespace

std::unique_ptr<Renderer> makeDeferred() { return std::make_unique<DeferredRenderer>(); }

}  // namespace tally::renderers
