#include "renderers/renderer_base.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>

#include <glm/gtc/matrix_transform.hpp>

#include "gpu/shaders.hpp"
#include "gpu/vk_check.hpp"
#include "renderers/techniques/bloom.hpp"
#include "renderers/projection.hpp"
#include "renderers/techniques/tile_memory.hpp"
#include "shared.h"

namespace tally::renderers {

std::string shaderDirectory() {
  // The binary may run where the source tree is elsewhere (tests/gpu/).
  if (const char* dir = std::getenv("TALLY_SHADER_DIR"); dir != nullptr && *dir) return dir;
  return TALLY_RENDERER_SHADER_DIR;
}

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
  }
  return depthOnlyView_;
}

VkFramebuffer RendererBase::framebuffer(VkRenderPass renderPass, const std::vector<VkImageView>& views) {
  framebuffers_.push_back(gpu::createFramebuffer(*ctx_, renderPass, views, extent_));
  return framebuffers_.back();
}

Result<gpu::GraphicsPipelineDesc> RendererBase::shaderPipeline(uint32_t passIndex, const std::string& vertex,
                                                               const std::string& fragment, VkPipelineLayout layout,
                                                               VkRenderPass renderPass,
                                                               const std::vector<std::string>& fragmentDefines) {
  auto vs = shader(passIndex, vertex);
  if (!vs) return makeError(vs.error());
  auto fs = shader(passIndex, fragment, fragmentDefines);
  if (!fs) return makeError(fs.error());
  gpu::GraphicsPipelineDesc desc;
  desc.vertex = *vs;
  desc.fragment = *fs;
  desc.layout = layout;
  desc.renderPass = renderPass;
  return desc;
}

Result<VkShaderModule> RendererBase::shader(uint32_t passIndex, const std::string& file,
                                            const std::vector<std::string>& defines) {
  auto source = gpu::loadShaderSource(*ctx_, shaderDirectory(), file);
  if (!source) return makeError(source.error());
  std::vector<std::string> allDefines = defines;
  if (packedVertices_) allDefines.push_back("TALLY_TBN_QUATERNION");  // shaders/tbn.h; none: float as it was
  for (auto& d : scene_->featureDefines()) allDefines.push_back(std::move(d));  // glTF features; none for procedural scenes
  for (auto& d : shadowDefines()) allDefines.push_back(std::move(d));    // shaders/shadow.h; none with shadows off
  if (!allDefines.empty()) {
    size_t eol = source->source.find('\n');
    std::string text;
    for (const auto& d : allDefines) text += "#define " + d + "\n";
    source->source.insert(eol == std::string::npos ? source->source.size() : eol + 1, text);
  }
  std::vector<uint32_t> words;
  if (options_.instrumented) {
    auto instrumentOptions = gpu::instrumentOptionsFor(*ctx_, options_.counting, slotCount_);
    if (auto why = gpu::unsupportedReason(*ctx_, source->stage, instrumentOptions); !why.empty()) {
      return makeError(file + ": " + why);
    }
    auto compiled = gpu::compileAndInstrument(*ctx_, *source, instrumentOptions);
    if (!compiled) return makeError(file + ": " + compiled.error());
    counterSet_ = instrumentOptions.set;
    slotCount_ += compiled->result.slotCount;
    auto& sites = passes_[passIndex].sites;
    sites.insert(sites.end(), compiled->result.sites.begin(), compiled->result.sites.end());
    words = std::move(compiled->words);
  } else {
    auto compiled = gpu::compileShader(*source);
    if (!compiled) return makeError(file + ": " + compiled.error());
    words = std::move(compiled->words);
  }
  modules_.push_back(gpu::createShaderModule(*ctx_, words));
  return modules_.back();
}

VkDescriptorSetLayout RendererBase::setLayout(const std::vector<VkDescriptorType>& types,
                                              const std::vector<uint32_t>& counts) {
  std::vector<VkDescriptorSetLayoutBinding> bindings;
  for (uint32_t i = 0; i < types.size(); ++i) {
    VkDescriptorSetLayoutBinding b = {};
    b.binding = i;
    b.descriptorType = types[i];
    b.descriptorCount = i < counts.size() ? counts[i] : 1;
    b.stageFlags = VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT | VK_SHADER_STAGE_COMPUTE_BIT;
    bindings.push_back(b);
  }
  ownedSetLayouts_.push_back(gpu::createDescriptorSetLayout(*ctx_, bindings));
  return ownedSetLayouts_.back();
}

