// A plain Vulkan application for the layer's early-test check
// (tests/layer/early_tests.py). It never presents: a frame is one
// submission. Each frame draws the quads given on the command line, in that
// order (front to back), into a 64x64 colour and depth target cleared to
// depth 1, with depth test LESS and depth writes, twice:
//   pass "early": a fragment shader without early_fragment_tests that has
//                 nothing needing late tests (no discard, no depth output,
//                 no stores), which the layer may give early tests;
//   pass "late":  the same with a discard that is never taken, which must
//                 keep its late tests;
//   passes "coverage-off" and "coverage-on": the first shader in a pipeline
//                 whose alpha to coverage is dynamic state
//                 (VK_EXT_extended_dynamic_state3), set off, then on (every
//                 quad is opaque, so coverage stays whole either way).
// It checks that every pixel of each pass shows its front quad's colour, so
// a layer that changed what the depth test keeps fails the test. With
// --queries 1 it measures each pass itself: a pipeline-statistics query
// (fragment shader invocations) and a precise occlusion query (samples that
// passed the depth test), one JSON line per pass and frame on stdout.
//
//   depth_app --frames N --queries 0|1 --quads "x0,y0,x1,y1,z;..."  (pixels, z in [0, 1])
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

#include "gpu/glsl.hpp"

namespace {

constexpr uint32_t kSize = 64;  // a power of two: pixel edges are exact in normalized device coordinates
constexpr VkFormat kColorFormat = VK_FORMAT_R8G8B8A8_UNORM;
constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;
constexpr uint32_t kMaxPasses = 4;

void check(VkResult r, const char* what) {
  if (r != VK_SUCCESS) {
    std::fprintf(stderr, "depth_app: %s failed (VkResult %d)\n", what, int(r));
    std::exit(1);
  }
}

struct Quad {
  float x0, y0, x1, y1, z;
};

std::vector<Quad> parseQuads(const std::string& text) {
  std::vector<Quad> quads;
  std::stringstream all(text);
  std::string one;
  while (std::getline(all, one, ';')) {
    Quad q{};
    if (std::sscanf(one.c_str(), "%f,%f,%f,%f,%f", &q.x0, &q.y0, &q.x1, &q.y1, &q.z) != 5) {
      std::fprintf(stderr, "depth_app: --quads: '%s' is not x0,y0,x1,y1,z\n", one.c_str());
      std::exit(2);
    }
    quads.push_back(q);
  }
  if (quads.empty()) {
    std::fprintf(stderr, "depth_app: --quads names no quad\n");
    std::exit(2);
  }
  return quads;
}

// The colour quad i is drawn in: red steps of 1/8 (exact in UNORM8 after rounding).
float redOf(size_t i) { return float(i + 1) / 8.0f; }

struct PushBlock {
  float rect[4];  // x0, y0, x1, y1 in normalized device coordinates
  float color[4];
  float depth;
};

constexpr const char* kVertex = R"(#version 450
layout(push_constant) uniform Quad { vec4 rect; vec4 color; float depth; } quad;
void main() {
  const vec2 corners[6] = vec2[6](vec2(0, 0), vec2(1, 0), vec2(0, 1), vec2(1, 0), vec2(1, 1), vec2(0, 1));
  gl_Position = vec4(mix(quad.rect.xy, quad.rect.zw, corners[gl_VertexIndex]), quad.depth, 1.0);
}
)";
constexpr const char* kEarly = R"(#version 450
layout(push_constant) uniform Quad { vec4 rect; vec4 color; float depth; } quad;
layout(location = 0) out vec4 color;
void main() { color = quad.color; }
)";
constexpr const char* kLate = R"(#version 450
layout(push_constant) uniform Quad { vec4 rect; vec4 color; float depth; } quad;
layout(location = 0) out vec4 color;
void main() {
  if (quad.color.a < 0.0) discard;  // never: every quad is opaque
  color = quad.color;
}
)";

