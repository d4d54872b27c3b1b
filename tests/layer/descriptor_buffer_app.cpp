// A plain Vulkan 1.3 application whose every descriptor lives in descriptor
// buffers (VK_EXT_descriptor_buffer), for tests/gpu/descriptor_buffers.sh.
// It never presents; each frame is one submission of two labelled passes:
//
//   "draw": dynamic rendering into "target", 64x64 RGBA8, two triangles made
//     from gl_VertexIndex that cover it exactly (the shared diagonal belongs
//     to one of them): 64 * 64 = 4096 fragments. Each fragment samples
//     "texture" (16x16 RGBA8) once and reads one uint of the storage buffer
//     "lookup": 4096 texture reads of 4 B, 4096 buffer reads of 4 B, and 4096
//     writes of 4 B to "target". Set 0 (sampled image, storage buffer) lies
//     in the resource descriptor buffer, set 1 (the sampler) in the sampler one.
//   "double": a dispatch of 8 groups of 64: output[i] = input[i] * 2, so 512
//     reads of 4 B from "input" and 512 writes of 4 B to "output". Its
//     descriptors are written after the command buffer is recorded and
//     before it is submitted, as the extension allows.
//
// The application checks "output" itself. A device without the extension
// (or without descriptorBuffer, bufferDeviceAddress, dynamicRendering):
// prints "descriptor_buffer_app: no VK_EXT_descriptor_buffer" and exits 77.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

#include "gpu/glsl.hpp"

