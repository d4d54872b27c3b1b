// The tile-memory byte model (docs/measurement.md, "Byte models") and the
// transient attachments it is about (docs/techniques.md, "Tile memory").
//
// Beside the immediate-mode model (every access line costs its bytes in
// DRAM), a tile-based GPU keeps some traffic in tile memory: writes of
// attachments whose storeOp is DONT_CARE (transient) and input-attachment
// reads (subpassLoad) of the render pass that wrote them. A renderer names
// those resources per pass (RendererBase::Pass::onChip); RendererBase marks
// the pass's lines Access::onChip and summarises both models here.
#pragma once

#include <string>

#include <vulkan/vulkan.h>
#include <nlohmann/json.hpp>

#include "gpu/context.hpp"
#include "gpu/resources.hpp"
#include "renderers/renderer.hpp"

namespace tally::renderers {

// "lazily_allocated", "device_local" or "host_visible", from a memory type's flags.
std::string memoryKindName(VkMemoryPropertyFlags flags);

// The memory type gpu::createImage takes for `requirements` (device-local
// preferred), by name.
std::string imageMemoryKind(const gpu::Context& ctx, const VkMemoryRequirements& requirements);

// Both byte models of a frame: {"bytes": immediate total, "bytes_dram": the
// tile model's total (on-chip lines cost 0), "bytes_on_chip": their
// difference, "passes": {pass: {"bytes", "bytes_dram"}}, "on_chip_lines":
// ["pass/resource/read|write", ...]}.
nlohmann::json tileMemorySummary(const FrameResult& frame);

// A 2D single-sample colour attachment for `usage` (which should hold
// VK_IMAGE_USAGE_TRANSIENT_ATTACHMENT_BIT): memory from a LAZILY_ALLOCATED
// type where its requirements allow one, else as gpu::createImage.
// `memoryKind` gets memoryKindName of the type taken. Destroy with
// gpu::destroyImage.
gpu::Image createTransientImage(const gpu::Context& ctx, uint32_t width, uint32_t height, VkFormat format,
                                VkImageUsageFlags usage, std::string& memoryKind);

}  // namespace tally::renderers
