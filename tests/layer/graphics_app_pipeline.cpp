// graphics_app's pipeline: one monolithic graphics pipeline, or the same
// state as four graphics pipeline libraries (vertex input, pre-rasterization
// shaders, fragment shader, fragment output) linked into one, as zink builds
// its pipelines on drivers with VK_EXT_graphics_pipeline_library.
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

#include "graphics_app.hpp"

namespace {

void check(VkResult r, const char* what) {
  if (r != VK_SUCCESS) {
    std::fprintf(stderr, "graphics_app: %s failed (VkResult %d)\n", what, int(r));
    std::exit(1);
  }
}

}  // namespace

VkPipeline createGraphicsPipeline(VkDevice device, const std::string& kind, VkShaderModule vertex,
                                  VkShaderModule fragment, VkPipelineLayout layout, VkPipelineLayout vertexLayout,
                                  VkPipelineLayout fragmentLayout, VkFormat format) {
  VkPipelineShaderStageCreateInfo stages[2] = {
      {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_VERTEX_BIT, vertex, "main",
       nullptr},
      {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_FRAGMENT_BIT, fragment, "main",
       nullptr}};
  VkVertexInputBindingDescription binding = {0, 8, VK_VERTEX_INPUT_RATE_VERTEX};
  VkVertexInputAttributeDescription attribute = {0, 0, VK_FORMAT_R32G32_SFLOAT, 0};
  VkPipelineVertexInputStateCreateInfo vertexInput = {VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
  vertexInput.vertexBindingDescriptionCount = 1;
  vertexInput.pVertexBindingDescriptions = &binding;
  vertexInput.vertexAttributeDescriptionCount = 1;
  vertexInput.pVertexAttributeDescriptions = &attribute;
  VkPipelineInputAssemblyStateCreateInfo assembly = {VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
  assembly.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  VkPipelineViewportStateCreateInfo viewport = {VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
  viewport.viewportCount = viewport.scissorCount = 1;
  VkPipelineRasterizationStateCreateInfo raster = {VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
  raster.polygonMode = VK_POLYGON_MODE_FILL;
  raster.cullMode = VK_CULL_MODE_NONE;
  raster.lineWidth = 1.0f;
  VkPipelineMultisampleStateCreateInfo multisample = {VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
  multisample.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
  VkPipelineDepthStencilStateCreateInfo depth = {VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO};
  VkPipelineColorBlendAttachmentState blendAttachment = {};
  blendAttachment.colorWriteMask = 0xf;
  VkPipelineColorBlendStateCreateInfo blend = {VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
  blend.attachmentCount = 1;
  blend.pAttachments = &blendAttachment;
  VkDynamicState dynamics[] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
  VkPipelineDynamicStateCreateInfo dynamic = {VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO};
  dynamic.dynamicStateCount = 2;
  dynamic.pDynamicStates = dynamics;
  VkPipelineRenderingCreateInfo rendering = {VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO};
  rendering.colorAttachmentCount = 1;
  rendering.pColorAttachmentFormats = &format;

  VkGraphicsPipelineCreateInfo whole = {VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO, &rendering};
  whole.stageCount = 2;
  whole.pStages = stages;
  whole.pVertexInputState = &vertexInput;
  whole.pInputAssemblyState = &assembly;
  whole.pViewportState = &viewport;
  whole.pRasterizationState = &raster;
  whole.pMultisampleState = &multisample;
  whole.pDepthStencilState = &depth;
  whole.pColorBlendState = &blend;
  whole.pDynamicState = &dynamic;
  whole.layout = layout;
  VkPipeline pipeline;
  if (kind == "monolithic") {
    check(vkCreateGraphicsPipelines(device, VK_NULL_HANDLE, 1, &whole, nullptr, &pipeline), "vkCreateGraphicsPipelines");
    return pipeline;
  }

  // Each library holds one part: the whole create info with its part's flag
  // (the parts a library does not define are ignored by Vulkan), its stages
  // and the layout of its own sets.
  const VkGraphicsPipelineLibraryFlagsEXT parts[] = {
      VK_GRAPHICS_PIPELINE_LIBRARY_VERTEX_INPUT_INTERFACE_BIT_EXT,
      VK_GRAPHICS_PIPELINE_LIBRARY_PRE_RASTERIZATION_SHADERS_BIT_EXT,
      VK_GRAPHICS_PIPELINE_LIBRARY_FRAGMENT_SHADER_BIT_EXT,
      VK_GRAPHICS_PIPELINE_LIBRARY_FRAGMENT_OUTPUT_INTERFACE_BIT_EXT};
  std::vector<VkPipeline> libraries(4);
  for (int i = 0; i < 4; ++i) {
    VkGraphicsPipelineLibraryCreateInfoEXT library = {VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_LIBRARY_CREATE_INFO_EXT,
                                                      &rendering, parts[i]};
    VkGraphicsPipelineCreateInfo info = whole;
    info.pNext = &library;
    info.flags = VK_PIPELINE_CREATE_LIBRARY_BIT_KHR;
    info.stageCount = i == 1 || i == 2 ? 1 : 0;
    info.pStages = i == 1 ? &stages[0] : i == 2 ? &stages[1] : nullptr;
    info.layout = i == 1 ? vertexLayout : i == 2 ? fragmentLayout : VK_NULL_HANDLE;
    check(vkCreateGraphicsPipelines(device, VK_NULL_HANDLE, 1, &info, nullptr, &libraries[i]),
          "vkCreateGraphicsPipelines (a library)");
  }
  VkPipelineLibraryCreateInfoKHR linked = {VK_STRUCTURE_TYPE_PIPELINE_LIBRARY_CREATE_INFO_KHR};
  linked.libraryCount = 4;
  linked.pLibraries = libraries.data();
  VkGraphicsPipelineCreateInfo link = {VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO, &linked};
  link.layout = layout;
  link.pColorBlendState = &blend;  // ignored (the output library holds it); validation 1.3.239 asks for it
  check(vkCreateGraphicsPipelines(device, VK_NULL_HANDLE, 1, &link, nullptr, &pipeline),
        "vkCreateGraphicsPipelines (linking the libraries)");
  return pipeline;
}
