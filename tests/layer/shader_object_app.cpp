// A plain Vulkan application that draws and dispatches through shader
// objects (VK_EXT_shader_object), for the layer's test on a device that
// offers them (tests/gpu/shader_objects.sh). Each frame is one submission:
//   "shaded": two triangles covering a 64x64 R8G8B8A8 target exactly (4,096
//             fragments); the vertex shader reads its position from the
//             storage buffer "positions" (6 vec2 reads), the fragment shader
//             reads the uniform block "tint" and writes it to the target;
//   "fill":   a compute shader writes out[i] = 3i + 1 into "out" (50 groups of
//             64: 3,200 4-byte writes).
// It checks its own results (every texel the tint, every out[i] right), so a
// layer that changed what the application computes fails the test.
//   --linked 1   the vertex and fragment shaders are created linked
//                (VK_SHADER_CREATE_LINK_STAGE_BIT_EXT), in one call
//   --binary 1   the dispatch runs a shader created from the compute
//                shader's binary (vkGetShaderBinaryDataEXT), which the
//                layer cannot instrument
//   --frames N   (default 4)
// Exit 77 with "offers no VK_EXT_shader_object" where the device lacks it.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <type_traits>
#include <vector>

#include "app_support.hpp"
#include "layer/shader_object_api.hpp"

namespace {

constexpr uint32_t kSize = 64;
constexpr uint32_t kInvocations = 64 * 50;
constexpr float kTint[4] = {0.25f, 0.5f, 0.75f, 1.0f};
constexpr int kNoShaderObjects = 77;

constexpr const char* kVertex = R"(#version 450
layout(std430, set = 0, binding = 0) readonly buffer Positions { vec2 p[]; };
void main() { gl_Position = vec4(p[gl_VertexIndex], 0.0, 1.0); }
)";
constexpr const char* kFragment = R"(#version 450
layout(set = 0, binding = 1) uniform Tint { vec4 tint; };
layout(location = 0) out vec4 color;
void main() { color = tint; }
)";
constexpr const char* kCompute = R"(#version 450
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 2) buffer Out { uint v[]; };
void main() { v[gl_GlobalInvocationID.x] = gl_GlobalInvocationID.x * 3u + 1u; }
)";

struct Options {
  uint32_t frames = 4, linked = 0, binary = 0;
};

bool offers(VkPhysicalDevice physical, const char* extension) {
  uint32_t count = 0;
  vkEnumerateDeviceExtensionProperties(physical, nullptr, &count, nullptr);
  std::vector<VkExtensionProperties> all(count);
  vkEnumerateDeviceExtensionProperties(physical, nullptr, &count, all.data());
  for (const auto& e : all) {
    if (std::strcmp(e.extensionName, extension) == 0) return true;
  }
  return false;
}

