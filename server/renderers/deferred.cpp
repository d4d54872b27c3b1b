// Deferred shading: the G-buffer pass samples the draw's five maps per
// fragment that passes the early depth test and writes normal (RGBA16F),
// diffuse and specular (RGBA8) plus D32_S8 depth/stencil; the lighting pass
// (full screen, stencil == 1) reads one texel of each per covered pixel,
// reconstructs position from depth and shades every light.
// zprepass=true: a depth-only "zprepass" pass (forward-zprepass's) first, then
// the G-buffer pass tests depth EQUAL without writing it: one G-buffer
// fragment per covered pixel.
// msaa=N > 1 (renderers/techniques/msaa.hpp): the G-buffer targets and "depth.msaa" have
// N samples; the lighting pass (no stencil test) fetches every sample's depth,
// and the G-buffer texels of the covered ones (depth < 1), shades each covered
// sample and averages them into the 1-sample "hdr"; it discards pixels with no
// covered sample and marks the others with stencil 1 in the 1-sample "depth".
// gbuffer=subpass (docs/techniques.md, "Tile memory"): the G-buffer and
// lighting passes are the two subpasses of one render pass; the G-buffer
// targets are transient (lazily allocated where the device has such memory),
// cleared and never stored, and the lighting subpass reads them and the depth
// aspect with subpassLoad (lighting_subpass.frag).
#include "gpu/vk_check.hpp"
#include "renderers/techniques/msaa.hpp"
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
  ~DeferredRenderer() override { destroy(); }
  nlohmann::json frameExtras() override {
    nlohmann::json extras = RendererBase::frameExtras();
    if (options_.msaa > 1) extras["msaa"] = msaaExtras(resources_, options_.msaa);
    return extras;
  }

 protected:
  std::vector<std::string> ownPassNames() const override {
    if (options_.zprepass) return {"zprepass", "gbuffer", "lighting"};
    return {"gbuffer", "lighting"};
  }
  nlohmann::json notes() const override {
    nlohmann::json notes = nlohmann::json::object();
    // As forward-zprepass: the counting-only fragment shader gives the pre-pass's depth writes.
    if (options_.zprepass) notes["zprepass_fragment_shader"] = options_.instrumented ? "counting_only" : "none";
    computeShadingNotes(notes);
    if (options_.gbufferSubpass) {
      notes["gbuffer"] = "subpass";
      notes["gbuffer_memory"] = gbufferMemory_;
      // Timestamps bracket whole records, outside render passes: "gbuffer"
      // records the one render pass of both subpasses; lighting reports 0.
      notes["timing"] = "gbuffer_ms_covers_both_subpasses";
    }
    return notes;
  }

  VkImageUsageFlags hdrExtraUsage() const override { return computeShadingUsage(); }

  void destroyPasses() override {
    if (msaaDepthView_ != VK_NULL_HANDLE) vkDestroyImageView(ctx_->device, msaaDepthView_, nullptr);
    msaaDepthView_ = VK_NULL_HANDLE;
    if (subpassPool_ != VK_NULL_HANDLE) vkDestroyDescriptorPool(ctx_->device, subpassPool_, nullptr);
    if (subpassLayout_ != VK_NULL_HANDLE) vkDestroyDescriptorSetLayout(ctx_->device, subpassLayout_, nullptr);
    subpassPool_ = VK_NULL_HANDLE;
    subpassLayout_ = VK_NULL_HANDLE;
  }
  FrameResult finishFrame(FrameResult frame) override {
    for (auto& p : frame.passes) {
      // gbuffer=subpass: lighting records nothing of its own (notes()["timing"]).
      if (p.name == "lighting" && options_.gbufferSubpass) p.gpuMs = 0;
      if (p.name == "gbuffer") scaleSampleWrites(p, resources_, options_.msaa);
    }
    return frame;
  }

  Result<bool> setupPasses() override {
    for (auto& r : scene_->materialMapResources()) resources_.push_back(r);
    const VkImageUsageFlags usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT;
    const uint32_t n = options_.msaa;
    const bool msaa = n > 1;
    const auto samples = VkSampleCountFlagBits(n);
    if (options_.computeShading && (msaa || options_.gbufferSubpass)) {
      return makeError(options_.gbufferSubpass
                           ? "deferred: shading=compute with gbuffer=subpass is not supported (subpassLoad is "
                             "fragment-only)"
                           : "deferred: shading=compute with msaa " + std::to_string(n) + " is not supported");
    }
    if (options_.gbufferSubpass) {
      if (msaa) return makeError("deferred: gbuffer=subpass with msaa " + std::to_string(n) + " is not supported");
      return setupSubpassPasses();
    }
    if (msaa && options_.zprepass) {
      return makeError("deferred: msaa " + std::to_string(n) +
                       " with zprepass=true is not supported (the depth pre-pass renders at 1 sample)");
    }
    if (auto why = msaaUnsupported(*ctx_, n, {{kNormalFormat, usage}, {kDiffuseFormat, usage}, {kSpecularFormat, usage}},
                                   true);
        !why.empty()) {
      return makeError("deferred: " + why);
    }
    const gpu::Image* normal =
        createTarget("gbuffer.normal", kNormalFormat, usage, ResourceKind::Attachment, n);
    const gpu::Image* diffuse =
        createTarget("gbuffer.diffuse", kDiffuseFormat, usage, ResourceKind::Attachment, n);
    const gpu::Image* specular =
        createTarget("gbuffer.specular", kSpecularFormat, usage, ResourceKind::Attachment, n);
    // glTF emission (featureRefusal: 1 sample, fragment lighting): a fourth target.
    const bool emissive = scene_->features().emissive;
    const gpu::Image* emission =
        emissive ? createTarget("gbuffer.emissive", kHdrFormat, usage, ResourceKind::Attachment) : nullptr;
    // The geometry pass's depth: "depth" itself at 1 sample, else an N-sample one.
    const gpu::Image* geometryDepth =
        msaa ? createTarget(kMsaaDepthName, kDepthFormat,
                            VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT,
                            ResourceKind::Depth, n)
             : depth_;
    const std::string geometryDepthName = msaa ? kMsaaDepthName : "depth";
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
      depth.samples = samples;
      std::vector<AttachmentSpec> colors = {{kNormalFormat}, {kDiffuseFormat}, {kSpecularFormat}};
      std::vector<VkImageView> views = {normal->view, diffuse->view, specular->view};
      if (emissive) {
        colors.push_back({kHdrFormat});
        views.push_back(emission->view);
      }
      for (auto& c : colors) c.samples = samples;
      views.push_back(geometryDepth->view);
      VkRenderPass rp = ownRenderPass(createPassRenderPass(*ctx_, colors, depth));
      VkFramebuffer fb = framebuffer(rp, views);
      auto g = gbufferPipeline(p, rp, uint32_t(colors.size()), samples, geometryDepthName);
      if (!g) return makeError(g.error());
      const size_t clearCount = colors.size() + 1;
      pass(p).record = [=, this, g = *g](VkCommandBuffer cmd) {
        std::vector<VkClearValue> clears(clearCount);
        clears.back() = depthClear();
        beginRenderPass(cmd, p, rp, fb, clears);
        recordGbuffer(cmd, p, g);
        endRenderPass(cmd, p);
      };
    }
    // Lighting: full screen, stencil == 1 (geometry), depth attached read-only.
    {
      uint32_t p = addPass("lighting");
      using T = VkDescriptorType;
      const T image = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
      // shading=compute: the same four inputs and "hdr" as a storage image (compute_shading.cpp).
      VkDescriptorSetLayout inputLayout =
          options_.computeShading ? computeShadingInputLayout(4)
          : emissive              ? setLayout({image, image, image, image, image})  // + kBindingEmissiveTarget
                                  : setLayout({image, image, image, image});
      VkDescriptorSet input = allocateSet(inputLayout);
      if (msaa) msaaDepthView_ = depthAspectView(*ctx_, *geometryDepth);
      writeImage(input, shaders::kBindingDepthTarget, msaa ? msaaDepthView_ : depthOnlyView(), targetSampler_,
                 depthReadOnly);
      writeImage(input, shaders::kBindingNormalTarget, normal->view, targetSampler_, shaderRead);
      writeImage(input, shaders::kBindingDiffuseTarget, diffuse->view, targetSampler_, shaderRead);
      writeImage(input, shaders::kBindingSpecularTarget, specular->view, targetSampler_, shaderRead);
      auto& b = pass(p).bindings;
      b.bind(shaders::kSetPassInput, shaders::kBindingDepthTarget, geometryDepthName);
      b.elementBytes[{shaders::kSetPassInput, shaders::kBindingDepthTarget}] = 4;  // the D32 depth aspect
      b.bind(shaders::kSetPassInput, shaders::kBindingNormalTarget, "gbuffer.normal");
      b.bind(shaders::kSetPassInput, shaders::kBindingDiffuseTarget, "gbuffer.diffuse");
      b.bind(shaders::kSetPassInput, shaders::kBindingSpecularTarget, "gbuffer.specular");
      if (emissive) {
        writeImage(input, shaders::kBindingEmissiveTarget, emission->view, targetSampler_, shaderRead);
        b.bind(shaders::kSetPassInput, shaders::kBindingEmissiveTarget, "gbuffer.emissive");
      }
      if (options_.computeShading) {
        return addComputeShading(p, "lighting.comp.glsl", VK_NULL_HANDLE, VK_NULL_HANDLE, inputLayout, input,
                                 VK_NULL_HANDLE);
      }
      return addFullScreenShading(p, "lighting.frag.glsl", VK_NULL_HANDLE, VK_NULL_HANDLE, inputLayout, input,
                                  VK_NULL_HANDLE);
    }
  }

 private:
  Result<bool> setupSubpassPasses();

  // The G-buffer pass as both layouts build it: its pipeline on subpass 0 of
  // `rp` with `colors` color attachments (normal, diffuse, specular[,
  // emissive]), the masked twin, and the pass's bindings (material maps,
  // outputs, the depth it writes unless a pre-pass did).
  struct Gbuffer {
    VkPipeline pipeline = VK_NULL_HANDLE;
    VkPipelineLayout layout = VK_NULL_HANDLE;
    DrawRecorder masked;
  };
  Result<Gbuffer> gbufferPipeline(uint32_t p, VkRenderPass rp, uint32_t colors, VkSampleCountFlagBits samples,
                                  const std::string& depthName);
  void recordGbuffer(VkCommandBuffer cmd, uint32_t p, const Gbuffer& g) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, g.pipeline);
    bindSets(cmd, g.layout, VK_NULL_HANDLE, VK_NULL_HANDLE);
    drawScene(cmd, p, g.layout, true);
    if (g.masked) g.masked(cmd);
  }

  VkImageView msaaDepthView_ = VK_NULL_HANDLE;  // the depth aspect of "depth.msaa" (msaa > 1)
  // gbuffer=subpass: the input attachments' set (fragment stage only, so its own layout and pool).
  VkDescriptorSetLayout subpassLayout_ = VK_NULL_HANDLE;
  VkDescriptorPool subpassPool_ = VK_NULL_HANDLE;
  nlohmann::json gbufferMemory_ = nlohmann::json::object();  // G-buffer target -> ResourceInfo::memory
};

