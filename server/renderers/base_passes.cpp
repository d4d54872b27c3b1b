// RendererBase: passes, their targets and framebuffers, and beginning and
// ending render and compute passes (with the per-pass queries).
#include "renderers/renderer_base.hpp"

#include "gpu/vk_check.hpp"
#include "renderers/techniques/tile_memory.hpp"

namespace tally::renderers {

namespace {

std::string formatName(VkFormat format) {
  switch (format) {
    case VK_FORMAT_R16G16B16A16_SFLOAT: return "R16G16B16A16_SFLOAT";
    case VK_FORMAT_R8G8B8A8_SRGB: return "R8G8B8A8_SRGB";
    case VK_FORMAT_R8G8B8A8_UNORM: return "R8G8B8A8_UNORM";
    case VK_FORMAT_D32_SFLOAT_S8_UINT: return "D32_SFLOAT_S8_UINT";
    case VK_FORMAT_R32G32_UINT: return "R32G32_UINT";
    case VK_FORMAT_R32_UINT: return "R32_UINT";
    case VK_FORMAT_R32_SFLOAT: return "R32_SFLOAT";
    case VK_FORMAT_R32G32B32_UINT: return "R32G32B32_UINT";
    case VK_FORMAT_R32G32B32A32_UINT: return "R32G32B32A32_UINT";
    default: return "VkFormat " + std::to_string(int(format));
  }
}

std::string usageName(VkImageUsageFlags usage) {
  std::string out;
  auto add = [&](VkImageUsageFlags bit, const char* name) {
    if (usage & bit) out += (out.empty() ? "" : "|") + std::string(name);
  };
  add(VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT, "color_attachment");
  add(VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, "depth_stencil_attachment");
  add(VK_IMAGE_USAGE_SAMPLED_BIT, "sampled");
  add(VK_IMAGE_USAGE_TRANSFER_SRC_BIT, "transfer_src");
  add(VK_IMAGE_USAGE_INPUT_ATTACHMENT_BIT, "input_attachment");
  add(VK_IMAGE_USAGE_TRANSIENT_ATTACHMENT_BIT, "transient_attachment");
  add(VK_IMAGE_USAGE_STORAGE_BIT, "storage");  // compute passes' imageStore targets
  return out;
}

}  // namespace

std::string_view toString(ResourceKind kind) {
  switch (kind) {
    case ResourceKind::Texture: return "texture";
    case ResourceKind::Attachment: return "attachment";
    case ResourceKind::Depth: return "depth";
    case ResourceKind::Buffer: return "buffer";
  }
  return "texture";
}

VkRenderPass createPassRenderPass(const gpu::Context& ctx, const std::vector<AttachmentSpec>& colors,
                                  std::optional<AttachmentSpec> depth) {
  std::vector<VkAttachmentDescription> attachments;
  std::vector<VkAttachmentReference> colorRefs;
  for (const auto& c : colors) {
    VkAttachmentDescription a = {};
    a.format = c.format;
    a.samples = c.samples;
    a.loadOp = c.clear ? VK_ATTACHMENT_LOAD_OP_CLEAR : VK_ATTACHMENT_LOAD_OP_LOAD;
    a.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    a.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    a.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    a.initialLayout = c.initial;
    a.finalLayout = c.final;
    colorRefs.push_back({uint32_t(attachments.size()), c.layout});
    attachments.push_back(a);
  }
  VkAttachmentReference depthRef = {};
  if (depth) {
    VkAttachmentDescription a = {};
    a.format = depth->format;
    a.samples = depth->samples;
    a.loadOp = depth->clear ? VK_ATTACHMENT_LOAD_OP_CLEAR : VK_ATTACHMENT_LOAD_OP_LOAD;
    a.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    a.stencilLoadOp = a.loadOp;
    a.stencilStoreOp = VK_ATTACHMENT_STORE_OP_STORE;
    a.initialLayout = depth->initial;
    a.finalLayout = depth->final;
    depthRef = {uint32_t(attachments.size()), depth->layout};
    attachments.push_back(a);
  }
  VkSubpassDescription subpass = {};
  subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
  subpass.colorAttachmentCount = uint32_t(colorRefs.size());
  subpass.pColorAttachments = colorRefs.data();
  subpass.pDepthStencilAttachment = depth ? &depthRef : nullptr;
  VkSubpassDependency deps[2] = {};
  deps[0].srcSubpass = VK_SUBPASS_EXTERNAL;
  deps[0].dstSubpass = 0;
  deps[1].srcSubpass = 0;
  deps[1].dstSubpass = VK_SUBPASS_EXTERNAL;
  for (auto& d : deps) {
    d.srcStageMask = VK_PIPELINE_STAGE_ALL_COMMANDS_BIT;
    d.dstStageMask = VK_PIPELINE_STAGE_ALL_COMMANDS_BIT;
    d.srcAccessMask = VK_ACCESS_MEMORY_WRITE_BIT;
    d.dstAccessMask = VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT;
  }
  VkRenderPassCreateInfo info = {VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO};
  info.attachmentCount = uint32_t(attachments.size());
  info.pAttachments = attachments.data();
  info.subpassCount = 1;
  info.pSubpasses = &subpass;
  info.dependencyCount = 2;
  info.pDependencies = deps;
  VkRenderPass rp = VK_NULL_HANDLE;
  VK_CHECK(vkCreateRenderPass(ctx.device, &info, nullptr, &rp));
  return rp;
}

std::vector<std::string> RendererBase::passNames() const {
  auto names = ownPassNames();
  if (options_.shadows.filter != ShadowFilter::Off) names.insert(names.begin(), "shadow");  // shadows.cpp
  for (auto& n : bloomPassNames()) names.push_back(std::move(n));
  names.push_back("tonemap");
  if (drawsSky()) names.push_back("skybox");
  if (hasTransparentPass()) names.push_back("transparent");
  return names;
}

uint32_t RendererBase::addPass(std::string name) {
  Pass p;
  p.name = std::move(name);
  p.bindings = commonBindings();
  passes_.push_back(std::move(p));
  return uint32_t(passes_.size() - 1);
}

PassBindings RendererBase::commonBindings() const {
  PassBindings b;
  b.bind(shaders::kSetFrame, shaders::kBindingCamera, "camera");
  b.bind(shaders::kSetFrame, shaders::kBindingLighting, "lighting");
  b.bind(shaders::kSetFrame, shaders::kBindingLights, "lights");
  b.bind(shaders::kSetGeometry, shaders::kBindingDraws, "draws");
  b.bind(shaders::kSetGeometry, shaders::kBindingMaterials, "materials");
  b.bind(shaders::kSetGeometry, shaders::kBindingVertices, "vertices");
  b.bind(shaders::kSetGeometry, shaders::kBindingIndices, "indices");
  b.bind(shaders::kSetGeometry, shaders::kBindingVertexAttributes, "vertex_attributes");
  b.bind(shaders::kSetGeometry, shaders::kBindingMaterialExtras, "material_extras");
  b.vertexInputsAt[shaders::kAttribColor] = "vertex_attributes";  // vertex buffer 1 (glTF scenes)
  b.vertexInputsAt[shaders::kAttribUv1] = "vertex_attributes";
  shadowBindings(b);  // "shadow", "shadow_map" in set 0 with shadows on
  return b;
}

const gpu::Image* RendererBase::createTarget(const std::string& name, VkFormat format,
                                             VkImageUsageFlags usage, ResourceKind kind, uint32_t samples) {
  targets_.push_back(gpu::createImage(*ctx_, extent_.width, extent_.height, format, usage,
                                      VkSampleCountFlagBits(samples)));
  targetNames_.push_back({name, usage});
  const gpu::Image& image = targets_.back();
  VkMemoryRequirements r;
  vkGetImageMemoryRequirements(ctx_->device, image.image, &r);
  ResourceInfo info;
  info.name = name;
  info.kind = kind;
  info.format = format;
  info.formatName = formatName(format);
  info.elementBytes = gpu::formatBytes(format);
  info.width = extent_.width;
  info.height = extent_.height;
  info.samples = samples;
  info.allocationBytes = r.size;
  info.usage = usageName(usage);
  info.memory = imageMemoryKind(*ctx_, r);
  info.objects = {gpu::objectOf(image.image)};
  resources_.push_back(info);
  return &image;
}

const gpu::Image* RendererBase::createTransientTarget(const std::string& name, VkFormat format,
                                                      VkImageUsageFlags usage) {
  std::string memory;
  targets_.push_back(createTransientImage(*ctx_, extent_.width, extent_.height, format, usage, memory));
  targetNames_.push_back({name, usage});
  const gpu::Image& image = targets_.back();
  VkMemoryRequirements r;
  vkGetImageMemoryRequirements(ctx_->device, image.image, &r);
  ResourceInfo info;
  info.name = name;
  info.kind = ResourceKind::Attachment;
  info.format = format;
  info.formatName = formatName(format);
  info.elementBytes = gpu::formatBytes(format);
  info.width = extent_.width;
  info.height = extent_.height;
  info.allocationBytes = r.size;
  info.usage = usageName(usage);
  info.memory = memory;
  info.objects = {gpu::objectOf(image.image)};
  resources_.push_back(info);
  return &image;
}

VkImageView RendererBase::depthOnlyView() {
  if (depthOnlyView_ == VK_NULL_HANDLE) {
    VkImageViewCreateInfo view = {VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    view.image = depth_->image;
    view.viewType = VK_IMAGE_VIEW_TYPE_2D;
    view.format = depth_->format;
    view.subresourceRange = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, 0, 1};
    VK_CHECK(vkCreateImageView(ctx_->device, &view, nullptr, &depthOnlyView_));
    ctx_->log->view(depthOnlyView_, {depth_->extent.width, depth_->extent.height, 1, 0, 1, 1, 4, VK_IMAGE_VIEW_TYPE_2D});
  }
  return depthOnlyView_;
}

VkFramebuffer RendererBase::framebuffer(VkRenderPass renderPass, const std::vector<VkImageView>& views) {
  framebuffers_.push_back(gpu::createFramebuffer(*ctx_, renderPass, views, extent_));
  return framebuffers_.back();
}

void RendererBase::beginComputePass(VkCommandBuffer cmd, uint32_t passIndex) {
  if (statistics_.pool != VK_NULL_HANDLE) gpu::beginStatistics(cmd, statistics_, passIndex);
}

void RendererBase::endComputePass(VkCommandBuffer cmd, uint32_t passIndex) {
  if (statistics_.pool != VK_NULL_HANDLE) gpu::endStatistics(cmd, statistics_, passIndex);
}

void RendererBase::beginRenderPass(VkCommandBuffer cmd, uint32_t passIndex, VkRenderPass renderPass,
                                   VkFramebuffer fb, const std::vector<VkClearValue>& clears) {
  VkRenderPassBeginInfo begin = {VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
  begin.renderPass = renderPass;
  begin.framebuffer = fb;
  begin.renderArea = {{0, 0}, extent_};
  begin.clearValueCount = uint32_t(clears.size());
  begin.pClearValues = clears.data();
  vkCmdBeginRenderPass(cmd, &begin, VK_SUBPASS_CONTENTS_INLINE);
  // Inside the render pass: lavapipe crashes when the query brackets it.
  if (statistics_.pool != VK_NULL_HANDLE) gpu::beginStatistics(cmd, statistics_, passIndex);
  gpu::setViewportAndScissor(cmd, extent_);
}

void RendererBase::endRenderPass(VkCommandBuffer cmd, uint32_t passIndex) {
  if (statistics_.pool != VK_NULL_HANDLE) gpu::endStatistics(cmd, statistics_, passIndex);
  vkCmdEndRenderPass(cmd);
}

void RendererBase::nextSubpass(VkCommandBuffer cmd, uint32_t fromPass, uint32_t toPass) {
  if (statistics_.pool != VK_NULL_HANDLE) gpu::endStatistics(cmd, statistics_, fromPass);
  // The debug labels follow the passes the counters do: `toPass`'s subpass
  // under its own name, inside the render pass `fromPass` records.
  endPassLabel(cmd);
  vkCmdNextSubpass(cmd, VK_SUBPASS_CONTENTS_INLINE);
  beginPassLabel(cmd, toPass);
  subpassLabelled_.insert(toPass);
  if (statistics_.pool != VK_NULL_HANDLE) gpu::beginStatistics(cmd, statistics_, toPass);
}

void RendererBase::beginPassLabel(VkCommandBuffer cmd, uint32_t passIndex) {
  endPassLabel(cmd);
  gpu::beginLabel(*ctx_, cmd, passes_[passIndex].name);
  labelOpen_ = true;
}

void RendererBase::endPassLabel(VkCommandBuffer cmd) {
  if (!labelOpen_) return;
  gpu::endLabel(*ctx_, cmd);
  labelOpen_ = false;
}

}  // namespace tally::renderers