VkDescriptorSet RendererBase::allocateSet(VkDescriptorSetLayout layout) {
  return gpu::allocateDescriptorSet(*ctx_, pool_, layout);
}

void RendererBase::writeImage(VkDescriptorSet set, uint32_t binding, VkImageView view, VkSampler sampler,
                              VkImageLayout layout) {
  gpu::DescriptorWrite w;
  w.binding = binding;
  w.type = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  w.image = {sampler, view, layout};
  gpu::updateDescriptorSet(*ctx_, set, {&w, 1});
}

VkPipelineLayout RendererBase::pipelineLayout(VkDescriptorSetLayout material,
                                              VkDescriptorSetLayout passInput) {
  return makePipelineLayout(material, passInput, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT);
}

VkPipelineLayout RendererBase::makePipelineLayout(VkDescriptorSetLayout material, VkDescriptorSetLayout passInput,
                                                  VkShaderStageFlags pushStages) {
  std::vector<VkDescriptorSetLayout> sets(counterSet_ + 1, emptyLayout_);
  sets[shaders::kSetFrame] = frameLayout_;
  sets[shaders::kSetGeometry] = geometryLayout_;
  if (material != VK_NULL_HANDLE) sets[shaders::kSetMaterial] = material;
  if (passInput != VK_NULL_HANDLE) sets[shaders::kSetPassInput] = passInput;
  sets[counterSet_] = counterLayout_;
  pipelineLayouts_.push_back(gpu::createPipelineLayout(*ctx_, sets, sizeof(shaders::DrawPush), pushStages));
  return pipelineLayouts_.back();
}

VkPipeline RendererBase::pipeline(const gpu::GraphicsPipelineDesc& desc) {
  pipelines_.push_back(gpu::createGraphicsPipeline(*ctx_, desc));
  return pipelines_.back();
}

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

Result<gpu::GraphicsPipelineDesc> RendererBase::depthOnlyPipeline(uint32_t passIndex, const std::string& vertex,
                                                                  VkRenderPass renderPass) {
  auto vs = shader(passIndex, vertex);
  if (!vs) return makeError(vs.error());
  gpu::GraphicsPipelineDesc desc;
  desc.vertex = *vs;
  if (options_.instrumented) {
    auto fs = shader(passIndex, "zprepass.frag.glsl");
    if (!fs) return makeError(fs.error());
    desc.fragment = *fs;
  }
  desc.layout = pipelineLayout(VK_NULL_HANDLE, VK_NULL_HANDLE);
  desc.renderPass = renderPass;
  desc.colorAttachmentCount = 0;
  meshVertexInput(desc);
  return desc;
}

void RendererBase::geometryState(gpu::GraphicsPipelineDesc& desc, bool writeDepth) {
  desc.depthTest = true;
  desc.depthWrite = writeDepth;
  desc.depthCompare = VK_COMPARE_OP_LESS;  // depth [0, 1], far = 1 (shared.h)
  desc.stencilTest = true;
  desc.stencilCompare = VK_COMPARE_OP_ALWAYS;
  desc.stencilPassOp = VK_STENCIL_OP_REPLACE;
  desc.stencilReference = kStencilGeometry;
  desc.stencilWriteMask = 0xff;
}

VkClearValue RendererBase::depthClear() {
  VkClearValue v = {};
  v.depthStencil = {1.0f, 0};
  return v;
}

void RendererBase::geometryPixelsOnly(gpu::GraphicsPipelineDesc& desc) {
  desc.stencilTest = true;
  desc.stencilCompare = VK_COMPARE_OP_EQUAL;
  desc.stencilReference = kStencilGeometry;
}

void RendererBase::meshVertexInput(gpu::GraphicsPipelineDesc& desc) const {
  desc.dynamicCullMode = dynamicCull_;
  meshVertexStreams(desc);
  const auto& f = scene_->features();
  if (f.vertexColors || f.uv1) {  // glTF's optional streams: vertex buffer 1
    desc.vertexBindings.push_back({1, sizeof(shaders::VertexAttributes), VK_VERTEX_INPUT_RATE_VERTEX});
    if (f.vertexColors) desc.vertexAttributes.push_back({shaders::kAttribColor, 1, VK_FORMAT_R16G16B16A16_UNORM, 0});
    if (f.uv1) desc.vertexAttributes.push_back({shaders::kAttribUv1, 1, VK_FORMAT_R32G32_SFLOAT, 8});
  }
}