// A Vulkan 1.3 instance and device with shader objects, dynamic rendering and
// the stores the layer's counters need.
app::Device createDevice(app::Instance& instance) {
  VkApplicationInfo info = {VK_STRUCTURE_TYPE_APPLICATION_INFO};
  info.pApplicationName = "shader_object_app";
  info.apiVersion = VK_API_VERSION_1_3;
  const char* debugUtils = VK_EXT_DEBUG_UTILS_EXTENSION_NAME;
  VkInstanceCreateInfo ici = {VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ici.pApplicationInfo = &info;
  ici.enabledExtensionCount = 1;
  ici.ppEnabledExtensionNames = &debugUtils;
  app::check(vkCreateInstance(&ici, nullptr, &instance.instance), "vkCreateInstance (Vulkan 1.3, debug utils)");
  instance.debugUtils = true;
  uint32_t physicalCount = 1;
  vkEnumeratePhysicalDevices(instance.instance, &physicalCount, &instance.physical);
  VkPhysicalDeviceProperties props;
  vkGetPhysicalDeviceProperties(instance.physical, &props);
  if (!offers(instance.physical, VK_EXT_SHADER_OBJECT_EXTENSION_NAME) || props.apiVersion < VK_API_VERSION_1_3) {
    std::fprintf(stderr, "shader_object_app: %s offers no VK_EXT_shader_object (with Vulkan 1.3)\n", props.deviceName);
    std::exit(kNoShaderObjects);
  }
  VkPhysicalDeviceShaderObjectFeaturesEXT objects = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SHADER_OBJECT_FEATURES_EXT};
  objects.shaderObject = VK_TRUE;
  VkPhysicalDeviceVulkan13Features v13 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES, &objects};
  v13.dynamicRendering = VK_TRUE;
  VkPhysicalDeviceFeatures supported;
  vkGetPhysicalDeviceFeatures(instance.physical, &supported);
  VkPhysicalDeviceFeatures2 features = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &v13};
  features.features.fragmentStoresAndAtomics = supported.fragmentStoresAndAtomics;
  features.features.vertexPipelineStoresAndAtomics = supported.vertexPipelineStoresAndAtomics;

  app::Device out;
  out.physical = instance.physical;
  uint32_t familyCount = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(instance.physical, &familyCount, nullptr);
  std::vector<VkQueueFamilyProperties> families(familyCount);
  vkGetPhysicalDeviceQueueFamilyProperties(instance.physical, &familyCount, families.data());
  const VkQueueFlags want = VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT;
  while (out.family < familyCount && (families[out.family].queueFlags & want) != want) ++out.family;
  const float priority = 1.0f;
  VkDeviceQueueCreateInfo qci = {VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qci.queueFamilyIndex = out.family;
  qci.queueCount = 1;
  qci.pQueuePriorities = &priority;
  const char* extension = VK_EXT_SHADER_OBJECT_EXTENSION_NAME;
  VkDeviceCreateInfo dci = {VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO, &features};
  dci.queueCreateInfoCount = 1;
  dci.pQueueCreateInfos = &qci;
  dci.enabledExtensionCount = 1;
  dci.ppEnabledExtensionNames = &extension;
  app::check(vkCreateDevice(instance.physical, &dci, nullptr, &out.device), "vkCreateDevice (shader objects)");
  out.queues.resize(1);
  vkGetDeviceQueue(out.device, out.family, 0, &out.queues[0]);
  vkGetPhysicalDeviceMemoryProperties(instance.physical, &out.memory);
  auto proc = [&](const char* name) { return vkGetDeviceProcAddr(out.device, name); };
  out.setName = reinterpret_cast<PFN_vkSetDebugUtilsObjectNameEXT>(proc("vkSetDebugUtilsObjectNameEXT"));
  out.beginLabel = reinterpret_cast<PFN_vkCmdBeginDebugUtilsLabelEXT>(proc("vkCmdBeginDebugUtilsLabelEXT"));
  out.endLabel = reinterpret_cast<PFN_vkCmdEndDebugUtilsLabelEXT>(proc("vkCmdEndDebugUtilsLabelEXT"));
  return out;
}

// The dynamic state shader objects leave to the command buffer that Vulkan
// 1.3's core does not hold.
struct StateCalls {
  PFN_vkCmdSetVertexInputEXT vertexInput = nullptr;
  PFN_vkCmdSetPolygonModeEXT polygonMode = nullptr;
  PFN_vkCmdSetRasterizationSamplesEXT samples = nullptr;
  PFN_vkCmdSetSampleMaskEXT sampleMask = nullptr;
  PFN_vkCmdSetAlphaToCoverageEnableEXT alphaToCoverage = nullptr;
  PFN_vkCmdSetColorBlendEnableEXT blendEnable = nullptr;
  PFN_vkCmdSetColorWriteMaskEXT writeMask = nullptr;
};

// The extension's calls, and that state.
struct Calls {
  PFN_vkCreateShadersEXT createShaders = nullptr;
  PFN_vkDestroyShaderEXT destroyShader = nullptr;
  PFN_vkGetShaderBinaryDataEXT binaryData = nullptr;
  PFN_vkCmdBindShadersEXT bindShaders = nullptr;
  StateCalls state;
};

Calls loadCalls(VkDevice device) {
  Calls c;
  auto load = [&](auto& to, const char* name) {
    to = reinterpret_cast<std::remove_reference_t<decltype(to)>>(vkGetDeviceProcAddr(device, name));
    if (to == nullptr) {
      std::fprintf(stderr, "shader_object_app: the device gives no %s\n", name);
      std::exit(1);
    }
  };
  load(c.createShaders, "vkCreateShadersEXT");
  load(c.destroyShader, "vkDestroyShaderEXT");
  load(c.binaryData, "vkGetShaderBinaryDataEXT");
  load(c.bindShaders, "vkCmdBindShadersEXT");
  load(c.state.vertexInput, "vkCmdSetVertexInputEXT");
  load(c.state.polygonMode, "vkCmdSetPolygonModeEXT");
  load(c.state.samples, "vkCmdSetRasterizationSamplesEXT");
  load(c.state.sampleMask, "vkCmdSetSampleMaskEXT");
  load(c.state.alphaToCoverage, "vkCmdSetAlphaToCoverageEnableEXT");
  load(c.state.blendEnable, "vkCmdSetColorBlendEnableEXT");
  load(c.state.writeMask, "vkCmdSetColorWriteMaskEXT");
  return c;
}

