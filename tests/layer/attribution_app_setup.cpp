// attribution_app.hpp: the device, images, render passes and pipelines.
#include "attribution_app.hpp"

#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "gpu/glsl.hpp"

namespace attribution {

void check(VkResult r, const char* what) {
  if (r != VK_SUCCESS) {
    std::fprintf(stderr, "attribution_app: %s failed (VkResult %d)\n", what, int(r));
    std::exit(1);
  }
}

namespace {
constexpr const char* kVertex = R"(#version 450
layout(location = 0) in vec2 position;
layout(location = 1) in float shade;  // from an R32G32_SFLOAT attribute: the format's 8 bytes are read
layout(location = 0) out float vShade;
void main() { vShade = shade; gl_Position = vec4(position, 0.0, 1.0); }
)";
}  // namespace

void App::name(VkObjectType type, uint64_t handle, const char* text) const {
  VkDebugUtilsObjectNameInfoEXT info = {VK_STRUCTURE_TYPE_DEBUG_UTILS_OBJECT_NAME_INFO_EXT};
  info.objectType = type;
  info.objectHandle = handle;
  info.pObjectName = text;
  setName(device, &info);
}
VkDeviceMemory App::allocate(VkMemoryRequirements req, VkMemoryPropertyFlags want) const {
  uint32_t type = 0;
  while (type < memory.memoryTypeCount &&
         (!(req.memoryTypeBits & (1u << type)) || (memory.memoryTypes[type].propertyFlags & want) != want)) {
    ++type;
  }
  VkMemoryAllocateInfo info = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  info.allocationSize = req.size;
  info.memoryTypeIndex = type;
  VkDeviceMemory out;
  check(vkAllocateMemory(device, &info, nullptr, &out), "vkAllocateMemory");
  return out;
}
VkShaderModule App::shader(const char* source, tally::spirv::Stage stage) const {
  auto words = tally::glsl::compile(source, stage, {tally::glsl::Target::Vulkan11, false, "attribution_app", {}});
  if (!words) {
    std::fprintf(stderr, "attribution_app: %s\n", words.error().c_str());
    std::exit(1);
  }
  VkShaderModuleCreateInfo info = {VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  info.codeSize = words->size() * 4;
  info.pCode = words->data();
  VkShaderModule module;
  check(vkCreateShaderModule(device, &info, nullptr, &module), "vkCreateShaderModule");
  return module;
}
Image App::image(const char* label, VkFormat format, VkImageUsageFlags usage, uint32_t layers) {
  VkImageCreateInfo info = {VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  info.imageType = VK_IMAGE_TYPE_2D;
  info.format = format;
  info.extent = {kWidth, kHeight, 1};
  info.mipLevels = 1;
  info.arrayLayers = layers;
  info.samples = VK_SAMPLE_COUNT_1_BIT;
  info.usage = usage;
  Image out;
  check(vkCreateImage(device, &info, nullptr, &out.image), "vkCreateImage");
  VkMemoryRequirements req;
  vkGetImageMemoryRequirements(device, out.image, &req);
  vkBindImageMemory(device, out.image, allocate(req, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT), 0);
  const bool depth = format == VK_FORMAT_D32_SFLOAT;
  VkImageViewCreateInfo view = {VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
  view.image = out.image;
  view.viewType = layers > 1 ? VK_IMAGE_VIEW_TYPE_2D_ARRAY : VK_IMAGE_VIEW_TYPE_2D;
  view.format = format;
  view.subresourceRange = {VkImageAspectFlags(depth ? VK_IMAGE_ASPECT_DEPTH_BIT : VK_IMAGE_ASPECT_COLOR_BIT), 0, 1,
                           0, layers};
  check(vkCreateImageView(device, &view, nullptr, &out.view), "vkCreateImageView");
  name(VK_OBJECT_TYPE_IMAGE, reinterpret_cast<uint64_t>(out.image), label);
  images.emplace_back(out.image, view.subresourceRange.aspectMask);
  return out;
}
VkBuffer App::vertexBuffer(const char* label) const {
  // A triangle covering the viewport: position.xy, shade, padding.
  const float vertices[] = {-1, -1, 0.5f, 0, 3, -1, 0.5f, 0, -1, 3, 0.5f, 0};
  VkBufferCreateInfo info = {VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  info.size = sizeof vertices;
  info.usage = VK_BUFFER_USAGE_VERTEX_BUFFER_BIT;
  VkBuffer buffer;
  check(vkCreateBuffer(device, &info, nullptr, &buffer), "vkCreateBuffer");
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(device, buffer, &req);
  VkDeviceMemory bound =
      allocate(req, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
  vkBindBufferMemory(device, buffer, bound, 0);
  void* mapped = nullptr;
  vkMapMemory(device, bound, 0, VK_WHOLE_SIZE, 0, &mapped);
  std::memcpy(mapped, vertices, sizeof vertices);
  name(VK_OBJECT_TYPE_BUFFER, reinterpret_cast<uint64_t>(buffer), label);
  return buffer;
}
void App::label(VkCommandBuffer cmd, const char* text) const {
  VkDebugUtilsLabelEXT l = {VK_STRUCTURE_TYPE_DEBUG_UTILS_LABEL_EXT};
  l.pLabelName = text;
  beginLabel(cmd, &l);
}

void createDevice(App& app) {
  VkApplicationInfo info = {VK_STRUCTURE_TYPE_APPLICATION_INFO};
  info.pApplicationName = "attribution_app";
  info.apiVersion = VK_API_VERSION_1_3;
  const char* instanceExtension = VK_EXT_DEBUG_UTILS_EXTENSION_NAME;
  VkInstanceCreateInfo ici = {VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ici.pApplicationInfo = &info;
  ici.enabledExtensionCount = 1;
  ici.ppEnabledExtensionNames = &instanceExtension;
  check(vkCreateInstance(&ici, nullptr, &app.instance), "vkCreateInstance");
  uint32_t count = 1;
  vkEnumeratePhysicalDevices(app.instance, &count, &app.physical);
  vkGetPhysicalDeviceMemoryProperties(app.physical, &app.memory);
  uint32_t familyCount = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(app.physical, &familyCount, nullptr);
  std::vector<VkQueueFamilyProperties> families(familyCount);
  vkGetPhysicalDeviceQueueFamilyProperties(app.physical, &familyCount, families.data());
  while (app.family < familyCount && !(families[app.family].queueFlags & VK_QUEUE_GRAPHICS_BIT)) ++app.family;
  const float priority = 1.0f;
  VkDeviceQueueCreateInfo qci = {VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qci.queueFamilyIndex = app.family;
  qci.queueCount = 1;
  qci.pQueuePriorities = &priority;
  VkPhysicalDeviceExtendedDynamicState3FeaturesEXT dynamic3 = {
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_EXTENDED_DYNAMIC_STATE_3_FEATURES_EXT};
  dynamic3.extendedDynamicState3ColorWriteMask = VK_TRUE;
  VkPhysicalDeviceColorWriteEnableFeaturesEXT writeEnable = {
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_COLOR_WRITE_ENABLE_FEATURES_EXT, &dynamic3, VK_TRUE};
  VkPhysicalDeviceVertexInputDynamicStateFeaturesEXT vertexInput = {
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VERTEX_INPUT_DYNAMIC_STATE_FEATURES_EXT, &writeEnable, VK_TRUE};
  VkPhysicalDeviceVulkan13Features v13 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES, &vertexInput};
  v13.dynamicRendering = VK_TRUE;
  VkPhysicalDeviceVulkan11Features v11 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_1_FEATURES, &v13};
  v11.multiview = VK_TRUE;
  VkPhysicalDeviceFeatures2 features = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &v11};
  features.features.independentBlend = VK_TRUE;  // the write masks differ per attachment
  features.features.multiDrawIndirect = VK_TRUE;  // draws_app: one indirect command of two draws
  const char* extensions[] = {VK_EXT_VERTEX_INPUT_DYNAMIC_STATE_EXTENSION_NAME, VK_EXT_COLOR_WRITE_ENABLE_EXTENSION_NAME,
                              VK_EXT_EXTENDED_DYNAMIC_STATE_3_EXTENSION_NAME};
  VkDeviceCreateInfo dci = {VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO, &features};
  dci.queueCreateInfoCount = 1;
  dci.pQueueCreateInfos = &qci;
  dci.enabledExtensionCount = 3;
  dci.ppEnabledExtensionNames = extensions;
  check(vkCreateDevice(app.physical, &dci, nullptr, &app.device),
        "vkCreateDevice (dynamic rendering, multiview, multi-draw indirect, vertex input dynamic state, color write "
        "enable, extended dynamic state 3)");
  vkGetDeviceQueue(app.device, app.family, 0, &app.queue);
  auto load = [&](const char* name) { return vkGetDeviceProcAddr(app.device, name); };
  app.setName = reinterpret_cast<PFN_vkSetDebugUtilsObjectNameEXT>(load("vkSetDebugUtilsObjectNameEXT"));
  app.beginLabel = reinterpret_cast<PFN_vkCmdBeginDebugUtilsLabelEXT>(load("vkCmdBeginDebugUtilsLabelEXT"));
  app.endLabel = reinterpret_cast<PFN_vkCmdEndDebugUtilsLabelEXT>(load("vkCmdEndDebugUtilsLabelEXT"));
  app.setVertexInput = reinterpret_cast<PFN_vkCmdSetVertexInputEXT>(load("vkCmdSetVertexInputEXT"));
  app.setColorWriteEnable = reinterpret_cast<PFN_vkCmdSetColorWriteEnableEXT>(load("vkCmdSetColorWriteEnableEXT"));
  app.setColorWriteMask = reinterpret_cast<PFN_vkCmdSetColorWriteMaskEXT>(load("vkCmdSetColorWriteMaskEXT"));
  if (!app.setName || !app.beginLabel || !app.endLabel || !app.setVertexInput || !app.setColorWriteEnable ||
      !app.setColorWriteMask) {
    std::fprintf(stderr, "attribution_app: a device function is missing\n");
    std::exit(1);
  }
  app.vertex = app.shader(kVertex, tally::spirv::Stage::Vertex);
}

VkRenderPass renderPass(const App& app, const std::vector<VkFormat>& formats, const std::vector<uint32_t>& colors,
                        bool depth, uint32_t viewMask) {
  std::vector<VkAttachmentDescription> attachments;
  for (VkFormat f : formats) {
    attachments.push_back({0, f, VK_SAMPLE_COUNT_1_BIT, VK_ATTACHMENT_LOAD_OP_DONT_CARE, VK_ATTACHMENT_STORE_OP_STORE,
                           VK_ATTACHMENT_LOAD_OP_DONT_CARE, VK_ATTACHMENT_STORE_OP_DONT_CARE, kGeneral, kGeneral});
  }
  std::vector<VkAttachmentReference> references;
  for (uint32_t c : colors) references.push_back({c, kGeneral});
  VkAttachmentReference depthReference = {uint32_t(formats.size()) - 1, kGeneral};
  VkSubpassDescription subpass = {};
  subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
  subpass.colorAttachmentCount = uint32_t(references.size());
  subpass.pColorAttachments = references.data();
  subpass.pDepthStencilAttachment = depth ? &depthReference : nullptr;
  VkRenderPassMultiviewCreateInfo multiview = {VK_STRUCTURE_TYPE_RENDER_PASS_MULTIVIEW_CREATE_INFO};
  multiview.subpassCount = 1;
  multiview.pViewMasks = &viewMask;
  VkRenderPassCreateInfo info = {VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO, viewMask != 0 ? &multiview : nullptr};
  info.attachmentCount = uint32_t(attachments.size());
  info.pAttachments = attachments.data();
  info.subpassCount = 1;
  info.pSubpasses = &subpass;
  VkRenderPass out;
  check(vkCreateRenderPass(app.device, &info, nullptr, &out), "vkCreateRenderPass");
  return out;
}

VkFramebuffer framebuffer(const App& app, VkRenderPass pass, const std::vector<VkImageView>& views) {
  VkFramebufferCreateInfo info = {VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO};
  info.renderPass = pass;
  info.attachmentCount = uint32_t(views.size());
  info.pAttachments = views.data();
  info.width = kWidth;
  info.height = kHeight;
  info.layers = 1;
  VkFramebuffer out;
  check(vkCreateFramebuffer(app.device, &info, nullptr, &out), "vkCreateFramebuffer");
  return out;
}


VkPipeline pipeline(const App& app, const PipelineDesc& d) {
  VkPipelineShaderStageCreateInfo stages[2] = {
      {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_VERTEX_BIT, app.vertex, "main"},
      {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_FRAGMENT_BIT, d.fragment, "main"}};
  const VkVertexInputBindingDescription binding = {0, 16, VK_VERTEX_INPUT_RATE_VERTEX};
  const VkVertexInputAttributeDescription attributes[] = {{0, 0, VK_FORMAT_R32G32_SFLOAT, 0},
                                                          {1, 0, VK_FORMAT_R32G32_SFLOAT, 8}};
  VkPipelineVertexInputStateCreateInfo input = {VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
  input.vertexBindingDescriptionCount = 1;
  input.pVertexBindingDescriptions = &binding;
  input.vertexAttributeDescriptionCount = 2;
  input.pVertexAttributeDescriptions = attributes;
  VkPipelineInputAssemblyStateCreateInfo assembly = {VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
  assembly.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  VkPipelineViewportStateCreateInfo viewport = {VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
  viewport.viewportCount = viewport.scissorCount = 1;
  VkPipelineRasterizationStateCreateInfo raster = {VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
  raster.polygonMode = VK_POLYGON_MODE_FILL;
  raster.lineWidth = 1.0f;
  VkPipelineMultisampleStateCreateInfo multisample = {VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
  multisample.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
  VkPipelineDepthStencilStateCreateInfo depth = {VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO};
  depth.depthTestEnable = depth.depthWriteEnable = d.depth ? VK_TRUE : VK_FALSE;
  depth.depthCompareOp = VK_COMPARE_OP_ALWAYS;
  std::vector<VkPipelineColorBlendAttachmentState> blends;
  for (VkColorComponentFlags mask : d.masks) blends.push_back({VK_FALSE, {}, {}, {}, {}, {}, {}, mask});
  VkPipelineColorBlendStateCreateInfo blend = {VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
  blend.attachmentCount = uint32_t(blends.size());
  blend.pAttachments = blends.data();
  std::vector<VkDynamicState> states = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
  states.insert(states.end(), d.dynamic.begin(), d.dynamic.end());
  VkPipelineDynamicStateCreateInfo dynamic = {VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO};
  dynamic.dynamicStateCount = uint32_t(states.size());
  dynamic.pDynamicStates = states.data();
  VkPipelineRenderingCreateInfo rendering = {VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO};
  rendering.colorAttachmentCount = uint32_t(d.formats.size());
  rendering.pColorAttachmentFormats = d.formats.data();
  VkGraphicsPipelineCreateInfo info = {VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO,
                                       d.renderPass == VK_NULL_HANDLE ? &rendering : nullptr};
  info.stageCount = 2;
  info.pStages = stages;
  info.pVertexInputState = &input;
  info.pInputAssemblyState = &assembly;
  info.pViewportState = &viewport;
  info.pRasterizationState = &raster;
  info.pMultisampleState = &multisample;
  info.pDepthStencilState = &depth;
  info.pColorBlendState = &blend;
  info.pDynamicState = &dynamic;
  info.layout = d.layout;
  info.renderPass = d.renderPass;
  VkPipeline out;
  check(vkCreateGraphicsPipelines(app.device, VK_NULL_HANDLE, 1, &info, nullptr, &out), "vkCreateGraphicsPipelines");
  return out;
}

VkCommandPool commandPool(const App& app) {
  VkCommandPoolCreateInfo info = {VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  info.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  info.queueFamilyIndex = app.family;
  VkCommandPool out;
  check(vkCreateCommandPool(app.device, &info, nullptr, &out), "vkCreateCommandPool");
  return out;
}

VkCommandBuffer commandBuffer(const App& app, VkCommandPool pool, VkCommandBufferLevel level) {
  VkCommandBufferAllocateInfo info = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  info.commandPool = pool;
  info.level = level;
  info.commandBufferCount = 1;
  VkCommandBuffer out;
  check(vkAllocateCommandBuffers(app.device, &info, &out), "vkAllocateCommandBuffers");
  return out;
}

VkFence fence(const App& app) {
  VkFenceCreateInfo info = {VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  VkFence out;
  check(vkCreateFence(app.device, &info, nullptr, &out), "vkCreateFence");
  return out;
}

void submit(const App& app, VkCommandBuffer cmd, VkFence fence) {
  VkSubmitInfo info = {VK_STRUCTURE_TYPE_SUBMIT_INFO};
  info.commandBufferCount = 1;
  info.pCommandBuffers = &cmd;
  check(vkQueueSubmit(app.queue, 1, &info, fence), "vkQueueSubmit");
  check(vkWaitForFences(app.device, 1, &fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
  vkResetFences(app.device, 1, &fence);
}

// Every image to GENERAL, once.
void prepareImages(const App& app, VkCommandBuffer cmd, VkFence fence) {
  VkCommandBufferBeginInfo begin = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  check(vkBeginCommandBuffer(cmd, &begin), "vkBeginCommandBuffer");
  std::vector<VkImageMemoryBarrier> barriers;
  for (const auto& [image, aspect] : app.images) {
    VkImageMemoryBarrier b = {VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER};
    b.dstAccessMask = VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT;
    b.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    b.newLayout = kGeneral;
    b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.image = image;
    b.subresourceRange = {aspect, 0, 1, 0, VK_REMAINING_ARRAY_LAYERS};
    barriers.push_back(b);
  }
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, 0, 0, nullptr, 0,
                       nullptr, uint32_t(barriers.size()), barriers.data());
  check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
  submit(app, cmd, fence);
}

}  // namespace attribution