struct App {
  VkInstance instance = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  VkQueue queue = VK_NULL_HANDLE;
  uint32_t family = 0;
  bool debugUtils = false;
  PFN_vkCmdBeginDebugUtilsLabelEXT beginLabel = nullptr;
  PFN_vkCmdEndDebugUtilsLabelEXT endLabel = nullptr;
  VkPhysicalDeviceMemoryProperties memory{};
  PFN_vkCmdSetAlphaToCoverageEnableEXT setAlphaToCoverage = nullptr;  // null: no dynamic alpha to coverage
};

// Whether the device offers alpha to coverage as dynamic state.
bool hasDynamicAlphaToCoverage(VkPhysicalDevice physical) {
  uint32_t count = 0;
  vkEnumerateDeviceExtensionProperties(physical, nullptr, &count, nullptr);
  std::vector<VkExtensionProperties> exts(count);
  vkEnumerateDeviceExtensionProperties(physical, nullptr, &count, exts.data());
  bool extension = false;
  for (const auto& e : exts) extension |= std::strcmp(e.extensionName, VK_EXT_EXTENDED_DYNAMIC_STATE_3_EXTENSION_NAME) == 0;
  if (!extension) return false;
  VkPhysicalDeviceExtendedDynamicState3FeaturesEXT eds3 = {
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_EXTENDED_DYNAMIC_STATE_3_FEATURES_EXT};
  VkPhysicalDeviceFeatures2 features = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &eds3};
  vkGetPhysicalDeviceFeatures2(physical, &features);
  return eds3.extendedDynamicState3AlphaToCoverageEnable == VK_TRUE;
}

