// Shadow mapping (shadows.hpp): the option's names, the sun's fitted
// orthographic projection and RendererBase's shadow pass.
#include "renderers/techniques/shadows.hpp"

#include <algorithm>
#include <cmath>

#include <glm/gtc/matrix_transform.hpp>

#include "gpu/pipelines.hpp"
#include "gpu/vk_check.hpp"
#include "renderers/renderer_base.hpp"

namespace tally::renderers {

constexpr VkFormat kShadowFormat = VK_FORMAT_D32_SFLOAT;

std::string_view toString(ShadowFilter filter) {
  switch (filter) {
    case ShadowFilter::Off: return "off";
    case ShadowFilter::Hard: return "hard";
    case ShadowFilter::Pcf2x2: return "pcf2x2";
    case ShadowFilter::Pcf4x4: return "pcf4x4";
  }
  return "off";
}

std::optional<ShadowFilter> parseShadowFilter(std::string_view name) {
  for (ShadowFilter f : {ShadowFilter::Off, ShadowFilter::Hard, ShadowFilter::Pcf2x2, ShadowFilter::Pcf4x4}) {
    if (toString(f) == name) return f;
  }
  return std::nullopt;
}

uint32_t shadowTapsPerPixel(ShadowFilter filter) {
  switch (filter) {
    case ShadowFilter::Off: return 0;
    case ShadowFilter::Hard:
    case ShadowFilter::Pcf2x2: return 1;
    case ShadowFilter::Pcf4x4: return 4;
  }
  return 0;
}

shaders::Shadow shadowUniform(const scenes::Bounds& bounds, const ShadowOptions& options) {
  glm::vec3 dir(options.sunDirection[0], options.sunDirection[1], options.sunDirection[2]);
  dir = glm::length(dir) > 0 ? glm::normalize(dir) : glm::vec3(0, 1, 0);
  const glm::vec3 lo = bounds.empty() ? glm::vec3(-1) : bounds.min;
  const glm::vec3 hi = bounds.empty() ? glm::vec3(1) : bounds.max;
  const glm::vec3 centre = (lo + hi) * 0.5f;
  const glm::vec3 up = std::abs(dir.y) > 0.99f ? glm::vec3(0, 0, 1) : glm::vec3(0, 1, 0);
  const glm::mat4 view = glm::lookAt(centre + dir, centre, up);  // looks along -dir
  glm::vec3 mn(std::numeric_limits<float>::max()), mx(std::numeric_limits<float>::lowest());
  for (int i = 0; i < 8; ++i) {
    glm::vec3 corner((i & 1) ? hi.x : lo.x, (i & 2) ? hi.y : lo.y, (i & 4) ? hi.z : lo.z);
    glm::vec3 v = glm::vec3(view * glm::vec4(corner, 1.0f));
    v.z = -v.z;  // distance along the light's view direction
    mn = glm::min(mn, v);
    mx = glm::max(mx, v);
  }
  const glm::vec3 pad = glm::max((mx - mn) * 0.01f, glm::vec3(1e-3f));
  mn -= pad;
  mx += pad;
  // Orthographic: x, y to [-1, 1] (rows follow +y: uv = xy * 0.5 + 0.5 in
  // shadow.h addresses the texel the rasterizer wrote), depth to [0, 1].
  glm::mat4 proj(1.0f);
  proj[0][0] = 2.0f / (mx.x - mn.x);
  proj[3][0] = -(mx.x + mn.x) / (mx.x - mn.x);
  proj[1][1] = 2.0f / (mx.y - mn.y);
  proj[3][1] = -(mx.y + mn.y) / (mx.y - mn.y);
  proj[2][2] = -1.0f / (mx.z - mn.z);  // view z is -distance
  proj[3][2] = -mn.z / (mx.z - mn.z);
  shaders::Shadow s = {};
  s.viewProj = proj * view;
  s.direction = glm::vec4(dir, 0.0f);
  s.color = glm::vec4(kSunRadiance, kSunRadiance, kSunRadiance, 0.0f);
  const float size = float(std::max(options.mapSize, 1u));
  s.params = glm::vec4(options.bias, std::max(mx.x - mn.x, mx.y - mn.y) / size, mx.z - mn.z, size);
  return s;
}

std::vector<std::string> RendererBase::shadowDefines() const {
  if (options_.shadows.filter == ShadowFilter::Off) return {};
  std::vector<std::string> out = {"TALLY_SHADOWS"};
  if (options_.shadows.filter == ShadowFilter::Pcf4x4) out.push_back("TALLY_SHADOW_PCF4X4");
  return out;
}

void RendererBase::shadowBindings(PassBindings& b) const {
  if (options_.shadows.filter == ShadowFilter::Off) return;
  b.bind(shaders::kSetFrame, shaders::kBindingShadow, "shadow");
  b.bind(shaders::kSetFrame, shaders::kBindingShadowMap, "shadow_map");
  b.elementBytes[{shaders::kSetFrame, shaders::kBindingShadowMap}] = 4;  // one D32_SFLOAT texel per compare tap
}

// Before setupPasses(), after the frame set exists: the map, its compare
// sampler, the sun's uniform, set 0's two shadow bindings and the pass.
Result<bool> RendererBase::setupShadows() {
  const ShadowOptions& o = options_.shadows;
  if (o.filter == ShadowFilter::Off) return true;
  const uint32_t size = o.mapSize;
  if (size == 0 || size > ctx_->properties.limits.maxFramebufferWidth ||
      size > ctx_->properties.limits.maxFramebufferHeight) {
    return makeError("shadow_map_size: " + std::to_string(size) + " exceeds the device's framebuffer limit");
  }
  VkFormatProperties props = {};
  vkGetPhysicalDeviceFormatProperties(ctx_->physicalDevice, kShadowFormat, &props);
  const VkFormatFeatureFlags need = VK_FORMAT_FEATURE_DEPTH_STENCIL_ATTACHMENT_BIT |
                                    VK_FORMAT_FEATURE_SAMPLED_IMAGE_BIT;
  if ((props.optimalTilingFeatures & need) != need) {
    return makeError("shadows: the device cannot render and sample D32_SFLOAT (the shadow map)");
  }
  const bool linear = o.filter != ShadowFilter::Hard;
  if (linear && (props.optimalTilingFeatures & VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT) == 0) {
    return makeError("shadows=" + std::string(toString(o.filter)) +
                     ": the device cannot linear-filter D32_SFLOAT (hardware PCF)");
  }
  shadow_.map = gpu::createImage(*ctx_, size, size, kShadowFormat,
                                 VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT);
  VkMemoryRequirements req;
  vkGetImageMemoryRequirements(ctx_->device, shadow_.map.image, &req);
  ResourceInfo info;
  info.name = "shadow_map";
  info.kind = ResourceKind::Depth;
  info.format = kShadowFormat;
  info.formatName = "D32_SFLOAT";
  info.elementBytes = gpu::formatBytes(kShadowFormat);
  info.width = info.height = size;
  info.allocationBytes = req.size;
  info.usage = "depth_stencil_attachment|sampled";
  info.objects = {gpu::objectOf(shadow_.map.image)};
  resources_.push_back(info);

  VkSamplerCreateInfo sampler = {VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  sampler.magFilter = sampler.minFilter = linear ? VK_FILTER_LINEAR : VK_FILTER_NEAREST;
  sampler.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
  sampler.addressModeU = sampler.addressModeV = sampler.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  sampler.compareEnable = VK_TRUE;
  sampler.compareOp = VK_COMPARE_OP_LESS_OR_EQUAL;  // lit where reference <= stored depth
  sampler.maxLod = 0.0f;
  sampler.borderColor = VK_BORDER_COLOR_FLOAT_OPAQUE_WHITE;
  VK_CHECK(vkCreateSampler(ctx_->device, &sampler, nullptr, &shadow_.sampler));
  ctx_->log->sampler(shadow_.sampler, sampler);

  const shaders::Shadow uniform = shadowUniform(scene_->bounds(), o);
  shadow_.uniform = gpu::createBuffer(*ctx_, sizeof uniform, VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, gpu::MemoryUse::Upload);
  gpu::uploadBuffer(*ctx_, shadow_.uniform, {reinterpret_cast<const uint8_t*>(&uniform), sizeof uniform});
  ResourceInfo ubo;
  ubo.name = "shadow";
  ubo.kind = ResourceKind::Buffer;
  ubo.elementBytes = sizeof(shaders::Shadow);
  ubo.allocationBytes = shadow_.uniform.size;
  ubo.usage = "uniform";
  ubo.objects = {gpu::objectOf(shadow_.uniform.buffer)};
  resources_.push_back(ubo);

  gpu::DescriptorWrite writes[2];
  writes[0].binding = shaders::kBindingShadow;
  writes[0].type = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
  writes[0].buffer = {shadow_.uniform.buffer, 0, VK_WHOLE_SIZE};
  writes[1].binding = shaders::kBindingShadowMap;
  writes[1].type = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  writes[1].image = {shadow_.sampler, shadow_.map.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  gpu::updateDescriptorSet(*ctx_, frameSet_, writes);

  // The pass: depth only, LESS, cleared to 1; the empty counting fragment
  // shader in instrumented runs (as the z pre-pass) so its depth writes are
  // its counted fragment invocations (early tests).
  uint32_t p = addPass("shadow");
  VkRenderPass rp = ownRenderPass(createPassRenderPass(
      *ctx_, {},
      AttachmentSpec{kShadowFormat, true, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
                     VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL}));
  const VkExtent2D extent = {size, size};
  framebuffers_.push_back(gpu::createFramebuffer(*ctx_, rp, std::span<const VkImageView>(&shadow_.map.view, 1), extent));
  VkFramebuffer fb = framebuffers_.back();
  auto depthOnly = depthOnlyPipeline(p, "shadow.vert.glsl", rp);
  if (!depthOnly) return makeError(depthOnly.error());
  gpu::GraphicsPipelineDesc desc = *depthOnly;
  desc.depthTest = true;
  desc.depthWrite = true;
  desc.depthCompare = VK_COMPARE_OP_LESS;
  VkPipeline pipe = pipeline(desc);
  VkPipelineLayout layout = desc.layout;
  pass(p).indexFetches = true;
  pass(p).depthWrite = "shadow_map";
  // alphaMode MASK draws cast the shadow of what their test keeps.
  auto masked = maskedDraws(p, desc, "shadow.vert.glsl", "zprepass.frag.glsl");
  if (!masked) return makeError(masked.error());
  pass(p).record = [=, this, masked = *masked](VkCommandBuffer cmd) {
    VkClearValue clear = {};
    clear.depthStencil = {1.0f, 0};
    VkRenderPassBeginInfo begin = {VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
    begin.renderPass = rp;
    begin.framebuffer = fb;
    begin.renderArea = {{0, 0}, extent};
    begin.clearValueCount = 1;
    begin.pClearValues = &clear;
    vkCmdBeginRenderPass(cmd, &begin, VK_SUBPASS_CONTENTS_INLINE);
    if (statistics_.pool != VK_NULL_HANDLE) gpu::beginStatistics(cmd, statistics_, p);
    gpu::setViewportAndScissor(cmd, extent);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipe);
    bindSets(cmd, layout, VK_NULL_HANDLE, VK_NULL_HANDLE);
    drawScene(cmd, p, layout, false);
    if (masked) masked(cmd);
    endRenderPass(cmd, p);
  };
  const glm::vec4 d = uniform.direction;
  shadow_.extras = {{"filter", std::string(toString(o.filter))},
                    {"map_size", size},
                    {"bias", o.bias},
                    {"bias_unit", "texels"},
                    {"texel_m", uniform.params.y},
                    {"sun_direction", {d.x, d.y, d.z}},
                    {"taps_per_shaded_pixel", shadowTapsPerPixel(o.filter)}};
  return true;
}

void RendererBase::destroyShadows() {
  if (ctx_ == nullptr) return;
  if (shadow_.sampler != VK_NULL_HANDLE) vkDestroySampler(ctx_->device, shadow_.sampler, nullptr);
  gpu::destroyImage(*ctx_, shadow_.map);
  gpu::destroyBuffer(*ctx_, shadow_.uniform);
  shadow_ = ShadowState{};
}

}  // namespace tally::renderers
