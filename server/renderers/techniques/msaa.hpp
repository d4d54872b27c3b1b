// MSAA for the deferred and visibility-buffer renderers
// (RendererOptions::msaa; docs/techniques.md, "MSAA footprint"). With N > 1
// samples the geometry pass renders its targets and a "depth.msaa"
// depth/stencil at N samples; the full-screen shading pass (no stencil test)
// fetches every sample (texelFetch of a sampler2DMS), shades and averages the
// covered ones into the 1-sample "hdr", discards pixels with no covered
// sample and writes stencil 1 into the 1-sample "depth" elsewhere, so that
// the skybox pass keeps its stencil test. msaa = 1 is the renderers as they were.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "gpu/context.hpp"
#include "gpu/pipelines.hpp"
#include "gpu/resources.hpp"
#include "renderers/renderer.hpp"

namespace tally::renderers {

constexpr const char* kMsaaDepthName = "depth.msaa";  // the N-sample depth/stencil of the geometry pass

// A target the geometry pass renders at N samples and the shading pass samples.
struct MsaaTarget {
  VkFormat format = VK_FORMAT_UNDEFINED;
  VkImageUsageFlags usage = 0;
};

// Why `samples` cannot run on this device ("" when it can): the sample count
// must be 1, 2, 4 or 8 and in VkPhysicalDeviceLimits' framebufferColor-,
// framebufferDepth-, framebufferStencilSampleCounts, in sampledImageColor- or
// sampledImageIntegerSampleCounts for each colour target (by its format),
// in sampledImageDepthSampleCounts where `sampledDepth`, and in each format's
// VkImageFormatProperties::sampleCounts.
std::string msaaUnsupported(const gpu::Context& ctx, uint32_t samples, const std::vector<MsaaTarget>& targets,
                            bool sampledDepth);

// The sample counts in `flags` as "1, 4".
std::string sampleCountList(VkSampleCountFlags flags);

// {"samples", "render_target_bytes", "per_sample_bytes", "per_pixel_bytes"}
// from the targets' real allocations: per-sample bytes are those of targets
// with more than one sample, per-pixel bytes those of the other attachment and
// depth targets (hdr, final, the 1-sample stencil mask "depth", bloom's).
nlohmann::json msaaExtras(const std::vector<ResourceInfo>& resources, uint32_t samples);

// The geometry pass's attachment writes at N > 1 samples: the counters count
// one output per fragment invocation, the device writes every covered sample
// of it. Write lines on targets with more than one sample (the outputs and
// the derived depth writes) become fragments x N, source "derived" (exact
// where fragments cover every sample, an upper bound at edges).
void scaleSampleWrites(PassResult& pass, const std::vector<ResourceInfo>& resources, uint32_t samples);

// A view of the depth aspect of a depth/stencil image (multisampled or not), for sampling.
VkImageView depthAspectView(const gpu::Context& ctx, const gpu::Image& image);

// The shading pass's state with N > 1: no depth test, stencil ALWAYS with
// REPLACE of kStencilGeometry into the 1-sample "depth" (cleared to 0), so
// the pixels the shader does not discard become geometry for the skybox.
void msaaResolveState(gpu::GraphicsPipelineDesc& desc);

}  // namespace tally::renderers