namespace {

constexpr int kNoExtension = 77;
constexpr uint32_t kSize = 64, kTexture = 16, kLookup = 16, kGroups = 8, kElements = kGroups * 64;

void check(VkResult r, const char* what) {
  if (r != VK_SUCCESS) {
    std::fprintf(stderr, "descriptor_buffer_app: %s failed (VkResult %d)\n", what, int(r));
    std::exit(1);
  }
}

std::vector<uint32_t> compile(const char* source, tally::spirv::Stage stage) {
  auto words = tally::glsl::compile(source, stage, {tally::glsl::Target::Vulkan13, false, "descriptor_buffer_app", {}});
  if (!words) {
    std::fprintf(stderr, "descriptor_buffer_app: %s\n", words.error().c_str());
    std::exit(1);
  }
  return *words;
}

constexpr const char* kVertex = R"(#version 450
void main() {
  const vec2 corners[6] = vec2[](vec2(-1, -1), vec2(1, -1), vec2(1, 1), vec2(-1, -1), vec2(1, 1), vec2(-1, 1));
  gl_Position = vec4(corners[gl_VertexIndex], 0, 1);
}
)";
constexpr const char* kFragment = R"(#version 450
layout(set = 0, binding = 0) uniform texture2D tex;
layout(std430, set = 0, binding = 1) readonly buffer Lookup { uint lookup[]; };
layout(set = 1, binding = 0) uniform sampler smp;
layout(location = 0) out vec4 color;
void main() {
  uint i = uint(gl_FragCoord.x) % 16u;
  color = texture(sampler2D(tex, smp), gl_FragCoord.xy / 64.0) + vec4(float(lookup[i]) / 256.0);
}
)";
constexpr const char* kCompute = R"(#version 450
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer In { uint a[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Out { uint b[]; };
void main() { b[gl_GlobalInvocationID.x] = a[gl_GlobalInvocationID.x] * 2u; }
)";

struct Buffer {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  uint8_t* mapped = nullptr;
  VkDeviceAddress address = 0;
  VkDeviceSize size = 0;
  VkBufferUsageFlags usage = 0;  // as created: a descriptor buffer's binding repeats it
};

struct App {
  VkInstance instance = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  VkQueue queue = VK_NULL_HANDLE;
  uint32_t family = 0;
  VkPhysicalDeviceMemoryProperties memory{};
  VkPhysicalDeviceDescriptorBufferPropertiesEXT props = {
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DESCRIPTOR_BUFFER_PROPERTIES_EXT};
  PFN_vkSetDebugUtilsObjectNameEXT setName = nullptr;
  PFN_vkCmdBeginDebugUtilsLabelEXT beginLabel = nullptr;
  PFN_vkCmdEndDebugUtilsLabelEXT endLabel = nullptr;
  PFN_vkGetDescriptorEXT getDescriptor = nullptr;
  PFN_vkGetDescriptorSetLayoutSizeEXT layoutSize = nullptr;
  PFN_vkGetDescriptorSetLayoutBindingOffsetEXT bindingOffset = nullptr;
  PFN_vkCmdBindDescriptorBuffersEXT bindBuffers = nullptr;
  PFN_vkCmdSetDescriptorBufferOffsetsEXT setOffsets = nullptr;

  void name(VkObjectType type, uint64_t handle, const char* text) const {
    VkDebugUtilsObjectNameInfoEXT info = {VK_STRUCTURE_TYPE_DEBUG_UTILS_OBJECT_NAME_INFO_EXT};
    info.objectType = type;
    info.objectHandle = handle;
    info.pObjectName = text;
    setName(device, &info);
  }
  uint32_t memoryType(uint32_t bits, VkMemoryPropertyFlags want) const {
    for (uint32_t t = 0; t < memory.memoryTypeCount; ++t) {
      if ((bits & (1u << t)) && (memory.memoryTypes[t].propertyFlags & want) == want) return t;
    }
    std::fprintf(stderr, "descriptor_buffer_app: no memory type with flags 0x%x\n", unsigned(want));
    std::exit(1);
  }
  Buffer buffer(VkDeviceSize size, VkBufferUsageFlags usage, const char* label) const {
    Buffer b;
    b.size = size;
    VkBufferCreateInfo info = {VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
    info.size = size;
    info.usage = b.usage = usage | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT;
    check(vkCreateBuffer(device, &info, nullptr, &b.buffer), "vkCreateBuffer");
    name(VK_OBJECT_TYPE_BUFFER, reinterpret_cast<uint64_t>(b.buffer), label);
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(device, b.buffer, &req);
    VkMemoryAllocateFlagsInfo flags = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_FLAGS_INFO};
    flags.flags = VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT;
    VkMemoryAllocateInfo alloc = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO, &flags, req.size};
    alloc.memoryTypeIndex =
        memoryType(req.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
    check(vkAllocateMemory(device, &alloc, nullptr, &b.memory), "vkAllocateMemory");
    check(vkBindBufferMemory(device, b.buffer, b.memory, 0), "vkBindBufferMemory");
    check(vkMapMemory(device, b.memory, 0, VK_WHOLE_SIZE, 0, reinterpret_cast<void**>(&b.mapped)), "vkMapMemory");
    VkBufferDeviceAddressInfo at = {VK_STRUCTURE_TYPE_BUFFER_DEVICE_ADDRESS_INFO, nullptr, b.buffer};
    b.address = vkGetBufferDeviceAddress(device, &at);
    return b;
  }
};

bool hasExtension(VkPhysicalDevice physical, const char* name) {
  uint32_t count = 0;
  vkEnumerateDeviceExtensionProperties(physical, nullptr, &count, nullptr);
  std::vector<VkExtensionProperties> exts(count);
  vkEnumerateDeviceExtensionProperties(physical, nullptr, &count, exts.data());
  for (const auto& e : exts) {
    if (std::strcmp(e.extensionName, name) == 0) return true;
  }
  return false;
}

// Instance and device; false when the device lacks what descriptor buffers need.
bool createDevice(App& app) {
  VkApplicationInfo info = {VK_STRUCTURE_TYPE_APPLICATION_INFO};
  info.pApplicationName = "descriptor_buffer_app";
  info.apiVersion = VK_API_VERSION_1_3;
  const char* instanceExt = VK_EXT_DEBUG_UTILS_EXTENSION_NAME;
  VkInstanceCreateInfo ici = {VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ici.pApplicationInfo = &info;
  ici.enabledExtensionCount = 1;
  ici.ppEnabledExtensionNames = &instanceExt;
  check(vkCreateInstance(&ici, nullptr, &app.instance), "vkCreateInstance");
  uint32_t count = 1;
  vkEnumeratePhysicalDevices(app.instance, &count, &app.physical);
  if (count == 0) return false;
  VkPhysicalDeviceProperties props;
  vkGetPhysicalDeviceProperties(app.physical, &props);
  if (props.apiVersion < VK_API_VERSION_1_3 || !hasExtension(app.physical, VK_EXT_DESCRIPTOR_BUFFER_EXTENSION_NAME)) {
    return false;
  }
  VkPhysicalDeviceDescriptorBufferFeaturesEXT db = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DESCRIPTOR_BUFFER_FEATURES_EXT};
  VkPhysicalDeviceVulkan13Features v13 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES, &db};
  VkPhysicalDeviceVulkan12Features v12 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES, &v13};
  VkPhysicalDeviceFeatures2 supported = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &v12};
  vkGetPhysicalDeviceFeatures2(app.physical, &supported);
  if (!db.descriptorBuffer || !v12.bufferDeviceAddress || !v13.dynamicRendering) return false;
  // Only what the application uses: the layer enables what it needs itself.
  VkPhysicalDeviceDescriptorBufferFeaturesEXT dbOn = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DESCRIPTOR_BUFFER_FEATURES_EXT};
  dbOn.descriptorBuffer = VK_TRUE;
  VkPhysicalDeviceVulkan13Features v13On = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES, &dbOn};
  v13On.dynamicRendering = VK_TRUE;
  VkPhysicalDeviceVulkan12Features v12On = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES, &v13On};
  v12On.bufferDeviceAddress = VK_TRUE;
  VkPhysicalDeviceFeatures2 enabled = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &v12On};
  enabled.features.pipelineStatisticsQuery = supported.features.pipelineStatisticsQuery;

  uint32_t familyCount = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(app.physical, &familyCount, nullptr);
  std::vector<VkQueueFamilyProperties> families(familyCount);
  vkGetPhysicalDeviceQueueFamilyProperties(app.physical, &familyCount, families.data());
  constexpr VkQueueFlags kBoth = VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT;
  while (app.family < familyCount && (families[app.family].queueFlags & kBoth) != kBoth) ++app.family;
  const float priority = 1.0f;
  VkDeviceQueueCreateInfo qci = {VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qci.queueFamilyIndex = app.family;
  qci.queueCount = 1;
  qci.pQueuePriorities = &priority;
  const char* deviceExt = VK_EXT_DESCRIPTOR_BUFFER_EXTENSION_NAME;
  VkDeviceCreateInfo dci = {VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO, &enabled};
  dci.queueCreateInfoCount = 1;
  dci.pQueueCreateInfos = &qci;
  dci.enabledExtensionCount = 1;
  dci.ppEnabledExtensionNames = &deviceExt;
  check(vkCreateDevice(app.physical, &dci, nullptr, &app.device), "vkCreateDevice");
  vkGetDeviceQueue(app.device, app.family, 0, &app.queue);
  vkGetPhysicalDeviceMemoryProperties(app.physical, &app.memory);
  VkPhysicalDeviceProperties2 props2 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, &app.props};
  vkGetPhysicalDeviceProperties2(app.physical, &props2);
  auto device = [&](const char* n) { return vkGetDeviceProcAddr(app.device, n); };
  app.setName = reinterpret_cast<PFN_vkSetDebugUtilsObjectNameEXT>(device("vkSetDebugUtilsObjectNameEXT"));
  app.beginLabel = reinterpret_cast<PFN_vkCmdBeginDebugUtilsLabelEXT>(device("vkCmdBeginDebugUtilsLabelEXT"));
  app.endLabel = reinterpret_cast<PFN_vkCmdEndDebugUtilsLabelEXT>(device("vkCmdEndDebugUtilsLabelEXT"));
  app.getDescriptor = reinterpret_cast<PFN_vkGetDescriptorEXT>(device("vkGetDescriptorEXT"));
  app.layoutSize = reinterpret_cast<PFN_vkGetDescriptorSetLayoutSizeEXT>(device("vkGetDescriptorSetLayoutSizeEXT"));
  app.bindingOffset = reinterpret_cast<PFN_vkGetDescriptorSetLayoutBindingOffsetEXT>(
      device("vkGetDescriptorSetLayoutBindingOffsetEXT"));
  app.bindBuffers = reinterpret_cast<PFN_vkCmdBindDescriptorBuffersEXT>(device("vkCmdBindDescriptorBuffersEXT"));
  app.setOffsets = reinterpret_cast<PFN_vkCmdSetDescriptorBufferOffsetsEXT>(device("vkCmdSetDescriptorBufferOffsetsEXT"));
  return true;
}