void RendererBase::meshVertexStreams(gpu::GraphicsPipelineDesc& desc) const {
  if (packedVertices_) {  // renderers/techniques/tbn.hpp: PackedVertex
    desc.vertexBindings = {{0, sizeof(PackedVertex), VK_VERTEX_INPUT_RATE_VERTEX}};
    desc.vertexAttributes = {
        {shaders::kAttribPosition, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(PackedVertex, position)},
        {shaders::kAttribNormal, 0, VK_FORMAT_R32_UINT, offsetof(PackedVertex, tbn)},
        {shaders::kAttribUv, 0, VK_FORMAT_R32G32_SFLOAT, offsetof(PackedVertex, uv)},
    };
    return;
  }
  desc.vertexBindings = {{0, sizeof(shaders::Vertex), VK_VERTEX_INPUT_RATE_VERTEX}};
  desc.vertexAttributes = {
      {shaders::kAttribPosition, 0, VK_FORMAT_R32G32B32_SFLOAT, 0},
      {shaders::kAttribNormal, 0, VK_FORMAT_R32G32B32_SFLOAT, 12},
      {shaders::kAttribTangent, 0, VK_FORMAT_R32G32B32A32_SFLOAT, 24},
      {shaders::kAttribUv, 0, VK_FORMAT_R32G32_SFLOAT, 40},
  };
}

void RendererBase::bindSets(VkCommandBuffer cmd, VkPipelineLayout layout, VkDescriptorSet material,
                            VkDescriptorSet passInput, VkDescriptorSet geometry) {
  bindSetsAt(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout, material, passInput, geometry);
}

void RendererBase::bindComputeSets(VkCommandBuffer cmd, VkPipelineLayout layout, VkDescriptorSet material,
                                   VkDescriptorSet passInput, VkDescriptorSet geometry) {
  bindSetsAt(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, material, passInput, geometry);
}

VkPipelineLayout RendererBase::computePipelineLayout(VkDescriptorSetLayout material,
                                                     VkDescriptorSetLayout passInput) {
  return makePipelineLayout(material, passInput, VK_SHADER_STAGE_COMPUTE_BIT);
}

Result<VkPipeline> RendererBase::computePipeline(uint32_t passIndex, const std::string& file,
                                                 VkPipelineLayout layout, const std::vector<std::string>& defines) {
  auto module = shader(passIndex, file, defines);
  if (!module) return makeError(module.error());
  pipelines_.push_back(gpu::createComputePipeline(*ctx_, *module, layout));
  return pipelines_.back();
}

void RendererBase::beginComputePass(VkCommandBuffer cmd, uint32_t passIndex) {
  if (statistics_.pool != VK_NULL_HANDLE) gpu::beginStatistics(cmd, statistics_, passIndex);
}

void RendererBase::endComputePass(VkCommandBuffer cmd, uint32_t passIndex) {
  if (statistics_.pool != VK_NULL_HANDLE) gpu::endStatistics(cmd, statistics_, passIndex);
}

void RendererBase::writeStorageImage(VkDescriptorSet set, uint32_t binding, VkImageView view) {
  gpu::DescriptorWrite w;
  w.binding = binding;
  w.type = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
  w.image = {VK_NULL_HANDLE, view, VK_IMAGE_LAYOUT_GENERAL};
  gpu::updateDescriptorSet(*ctx_, set, {&w, 1});
}

void RendererBase::bindSetsAt(VkCommandBuffer cmd, VkPipelineBindPoint point, VkPipelineLayout layout,
                              VkDescriptorSet material, VkDescriptorSet passInput, VkDescriptorSet geometry) {
  auto bind = [&](uint32_t index, VkDescriptorSet set) {
    if (set != VK_NULL_HANDLE) vkCmdBindDescriptorSets(cmd, point, layout, index, 1, &set, 0, nullptr);
  };
  bind(shaders::kSetFrame, frameSet_);
  bind(shaders::kSetMaterial, material);
  bind(shaders::kSetGeometry, geometry != VK_NULL_HANDLE ? geometry : geometrySet_);
  bind(shaders::kSetPassInput, passInput);
  bind(counterSet_, counterDescriptorSet_);
}