struct Shaders {
  VkShaderEXT vertex = VK_NULL_HANDLE, fragment = VK_NULL_HANDLE, compute = VK_NULL_HANDLE;
};

VkShaderCreateInfoEXT shaderInfo(VkShaderStageFlagBits stage, VkShaderStageFlags next,
                                 const std::vector<uint32_t>& words, const VkDescriptorSetLayout* setLayout) {
  VkShaderCreateInfoEXT info = {VK_STRUCTURE_TYPE_SHADER_CREATE_INFO_EXT};
  info.stage = stage;
  info.nextStage = next;
  info.codeType = VK_SHADER_CODE_TYPE_SPIRV_EXT;
  info.codeSize = words.size() * 4;
  info.pCode = words.data();
  info.pName = "main";
  info.setLayoutCount = 1;
  info.pSetLayouts = setLayout;
  return info;
}

Shaders createShaders(const app::Device& device, const Calls& calls, const Options& options,
                      const VkDescriptorSetLayout* setLayout) {
  using tally::spirv::Stage;
  const auto vertex = app::compile(kVertex, Stage::Vertex);
  const auto fragment = app::compile(kFragment, Stage::Fragment);
  const auto compute = app::compile(kCompute, Stage::Compute);
  VkShaderCreateInfoEXT graphics[2] = {
      shaderInfo(VK_SHADER_STAGE_VERTEX_BIT, VK_SHADER_STAGE_FRAGMENT_BIT, vertex, setLayout),
      shaderInfo(VK_SHADER_STAGE_FRAGMENT_BIT, 0, fragment, setLayout)};
  Shaders out;
  VkShaderEXT pair[2] = {};
  if (options.linked) {
    for (auto& info : graphics) info.flags = VK_SHADER_CREATE_LINK_STAGE_BIT_EXT;
    app::check(calls.createShaders(device.device, 2, graphics, nullptr, pair), "vkCreateShadersEXT (linked)");
  } else {
    for (uint32_t i = 0; i < 2; ++i) {
      app::check(calls.createShaders(device.device, 1, &graphics[i], nullptr, &pair[i]), "vkCreateShadersEXT");
    }
  }
  out.vertex = pair[0];
  out.fragment = pair[1];
  const VkShaderCreateInfoEXT computeInfo = shaderInfo(VK_SHADER_STAGE_COMPUTE_BIT, 0, compute, setLayout);
  app::check(calls.createShaders(device.device, 1, &computeInfo, nullptr, &out.compute), "vkCreateShadersEXT (compute)");
  if (options.binary) {
    // The binary of the application's shader, and a shader created from it.
    size_t size = 0;
    app::check(calls.binaryData(device.device, out.compute, &size, nullptr), "vkGetShaderBinaryDataEXT (size)");
    std::vector<uint8_t> data(size);
    app::check(calls.binaryData(device.device, out.compute, &size, data.data()), "vkGetShaderBinaryDataEXT");
    VkShaderCreateInfoEXT fromBinary = computeInfo;
    fromBinary.codeType = VK_SHADER_CODE_TYPE_BINARY_EXT;
    fromBinary.codeSize = size;
    fromBinary.pCode = data.data();
    VkShaderEXT binary = VK_NULL_HANDLE;
    app::check(calls.createShaders(device.device, 1, &fromBinary, nullptr, &binary), "vkCreateShadersEXT (binary)");
    calls.destroyShader(device.device, out.compute, nullptr);
    out.compute = binary;
  }
  return out;
}

struct Target {
  VkImage image = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkImageView view = VK_NULL_HANDLE;
};

