// Graphics pipeline libraries (VK_EXT_graphics_pipeline_library): which parts
// of a pipeline a create info holds, and a pipeline linked from libraries
// counted as the union of its libraries' sites (docs/layer.md).
#pragma once

#include <cstdint>
#include <vector>

#include "state.hpp"

namespace tally::layer {

// All four parts (VkGraphicsPipelineLibraryFlagsEXT): a complete pipeline.
constexpr uint32_t kAllLibraryParts = VK_GRAPHICS_PIPELINE_LIBRARY_VERTEX_INPUT_INTERFACE_BIT_EXT |
                                      VK_GRAPHICS_PIPELINE_LIBRARY_PRE_RASTERIZATION_SHADERS_BIT_EXT |
                                      VK_GRAPHICS_PIPELINE_LIBRARY_FRAGMENT_SHADER_BIT_EXT |
                                      VK_GRAPHICS_PIPELINE_LIBRARY_FRAGMENT_OUTPUT_INTERFACE_BIT_EXT;

// In pipelines made of libraries, fragment stages count from this slot and
// pre-rasterization stages below it, so that libraries instrumented apart
// never share a slot once linked. 512 slots: 4 KiB of each region.
constexpr uint32_t kPreRasterizationSlots = 512;

struct LibraryUse {
  bool library = false;              // VK_PIPELINE_CREATE_LIBRARY_BIT_KHR: not bindable
  uint32_t parts = kAllLibraryParts;  // the parts this create info defines itself
  std::vector<uint64_t> linked;      // VkPipelineLibraryCreateInfoKHR's libraries
  bool split() const { return library || !linked.empty(); }  // slots as kPreRasterizationSlots says
};

LibraryUse libraryUse(const VkGraphicsPipelineCreateInfo& info);

// Whether a graphics stage belongs to the shader parts in `parts` (a library
// ignores the others); compute stages always do.
bool stageInParts(VkShaderStageFlagBits stage, uint32_t parts);

// Adds the libraries' sites, slots and vertex bindings to `info` (the
// union); the layout is the libraries' where the pipeline names none.
// Returns the parts the libraries hold.
uint32_t mergeLibraries(const DeviceState& dev, const std::vector<uint64_t>& libraries, PipelineInfo& info);

}  // namespace tally::layer