Result<DeferredRenderer::Gbuffer> DeferredRenderer::gbufferPipeline(uint32_t p, VkRenderPass rp, uint32_t colors,
                                                                 VkSampleCountFlagBits samples,
                                                                 const std::string& depthName) {
  const bool prepass = options_.zprepass;
  auto shaders = shaderPipeline(p, "gbuffer.vert.glsl", "gbuffer.frag.glsl",
                                pipelineLayout(materialLayout_, VK_NULL_HANDLE), rp);
  if (!shaders) return makeError(shaders.error());
  gpu::GraphicsPipelineDesc desc = *shaders;
  desc.colorAttachmentCount = colors;
  desc.samples = samples;
  meshVertexInput(desc);
  geometryState(desc, !prepass);
  if (prepass) desc.depthCompare = VK_COMPARE_OP_EQUAL;  // bit-identical depth (`invariant`)
  Gbuffer g;
  g.pipeline = pipeline(desc);
  g.layout = desc.layout;
  for (uint32_t k = 0; k < scenes::kMapSlotCount; ++k) {
    pass(p).bindings.bind(shaders::kSetMaterial, k, std::string("material_maps.") + mapKindName(k));
  }
  pass(p).bindings.outputs[shaders::kOutNormal] = "gbuffer.normal";
  pass(p).bindings.outputs[shaders::kOutDiffuse] = "gbuffer.diffuse";
  pass(p).bindings.outputs[shaders::kOutSpecular] = "gbuffer.specular";
  if (colors > 3) pass(p).bindings.outputs[shaders::kOutEmissive] = "gbuffer.emissive";
  if (scene_->features().emissiveMaps) {
    pass(p).bindings.bind(shaders::kSetMaterial, shaders::kBindingEmissiveMap, "material_maps.emissive");
  }
  if (!prepass) pass(p).depthWrite = depthName;
  pass(p).indexFetches = true;
  auto masked = maskedDraws(p, desc, "gbuffer.vert.glsl", "gbuffer.frag.glsl");
  if (!masked) return makeError(masked.error());
  g.masked = std::move(masked).value();
  return g;
}