VkDescriptorSet RendererBase::geometrySetWith(const gpu::Buffer& materials, const gpu::Buffer& materialExtras) {
  VkDescriptorSet set = allocateSet(geometryLayout_);
  const gpu::Buffer* buffers[] = {&drawsBuffer(),  &materials, &vertexBuffer(), &indexBuffer(),
                                  &scene_->attributeBuffer(), &materialExtras};
  gpu::DescriptorWrite writes[6];
  for (uint32_t i = 0; i < 6; ++i) {
    writes[i].binding = i;
    writes[i].type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[i].buffer = {buffers[i]->buffer, 0, VK_WHOLE_SIZE};
  }
  gpu::updateDescriptorSet(*ctx_, set, writes);
  return set;
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
    }
    shaders::DrawPush push = {i, d.material};
    vkCmdPushConstants(cmd, layout, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof push,
                       &push);
    vkCmdDrawIndexed(cmd, d.indexCount, 1, d.firstIndex, d.vertexOffset, 0);
    passes_[passIndex].indicesDrawn += d.indexCount;
  }
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
  vkCmdNextSubpass(cmd, VK_SUBPASS_CONTENTS_INLINE);
  if (statistics_.pool != VK_NULL_HANDLE) gpu::beginStatistics(cmd, statistics_, toPass);
}

