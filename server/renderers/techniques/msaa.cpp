#include "renderers/techniques/msaa.hpp"

#include <algorithm>

#include "gpu/vk_check.hpp"
#include "renderers/renderer_base.hpp"

namespace tally::renderers {
namespace {

bool isIntegerFormat(VkFormat format) {
  switch (format) {
    case VK_FORMAT_R32_UINT:
    case VK_FORMAT_R32G32_UINT:
    case VK_FORMAT_R32G32B32_UINT:
    case VK_FORMAT_R32G32B32A32_UINT: return true;
    default: return false;
  }
}

}  // namespace

std::string sampleCountList(VkSampleCountFlags flags) {
  std::string out;
  for (uint32_t n = 1; n <= 64; n *= 2) {
    if (flags & n) out += (out.empty() ? "" : ", ") + std::to_string(n);
  }
  return out.empty() ? "none" : out;
}

std::string msaaUnsupported(const gpu::Context& ctx, uint32_t samples, const std::vector<MsaaTarget>& targets,
                            bool sampledDepth) {
  if (samples != 1 && samples != 2 && samples != 4 && samples != 8) {
    return "msaa " + std::to_string(samples) + ": the sample count must be 1, 2, 4 or 8";
  }
  if (samples == 1) return "";
  VkPhysicalDeviceProperties props;
  vkGetPhysicalDeviceProperties(ctx.physicalDevice, &props);
  const VkPhysicalDeviceLimits& l = props.limits;
  const std::string head = "msaa " + std::to_string(samples) + " is not supported by this device: ";
  auto lacks = [&](VkSampleCountFlags flags, const char* limit) -> std::string {
    if (flags & samples) return "";
    return head + "VkPhysicalDeviceLimits::" + limit + " lacks VK_SAMPLE_COUNT_" + std::to_string(samples) +
           "_BIT (it has " + sampleCountList(flags) + ")";
  };
  for (auto [flags, limit] : {std::pair{l.framebufferColorSampleCounts, "framebufferColorSampleCounts"},
                              std::pair{l.framebufferDepthSampleCounts, "framebufferDepthSampleCounts"},
                              std::pair{l.framebufferStencilSampleCounts, "framebufferStencilSampleCounts"}}) {
    if (auto why = lacks(flags, limit); !why.empty()) return why;
  }
  if (sampledDepth) {
    if (auto why = lacks(l.sampledImageDepthSampleCounts, "sampledImageDepthSampleCounts"); !why.empty()) return why;
  }
  for (const auto& t : targets) {
    const bool integer = isIntegerFormat(t.format);
    auto why = integer ? lacks(l.sampledImageIntegerSampleCounts, "sampledImageIntegerSampleCounts")
                       : lacks(l.sampledImageColorSampleCounts, "sampledImageColorSampleCounts");
    if (!why.empty()) return why;
    VkImageFormatProperties f = {};
    VkResult r = vkGetPhysicalDeviceImageFormatProperties(ctx.physicalDevice, t.format, VK_IMAGE_TYPE_2D,
                                                          VK_IMAGE_TILING_OPTIMAL, t.usage, 0, &f);
    if (r != VK_SUCCESS || (f.sampleCounts & samples) == 0) {
      return head + "VkImageFormatProperties::sampleCounts of VkFormat " + std::to_string(int(t.format)) +
             " lacks VK_SAMPLE_COUNT_" + std::to_string(samples) + "_BIT (it has " +
             sampleCountList(r == VK_SUCCESS ? f.sampleCounts : 0) + ")";
    }
  }
  return "";
}

nlohmann::json msaaExtras(const std::vector<ResourceInfo>& resources, uint32_t samples) {
  uint64_t perSample = 0, perPixel = 0;
  for (const auto& r : resources) {
    if (r.kind != ResourceKind::Attachment && r.kind != ResourceKind::Depth) continue;
    (r.samples > 1 ? perSample : perPixel) += r.allocationBytes;
  }
  return {{"samples", samples},
          {"render_target_bytes", perSample + perPixel},
          {"per_sample_bytes", perSample},
          {"per_pixel_bytes", perPixel}};
}

void scaleSampleWrites(PassResult& pass, const std::vector<ResourceInfo>& resources, uint32_t samples) {
  if (samples <= 1) return;
  for (auto& access : pass.accesses) {
    if (!access.write) continue;
    auto it = std::find_if(resources.begin(), resources.end(),
                           [&](const ResourceInfo& r) { return r.name == access.resource; });
    if (it == resources.end() || it->samples <= 1) continue;
    access.count *= samples;
    access.bytes *= samples;
    access.source = "derived";
  }
}

VkImageView depthAspectView(const gpu::Context& ctx, const gpu::Image& image) {
  VkImageViewCreateInfo view = {VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
  view.image = image.image;
  view.viewType = VK_IMAGE_VIEW_TYPE_2D;
  view.format = image.format;
  view.subresourceRange = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, 0, 1};
  VkImageView out = VK_NULL_HANDLE;
  VK_CHECK(vkCreateImageView(ctx.device, &view, nullptr, &out));
  ctx.log->view(out, {image.extent.width, image.extent.height, 1, 0, 1, 1, 4, VK_IMAGE_VIEW_TYPE_2D});
  return out;
}

void msaaResolveState(gpu::GraphicsPipelineDesc& desc) {
  desc.depthTest = false;
  desc.depthWrite = false;
  desc.stencilTest = true;
  desc.stencilCompare = VK_COMPARE_OP_ALWAYS;
  desc.stencilPassOp = VK_STENCIL_OP_REPLACE;
  desc.stencilReference = kStencilGeometry;
  desc.stencilWriteMask = 0xff;
}

}  // namespace tally::renderers