void createDevice(App& a, bool queries) {
  VkApplicationInfo info = {VK_STRUCTURE_TYPE_APPLICATION_INFO};
  info.pApplicationName = "depth_app";
  info.apiVersion = VK_API_VERSION_1_1;
  uint32_t extCount = 0;
  vkEnumerateInstanceExtensionProperties(nullptr, &extCount, nullptr);
  std::vector<VkExtensionProperties> exts(extCount);
  vkEnumerateInstanceExtensionProperties(nullptr, &extCount, exts.data());
  for (const auto& e : exts) a.debugUtils |= std::strcmp(e.extensionName, VK_EXT_DEBUG_UTILS_EXTENSION_NAME) == 0;
  const char* debugExt = VK_EXT_DEBUG_UTILS_EXTENSION_NAME;
  VkInstanceCreateInfo ici = {VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ici.pApplicationInfo = &info;
  ici.enabledExtensionCount = a.debugUtils ? 1 : 0;
  ici.ppEnabledExtensionNames = &debugExt;
  check(vkCreateInstance(&ici, nullptr, &a.instance), "vkCreateInstance");
  uint32_t physicalCount = 1;
  vkEnumeratePhysicalDevices(a.instance, &physicalCount, &a.physical);
  if (physicalCount == 0) check(VK_ERROR_INITIALIZATION_FAILED, "vkEnumeratePhysicalDevices (no device)");
  vkGetPhysicalDeviceMemoryProperties(a.physical, &a.memory);
  uint32_t familyCount = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(a.physical, &familyCount, nullptr);
  std::vector<VkQueueFamilyProperties> families(familyCount);
  vkGetPhysicalDeviceQueueFamilyProperties(a.physical, &familyCount, families.data());
  while (a.family < familyCount && !(families[a.family].queueFlags & VK_QUEUE_GRAPHICS_BIT)) ++a.family;
  VkPhysicalDeviceFeatures supported{}, enabled{};
  vkGetPhysicalDeviceFeatures(a.physical, &supported);
  if (queries && !(supported.pipelineStatisticsQuery && supported.occlusionQueryPrecise)) {
    std::fprintf(stderr, "depth_app: the device has no pipelineStatisticsQuery or occlusionQueryPrecise\n");
    std::exit(1);
  }
  enabled.pipelineStatisticsQuery = queries;
  enabled.occlusionQueryPrecise = queries;
  const bool dynamicCoverage = hasDynamicAlphaToCoverage(a.physical);
  VkPhysicalDeviceExtendedDynamicState3FeaturesEXT eds3 = {
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_EXTENDED_DYNAMIC_STATE_3_FEATURES_EXT};
  eds3.extendedDynamicState3AlphaToCoverageEnable = VK_TRUE;
  const char* eds3Name = VK_EXT_EXTENDED_DYNAMIC_STATE_3_EXTENSION_NAME;
  const float priority = 1.0f;
  VkDeviceQueueCreateInfo qci = {VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qci.queueFamilyIndex = a.family;
  qci.queueCount = 1;
  qci.pQueuePriorities = &priority;
  VkDeviceCreateInfo dci = {VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  dci.queueCreateInfoCount = 1;
  dci.pQueueCreateInfos = &qci;
  dci.pEnabledFeatures = &enabled;
  if (dynamicCoverage) {
    dci.pNext = &eds3;
    dci.enabledExtensionCount = 1;
    dci.ppEnabledExtensionNames = &eds3Name;
  }
  check(vkCreateDevice(a.physical, &dci, nullptr, &a.device), "vkCreateDevice");
  vkGetDeviceQueue(a.device, a.family, 0, &a.queue);
  if (dynamicCoverage) {
    a.setAlphaToCoverage = reinterpret_cast<PFN_vkCmdSetAlphaToCoverageEnableEXT>(
        vkGetDeviceProcAddr(a.device, "vkCmdSetAlphaToCoverageEnableEXT"));
  }
  a.beginLabel = reinterpret_cast<PFN_vkCmdBeginDebugUtilsLabelEXT>(
      vkGetInstanceProcAddr(a.instance, "vkCmdBeginDebugUtilsLabelEXT"));
  a.endLabel =
      reinterpret_cast<PFN_vkCmdEndDebugUtilsLabelEXT>(vkGetInstanceProcAddr(a.instance, "vkCmdEndDebugUtilsLabelEXT"));
}

VkDeviceMemory allocate(App& a, VkMemoryRequirements req, VkMemoryPropertyFlags want) {
  uint32_t type = 0;
  while (type < a.memory.memoryTypeCount &&
         (!(req.memoryTypeBits & (1u << type)) || (a.memory.memoryTypes[type].propertyFlags & want) != want)) {
    ++type;
  }
  VkMemoryAllocateInfo mai = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  mai.allocationSize = req.size;
  mai.memoryTypeIndex = type;
  VkDeviceMemory memory;
  check(vkAllocateMemory(a.device, &mai, nullptr, &memory), "vkAllocateMemory");
  return memory;
}

struct Target {
  VkImage color = VK_NULL_HANDLE, depth = VK_NULL_HANDLE;
  VkImageView colorView = VK_NULL_HANDLE, depthView = VK_NULL_HANDLE;
  VkDeviceMemory colorMemory = VK_NULL_HANDLE, depthMemory = VK_NULL_HANDLE;
  VkRenderPass pass = VK_NULL_HANDLE;
  VkFramebuffer framebuffer = VK_NULL_HANDLE;
  VkBuffer readback = VK_NULL_HANDLE;  // one kSize x kSize image per pass, kMaxPasses
  VkDeviceMemory readbackMemory = VK_NULL_HANDLE;
  const uint8_t* pixels = nullptr;
};

void createImage(App& a, VkFormat format, VkImageUsageFlags usage, VkImageAspectFlags aspect, VkImage& image,
                 VkDeviceMemory& memory, VkImageView& view) {
  VkImageCreateInfo ici = {VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  ici.imageType = VK_IMAGE_TYPE_2D;
  ici.format = format;
  ici.extent = {kSize, kSize, 1};
  ici.mipLevels = 1;
  ici.arrayLayers = 1;
  ici.samples = VK_SAMPLE_COUNT_1_BIT;
  ici.usage = usage;
  check(vkCreateImage(a.device, &ici, nullptr, &image), "vkCreateImage");
  VkMemoryRequirements req;
  vkGetImageMemoryRequirements(a.device, image, &req);
  memory = allocate(a, req, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  check(vkBindImageMemory(a.device, image, memory, 0), "vkBindImageMemory");
  VkImageViewCreateInfo vci = {VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
  vci.image = image;
  vci.viewType = VK_IMAGE_VIEW_TYPE_2D;
  vci.format = format;
  vci.subresourceRange = {aspect, 0, 1, 0, 1};
  check(vkCreateImageView(a.device, &vci, nullptr, &view), "vkCreateImageView");
}

Target createTarget(App& a) {
  Target t;
  createImage(a, kColorFormat, VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
              VK_IMAGE_ASPECT_COLOR_BIT, t.color, t.colorMemory, t.colorView);
  createImage(a, kDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, VK_IMAGE_ASPECT_DEPTH_BIT, t.depth,
              t.depthMemory, t.depthView);
  VkAttachmentDescription attachments[2] = {};
  attachments[0] = {0, kColorFormat, VK_SAMPLE_COUNT_1_BIT, VK_ATTACHMENT_LOAD_OP_CLEAR, VK_ATTACHMENT_STORE_OP_STORE,
                    VK_ATTACHMENT_LOAD_OP_DONT_CARE, VK_ATTACHMENT_STORE_OP_DONT_CARE, VK_IMAGE_LAYOUT_UNDEFINED,
                    VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL};
  attachments[1] = {0, kDepthFormat, VK_SAMPLE_COUNT_1_BIT, VK_ATTACHMENT_LOAD_OP_CLEAR,
                    VK_ATTACHMENT_STORE_OP_DONT_CARE, VK_ATTACHMENT_LOAD_OP_DONT_CARE, VK_ATTACHMENT_STORE_OP_DONT_CARE,
                    VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
  VkAttachmentReference colorRef = {0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
  VkAttachmentReference depthRef = {1, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
  VkSubpassDescription subpass = {};
  subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
  subpass.colorAttachmentCount = 1;
  subpass.pColorAttachments = &colorRef;
  subpass.pDepthStencilAttachment = &depthRef;
  // The copy after the pass waits for its colour writes.
  VkSubpassDependency after = {0, VK_SUBPASS_EXTERNAL, VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT,
                               VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT,
                               VK_ACCESS_TRANSFER_READ_BIT, 0};
  VkRenderPassCreateInfo rpci = {VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO};
  rpci.attachmentCount = 2;
  rpci.pAttachments = attachments;
  rpci.subpassCount = 1;
  rpci.pSubpasses = &subpass;
  rpci.dependencyCount = 1;
  rpci.pDependencies = &after;
  check(vkCreateRenderPass(a.device, &rpci, nullptr, &t.pass), "vkCreateRenderPass");
  VkImageView views[2] = {t.colorView, t.depthView};
  VkFramebufferCreateInfo fci = {VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO};
  fci.renderPass = t.pass;
  fci.attachmentCount = 2;
  fci.pAttachments = views;
  fci.width = fci.height = kSize;
  fci.layers = 1;
  check(vkCreateFramebuffer(a.device, &fci, nullptr, &t.framebuffer), "vkCreateFramebuffer");
  VkBufferCreateInfo bci = {VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bci.size = kMaxPasses * kSize * kSize * 4;
  bci.usage = VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  check(vkCreateBuffer(a.device, &bci, nullptr, &t.readback), "vkCreateBuffer");
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(a.device, t.readback, &req);
  t.readbackMemory = allocate(a, req, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
  check(vkBindBufferMemory(a.device, t.readback, t.readbackMemory, 0), "vkBindBufferMemory");
  void* mapped = nullptr;
  check(vkMapMemory(a.device, t.readbackMemory, 0, VK_WHOLE_SIZE, 0, &mapped), "vkMapMemory");
  t.pixels = static_cast<const uint8_t*>(mapped);
  return t;
}

VkShaderModule shaderModule(App& a, const char* source, tally::spirv::Stage stage) {
  auto words = tally::glsl::compile(source, stage, {tally::glsl::Target::Vulkan11, false, "depth_app", {}});
  if (!words) {
    std::fprintf(stderr, "depth_app: %s\n", words.error().c_str());
    std::exit(1);
  }
  VkShaderModuleCreateInfo smci = {VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  smci.codeSize = words->size() * 4;
  smci.pCode = words->data();
  VkShaderModule module;
  check(vkCreateShaderModule(a.device, &smci, nullptr, &module), "vkCreateShaderModule");
  return module;
}

VkPipeline createPipeline(App& a, const Target& t, VkPipelineLayout layout, const char* fragment,
                          bool dynamicCoverage = false) {
  VkShaderModule vs = shaderModule(a, kVertex, tally::spirv::Stage::Vertex);
  VkShaderModule fs = shaderModule(a, fragment, tally::spirv::Stage::Fragment);
  VkPipelineShaderStageCreateInfo stages[2] = {
      {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_VERTEX_BIT, vs, "main", nullptr},
      {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_FRAGMENT_BIT, fs, "main",
       nullptr}};
  VkPipelineVertexInputStateCreateInfo vertexInput = {VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
  VkPipelineInputAssemblyStateCreateInfo assembly = {VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
  assembly.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  VkViewport viewport = {0, 0, float(kSize), float(kSize), 0, 1};
  VkRect2D scissor = {{0, 0}, {kSize, kSize}};
  VkPipelineViewportStateCreateInfo viewportState = {VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
  viewportState.viewportCount = viewportState.scissorCount = 1;
  viewportState.pViewports = &viewport;
  viewportState.pScissors = &scissor;
  VkPipelineRasterizationStateCreateInfo raster = {VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
  raster.cullMode = VK_CULL_MODE_NONE;
  raster.lineWidth = 1.0f;
  VkPipelineMultisampleStateCreateInfo multisample = {VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
  multisample.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
  VkPipelineDepthStencilStateCreateInfo depth = {VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO};
  depth.depthTestEnable = depth.depthWriteEnable = VK_TRUE;
  depth.depthCompareOp = VK_COMPARE_OP_LESS;
  VkPipelineColorBlendAttachmentState blendAttachment = {};
  blendAttachment.colorWriteMask = 0xf;
  VkPipelineColorBlendStateCreateInfo blend = {VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
  blend.attachmentCount = 1;
  blend.pAttachments = &blendAttachment;
  VkGraphicsPipelineCreateInfo gpci = {VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO};
  gpci.stageCount = 2;
  gpci.pStages = stages;
  gpci.pVertexInputState = &vertexInput;
  gpci.pInputAssemblyState = &assembly;
  gpci.pViewportState = &viewportState;
  gpci.pRasterizationState = &raster;
  gpci.pMultisampleState = &multisample;
  gpci.pDepthStencilState = &depth;
  gpci.pColorBlendState = &blend;
  const VkDynamicState coverage = VK_DYNAMIC_STATE_ALPHA_TO_COVERAGE_ENABLE_EXT;
  VkPipelineDynamicStateCreateInfo dynamic = {VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO};
  dynamic.dynamicStateCount = 1;
  dynamic.pDynamicStates = &coverage;
  if (dynamicCoverage) gpci.pDynamicState = &dynamic;
  gpci.layout = layout;
  gpci.renderPass = t.pass;
  VkPipeline pipeline;
  check(vkCreateGraphicsPipelines(a.device, VK_NULL_HANDLE, 1, &gpci, nullptr, &pipeline), "vkCreateGraphicsPipelines");
  vkDestroyShaderModule(a.device, vs, nullptr);
  vkDestroyShaderModule(a.device, fs, nullptr);
  return pipeline;
}

// A pass: its label, pipeline and, for a pipeline with dynamic alpha to coverage, the value set (-1: static).
struct Pass {
  const char* label;
  VkPipeline pipeline;
  int alphaToCoverage;
};

struct Frame {
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkQueryPool statistics = VK_NULL_HANDLE, occlusion = VK_NULL_HANDLE;  // one query per pass; none without --queries
};

// One pass: the quads front to back, then a copy of the colour image to the pass's readback slot.
void recordPass(App& a, const Target& t, const Frame& f, const Pass& pass, const std::vector<Quad>& quads,
                uint32_t index) {
  const char* label = pass.label;
  if (a.debugUtils && a.beginLabel != nullptr) {
    VkDebugUtilsLabelEXT l = {VK_STRUCTURE_TYPE_DEBUG_UTILS_LABEL_EXT};
    l.pLabelName = label;
    a.beginLabel(f.cmd, &l);
  }
  if (f.statistics != VK_NULL_HANDLE) {
    vkCmdBeginQuery(f.cmd, f.statistics, index, 0);
    vkCmdBeginQuery(f.cmd, f.occlusion, index, VK_QUERY_CONTROL_PRECISE_BIT);
  }
  VkClearValue clears[2] = {};
  clears[1].depthStencil = {1.0f, 0};
  VkRenderPassBeginInfo begin = {VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
  begin.renderPass = t.pass;
  begin.framebuffer = t.framebuffer;
  begin.renderArea = {{0, 0}, {kSize, kSize}};
  begin.clearValueCount = 2;
  begin.pClearValues = clears;
  vkCmdBeginRenderPass(f.cmd, &begin, VK_SUBPASS_CONTENTS_INLINE);
  vkCmdBindPipeline(f.cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pass.pipeline);
  if (pass.alphaToCoverage >= 0) a.setAlphaToCoverage(f.cmd, pass.alphaToCoverage ? VK_TRUE : VK_FALSE);
  for (size_t i = 0; i < quads.size(); ++i) {
    const Quad& q = quads[i];
    auto ndc = [](float pixels) { return pixels / float(kSize) * 2.0f - 1.0f; };
    PushBlock push = {{ndc(q.x0), ndc(q.y0), ndc(q.x1), ndc(q.y1)}, {redOf(i), 0.0f, 0.0f, 1.0f}, q.z};
    vkCmdPushConstants(f.cmd, f.layout, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(push),
                       &push);
    vkCmdDraw(f.cmd, 6, 1, 0, 0);
  }
  vkCmdEndRenderPass(f.cmd);
  if (f.statistics != VK_NULL_HANDLE) {
    vkCmdEndQuery(f.cmd, f.occlusion, index);
    vkCmdEndQuery(f.cmd, f.statistics, index);
  }
  if (a.debugUtils && a.endLabel != nullptr) a.endLabel(f.cmd);
  VkBufferImageCopy copy = {};
  copy.bufferOffset = VkDeviceSize(index) * kSize * kSize * 4;
  copy.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  copy.imageExtent = {kSize, kSize, 1};
  vkCmdCopyImageToBuffer(f.cmd, t.color, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, t.readback, 1, &copy);
  // The next pass clears the image the copy reads.
  VkMemoryBarrier barrier = {VK_STRUCTURE_TYPE_MEMORY_BARRIER, nullptr, VK_ACCESS_TRANSFER_READ_BIT,
                             VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT};
  vkCmdPipelineBarrier(f.cmd, VK_PIPELINE_STAGE_TRANSFER_BIT,
                       VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 1, &barrier,
                       0, nullptr, 0, nullptr);
}

// Every pixel shows the first quad (front to back) that covers its centre, or the clear colour.
bool checkPixels(const uint8_t* pixels, const std::vector<Quad>& quads, const char* label, uint32_t frame) {
  for (uint32_t y = 0; y < kSize; ++y) {
    for (uint32_t x = 0; x < kSize; ++x) {
      int expected = 0;
      for (size_t i = 0; i < quads.size(); ++i) {
        const Quad& q = quads[i];
        if (x + 0.5f > q.x0 && x + 0.5f < q.x1 && y + 0.5f > q.y0 && y + 0.5f < q.y1) {
          expected = int(redOf(i) * 255.0f + 0.5f);
          break;
        }
      }
      const int red = pixels[(y * kSize + x) * 4];
      if (std::abs(red - expected) > 1) {
        std::fprintf(stderr, "depth_app: frame %u, pass %s: pixel (%u, %u) has red %d, expected %d\n", frame, label, x,
                     y, red, expected);
        return false;
      }
    }
  }
  return true;
}

// One frame: every pass, one submission, then the pixels and the queries.
bool runFrame(App& a, const Target& t, const Frame& f, const std::vector<Pass>& passes,
              const std::vector<Quad>& quads, VkFence fence, uint32_t frame) {
  const uint32_t count = uint32_t(passes.size());
  VkCommandBufferBeginInfo begin = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  vkBeginCommandBuffer(f.cmd, &begin);
  if (f.statistics != VK_NULL_HANDLE) {
    vkCmdResetQueryPool(f.cmd, f.statistics, 0, count);
    vkCmdResetQueryPool(f.cmd, f.occlusion, 0, count);
  }
  for (uint32_t p = 0; p < count; ++p) recordPass(a, t, f, passes[p], quads, p);
  VkMemoryBarrier host = {VK_STRUCTURE_TYPE_MEMORY_BARRIER, nullptr, VK_ACCESS_TRANSFER_WRITE_BIT,
                          VK_ACCESS_HOST_READ_BIT};
  vkCmdPipelineBarrier(f.cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &host, 0, nullptr, 0,
                       nullptr);
  vkEndCommandBuffer(f.cmd);
  VkSubmitInfo submit = {VK_STRUCTURE_TYPE_SUBMIT_INFO};
  submit.commandBufferCount = 1;
  submit.pCommandBuffers = &f.cmd;
  check(vkQueueSubmit(a.queue, 1, &submit, fence), "vkQueueSubmit");
  check(vkWaitForFences(a.device, 1, &fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
  vkResetFences(a.device, 1, &fence);
  for (uint32_t p = 0; p < count; ++p) {
    if (!checkPixels(t.pixels + size_t(p) * kSize * kSize * 4, quads, passes[p].label, frame)) return false;
  }
  if (f.statistics == VK_NULL_HANDLE) return true;
  std::vector<uint64_t> statistics(count), samples(count);
  check(vkGetQueryPoolResults(a.device, f.statistics, 0, count, count * 8, statistics.data(), 8,
                              VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
        "vkGetQueryPoolResults (statistics)");
  check(vkGetQueryPoolResults(a.device, f.occlusion, 0, count, count * 8, samples.data(), 8,
                              VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
        "vkGetQueryPoolResults (occlusion)");
  for (uint32_t p = 0; p < count; ++p) {
    std::printf("{\"frame\": %u, \"pass\": \"%s\", \"fragment_invocations_statistic\": %llu, \"samples_passed\": %llu}\n",
                frame, passes[p].label, static_cast<unsigned long long>(statistics[p]),
                static_cast<unsigned long long>(samples[p]));
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  uint32_t frames = 3;
  bool queries = false;
  std::string quadText;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--frames") frames = uint32_t(std::strtoul(argv[i + 1], nullptr, 10));
    else if (flag == "--queries") queries = std::strtoul(argv[i + 1], nullptr, 10) != 0;
    else if (flag == "--quads") quadText = argv[i + 1];
  }
  const std::vector<Quad> quads = parseQuads(quadText);
  App a;
  createDevice(a, queries);
  Target t = createTarget(a);
  VkPushConstantRange range = {VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(PushBlock)};
  VkPipelineLayoutCreateInfo plci = {VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  plci.pushConstantRangeCount = 1;
  plci.pPushConstantRanges = &range;
  Frame f;
  check(vkCreatePipelineLayout(a.device, &plci, nullptr, &f.layout), "vkCreatePipelineLayout");
  std::vector<Pass> passes = {{"early", createPipeline(a, t, f.layout, kEarly), -1},
                              {"late", createPipeline(a, t, f.layout, kLate), -1}};
  if (a.setAlphaToCoverage != nullptr) {
    VkPipeline dynamic = createPipeline(a, t, f.layout, kEarly, true);
    passes.push_back({"coverage-off", dynamic, 0});
    passes.push_back({"coverage-on", dynamic, 1});
  } else {
    std::fprintf(stderr, "depth_app: no dynamic alpha to coverage (VK_EXT_extended_dynamic_state3): its passes left out\n");
  }
  if (queries) {
    VkQueryPoolCreateInfo qpci = {VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    qpci.queryType = VK_QUERY_TYPE_PIPELINE_STATISTICS;
    qpci.queryCount = uint32_t(passes.size());
    qpci.pipelineStatistics = VK_QUERY_PIPELINE_STATISTIC_FRAGMENT_SHADER_INVOCATIONS_BIT;
    check(vkCreateQueryPool(a.device, &qpci, nullptr, &f.statistics), "vkCreateQueryPool (statistics)");
    qpci.queryType = VK_QUERY_TYPE_OCCLUSION;
    qpci.pipelineStatistics = 0;
    check(vkCreateQueryPool(a.device, &qpci, nullptr, &f.occlusion), "vkCreateQueryPool (occlusion)");
  }
  VkCommandPoolCreateInfo cpci = {VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  cpci.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  cpci.queueFamilyIndex = a.family;
  VkCommandPool pool;
  check(vkCreateCommandPool(a.device, &cpci, nullptr, &pool), "vkCreateCommandPool");
  VkCommandBufferAllocateInfo cbai = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  cbai.commandPool = pool;
  cbai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  cbai.commandBufferCount = 1;
  check(vkAllocateCommandBuffers(a.device, &cbai, &f.cmd), "vkAllocateCommandBuffers");
  VkFenceCreateInfo fci = {VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  VkFence fence;
  check(vkCreateFence(a.device, &fci, nullptr, &fence), "vkCreateFence");
  for (uint32_t frame = 0; frame < frames; ++frame) {
    if (!runFrame(a, t, f, passes, quads, fence, frame)) return 1;
  }
  vkDeviceWaitIdle(a.device);
  std::fprintf(stderr, "depth_app: %u frames, every pixel shows its front quad\n", frames);
  vkDestroyFence(a.device, fence, nullptr);
  vkDestroyCommandPool(a.device, pool, nullptr);
  for (size_t p = 0; p < passes.size(); ++p) {
    if (p == 0 || passes[p].pipeline != passes[p - 1].pipeline) vkDestroyPipeline(a.device, passes[p].pipeline, nullptr);
  }
  vkDestroyPipelineLayout(a.device, f.layout, nullptr);
  if (queries) {
    vkDestroyQueryPool(a.device, f.statistics, nullptr);
    vkDestroyQueryPool(a.device, f.occlusion, nullptr);
  }
  vkDestroyFramebuffer(a.device, t.framebuffer, nullptr);
  vkDestroyRenderPass(a.device, t.pass, nullptr);
  vkDestroyImageView(a.device, t.colorView, nullptr);
  vkDestroyImageView(a.device, t.depthView, nullptr);
  vkDestroyImage(a.device, t.color, nullptr);
  vkDestroyImage(a.device, t.depth, nullptr);
  vkDestroyBuffer(a.device, t.readback, nullptr);
  for (VkDeviceMemory m : {t.colorMemory, t.depthMemory, t.readbackMemory}) vkFreeMemory(a.device, m, nullptr);
  vkDestroyDevice(a.device, nullptr);
  vkDestroyInstance(a.instance, nullptr);
  return 0;
}