Result<bool> RendererBase::setup(gpu::Context& ctx, const GpuScene& scene, const RendererOptions& options) {
  destroy();
  ctx_ = &ctx;
  scene_ = &scene;
  options_ = options;
  options_.lights = std::min(options.lights, shaders::kMaxLights);
  extent_ = options.extent;
  if (extent_.width == 0 || extent_.height == 0) return makeError("extent: must be at least 1x1");
  if (options.bloom.blur != BloomBlur::Off && (options.bloom.taps % 2 == 0 || options.bloom.taps > 63)) {
    return makeError("bloom_taps: must be an odd kernel width up to 63, got " + std::to_string(options.bloom.taps));
  }
  counterSet_ = gpu::instrumentOptionsFor(ctx, options.counting).set;
  if (counterSet_ <= shaders::kSetPassInput)
    return makeError("device: too few descriptor sets for the counters");
  try {
    const uint32_t materials = scene.materialCount();
    VkDescriptorPoolSize sizes[] = {
        {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 6 * (materials + 4) + 32 + shaders::kMaxMaterialMaps},
        {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 8},
        {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 48},
        {VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 16}};
    pool_ = gpu::createDescriptorPool(ctx, materials + 32, sizes);
    using T = VkDescriptorType;
    const T ubo = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, ssbo = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
            image = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    frameLayout_ = options.shadows.filter == ShadowFilter::Off
                       ? setLayout({ubo, ubo, ssbo})
                       : setLayout({ubo, ubo, ssbo, ubo, image});  // + shadow_shared.h's kBindingShadow(Map)
    // draws, materials, vertices, indices; vertex_attributes, material_extras (glTF features)
    geometryLayout_ = setLayout({ssbo, ssbo, ssbo, ssbo, ssbo, ssbo});
    emptyLayout_ = setLayout({});
    counterLayout_ = setLayout({ssbo});
    // The five maps; the emissive map at kBindingEmissiveMap where a material has one.
    const bool emissiveMaps = scene.features().emissiveMaps;
    materialLayout_ = emissiveMaps ? setLayout({image, image, image, image, image, image})
                                   : setLayout({image, image, image, image, image});
    mapArrayLayout_ = emissiveMaps ? setLayout({image, image, image, image, image, image})
                                   : setLayout({image, image, image, image, image});
    dynamicCull_ = scene.features().singleSided;
    if (dynamicCull_ && std::min(ctx.apiVersion, ctx.properties.apiVersion) < VK_API_VERSION_1_3) {
      destroy();
      return makeError(std::string(name()) +
                       ": the scene has single-sided materials; culling their back faces per draw needs "
                       "Vulkan 1.3 (dynamic cull mode)");
    }

    cameraBuffer_ = gpu::createBuffer(ctx, sizeof(shaders::Camera), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                                      gpu::MemoryUse::Upload);
    lightingBuffer_ = gpu::createBuffer(ctx, sizeof(shaders::Lighting), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                                        gpu::MemoryUse::Upload);
    shaders::Lighting lighting = {};
    lighting.lightCount = options_.lights;
    lighting.ambient = 0.15f;
    lighting.exposure = 1.0f;
    gpu::uploadBuffer(ctx, lightingBuffer_, {reinterpret_cast<const uint8_t*>(&lighting), sizeof lighting});

    if (options_.lodThresholdPx > 0) {  // levels of detail (renderers/techniques/lod.hpp): chains built on first use
      lod_ = std::make_unique<LodSelection>();
      if (auto ok = lod_->setup(ctx, scene, options_.lodThresholdPx); !ok) {
        lod_.reset();
        return makeError(ok.error());
      }
    }
    if (options_.tangentFrame == TangentFrameEncoding::Quaternion) {  // renderers/techniques/tbn.hpp
      auto packed = buildPackedVertices(ctx, scene);
      if (!packed) return makeError(packed.error());
      packedVertices_ = std::make_unique<PackedVertexBuffer>(std::move(*packed));
    }
    frameSet_ = allocateSet(frameLayout_);
    geometrySet_ = allocateSet(geometryLayout_);
    auto bufferWrite = [](uint32_t binding, VkDescriptorType type, const gpu::Buffer& b) {
      gpu::DescriptorWrite w;
      w.binding = binding;
      w.type = type;
      w.buffer = {b.buffer, 0, VK_WHOLE_SIZE};
      return w;
    };
    gpu::DescriptorWrite frameWrites[] = {bufferWrite(0, ubo, cameraBuffer_),
                                          bufferWrite(1, ubo, lightingBuffer_),
                                          bufferWrite(2, ssbo, scene.lightBuffer())};
    gpu::updateDescriptorSet(ctx, frameSet_, frameWrites);
    gpu::DescriptorWrite geometryWrites[] = {
        bufferWrite(0, ssbo, drawsBuffer()), bufferWrite(1, ssbo, scene.materialBuffer()),
        bufferWrite(2, ssbo, vertexBuffer()), bufferWrite(3, ssbo, indexBuffer()),
        bufferWrite(shaders::kBindingVertexAttributes, ssbo, scene.attributeBuffer()),
        bufferWrite(shaders::kBindingMaterialExtras, ssbo, scene.materialExtraBuffer())};
    gpu::updateDescriptorSet(ctx, geometrySet_, geometryWrites);
    const VkImageLayout readOnly = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
    for (uint32_t m = 0; m < materials; ++m) {  // each map with its texture's own sampler
      VkDescriptorSet set = allocateSet(materialLayout_);
      for (uint32_t k = 0; k < scenes::kMapSlotCount; ++k) {
        writeImage(set, k, scene.materialMap(m, k), scene.materialSampler(m, k), readOnly);
      }
      if (emissiveMaps) writeImage(set, shaders::kBindingEmissiveMap, scene.emissiveMap(m), scene.emissiveSampler(m), readOnly);
      materialSets_.push_back(set);
    }
    // Map arrays: one repeating trilinear sampler per kind; a texture that
    // wraps otherwise is wrapped in the shader (TALLY_WRAP_EMULATION).
    mapArraySet_ = allocateSet(mapArrayLayout_);
    for (uint32_t k = 0; k < scenes::kMapSlotCount; ++k) {
      writeImage(mapArraySet_, k, scene.mapArray(k), scene.sampler(), readOnly);
    }
    if (emissiveMaps) writeImage(mapArraySet_, shaders::kBindingEmissiveMap, scene.emissiveArray(), scene.sampler(), readOnly);
    targetSampler_ = gpu::createSampler(ctx, VK_FILTER_NEAREST, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE);

    // Shared targets and resources.
    for (auto& r : scene.bufferResources()) {
      // With LOD on, "indices" is the buffer the renderer binds: the original
      // indices and every coarser level.
      if (lod_ && r.name == "indices") r.allocationBytes = lod_->indexAllocationBytes();
      if (packedVertices_ && r.name == "vertices") r = packedVertices_->info;  // the buffer bound instead
      resources_.push_back(r);
    }
    ResourceInfo camera;
    camera.name = "camera";
    camera.kind = ResourceKind::Buffer;
    camera.elementBytes = sizeof(shaders::Camera);
    camera.allocationBytes = cameraBuffer_.size;
    camera.usage = "uniform";
    resources_.push_back(camera);
    camera.name = "lighting";
    camera.elementBytes = sizeof(shaders::Lighting);
    camera.allocationBytes = lightingBuffer_.size;
    resources_.push_back(camera);
    resources_.push_back(scene.skyResource());
    hdr_ = createTarget("hdr", kHdrFormat,
                        VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT | hdrExtraUsage(),
                        ResourceKind::Attachment);
    final_ = createTarget("final", kFinalFormat,
                          VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                          ResourceKind::Attachment);
    depth_ = createTarget("depth", kDepthFormat,
                          VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT |
                              VK_IMAGE_USAGE_TRANSFER_SRC_BIT,  // depthImage() reads it back
                          ResourceKind::Depth);

    if (auto ok = setupShadows(); !ok) {  // the "shadow" pass first (shadows.cpp)
      std::string why = ok.error();
      destroy();
      return makeError(why);
    }
    if (std::string why = featureRefusal(); !why.empty()) {
      destroy();
      return makeError(why);
    }
    if (auto ok = setupPasses(); !ok) {
      std::string why = ok.error();
      destroy();
      return makeError(why);
    }
    setupBloom();
    setupTonemapAndSkybox();

    counters_ = gpu::createBuffer(ctx, VkDeviceSize(std::max(slotCount_, 1u)) * sizeof(uint64_t),
                                  VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                                      VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                  gpu::MemoryUse::DeviceLocal);
    counterDescriptorSet_ = allocateSet(counterLayout_);
    gpu::DescriptorWrite counterWrite = bufferWrite(0, ssbo, counters_);
    gpu::updateDescriptorSet(ctx, counterDescriptorSet_, {&counterWrite, 1});
    if (ctx.timestamps) timestamps_ = gpu::createTimestampQueries(ctx, uint32_t(passes_.size()));
    if (ctx.pipelineStatistics) {
      statistics_ = gpu::createStatisticsQueries(ctx, uint32_t(passes_.size()),
                                                 VK_QUERY_PIPELINE_STATISTIC_FRAGMENT_SHADER_INVOCATIONS_BIT |
                                                     VK_QUERY_PIPELINE_STATISTIC_COMPUTE_SHADER_INVOCATIONS_BIT);
    }
  } catch (const std::exception& e) {
    destroy();
    return makeError(std::string(name()) + ": " + e.what());
  }
  ready_ = true;
  return true;
}