VkShaderModule module(const App& app, const char* source, tally::spirv::Stage stage) {
  const auto words = compile(source, stage);
  VkShaderModuleCreateInfo info = {VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  info.codeSize = words.size() * 4;
  info.pCode = words.data();
  VkShaderModule m;
  check(vkCreateShaderModule(app.device, &info, nullptr, &m), "vkCreateShaderModule");
  return m;
}

VkDescriptorSetLayout setLayout(const App& app, std::vector<VkDescriptorSetLayoutBinding> bindings) {
  VkDescriptorSetLayoutCreateInfo info = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  info.flags = VK_DESCRIPTOR_SET_LAYOUT_CREATE_DESCRIPTOR_BUFFER_BIT_EXT;
  info.bindingCount = uint32_t(bindings.size());
  info.pBindings = bindings.data();
  VkDescriptorSetLayout layout;
  check(vkCreateDescriptorSetLayout(app.device, &info, nullptr, &layout), "vkCreateDescriptorSetLayout");
  return layout;
}

VkImage image(const App& app, uint32_t size, VkImageUsageFlags usage, const char* label, VkImageView& view) {
  VkImageCreateInfo info = {VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  info.imageType = VK_IMAGE_TYPE_2D;
  info.format = VK_FORMAT_R8G8B8A8_UNORM;
  info.extent = {size, size, 1};
  info.mipLevels = info.arrayLayers = 1;
  info.samples = VK_SAMPLE_COUNT_1_BIT;
  info.usage = usage;
  VkImage img;
  check(vkCreateImage(app.device, &info, nullptr, &img), "vkCreateImage");
  app.name(VK_OBJECT_TYPE_IMAGE, reinterpret_cast<uint64_t>(img), label);
  VkMemoryRequirements req;
  vkGetImageMemoryRequirements(app.device, img, &req);
  VkMemoryAllocateInfo alloc = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO, nullptr, req.size};
  alloc.memoryTypeIndex = app.memoryType(req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  VkDeviceMemory memory;
  check(vkAllocateMemory(app.device, &alloc, nullptr, &memory), "vkAllocateMemory");
  check(vkBindImageMemory(app.device, img, memory, 0), "vkBindImageMemory");
  VkImageViewCreateInfo vinfo = {VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
  vinfo.image = img;
  vinfo.viewType = VK_IMAGE_VIEW_TYPE_2D;
  vinfo.format = info.format;
  vinfo.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
  check(vkCreateImageView(app.device, &vinfo, nullptr, &view), "vkCreateImageView");
  return img;
}

void layoutBarrier(VkCommandBuffer cmd, VkImage img, VkImageLayout from, VkImageLayout to, VkPipelineStageFlags2 dst) {
  VkImageMemoryBarrier2 b = {VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2};
  b.srcStageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
  b.srcAccessMask = VK_ACCESS_2_MEMORY_WRITE_BIT;
  b.dstStageMask = dst;
  b.dstAccessMask = VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT;
  b.oldLayout = from;
  b.newLayout = to;
  b.image = img;
  b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
  VkDependencyInfo dep = {VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  dep.imageMemoryBarrierCount = 1;
  dep.pImageMemoryBarriers = &b;
  vkCmdPipelineBarrier2(cmd, &dep);
}

// Writes the descriptor `info` makes at `at` in `buffer` (the application's host mapping).
void writeDescriptor(const App& app, const VkDescriptorGetInfoEXT& info, size_t size, const Buffer& buffer,
                     VkDeviceSize at) {
  app.getDescriptor(app.device, &info, size, buffer.mapped + at);
}

VkDeviceSize aligned(VkDeviceSize v, VkDeviceSize a) { return (v + a - 1) / a * a; }

struct Scene {
  VkImage texture = VK_NULL_HANDLE, target = VK_NULL_HANDLE;
  VkImageView textureView = VK_NULL_HANDLE, targetView = VK_NULL_HANDLE;
  VkSampler sampler = VK_NULL_HANDLE;
  Buffer lookup, input, output, resources, samplers;
  VkDescriptorSetLayout drawSet = VK_NULL_HANDLE, samplerSet = VK_NULL_HANDLE, computeSet = VK_NULL_HANDLE;
  VkPipelineLayout drawLayout = VK_NULL_HANDLE, computeLayout = VK_NULL_HANDLE;
  VkPipeline draw = VK_NULL_HANDLE, compute = VK_NULL_HANDLE;
  VkDeviceSize computeSetAt = 0;
};

void createPipelines(const App& app, Scene& s) {
  s.drawSet = setLayout(app, {{0, VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr},
                              {1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr}});
  s.samplerSet = setLayout(app, {{0, VK_DESCRIPTOR_TYPE_SAMPLER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr}});
  s.computeSet = setLayout(app, {{0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
                                 {1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr}});
  const VkDescriptorSetLayout drawSets[2] = {s.drawSet, s.samplerSet};
  VkPipelineLayoutCreateInfo pl = {VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  pl.setLayoutCount = 2;
  pl.pSetLayouts = drawSets;
  check(vkCreatePipelineLayout(app.device, &pl, nullptr, &s.drawLayout), "vkCreatePipelineLayout");
  pl.setLayoutCount = 1;
  pl.pSetLayouts = &s.computeSet;
  check(vkCreatePipelineLayout(app.device, &pl, nullptr, &s.computeLayout), "vkCreatePipelineLayout");

  using tally::spirv::Stage;
  VkComputePipelineCreateInfo cpci = {VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
  cpci.flags = VK_PIPELINE_CREATE_DESCRIPTOR_BUFFER_BIT_EXT;
  cpci.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_COMPUTE_BIT,
                module(app, kCompute, Stage::Compute), "main", nullptr};
  cpci.layout = s.computeLayout;
  check(vkCreateComputePipelines(app.device, VK_NULL_HANDLE, 1, &cpci, nullptr, &s.compute), "vkCreateComputePipelines");

  VkPipelineShaderStageCreateInfo stages[2] = {
      {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_VERTEX_BIT,
       module(app, kVertex, Stage::Vertex), "main", nullptr},
      {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_FRAGMENT_BIT,
       module(app, kFragment, Stage::Fragment), "main", nullptr}};
  VkPipelineVertexInputStateCreateInfo vertexInput = {VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
  VkPipelineInputAssemblyStateCreateInfo assembly = {VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
  assembly.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  VkViewport viewport = {0, 0, float(kSize), float(kSize), 0, 1};
  VkRect2D scissor = {{0, 0}, {kSize, kSize}};
  VkPipelineViewportStateCreateInfo vp = {VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
  vp.viewportCount = vp.scissorCount = 1;
  vp.pViewports = &viewport;
  vp.pScissors = &scissor;
  VkPipelineRasterizationStateCreateInfo raster = {VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
  raster.lineWidth = 1;
  VkPipelineMultisampleStateCreateInfo ms = {VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
  ms.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
  VkPipelineColorBlendAttachmentState blendAttachment = {};
  blendAttachment.colorWriteMask = 0xF;
  VkPipelineColorBlendStateCreateInfo blend = {VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
  blend.attachmentCount = 1;
  blend.pAttachments = &blendAttachment;
  const VkFormat format = VK_FORMAT_R8G8B8A8_UNORM;
  VkPipelineRenderingCreateInfo rendering = {VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO};
  rendering.colorAttachmentCount = 1;
  rendering.pColorAttachmentFormats = &format;
  VkGraphicsPipelineCreateInfo gp = {VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO, &rendering};
  gp.flags = VK_PIPELINE_CREATE_DESCRIPTOR_BUFFER_BIT_EXT;
  gp.stageCount = 2;
  gp.pStages = stages;
  gp.pVertexInputState = &vertexInput;
  gp.pInputAssemblyState = &assembly;
  gp.pViewportState = &vp;
  gp.pRasterizationState = &raster;
  gp.pMultisampleState = &ms;
  gp.pColorBlendState = &blend;
  gp.layout = s.drawLayout;
  check(vkCreateGraphicsPipelines(app.device, VK_NULL_HANDLE, 1, &gp, nullptr, &s.draw), "vkCreateGraphicsPipelines");
}

// The draw's descriptors: set 0 at the start of the resource buffer, the sampler at the start of the sampler one.
void writeDrawDescriptors(const App& app, Scene& s) {
  VkDeviceSize at = 0;
  VkDescriptorImageInfo image = {VK_NULL_HANDLE, s.textureView, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  VkDescriptorGetInfoEXT info = {VK_STRUCTURE_TYPE_DESCRIPTOR_GET_INFO_EXT};
  info.type = VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE;
  info.data.pSampledImage = &image;
  app.bindingOffset(app.device, s.drawSet, 0, &at);
  writeDescriptor(app, info, app.props.sampledImageDescriptorSize, s.resources, at);
  VkDescriptorAddressInfoEXT lookup = {VK_STRUCTURE_TYPE_DESCRIPTOR_ADDRESS_INFO_EXT, nullptr, s.lookup.address,
                                       s.lookup.size, VK_FORMAT_UNDEFINED};
  info.type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  info.data.pStorageBuffer = &lookup;
  app.bindingOffset(app.device, s.drawSet, 1, &at);
  writeDescriptor(app, info, app.props.storageBufferDescriptorSize, s.resources, at);
  info.type = VK_DESCRIPTOR_TYPE_SAMPLER;
  info.data.pSampler = &s.sampler;
  app.bindingOffset(app.device, s.samplerSet, 0, &at);
  writeDescriptor(app, info, app.props.samplerDescriptorSize, s.samplers, at);
}

void writeComputeDescriptors(const App& app, Scene& s) {
  VkDescriptorGetInfoEXT info = {VK_STRUCTURE_TYPE_DESCRIPTOR_GET_INFO_EXT};
  info.type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  const Buffer* buffers[2] = {&s.input, &s.output};
  for (uint32_t b = 0; b < 2; ++b) {
    VkDescriptorAddressInfoEXT range = {VK_STRUCTURE_TYPE_DESCRIPTOR_ADDRESS_INFO_EXT, nullptr, buffers[b]->address,
                                        buffers[b]->size, VK_FORMAT_UNDEFINED};
    info.data.pStorageBuffer = &range;
    VkDeviceSize at = 0;
    app.bindingOffset(app.device, s.computeSet, b, &at);
    writeDescriptor(app, info, app.props.storageBufferDescriptorSize, s.resources, s.computeSetAt + at);
  }
}

void createScene(const App& app, Scene& s) {
  s.texture = image(app, kTexture, VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT, "texture",
                    s.textureView);
  s.target = image(app, kSize, VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT, "target", s.targetView);
  VkSamplerCreateInfo sci = {VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  check(vkCreateSampler(app.device, &sci, nullptr, &s.sampler), "vkCreateSampler");
  s.lookup = app.buffer(kLookup * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "lookup");
  s.input = app.buffer(kElements * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "input");
  s.output = app.buffer(kElements * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "output");
  for (uint32_t i = 0; i < kLookup; ++i) reinterpret_cast<uint32_t*>(s.lookup.mapped)[i] = i * 16;
  for (uint32_t i = 0; i < kElements; ++i) reinterpret_cast<uint32_t*>(s.input.mapped)[i] = i + 7;
  createPipelines(app, s);
  VkDeviceSize drawBytes = 0, computeBytes = 0, samplerBytes = 0;
  app.layoutSize(app.device, s.drawSet, &drawBytes);
  app.layoutSize(app.device, s.computeSet, &computeBytes);
  app.layoutSize(app.device, s.samplerSet, &samplerBytes);
  s.computeSetAt = aligned(drawBytes, app.props.descriptorBufferOffsetAlignment);
  s.resources = app.buffer(s.computeSetAt + computeBytes, VK_BUFFER_USAGE_RESOURCE_DESCRIPTOR_BUFFER_BIT_EXT,
                           "resource descriptors");
  s.samplers = app.buffer(std::max<VkDeviceSize>(samplerBytes, 64), VK_BUFFER_USAGE_SAMPLER_DESCRIPTOR_BUFFER_BIT_EXT,
                          "sampler descriptors");
  writeDrawDescriptors(app, s);
}

void record(const App& app, const Scene& s, VkCommandBuffer cmd, bool first) {
  VkCommandBufferBeginInfo begin = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  check(vkBeginCommandBuffer(cmd, &begin), "vkBeginCommandBuffer");
  if (first) {
    layoutBarrier(cmd, s.texture, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                  VK_PIPELINE_STAGE_2_TRANSFER_BIT);
    VkClearColorValue grey = {{0.5f, 0.5f, 0.5f, 1.0f}};
    VkImageSubresourceRange range = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdClearColorImage(cmd, s.texture, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &grey, 1, &range);
    layoutBarrier(cmd, s.texture, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                  VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT);
  }
  layoutBarrier(cmd, s.target, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT);
  const VkDescriptorBufferBindingInfoEXT buffers[2] = {
      {VK_STRUCTURE_TYPE_DESCRIPTOR_BUFFER_BINDING_INFO_EXT, nullptr, s.resources.address, s.resources.usage},
      {VK_STRUCTURE_TYPE_DESCRIPTOR_BUFFER_BINDING_INFO_EXT, nullptr, s.samplers.address, s.samplers.usage}};
  app.bindBuffers(cmd, 2, buffers);

  VkDebugUtilsLabelEXT label = {VK_STRUCTURE_TYPE_DEBUG_UTILS_LABEL_EXT, nullptr, "draw", {}};
  app.beginLabel(cmd, &label);
  VkRenderingAttachmentInfo color = {VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  color.imageView = s.targetView;
  color.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  color.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  color.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  VkRenderingInfo rendering = {VK_STRUCTURE_TYPE_RENDERING_INFO};
  rendering.renderArea = {{0, 0}, {kSize, kSize}};
  rendering.layerCount = 1;
  rendering.colorAttachmentCount = 1;
  rendering.pColorAttachments = &color;
  vkCmdBeginRendering(cmd, &rendering);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, s.draw);
  const uint32_t indices[2] = {0, 1};
  const VkDeviceSize offsets[2] = {0, 0};
  app.setOffsets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, s.drawLayout, 0, 2, indices, offsets);
  vkCmdDraw(cmd, 6, 1, 0, 0);
  vkCmdEndRendering(cmd);
  app.endLabel(cmd);

  label.pLabelName = "double";
  app.beginLabel(cmd, &label);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, s.compute);
  app.setOffsets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, s.computeLayout, 0, 1, indices, &s.computeSetAt);
  vkCmdDispatch(cmd, kGroups, 1, 1);
  app.endLabel(cmd);
  check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
}

int runApp(App& app, uint32_t frames) {
  Scene s;
  createScene(app, s);
  VkCommandPoolCreateInfo pci = {VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pci.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pci.queueFamilyIndex = app.family;
  VkCommandPool pool;
  check(vkCreateCommandPool(app.device, &pci, nullptr, &pool), "vkCreateCommandPool");
  VkCommandBufferAllocateInfo cai = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  cai.commandPool = pool;
  cai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  cai.commandBufferCount = 1;
  VkCommandBuffer cmd;
  check(vkAllocateCommandBuffers(app.device, &cai, &cmd), "vkAllocateCommandBuffers");
  for (uint32_t f = 0; f < frames; ++f) {
    std::memset(s.output.mapped, 0, kElements * 4);
    std::memset(s.resources.mapped + s.computeSetAt, 0, s.resources.size - s.computeSetAt);
    record(app, s, cmd, f == 0);
    // The dispatch's descriptors are written after recording, before the submission.
    writeComputeDescriptors(app, s);
    VkSubmitInfo submit = {VK_STRUCTURE_TYPE_SUBMIT_INFO};
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &cmd;
    check(vkQueueSubmit(app.queue, 1, &submit, VK_NULL_HANDLE), "vkQueueSubmit");
    check(vkQueueWaitIdle(app.queue), "vkQueueWaitIdle");
    for (uint32_t i = 0; i < kElements; ++i) {
      const uint32_t got = reinterpret_cast<const uint32_t*>(s.output.mapped)[i];
      if (got != (i + 7) * 2) {
        std::fprintf(stderr, "descriptor_buffer_app: frame %u: output[%u] = %u, expected %u\n", f, i, got, (i + 7) * 2);
        return 1;
      }
    }
  }
  vkDeviceWaitIdle(app.device);
  vkDestroyDevice(app.device, nullptr);
  vkDestroyInstance(app.instance, nullptr);
  std::printf("descriptor_buffer_app: %u frames, output checked\n", frames);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  uint32_t frames = 3;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (std::string(argv[i]) == "--frames") frames = uint32_t(std::strtoul(argv[i + 1], nullptr, 10));
  }
  App app;
  if (!createDevice(app)) {
    std::printf("descriptor_buffer_app: no VK_EXT_descriptor_buffer (with descriptorBuffer, bufferDeviceAddress and "
                "dynamicRendering) on this device\n");
    return kNoExtension;
  }
  return runApp(app, frames);
}
