// What decides a line beyond the descriptors (docs/layer.md, "How counts are
// attributed"): where a draw's fragment outputs go (the scope's attachments,
// the pipeline's colour write masks and rasterizer discard, static or
// dynamic; a secondary command buffer's inherited attachments), which vertex
// buffer and format an attribute reads (static or dynamic vertex input), a
// line's kind from its use, and the numbering of passes that share a label.
// state.hpp includes this header for the structs; the functions are in
// attribution.cpp and dynamic_state.cpp.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <vulkan/vulkan.h>

#include "spirv/sites.hpp"

namespace tally::layer {

enum class Kind;
struct Bound;
struct Resource;
struct Region;
struct PassRecord;
struct PipelineInfo;
struct CommandBufferState;
struct DeviceState;

// Bound::resource of a fragment output the draw does not write: no
// attachment at its Location, a write mask of 0, a disabled colour write, or
// rasterizer discard. Its counter still runs; its count is dropped.
constexpr uint64_t kNotWritten = ~uint64_t(0);
// Bound::resource of a secondary command buffer's fragment output whose
// attachment is the executing primary's: resolved at vkCmdExecuteCommands.
constexpr uint64_t kInherited = ~uint64_t(0) - 1;

struct VertexAttribute {
  uint32_t binding = 0;
  VkFormat format = VK_FORMAT_UNDEFINED;
};

// What a graphics pipeline fixes of its draws' writes and vertex reads, and
// which of it the command buffer's dynamic state decides instead.
struct FixedFunction {
  std::vector<VkColorComponentFlags> writeMasks;  // per colour attachment; none given: all written
  std::vector<VkBool32> writeEnables;             // VkPipelineColorWriteCreateInfoEXT; none given: all enabled
  bool rasterizerDiscard = false;
  bool dynamicWriteMask = false, dynamicWriteEnable = false, dynamicDiscard = false, dynamicVertexInput = false;
  std::map<uint32_t, VertexAttribute> attributes;  // by Location
};

// The command buffer's dynamic state that FixedFunction defers to.
struct DynamicState {
  std::vector<VkColorComponentFlags> writeMasks;  // vkCmdSetColorWriteMaskEXT, per attachment
  std::vector<VkBool32> writeEnables;             // vkCmdSetColorWriteEnableEXT
  bool rasterizerDiscard = false;                 // vkCmdSetRasterizerDiscardEnable
  std::map<uint32_t, VertexAttribute> attributes;  // vkCmdSetVertexInputEXT, by Location
};

// ---- attribution.cpp

// vkCreateGraphicsPipelines: the pipeline's FixedFunction.
FixedFunction fixedFunctionOf(const DeviceState& dev, const VkGraphicsPipelineCreateInfo& info);
// A subpass's colour attachments by Location, from the render pass
// instance's attachments and the subpass's references (VK_ATTACHMENT_UNUSED:
// kNotWritten; an attachment whose image the layer does not know: none).
std::vector<Bound> subpassTargets(const std::vector<Bound>& attachments, const std::vector<uint32_t>& references);
// vkCmdBeginRendering: the scope's colour attachments (a null view: kNotWritten).
std::vector<Bound> renderingTargets(const DeviceState& dev, const VkRenderingInfo& info);
// vkBeginCommandBuffer of a secondary: its colour attachments from its
// inheritance info; kInherited where only the executing primary knows them.
void inheritTargets(const DeviceState& dev, CommandBufferState& cb, const VkCommandBufferBeginInfo& info);
// vkCmdExecuteCommands: a secondary's region with its kInherited outputs
// resolved against the primary's current scope.
void resolveInherited(const CommandBufferState& primary, Region& region);
// A draw: what fragment output `location` writes.
Bound outputTarget(const CommandBufferState& cb, const PipelineInfo& pipeline, uint32_t location);
// A draw: the vertex buffer (and the attribute's format) behind input `location`.
Bound vertexSource(const CommandBufferState& cb, const PipelineInfo& pipeline, uint32_t location);
// Bytes of one vertex attribute read: the shader type's, or the attribute
// format's element where the shader's type says less.
uint32_t vertexElementBytes(const spirv::Site& site, VkFormat format);
// What an unnamed image is called: its one role ("texture", "storage image",
// "attachment", "depth"), or "image" where its usage allows several (zink
// creates every image for attachment and sampled use); `kind` where none.
std::string imageRole(VkImageUsageFlags usage, Kind kind);
// A line's kind from its use: "texture", "storage image", "attachment",
// "depth" or "buffer".
std::string lineKind(const spirv::Site& site, const Resource* resource, VkFormat viewFormat);
// A frame's passes as written out: later subpasses without a label of their
// own joined to their render pass instance's first, every other pass kept,
// and passes that share a name numbered "name", "name #2", "name #3".
std::vector<PassRecord> distinctPasses(const std::vector<PassRecord>& passes);
// Bits set in a view mask, at least 1: query indices a query takes there.
uint32_t viewCount(uint32_t viewMask);

// ---- dynamic_state.cpp

// The dynamic-state commands the layer records, by name ("vkCmdSetVertexInputEXT").
PFN_vkVoidFunction interceptedDynamicState(std::string_view name);

}  // namespace tally::layer