nlohmann::json RendererBase::frameExtras() {
  nlohmann::json extras = nlohmann::json::object();
  if (!bloomExtras_.is_null()) extras["bloom"] = bloomExtras_;
  if (!shadow_.extras.is_null()) extras["shadows"] = shadow_.extras;
  if (lod_) extras["lod"] = lod_->extras();
  if (!tileMemoryExtras_.is_null()) extras["tile_memory"] = tileMemoryExtras_;
  if (packedVertices_) extras["tangent_frame"] = packedVertices_->stats;  // renderers/techniques/tbn.hpp
  return extras;
}

const gpu::Buffer& RendererBase::vertexBuffer() const {
  return packedVertices_ ? packedVertices_->buffer : scene_->vertices();
}
const gpu::Buffer& RendererBase::indexBuffer() const { return lod_ ? lod_->indexBuffer() : scene_->indices(); }
const gpu::Buffer& RendererBase::drawsBuffer() const { return lod_ ? lod_->drawBuffer() : scene_->drawBuffer(); }

void RendererBase::recordAll(VkCommandBuffer cmd) {
  vkCmdFillBuffer(cmd, counters_.buffer, 0, VK_WHOLE_SIZE, 0);  // counters are per frame
  VkMemoryBarrier barrier = {VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  barrier.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
  barrier.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT;
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, 0, 1,
                       &barrier, 0, nullptr, 0, nullptr);
  if (timestamps_.pool != VK_NULL_HANDLE) gpu::resetTimestamps(cmd, timestamps_);
  if (statistics_.pool != VK_NULL_HANDLE) gpu::resetStatistics(cmd, statistics_);
  for (uint32_t i = 0; i < passes_.size(); ++i) {
    passes_[i].indicesDrawn = 0;
    if (timestamps_.pool != VK_NULL_HANDLE) gpu::writePassBegin(cmd, timestamps_, i);
    passes_[i].record(cmd);
    if (timestamps_.pool != VK_NULL_HANDLE) gpu::writePassEnd(cmd, timestamps_, i);
  }
}