Target createTarget(const app::Device& device) {
  Target t;
  VkImageCreateInfo ici = {VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  ici.imageType = VK_IMAGE_TYPE_2D;
  ici.format = VK_FORMAT_R8G8B8A8_UNORM;
  ici.extent = {kSize, kSize, 1};
  ici.mipLevels = ici.arrayLayers = 1;
  ici.samples = VK_SAMPLE_COUNT_1_BIT;
  ici.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  app::check(vkCreateImage(device.device, &ici, nullptr, &t.image), "vkCreateImage");
  app::name(device, VK_OBJECT_TYPE_IMAGE, reinterpret_cast<uint64_t>(t.image), "target");
  VkMemoryRequirements req;
  vkGetImageMemoryRequirements(device.device, t.image, &req);
  uint32_t type = 0;
  while (!(req.memoryTypeBits & (1u << type))) ++type;
  VkMemoryAllocateInfo mai = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  mai.allocationSize = req.size;
  mai.memoryTypeIndex = type;
  app::check(vkAllocateMemory(device.device, &mai, nullptr, &t.memory), "vkAllocateMemory (target)");
  vkBindImageMemory(device.device, t.image, t.memory, 0);
  VkImageViewCreateInfo vci = {VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
  vci.image = t.image;
  vci.viewType = VK_IMAGE_VIEW_TYPE_2D;
  vci.format = ici.format;
  vci.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
  app::check(vkCreateImageView(device.device, &vci, nullptr, &t.view), "vkCreateImageView");
  return t;
}

void imageBarrier(VkCommandBuffer cmd, VkImage image, VkImageLayout from, VkImageLayout to, VkAccessFlags src,
                  VkAccessFlags dst, VkPipelineStageFlags srcStage, VkPipelineStageFlags dstStage) {
  const VkImageMemoryBarrier b = {VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER, nullptr, src, dst, from, to,
                                  VK_QUEUE_FAMILY_IGNORED, VK_QUEUE_FAMILY_IGNORED, image,
                                  {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1}};
  vkCmdPipelineBarrier(cmd, srcStage, dstStage, 0, 0, nullptr, 0, nullptr, 1, &b);
}

// Every state a draw through shader objects needs set (the features this
// device enabled add none).
void setDrawState(VkCommandBuffer cmd, const Calls& calls) {
  const VkViewport viewport = {0, 0, float(kSize), float(kSize), 0, 1};
  const VkRect2D scissor = {{0, 0}, {kSize, kSize}};
  vkCmdSetViewportWithCount(cmd, 1, &viewport);
  vkCmdSetScissorWithCount(cmd, 1, &scissor);
  vkCmdSetRasterizerDiscardEnable(cmd, VK_FALSE);
  vkCmdSetCullMode(cmd, VK_CULL_MODE_NONE);
  vkCmdSetFrontFace(cmd, VK_FRONT_FACE_COUNTER_CLOCKWISE);
  vkCmdSetDepthTestEnable(cmd, VK_FALSE);
  vkCmdSetDepthWriteEnable(cmd, VK_FALSE);
  vkCmdSetDepthBiasEnable(cmd, VK_FALSE);
  vkCmdSetStencilTestEnable(cmd, VK_FALSE);
  vkCmdSetPrimitiveTopology(cmd, VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST);
  vkCmdSetPrimitiveRestartEnable(cmd, VK_FALSE);
  calls.state.vertexInput(cmd, 0, nullptr, 0, nullptr);
  calls.state.polygonMode(cmd, VK_POLYGON_MODE_FILL);
  calls.state.samples(cmd, VK_SAMPLE_COUNT_1_BIT);
  const VkSampleMask mask = ~0u;
  calls.state.sampleMask(cmd, VK_SAMPLE_COUNT_1_BIT, &mask);
  calls.state.alphaToCoverage(cmd, VK_FALSE);
  const VkBool32 blend = VK_FALSE;
  calls.state.blendEnable(cmd, 0, 1, &blend);
  const VkColorComponentFlags all = 0xF;
  calls.state.writeMask(cmd, 0, 1, &all);
}

struct Scene {
  VkDescriptorSetLayout setLayout = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkDescriptorPool pool = VK_NULL_HANDLE;
  VkDescriptorSet set = VK_NULL_HANDLE;
  app::Buffer positions, tint, out, readback;
};

Scene createScene(const app::Device& device) {
  Scene s;
  const VkDescriptorSetLayoutBinding bindings[3] = {
      {0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_VERTEX_BIT, nullptr},
      {1, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr},
      {2, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr}};
  VkDescriptorSetLayoutCreateInfo dslci = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  dslci.bindingCount = 3;
  dslci.pBindings = bindings;
  app::check(vkCreateDescriptorSetLayout(device.device, &dslci, nullptr, &s.setLayout), "vkCreateDescriptorSetLayout");
  VkPipelineLayoutCreateInfo plci = {VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  plci.setLayoutCount = 1;
  plci.pSetLayouts = &s.setLayout;
  app::check(vkCreatePipelineLayout(device.device, &plci, nullptr, &s.layout), "vkCreatePipelineLayout");
  const VkDescriptorPoolSize sizes[2] = {{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 2}, {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1}};
  VkDescriptorPoolCreateInfo dpci = {VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  dpci.maxSets = 1;
  dpci.poolSizeCount = 2;
  dpci.pPoolSizes = sizes;
  app::check(vkCreateDescriptorPool(device.device, &dpci, nullptr, &s.pool), "vkCreateDescriptorPool");
  VkDescriptorSetAllocateInfo dsai = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  dsai.descriptorPool = s.pool;
  dsai.descriptorSetCount = 1;
  dsai.pSetLayouts = &s.setLayout;
  app::check(vkAllocateDescriptorSets(device.device, &dsai, &s.set), "vkAllocateDescriptorSets");

  s.positions = app::createBuffer(device, 6 * 8, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "positions");
  // Two triangles that cover the viewport once: every pixel centre in exactly one.
  const float corners[12] = {-1, -1, 1, -1, -1, 1, 1, -1, 1, 1, -1, 1};
  std::memcpy(s.positions.mapped, corners, sizeof corners);
  s.tint = app::createBuffer(device, 16, VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, "tint");
  std::memcpy(s.tint.mapped, kTint, sizeof kTint);
  s.out = app::createBuffer(device, kInvocations * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "out");
  s.readback = app::createBuffer(device, kSize * kSize * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT, "readback");
  const VkDescriptorBufferInfo infos[3] = {
      {s.positions.buffer, 0, VK_WHOLE_SIZE}, {s.tint.buffer, 0, VK_WHOLE_SIZE}, {s.out.buffer, 0, VK_WHOLE_SIZE}};
  VkWriteDescriptorSet writes[3] = {};
  for (uint32_t i = 0; i < 3; ++i) {
    writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    writes[i].dstSet = s.set;
    writes[i].dstBinding = i;
    writes[i].descriptorCount = 1;
    writes[i].descriptorType = bindings[i].descriptorType;
    writes[i].pBufferInfo = &infos[i];
  }
  vkUpdateDescriptorSets(device.device, 3, writes, 0, nullptr);
  return s;
}

void recordFrame(const app::Device& device, const Calls& calls, VkCommandBuffer cmd, const Scene& scene,
                 const Shaders& shaders, const Target& target) {
  VkCommandBufferBeginInfo begin = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  app::check(vkBeginCommandBuffer(cmd, &begin), "vkBeginCommandBuffer");
  imageBarrier(cmd, target.image, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, 0,
               VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT,
               VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT);
  app::label(device, cmd, "shaded");
  VkRenderingAttachmentInfo color = {VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  color.imageView = target.view;
  color.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  color.loadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
  color.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  VkRenderingInfo rendering = {VK_STRUCTURE_TYPE_RENDERING_INFO};
  rendering.renderArea = {{0, 0}, {kSize, kSize}};
  rendering.layerCount = 1;
  rendering.colorAttachmentCount = 1;
  rendering.pColorAttachments = &color;
  vkCmdBeginRendering(cmd, &rendering);
  // Every graphics stage the device's features allow, bound or unbound.
  const VkShaderStageFlagBits stages[5] = {VK_SHADER_STAGE_VERTEX_BIT, VK_SHADER_STAGE_TESSELLATION_CONTROL_BIT,
                                           VK_SHADER_STAGE_TESSELLATION_EVALUATION_BIT, VK_SHADER_STAGE_GEOMETRY_BIT,
                                           VK_SHADER_STAGE_FRAGMENT_BIT};
  const VkShaderEXT bound[5] = {shaders.vertex, VK_NULL_HANDLE, VK_NULL_HANDLE, VK_NULL_HANDLE, shaders.fragment};
  calls.bindShaders(cmd, 5, stages, bound);
  setDrawState(cmd, calls);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, scene.layout, 0, 1, &scene.set, 0, nullptr);
  vkCmdDraw(cmd, 6, 1, 0, 0);
  vkCmdEndRendering(cmd);
  app::unlabel(device, cmd);
  imageBarrier(cmd, target.image, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
               VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT, VK_ACCESS_TRANSFER_READ_BIT,
               VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT);
  VkBufferImageCopy copy = {};
  copy.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  copy.imageExtent = {kSize, kSize, 1};
  vkCmdCopyImageToBuffer(cmd, target.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, scene.readback.buffer, 1, &copy);

  app::label(device, cmd, "fill");
  const VkShaderStageFlagBits computeStage = VK_SHADER_STAGE_COMPUTE_BIT;
  calls.bindShaders(cmd, 1, &computeStage, &shaders.compute);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, scene.layout, 0, 1, &scene.set, 0, nullptr);
  vkCmdDispatch(cmd, kInvocations / 64, 1, 1);
  app::unlabel(device, cmd);
  VkMemoryBarrier host = {VK_STRUCTURE_TYPE_MEMORY_BARRIER, nullptr,
                          VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_HOST_READ_BIT};
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                       VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &host, 0, nullptr, 0, nullptr);
  app::check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
}

// Every texel the tint (R8G8B8A8_UNORM, rounded), and every out[i] filled.
bool resultsRight(const Scene& scene, uint32_t frame) {
  const auto* texels = reinterpret_cast<const uint8_t*>(scene.readback.mapped);
  for (uint32_t i = 0; i < kSize * kSize; ++i) {
    for (uint32_t c = 0; c < 4; ++c) {
      const int want = int(std::lround(kTint[c] * 255.0f));
      if (std::abs(int(texels[i * 4 + c]) - want) > 1) {
        std::fprintf(stderr, "shader_object_app: frame %u: texel %u channel %u = %d, expected %d\n", frame, i, c,
                     int(texels[i * 4 + c]), want);
        return false;
      }
    }
  }
  return app::filled(scene.out.mapped, kInvocations, "out");
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    const uint32_t value = uint32_t(std::strtoul(argv[i + 1], nullptr, 10));
    if (flag == "--frames") options.frames = value;
    else if (flag == "--linked") options.linked = value;
    else if (flag == "--binary") options.binary = value;
    else {
      std::fprintf(stderr, "shader_object_app: unknown flag %s (--frames, --linked, --binary)\n", flag.c_str());
      return 2;
    }
  }
  app::Instance instance;
  app::Device device = createDevice(instance);
  const Calls calls = loadCalls(device.device);
  Scene scene = createScene(device);
  const Shaders shaders = createShaders(device, calls, options, &scene.setLayout);
  const Target target = createTarget(device);
  VkCommandPool pool = app::createPool(device);
  VkCommandBuffer cmd = app::allocate(device, pool);
  VkFence fence = app::createFence(device);
  for (uint32_t frame = 0; frame < options.frames; ++frame) {
    std::memset(scene.out.mapped, 0, kInvocations * 4);
    recordFrame(device, calls, cmd, scene, shaders, target);
    app::submit(device.queues[0], cmd, fence);
    app::wait(device, fence);
    if (!resultsRight(scene, frame)) return 1;
  }
  vkDeviceWaitIdle(device.device);
  vkDestroyFence(device.device, fence, nullptr);
  vkDestroyCommandPool(device.device, pool, nullptr);
  for (VkShaderEXT s : {shaders.vertex, shaders.fragment, shaders.compute}) calls.destroyShader(device.device, s, nullptr);
  vkDestroyImageView(device.device, target.view, nullptr);
  vkDestroyImage(device.device, target.image, nullptr);
  vkFreeMemory(device.device, target.memory, nullptr);
  for (app::Buffer* b : {&scene.positions, &scene.tint, &scene.out, &scene.readback}) app::destroyBuffer(device, *b);
  vkDestroyDescriptorPool(device.device, scene.pool, nullptr);
  vkDestroyPipelineLayout(device.device, scene.layout, nullptr);
  vkDestroyDescriptorSetLayout(device.device, scene.setLayout, nullptr);
  vkDestroyDevice(device.device, nullptr);
  vkDestroyInstance(instance.instance, nullptr);
  std::printf("shader_object_app: %u frames (linked %u, binary %u), results correct\n", options.frames, options.linked,
              options.binary);
  return 0;
}