// The one render pass of gbuffer=subpass (attachments and subpasses as
// setupSubpassPasses describes them).
VkRenderPass createSubpassRenderPass(VkDevice device, const VkFormat (&formats)[3], bool prepass) {
  const VkImageLayout colorAttachment = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  const VkImageLayout depthAttachment = VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
  const VkImageLayout depthReadOnly = VK_IMAGE_LAYOUT_DEPTH_STENCIL_READ_ONLY_OPTIMAL;
  const VkImageLayout shaderRead = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
  std::vector<VkAttachmentDescription> attachments(5);
  for (uint32_t i = 0; i < 3; ++i) {
    VkAttachmentDescription& a = attachments[i];
    a.format = formats[i];
    a.samples = VK_SAMPLE_COUNT_1_BIT;
    a.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    a.storeOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    a.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    a.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    a.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    a.finalLayout = shaderRead;
  }
  VkAttachmentDescription& d = attachments[3];
  d.format = kDepthFormat;
  d.samples = VK_SAMPLE_COUNT_1_BIT;
  d.loadOp = prepass ? VK_ATTACHMENT_LOAD_OP_LOAD : VK_ATTACHMENT_LOAD_OP_CLEAR;
  d.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  d.stencilLoadOp = d.loadOp;
  d.stencilStoreOp = VK_ATTACHMENT_STORE_OP_STORE;
  d.initialLayout = prepass ? depthAttachment : VK_IMAGE_LAYOUT_UNDEFINED;
  d.finalLayout = depthReadOnly;
  VkAttachmentDescription& h = attachments[4];
  h.format = kHdrFormat;
  h.samples = VK_SAMPLE_COUNT_1_BIT;
  h.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  h.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  h.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
  h.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
  h.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  h.finalLayout = shaderRead;

  const VkAttachmentReference gbufferOut[3] = {{0, colorAttachment}, {1, colorAttachment}, {2, colorAttachment}};
  const VkAttachmentReference depthWrite = {3, depthAttachment};
  const VkAttachmentReference depthRead = {3, depthReadOnly};
  const VkAttachmentReference hdrOut = {4, colorAttachment};
  const VkAttachmentReference inputs[3] = {{0, shaderRead}, {1, shaderRead}, {2, shaderRead}};
  VkSubpassDescription subpasses[2] = {};
  subpasses[0].pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
  subpasses[0].colorAttachmentCount = 3;
  subpasses[0].pColorAttachments = gbufferOut;
  subpasses[0].pDepthStencilAttachment = &depthWrite;
  subpasses[1].pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
  subpasses[1].inputAttachmentCount = 3;
  subpasses[1].pInputAttachments = inputs;
  subpasses[1].colorAttachmentCount = 1;
  subpasses[1].pColorAttachments = &hdrOut;
  subpasses[1].pDepthStencilAttachment = &depthRead;
  // External dependencies as createPassRenderPass's (passes run one after
  // another); subpass 0 -> 1 by region: the G-buffer and depth writes before
  // the input-attachment and depth/stencil reads of the same pixel.
  std::vector<VkSubpassDependency> deps;
  for (uint32_t sp = 0; sp < 2; ++sp) {
    for (bool in : {true, false}) {
      VkSubpassDependency e = {};
      e.srcSubpass = in ? VK_SUBPASS_EXTERNAL : sp;
      e.dstSubpass = in ? sp : VK_SUBPASS_EXTERNAL;
      e.srcStageMask = e.dstStageMask = VK_PIPELINE_STAGE_ALL_COMMANDS_BIT;
      e.srcAccessMask = VK_ACCESS_MEMORY_WRITE_BIT;
      e.dstAccessMask = VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT;
      deps.push_back(e);
    }
  }
  VkSubpassDependency inner = {};
  inner.srcSubpass = 0;
  inner.dstSubpass = 1;
  inner.srcStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_EARLY_FRAGMENT_TESTS_BIT |
                       VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT;
  inner.dstStageMask = VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_EARLY_FRAGMENT_TESTS_BIT |
                       VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT;
  inner.srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT | VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
  // Depth is sampled (texelFetch at the pixel itself: by region still holds).
  inner.dstAccessMask =
      VK_ACCESS_INPUT_ATTACHMENT_READ_BIT | VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_SHADER_READ_BIT;
  inner.dependencyFlags = VK_DEPENDENCY_BY_REGION_BIT;
  deps.push_back(inner);
  VkRenderPassCreateInfo info = {VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO};
  info.attachmentCount = uint32_t(attachments.size());
  info.pAttachments = attachments.data();
  info.subpassCount = 2;
  info.pSubpasses = subpasses;
  info.dependencyCount = uint32_t(deps.size());
  info.pDependencies = deps.data();
  VkRenderPass created = VK_NULL_HANDLE;
  VK_CHECK(vkCreateRenderPass(device, &info, nullptr, &created));
  return created;
}