FrameResult RendererBase::renderFrame(const scenes::Camera& camera) {
  FrameResult frame;
  if (!ready_) return frame;
  // Near/far from the scene bounds unless the options fix them (sweeps).
  DepthRange range = options_.depthRange.zFar > options_.depthRange.zNear && options_.depthRange.zNear > 0
                         ? options_.depthRange
                         : depthRangeFor(scene_->bounds(), camera);
  shaders::Camera c = cameraUniform(camera, extent_, range);
  frameCamera_ = c;
  gpu::uploadBuffer(*ctx_, cameraBuffer_, {reinterpret_cast<const uint8_t*>(&c), sizeof c});
  if (lod_) lod_->select(camera, extent_);

  gpu::submitAndWait(*ctx_, [&](VkCommandBuffer cmd) { recordAll(cmd); });

  std::vector<double> times;
  if (timestamps_.pool != VK_NULL_HANDLE) times = gpu::readPassTimesMs(*ctx_, timestamps_);
  std::vector<gpu::PipelineStatistics> stats;
  if (statistics_.pool != VK_NULL_HANDLE) stats = gpu::readStatistics(*ctx_, statistics_);
  std::vector<uint64_t> counters;
  if (options_.instrumented && slotCount_ > 0) {
    auto bytes = gpu::readBuffer(*ctx_, counters_, 0, VkDeviceSize(slotCount_) * sizeof(uint64_t));
    counters.resize(slotCount_);
    std::memcpy(counters.data(), bytes.data(), counters.size() * sizeof(uint64_t));  // little-endian hosts
  }
  const uint32_t depthBytes = gpu::formatBytes(kDepthFormat);
  for (uint32_t i = 0; i < passes_.size(); ++i) {
    const Pass& p = passes_[i];
    PassResult r;
    r.name = p.name;
    if (i < times.size()) r.gpuMs = times[i];
    if (i < stats.size()) {
      r.fragmentInvocationsStatistic = int64_t(stats[i].fragmentShaderInvocations);
      r.computeInvocationsStatistic = int64_t(stats[i].computeShaderInvocations);
    }
    if (options_.instrumented) {
      PassCounts counts = attributeCounters(p.sites, counters, p.bindings, resources_);
      r.fragmentInvocations = counts.fragmentInvocations;
      r.computeInvocations = counts.computeInvocations;
      r.accesses = std::move(counts.accesses);
      r.maxSlotCount = counts.maxSlotCount;
      r.maxSlotResource = std::move(counts.maxSlotResource);
      if (p.indexFetches && p.indicesDrawn > 0) {
        addAccess(r.accesses, "indices", false, p.indicesDrawn, sizeof(uint32_t), "derived");
      }
      if (!p.depthWrite.empty()) {
        // The written target's texel ("depth": D32_S8; "shadow_map": D32_SFLOAT).
        uint32_t writeBytes = depthBytes;
        for (const auto& info : resources_) {
          if (info.name == p.depthWrite && info.elementBytes > 0) writeBytes = info.elementBytes;
        }
        addAccess(r.accesses, p.depthWrite, true, r.fragmentInvocations, writeBytes, "derived");
      }
      if (p.name == "transparent") {
        // Blending reads the destination texel of every write (docs/measurement.md).
        std::vector<Access> blendReads;
        for (const auto& a : r.accesses)
          if (a.write && a.source == "counter" && a.resource == "final") blendReads.push_back(a);
        for (const auto& a : blendReads)
          addAccess(r.accesses, a.resource, false, a.count, a.count ? a.bytes / a.count : 0, "derived");
      }
    }
    frame.passes.push_back(std::move(r));
  }
  frame = finishFrame(std::move(frame));
  // The tile-memory model: lines of the resources a pass keeps on chip.
  for (uint32_t i = 0; i < passes_.size() && i < frame.passes.size(); ++i) {
    for (auto& a : frame.passes[i].accesses) a.onChip = passes_[i].onChip.count(a.resource) > 0;
  }
  // Extras only where a pass keeps something on chip (a technique's
  // measurement, as bloom's); elsewhere both models agree line by line.
  const bool anyOnChip = std::any_of(passes_.begin(), passes_.end(), [](const Pass& p) { return !p.onChip.empty(); });
  if (options_.instrumented && anyOnChip) tileMemoryExtras_ = tileMemorySummary(frame);
  return frame;
}

