// The post passes every renderer shares after its own: bloom (its bright and
// blur passes, with bloom on), tonemap (hdr -> final) and skybox (the sky
// where no geometry is). Split from renderer_base.cpp: pass plumbing there,
// the passes here.
#include <stdexcept>

#include "renderers/techniques/bloom.hpp"
#include "renderers/renderer_base.hpp"
#include "shared.h"

namespace tally::renderers {

std::vector<std::string> RendererBase::bloomPassNames() const {
  switch (options_.bloom.blur) {
    case BloomBlur::Off: return {};
    case BloomBlur::Naive: return {"bloom_bright", "bloom_blur"};
    case BloomBlur::Separable:
    case BloomBlur::Bilinear: return {"bloom_bright", "bloom_blur_h", "bloom_blur_v"};
  }
  return {};
}

void RendererBase::setupBloom() {
  const BloomOptions& o = options_.bloom;
  if (o.blur == BloomBlur::Off) return;
  // Full resolution: every bloom target is the screen's size (createTarget),
  // so each pass shades one fragment per pixel and its reads are taps x pixels.
  // transfer_src: the tests read the targets back.
  const VkImageUsageFlags usage =
      VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  const gpu::Image* bright = createTarget("bloom_bright", kHdrFormat, usage, ResourceKind::Attachment);
  const bool twoPass = o.blur != BloomBlur::Naive;
  const gpu::Image* horizontal = twoPass ? createTarget("bloom_h", kHdrFormat, usage, ResourceKind::Attachment)
                                         : nullptr;
  bloom_ = createTarget("bloom", kHdrFormat, usage, ResourceKind::Attachment);
  VkRenderPass rp = ownRenderPass(createPassRenderPass(
      *ctx_,
      {{kHdrFormat, false, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
        VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL}},
      std::nullopt));
  VkDescriptorSetLayout inputLayout = setLayout({VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER});
  nlohmann::json tapsPerPixel = nlohmann::json::object();
  auto add = [&](const std::string& name, const gpu::Image& source, const std::string& sourceName,
                 const gpu::Image& target, const std::string& targetName, VkSampler sampler,
                 const std::vector<std::string>& defines, uint32_t taps) {
    uint32_t p = addPass(name);
    VkDescriptorSet input = allocateSet(inputLayout);
    writeImage(input, shaders::kBindingBloomSource, source.view, sampler, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    pass(p).bindings.bind(shaders::kSetPassInput, shaders::kBindingBloomSource, sourceName);
    pass(p).bindings.outputs[shaders::kOutColor] = targetName;
    VkFramebuffer fb = framebuffer(rp, {target.view});
    auto shaders = shaderPipeline(p, "fullscreen.vert.glsl", "bloom.frag.glsl",
                                  pipelineLayout(VK_NULL_HANDLE, inputLayout), rp, defines);
    if (!shaders) throw std::runtime_error(shaders.error());
    VkPipeline pipe = pipeline(*shaders);
    VkPipelineLayout layout = shaders->layout;
    pass(p).record = [=, this](VkCommandBuffer cmd) {
      beginRenderPass(cmd, p, rp, fb, {});
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipe);
      bindSets(cmd, layout, VK_NULL_HANDLE, input);
      drawFullScreen(cmd);
      endRenderPass(cmd, p);
    };
    tapsPerPixel[name] = taps;
  };
  add("bloom_bright", *hdr_, "hdr", *bright, "bloom_bright", targetSampler_,
      {"BLOOM_BRIGHT", "BLOOM_THRESHOLD " + glslFloat(o.threshold)}, 1);
  const std::vector<double> weights = gaussianWeights(o.taps);
  const std::string n = "BLOOM_TAPS " + std::to_string(o.taps);
  const std::string w = "BLOOM_WEIGHTS " + glslFloatArray(weights);
  const std::string h = "BLOOM_DIRECTION ivec2(1, 0)", v = "BLOOM_DIRECTION ivec2(0, 1)";
  switch (o.blur) {
    case BloomBlur::Off: break;
    case BloomBlur::Naive:
      add("bloom_blur", *bright, "bloom_bright", *bloom_, "bloom", targetSampler_, {"BLOOM_NAIVE", n, w},
          o.taps * o.taps);
      break;
    case BloomBlur::Separable:
      add("bloom_blur_h", *bright, "bloom_bright", *horizontal, "bloom_h", targetSampler_, {h, n, w}, o.taps);
      add("bloom_blur_v", *horizontal, "bloom_h", *bloom_, "bloom", targetSampler_, {v, n, w}, o.taps);
      break;
    case BloomBlur::Bilinear: {
      bloomSampler_ = gpu::createSampler(*ctx_, VK_FILTER_LINEAR, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE);
      std::vector<double> offsets, merged;
      for (const auto& t : linearTaps(weights)) {
        offsets.push_back(t.offset);
        merged.push_back(t.weight);
      }
      const uint32_t taps = uint32_t(merged.size());
      const std::vector<std::string> common = {"BLOOM_LINEAR", "BLOOM_TAPS " + std::to_string(taps),
                                               "BLOOM_WEIGHTS " + glslFloatArray(merged),
                                               "BLOOM_OFFSETS " + glslFloatArray(offsets)};
      auto with = [&](const std::string& direction) {
        auto d = common;
        d.push_back(direction);
        return d;
      };
      add("bloom_blur_h", *bright, "bloom_bright", *horizontal, "bloom_h", bloomSampler_, with(h), taps);
      add("bloom_blur_v", *horizontal, "bloom_h", *bloom_, "bloom", bloomSampler_, with(v), taps);
      break;
    }
  }
  tapsPerPixel["tonemap"] = 2;  // the HDR colour and the bloom
  bloomExtras_ = {{"variant", std::string(toString(o.blur))},
                  {"taps", o.taps},
                  {"sigma", bloomSigma(o.taps)},
                  {"threshold", o.threshold},
                  {"bloom_resolution", {extent_.width, extent_.height}},
                  {"taps_per_pixel", tapsPerPixel}};
}

void RendererBase::setupTonemapAndSkybox() {
  const VkImageLayout readOnlyDepth = VK_IMAGE_LAYOUT_DEPTH_STENCIL_READ_ONLY_OPTIMAL;
  // Tonemap: full screen, hdr (plus the bloom with bloom on) -> final. No
  // depth/stencil: every pixel.
  {
    uint32_t p = addPass("tonemap");
    std::vector<VkDescriptorType> inputs = {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER};
    if (bloom_ != nullptr) inputs.push_back(VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER);  // kBindingBloomTarget
    VkDescriptorSetLayout inputLayout = setLayout(inputs);
    VkDescriptorSet input = allocateSet(inputLayout);
    writeImage(input, shaders::kBindingHdrTarget, hdr_->view, targetSampler_,
               VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    pass(p).bindings.bind(shaders::kSetPassInput, shaders::kBindingHdrTarget, "hdr");
    std::vector<std::string> tonemapDefines;
    if (bloom_ != nullptr) {
      writeImage(input, shaders::kBindingBloomTarget, bloom_->view, targetSampler_,
                 VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
      pass(p).bindings.bind(shaders::kSetPassInput, shaders::kBindingBloomTarget, "bloom");
      tonemapDefines.push_back("BLOOM");
    }
    pass(p).bindings.outputs[shaders::kOutColor] = "final";
    VkRenderPass rp = ownRenderPass(createPassRenderPass(
        *ctx_,
        {{kFinalFormat, false, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
          // The skybox pass draws into it next; without one, finalImage() reads it.
          drawsSky() ? VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL : VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL}},
        std::nullopt));
    VkFramebuffer fb = framebuffer(rp, {final_->view});
    auto shaders = shaderPipeline(p, "fullscreen.vert.glsl", "tonemap.frag.glsl",
                                  pipelineLayout(VK_NULL_HANDLE, inputLayout), rp, tonemapDefines);
    if (!shaders) throw std::runtime_error(shaders.error());
    gpu::GraphicsPipelineDesc desc = *shaders;
    VkPipeline pipe = pipeline(desc);
    VkPipelineLayout layout = desc.layout;
    pass(p).record = [=, this](VkCommandBuffer cmd) {
      beginRenderPass(cmd, p, rp, fb, {});
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipe);
      bindSets(cmd, layout, VK_NULL_HANDLE, input);
      drawFullScreen(cmd);
      endRenderPass(cmd, p);
    };
  }
  // Skybox: the far plane where the stencil is 0 (no geometry), into final.
  if (drawsSky()) {
    uint32_t p = addPass("skybox");
    VkDescriptorSetLayout skyLayout = setLayout({VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER});
    VkDescriptorSet sky = allocateSet(skyLayout);
    writeImage(sky, shaders::kBindingSky, scene_->skyView(), scene_->skySampler(),
               VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    pass(p).bindings.bind(shaders::kSetMaterial, shaders::kBindingSky, "sky");
    pass(p).bindings.outputs[shaders::kOutColor] = "final";
    VkRenderPass rp = ownRenderPass(createPassRenderPass(
        *ctx_,
        {{kFinalFormat, false, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
          VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
          // The transparent pass blends into it next; without one, finalImage() reads it.
          hasTransparentPass() ? VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL : VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL}},
        AttachmentSpec{kDepthFormat, false, readOnlyDepth, readOnlyDepth, readOnlyDepth}));
    VkFramebuffer fb = framebuffer(rp, {final_->view, depth_->view});
    auto shaders = shaderPipeline(p, "skybox.vert.glsl", "skybox.frag.glsl", pipelineLayout(skyLayout, VK_NULL_HANDLE),
                                  rp);
    if (!shaders) throw std::runtime_error(shaders.error());
    gpu::GraphicsPipelineDesc desc = *shaders;
    desc.stencilTest = true;
    desc.stencilCompare = VK_COMPARE_OP_EQUAL;
    desc.stencilReference = 0;
    VkPipeline pipe = pipeline(desc);
    VkPipelineLayout layout = desc.layout;
    pass(p).record = [=, this](VkCommandBuffer cmd) {
      beginRenderPass(cmd, p, rp, fb, {});
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipe);
      bindSets(cmd, layout, sky, VK_NULL_HANDLE);
      drawFullScreen(cmd);
      endRenderPass(cmd, p);
    };
  }
  if (hasTransparentPass()) setupTransparentPass();
}

}  // namespace tally::renderers
