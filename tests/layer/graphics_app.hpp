// graphics_app's flags and its graphics pipeline (graphics_app.cpp says what
// the application draws and what each flag changes).
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <vulkan/vulkan.h>

struct Options {
  uint32_t frames = 3, width = 96, height = 64, pushSet = 0;
  std::string pipeline = "monolithic", descriptors = "sets", draw = "direct", submit = "fence";
  std::vector<std::pair<uint32_t, uint32_t>> indirect = {{6, 1}, {3, 2}};  // (indexCount, instanceCount)
};

// The flags; a bad one ends the application with a message (graphics_app_options.cpp).
Options parseOptions(int argc, char** argv);

// The graphics pipeline, monolithic or linked from four libraries
// (graphics_app_pipeline.cpp).
VkPipeline createGraphicsPipeline(VkDevice device, const std::string& kind, VkShaderModule vertex,
                                  VkShaderModule fragment, VkPipelineLayout layout, VkPipelineLayout vertexLayout,
                                  VkPipelineLayout fragmentLayout, VkFormat format);