std::vector<uint8_t> RendererBase::finalImage() {
  if (!ready_) return {};
  return gpu::readImage(*ctx_, *final_, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
}

std::vector<float> RendererBase::depthImage() {
  if (!ready_) return {};
  // After the skybox pass the depth target is read-only depth/stencil.
  std::vector<uint8_t> bytes =
      gpu::readImage(*ctx_, *depth_, VK_IMAGE_LAYOUT_DEPTH_STENCIL_READ_ONLY_OPTIMAL);
  std::vector<float> out(bytes.size() / sizeof(float));
  std::memcpy(out.data(), bytes.data(), out.size() * sizeof(float));
  return out;
}

std::vector<uint8_t> RendererBase::targetBytes(std::string_view resourceName) {
  if (!ready_) return {};
  for (size_t i = 0; i < targets_.size(); ++i) {
    if (targetNames_[i].name != resourceName) continue;
    if ((targetNames_[i].usage & VK_IMAGE_USAGE_TRANSFER_SRC_BIT) == 0) return {};
    // Where the last frame leaves each target: "final" after the skybox pass,
    // "depth" read-only, every other target sampled by a later pass
    // (AttachmentSpec::final).
    VkImageLayout layout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
    if (&targets_[i] == final_) layout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    if (&targets_[i] == depth_) layout = VK_IMAGE_LAYOUT_DEPTH_STENCIL_READ_ONLY_OPTIMAL;
    return gpu::readImage(*ctx_, targets_[i], layout);
  }
  return {};
}

void RendererBase::destroy() {
  if (ctx_ == nullptr) return;
  const gpu::Context& ctx = *ctx_;
  vkDeviceWaitIdle(ctx.device);
  destroyPasses();
  lod_.reset();
  if (packedVertices_) gpu::destroyBuffer(ctx, packedVertices_->buffer);
  packedVertices_.reset();
  for (auto p : pipelines_) vkDestroyPipeline(ctx.device, p, nullptr);
  for (auto l : pipelineLayouts_) vkDestroyPipelineLayout(ctx.device, l, nullptr);
  for (auto& m : modules_) gpu::destroyShaderModule(ctx, m);
  for (auto f : framebuffers_) vkDestroyFramebuffer(ctx.device, f, nullptr);
  for (auto r : renderPasses_) vkDestroyRenderPass(ctx.device, r, nullptr);
  if (pool_ != VK_NULL_HANDLE) vkDestroyDescriptorPool(ctx.device, pool_, nullptr);
  for (auto l : ownedSetLayouts_) vkDestroyDescriptorSetLayout(ctx.device, l, nullptr);
  if (targetSampler_ != VK_NULL_HANDLE) vkDestroySampler(ctx.device, targetSampler_, nullptr);
  if (depthOnlyView_ != VK_NULL_HANDLE) vkDestroyImageView(ctx.device, depthOnlyView_, nullptr);
  if (bloomSampler_ != VK_NULL_HANDLE) vkDestroySampler(ctx.device, bloomSampler_, nullptr);
  for (auto& t : targets_) gpu::destroyImage(ctx, t);
  for (auto* b : {&counters_, &cameraBuffer_, &lightingBuffer_}) gpu::destroyBuffer(ctx, *b);
  gpu::destroyTimestampQueries(ctx, timestamps_);
  gpu::destroyStatisticsQueries(ctx, statistics_);
  pipelines_.clear();
  pipelineLayouts_.clear();
  modules_.clear();
  framebuffers_.clear();
  renderPasses_.clear();
  ownedSetLayouts_.clear();
  targets_.clear();
  targetNames_.clear();
  passes_.clear();
  resources_.clear();
  materialSets_.clear();
  pool_ = VK_NULL_HANDLE;
  targetSampler_ = VK_NULL_HANDLE;
  depthOnlyView_ = VK_NULL_HANDLE;
  bloomSampler_ = VK_NULL_HANDLE;
  bloomExtras_ = nullptr;
  tileMemoryExtras_ = nullptr;
  hdr_ = final_ = depth_ = bloom_ = nullptr;
  destroyShadows();
  slotCount_ = 0;
  ready_ = false;
  ctx_ = nullptr;
}

}  // namespace tally::renderers
