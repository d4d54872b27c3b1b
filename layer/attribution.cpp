#include "attribution.hpp"

#include <algorithm>
#include <bit>

#include "names.hpp"
#include "state.hpp"

namespace tally::layer {

namespace {

constexpr VkColorComponentFlags kAllComponents = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT |
                                                 VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;

Bound viewTarget(const DeviceState& dev, VkImageView view) {
  if (view == VK_NULL_HANDLE) return {kNotWritten};
  auto it = dev.views.find(u64(view));
  if (it == dev.views.end()) return {};
  return {it->second.image, it->second.format, it->second.aspect};
}

// The colour attachments the pipeline is created for: its render pass's
// subpass, or its VkPipelineRenderingCreateInfo. pColorBlendState is ignored
// (and may point anywhere) where there are none.
uint32_t pipelineColorAttachments(const DeviceState& dev, const VkGraphicsPipelineCreateInfo& info) {
  if (info.renderPass != VK_NULL_HANDLE) {
    auto r = dev.renderPasses.find(u64(info.renderPass));
    if (r == dev.renderPasses.end() || info.subpass >= r->second.size()) return 0;
    return uint32_t(r->second[info.subpass].size());
  }
  for (auto* p = static_cast<const VkBaseInStructure*>(info.pNext); p != nullptr; p = p->pNext) {
    if (p->sType == VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO) {
      return reinterpret_cast<const VkPipelineRenderingCreateInfo*>(p)->colorAttachmentCount;
    }
  }
  return 0;
}

bool hasMeshStage(const VkGraphicsPipelineCreateInfo& info) {
  for (uint32_t s = 0; s < info.stageCount; ++s) {
    if (info.pStages[s].stage & (VK_SHADER_STAGE_MESH_BIT_EXT | VK_SHADER_STAGE_TASK_BIT_EXT)) return true;
  }
  return false;
}

bool depthOrStencil(VkFormat format) {
  switch (format) {
    case VK_FORMAT_D16_UNORM:
    case VK_FORMAT_X8_D24_UNORM_PACK32:
    case VK_FORMAT_D32_SFLOAT:
    case VK_FORMAT_S8_UINT:
    case VK_FORMAT_D16_UNORM_S8_UINT:
    case VK_FORMAT_D24_UNORM_S8_UINT:
    case VK_FORMAT_D32_SFLOAT_S8_UINT: return true;
    default: return false;
  }
}

// Adds a later subpass's counts, times and statistics to its render pass
// instance's first.
void join(PassRecord& into, const PassRecord& p) {
  into.gpuMs += p.gpuMs;
  into.timed = into.timed || p.timed;
  joinDraws(into, p, into.draws);
  into.draws += p.draws;
  into.dispatches += p.dispatches;
  into.fragmentInvocations += p.fragmentInvocations;
  into.vertexInvocations += p.vertexInvocations;
  into.computeInvocations += p.computeInvocations;
  auto addStatistic = [](int64_t& to, int64_t v) {
    if (v >= 0) to = std::max<int64_t>(to, 0) + v;
  };
  addStatistic(into.fragmentStatistic, p.fragmentStatistic);
  addStatistic(into.vertexStatistic, p.vertexStatistic);
  addStatistic(into.computeStatistic, p.computeStatistic);
  for (const auto& [key, line] : p.lines) {
    auto& to = into.lines[key];
    to.count += line.count;
    to.bytes += line.bytes;
    to.kind = line.kind;
    to.format = line.format;
  }
  for (const auto& [key, site] : p.sites) {
    auto [to, inserted] = into.sites.try_emplace(key, site);
    if (inserted) continue;
    to->second.count += site.count;
    to->second.bytes += site.bytes;
  }
}

}  // namespace

FixedFunction fixedFunctionOf(const DeviceState& dev, const VkGraphicsPipelineCreateInfo& info) {
  FixedFunction out;
  if (info.pDynamicState != nullptr) {
    for (uint32_t i = 0; i < info.pDynamicState->dynamicStateCount; ++i) {
      switch (info.pDynamicState->pDynamicStates[i]) {
        case VK_DYNAMIC_STATE_COLOR_WRITE_ENABLE_EXT: out.dynamicWriteEnable = true; break;
        case VK_DYNAMIC_STATE_COLOR_WRITE_MASK_EXT: out.dynamicWriteMask = true; break;
        case VK_DYNAMIC_STATE_RASTERIZER_DISCARD_ENABLE: out.dynamicDiscard = true; break;
        case VK_DYNAMIC_STATE_VERTEX_INPUT_EXT: out.dynamicVertexInput = true; break;
        default: break;
      }
    }
  }
  if (info.pRasterizationState != nullptr && !out.dynamicDiscard) {
    out.rasterizerDiscard = info.pRasterizationState->rasterizerDiscardEnable == VK_TRUE;
  }
  // The create info's pointers the pipeline ignores may be garbage: the
  // colour blend state without rasterization or colour attachments, the
  // vertex input state under dynamic vertex input or with mesh shaders.
  const VkPipelineColorBlendStateCreateInfo* blend = info.pColorBlendState;
  if (blend != nullptr && (!out.rasterizerDiscard || out.dynamicDiscard) && pipelineColorAttachments(dev, info) > 0) {
    for (uint32_t a = 0; a < blend->attachmentCount && blend->pAttachments != nullptr; ++a) {
      out.writeMasks.push_back(blend->pAttachments[a].colorWriteMask);
    }
    for (auto* p = static_cast<const VkBaseInStructure*>(blend->pNext); p != nullptr; p = p->pNext) {
      if (p->sType != VK_STRUCTURE_TYPE_PIPELINE_COLOR_WRITE_CREATE_INFO_EXT) continue;
      const auto* enables = reinterpret_cast<const VkPipelineColorWriteCreateInfoEXT*>(p);
      out.writeEnables.assign(enables->pColorWriteEnables, enables->pColorWriteEnables + enables->attachmentCount);
    }
  }
  const VkPipelineVertexInputStateCreateInfo* input = info.pVertexInputState;
  if (input != nullptr && !out.dynamicVertexInput && !hasMeshStage(info)) {
    for (uint32_t a = 0; a < input->vertexAttributeDescriptionCount; ++a) {
      const auto& attribute = input->pVertexAttributeDescriptions[a];
      out.attributes[attribute.location] = {attribute.binding, attribute.format};
    }
  }
  return out;
}

std::vector<Bound> subpassTargets(const std::vector<Bound>& attachments, const std::vector<uint32_t>& references) {
  std::vector<Bound> out;
  for (uint32_t a : references) {
    out.push_back(a == VK_ATTACHMENT_UNUSED ? Bound{kNotWritten} : a < attachments.size() ? attachments[a] : Bound{});
  }
  return out;
}

std::vector<Bound> renderingTargets(const DeviceState& dev, const VkRenderingInfo& info) {
  std::vector<Bound> out;
  for (uint32_t i = 0; i < info.colorAttachmentCount; ++i) out.push_back(viewTarget(dev, info.pColorAttachments[i].imageView));
  return out;
}

void inheritTargets(const DeviceState& dev, CommandBufferState& cb, const VkCommandBufferBeginInfo& info) {
  cb.colorAttachments.clear();
  if (!(info.flags & VK_COMMAND_BUFFER_USAGE_RENDER_PASS_CONTINUE_BIT) || info.pInheritanceInfo == nullptr) return;
  const VkCommandBufferInheritanceInfo& inheritance = *info.pInheritanceInfo;
  if (inheritance.renderPass != VK_NULL_HANDLE) {
    auto pass = dev.renderPasses.find(u64(inheritance.renderPass));
    if (pass == dev.renderPasses.end() || inheritance.subpass >= pass->second.size()) return;
    // The framebuffer is optional: without it (or imageless) the primary's
    // attachments decide at vkCmdExecuteCommands.
    std::vector<Bound> attachments;
    if (auto f = dev.framebuffers.find(u64(inheritance.framebuffer)); f != dev.framebuffers.end()) {
      for (uint64_t view : f->second) attachments.push_back(viewTarget(dev, reinterpret_cast<VkImageView>(view)));
    }
    for (uint32_t a : pass->second[inheritance.subpass]) {
      cb.colorAttachments.push_back(a == VK_ATTACHMENT_UNUSED ? Bound{kNotWritten}
                                    : a < attachments.size()  ? attachments[a]
                                                              : Bound{kInherited});
    }
    return;
  }
  for (auto* p = static_cast<const VkBaseInStructure*>(inheritance.pNext); p != nullptr; p = p->pNext) {
    if (p->sType != VK_STRUCTURE_TYPE_COMMAND_BUFFER_INHERITANCE_RENDERING_INFO) continue;
    const auto* rendering = reinterpret_cast<const VkCommandBufferInheritanceRenderingInfo*>(p);
    for (uint32_t i = 0; i < rendering->colorAttachmentCount; ++i) {
      const bool none = rendering->pColorAttachmentFormats[i] == VK_FORMAT_UNDEFINED;
      cb.colorAttachments.push_back({none ? kNotWritten : kInherited});
    }
  }
}

void resolveInherited(const CommandBufferState& primary, Region& region) {
  for (const auto& site : region.pipeline->sites) {
    if (site.kind != spirv::SiteKind::OutputWrite || site.slot >= region.slotResources.size()) continue;
    Bound& target = region.slotResources[site.slot];
    if (target.resource != kInherited) continue;
    const uint32_t location = site.location.value_or(0);
    target = location < primary.colorAttachments.size() ? primary.colorAttachments[location] : Bound{kNotWritten};
  }
}

Bound outputTarget(const CommandBufferState& cb, const PipelineInfo& pipeline, uint32_t location) {
  const FixedFunction& fixed = pipeline.fixed;
  if (fixed.dynamicDiscard ? cb.dynamic.rasterizerDiscard : fixed.rasterizerDiscard) return {kNotWritten};
  // Blend attachment i is colour attachment i, which fragment output Location i writes.
  const auto& masks = fixed.dynamicWriteMask ? cb.dynamic.writeMasks : fixed.writeMasks;
  const auto& enables = fixed.dynamicWriteEnable ? cb.dynamic.writeEnables : fixed.writeEnables;
  const VkColorComponentFlags mask = location < masks.size() ? masks[location] : kAllComponents;
  const bool enabled = location < enables.size() ? enables[location] == VK_TRUE : true;
  if (mask == 0 || !enabled || location >= cb.colorAttachments.size()) return {kNotWritten};
  return cb.colorAttachments[location];
}

Bound vertexSource(const CommandBufferState& cb, const PipelineInfo& pipeline, uint32_t location) {
  const auto& attributes = pipeline.fixed.dynamicVertexInput ? cb.dynamic.attributes : pipeline.fixed.attributes;
  auto attribute = attributes.find(location);
  if (attribute == attributes.end()) return {};
  auto buffer = cb.vertexBuffers.find(attribute->second.binding);
  if (buffer == cb.vertexBuffers.end()) return {};
  return {buffer->second, attribute->second.format};
}

uint32_t vertexElementBytes(const spirv::Site& site, VkFormat format) {
  return std::max(site.elementBytes, formatBytes(format));
}

std::string lineKind(const spirv::Site& site, const Resource* resource, VkFormat viewFormat) {
  if (resource != nullptr && !resource->image) return "buffer";  // texel buffers too
  if (site.kind == spirv::SiteKind::AttachmentRead) {
    const VkFormat format = viewFormat != VK_FORMAT_UNDEFINED || resource == nullptr ? viewFormat : resource->format;
    if (depthOrStencil(format)) return "depth";
  }
  return std::string(spirv::useKind(site));
}

std::vector<PassRecord> distinctPasses(const std::vector<PassRecord>& passes) {
  std::vector<PassRecord> out;
  std::vector<size_t> at(passes.size(), SIZE_MAX);  // each pass's place in out
  std::map<std::string, uint32_t> named;
  for (size_t i = 0; i < passes.size(); ++i) {
    const PassRecord& p = passes[i];
    if (p.joins >= 0 && size_t(p.joins) < i && at[size_t(p.joins)] != SIZE_MAX) {
      at[i] = at[size_t(p.joins)];
      join(out[at[i]], p);
      continue;
    }
    at[i] = out.size();
    out.push_back(p);
    const uint32_t n = ++named[p.name];
    if (n > 1) out.back().name += " #" + std::to_string(n);
  }
  return out;
}

std::string imageRole(VkImageUsageFlags usage, Kind kind) {
  const std::pair<VkImageUsageFlags, const char*> roles[] = {
      {VK_IMAGE_USAGE_SAMPLED_BIT, "texture"},
      {VK_IMAGE_USAGE_STORAGE_BIT, "storage image"},
      {VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_INPUT_ATTACHMENT_BIT, "attachment"},
      {VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, "depth"}};
  std::string out;
  for (const auto& [bits, role] : roles) {
    if (!(usage & bits)) continue;
    if (!out.empty()) return "image";
    out = role;
  }
  return out.empty() ? toString(kind) : out;
}

uint32_t viewCount(uint32_t viewMask) { return std::max(1, std::popcount(viewMask)); }

}  // namespace tally::layer