// gbuffer=subpass: one render pass. Attachments 0-2 the transient G-buffer
// (cleared, storeOp DONT_CARE), 3 depth/stencil (stored: the skybox tests its
// stencil; loaded after a pre-pass), 4 hdr (cleared, stored). Subpass 0 writes
// 0-3; subpass 1 reads 0-2 as input attachments 0-2 and the depth aspect of
// 3 through the sampled depth view (stored anyway; on the H200 its read as an
// input attachment differed), tests stencil == 1 against 3 read-only and
// writes 4.
Result<bool> DeferredRenderer::setupSubpassPasses() {
  const VkImageUsageFlags transient =
      VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_INPUT_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSIENT_ATTACHMENT_BIT;
  const std::string names[3] = {"gbuffer.normal", "gbuffer.diffuse", "gbuffer.specular"};
  const VkFormat formats[3] = {kNormalFormat, kDiffuseFormat, kSpecularFormat};
  const gpu::Image* targets[3];
  for (int i = 0; i < 3; ++i) {
    targets[i] = createTransientTarget(names[i], formats[i], transient);
    gbufferMemory_[names[i]] = resources_.back().memory;
  }
  const VkImageLayout depthReadOnly = VK_IMAGE_LAYOUT_DEPTH_STENCIL_READ_ONLY_OPTIMAL;
  const VkImageLayout shaderRead = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
  const bool prepass = options_.zprepass;
  if (prepass) {
    if (auto ok = addDepthPrepass(); !ok) return ok;
  }

  VkRenderPass rp = ownRenderPass(createSubpassRenderPass(ctx_->device, formats, prepass));
  VkFramebuffer fb = framebuffer(rp, {targets[0]->view, targets[1]->view, targets[2]->view, depth_->view, hdr_->view});

  // Subpass 0: the G-buffer, as the sampled variant's pass.
  uint32_t g = addPass("gbuffer");
  auto gpipe = gbufferPipeline(g, rp, 3, VK_SAMPLE_COUNT_1_BIT, "depth");
  if (!gpipe) return makeError(gpipe.error());
  for (uint32_t i = 0; i < 3; ++i) pass(g).onChip.insert(names[i]);  // DONT_CARE: tile memory only

  // Subpass 1: lighting from the input attachments. Their descriptors may be
  // visible to the fragment stage only: the set layout and pool are our own.
  uint32_t l = addPass("lighting");
  std::vector<VkDescriptorSetLayoutBinding> bindings;
  bindings.push_back({shaders::kBindingDepthTarget, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1,
                      VK_SHADER_STAGE_FRAGMENT_BIT, nullptr});
  for (uint32_t b : {shaders::kBindingNormalTarget, shaders::kBindingDiffuseTarget, shaders::kBindingSpecularTarget}) {
    bindings.push_back({b, VK_DESCRIPTOR_TYPE_INPUT_ATTACHMENT, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr});
  }
  subpassLayout_ = gpu::createDescriptorSetLayout(*ctx_, bindings);
  const VkDescriptorPoolSize sizes[] = {{VK_DESCRIPTOR_TYPE_INPUT_ATTACHMENT, 3},
                                        {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1}};
  subpassPool_ = gpu::createDescriptorPool(*ctx_, 1, sizes);
  VkDescriptorSet input = gpu::allocateDescriptorSet(*ctx_, subpassPool_, subpassLayout_);
  const VkImageView views[4] = {depthOnlyView(), targets[0]->view, targets[1]->view, targets[2]->view};
  const VkImageLayout layouts[4] = {depthReadOnly, shaderRead, shaderRead, shaderRead};
  gpu::DescriptorWrite writes[4];
  for (uint32_t i = 0; i < 4; ++i) {
    writes[i].binding = bindings[i].binding;
    writes[i].type = i == 0 ? VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER : VK_DESCRIPTOR_TYPE_INPUT_ATTACHMENT;
    writes[i].image = {i == 0 ? targetSampler_ : VK_NULL_HANDLE, views[i], layouts[i]};
  }
  gpu::updateDescriptorSet(*ctx_, input, writes);
  auto& b = pass(l).bindings;
  b.bind(shaders::kSetPassInput, shaders::kBindingDepthTarget, "depth");
  b.elementBytes[{shaders::kSetPassInput, shaders::kBindingDepthTarget}] = 4;  // the D32 depth aspect
  for (uint32_t i = 0; i < 3; ++i) b.bind(shaders::kSetPassInput, shaders::kBindingNormalTarget + i, names[i]);
  b.outputs[shaders::kOutColor] = "hdr";  // stored: DRAM
  // subpassLoad within the render pass; depth is sampled from its stored target: DRAM.
  pass(l).onChip = {names[0], names[1], names[2]};
  auto lshaders = shaderPipeline(l, "fullscreen.vert.glsl", "lighting_subpass.frag.glsl",
                                 pipelineLayout(VK_NULL_HANDLE, subpassLayout_), rp);
  if (!lshaders) return makeError(lshaders.error());
  gpu::GraphicsPipelineDesc ldesc = *lshaders;
  ldesc.subpass = 1;
  geometryPixelsOnly(ldesc);
  VkPipeline lpipe = pipeline(ldesc);
  VkPipelineLayout llayout = ldesc.layout;

  pass(g).record = [=, this, gbuffer = *gpipe](VkCommandBuffer cmd) {
    std::vector<VkClearValue> clears(5);
    clears[3] = depthClear();
    beginRenderPass(cmd, g, rp, fb, clears);
    recordGbuffer(cmd, g, gbuffer);
    nextSubpass(cmd, g, l);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, lpipe);
    bindSets(cmd, llayout, VK_NULL_HANDLE, input);
    drawFullScreen(cmd);
    endRenderPass(cmd, l);
  };
  pass(l).record = [](VkCommandBuffer) {};  // recorded by "gbuffer": one render pass
  return true;
}

}  // namespace

std::unique_ptr<Renderer> makeDeferred() { return std::make_unique<DeferredRenderer>(); }

}  // namespace tally::renderers
