// A plain Vulkan application for the layer's tests (tests/layer/features_test.py):
// it never presents, and each frame (one submission) draws a full-screen quad
// into a W x H target with dynamic rendering. The fragment shader samples the
// 8x8 texture "checker" once and reads the uniform "tint"; the vertex shader
// reads the uniform "offset" and the vertex buffer "quad"; indices come from
// "indices" (16-bit). What it exercises is chosen by flags:
//   --pipeline monolithic | library | library-independent
//       one pipeline, or four graphics pipeline libraries linked into one
//       (library-independent: each library's layout holds only its own set,
//       VK_PIPELINE_LAYOUT_CREATE_INDEPENDENT_SETS_BIT_EXT);
//   --descriptors sets | push | push-template
//       the fragment set (texture and tint) bound as a descriptor set, or
//       pushed with vkCmdPushDescriptorSetKHR or a push template;
//   --push-set 0|1   the fragment set's number (the vertex set takes the other);
//   --draw direct | indirect | indirect-count, --indirect-draws 6x1,3x2
//       vkCmdDrawIndexed(6, 1), or indexed indirect draws whose
//       (indexCount x instanceCount) a compute shader writes each frame from
//       the list given (indirect-count: the count too, with one more
//       record {6, 7} beyond it that must not be drawn).
// At the end it prints a hash of the target's pixels, so runs can be compared.
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

#include "gpu/glsl.hpp"
#include "graphics_app.hpp"

namespace {

void check(VkResult r, const char* what) {
  if (r != VK_SUCCESS) {
    std::fprintf(stderr, "graphics_app: %s failed (VkResult %d)\n", what, int(r));
    std::exit(1);
  }
}
void fail(const std::string& message) {
  std::fprintf(stderr, "graphics_app: %s\n", message.c_str());
  std::exit(1);
}

std::vector<uint32_t> compile(std::string source, tally::spirv::Stage stage, uint32_t vertexSet, uint32_t fragmentSet) {
  for (auto [key, value] : {std::pair{"VSET", vertexSet}, std::pair{"FSET", fragmentSet}}) {
    for (size_t at = source.find(key); at != std::string::npos; at = source.find(key)) {
      source.replace(at, 4, std::to_string(value));
    }
  }
  auto words = tally::glsl::compile(source, stage, {tally::glsl::Target::Vulkan11, false, "graphics_app", {}});
  if (!words) fail(words.error());
  return *words;
}

constexpr const char* kVertex = R"(#version 450
layout(set = VSET, binding = 0) uniform Offset { vec4 offset; };
layout(location = 0) in vec2 position;
layout(location = 0) out vec2 uv;
void main() { uv = position * 0.5 + 0.5; gl_Position = vec4(position + offset.xy, 0.0, 1.0); }
)";
constexpr const char* kFragment = R"(#version 450
layout(set = FSET, binding = 0) uniform sampler2D checker;
layout(set = FSET, binding = 1) uniform Tint { vec4 tint; };
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;
void main() { color = texture(checker, uv) * tint; }
)";
// Indexed indirect commands from (indexCount, instanceCount) pairs.
constexpr const char* kParameters = R"(#version 450
layout(local_size_x = 1) in;
layout(std430, set = 0, binding = 0) readonly buffer Spec { uint n; uint pairs[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Commands { uint words[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Count { uint count; };
void main() {
  for (uint i = 0; i <= n; ++i) {  // record n: {6, 7}, beyond the count
    words[i * 5 + 0] = i < n ? pairs[i * 2] : 6u;
    words[i * 5 + 1] = i < n ? pairs[i * 2 + 1] : 7u;
    words[i * 5 + 2] = 0u; words[i * 5 + 3] = 0u; words[i * 5 + 4] = 0u;
  }
  count = n;
}
)";

struct Context {
  VkInstance instance = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  VkQueue queue = VK_NULL_HANDLE;
  uint32_t family = 0;
  VkPhysicalDeviceMemoryProperties memory{};
  PFN_vkSetDebugUtilsObjectNameEXT setName = nullptr;
  PFN_vkCmdPushDescriptorSetKHR push = nullptr;
  PFN_vkCmdPushDescriptorSetWithTemplateKHR pushTemplate = nullptr;
};

Context createContext() {
  Context c;
  VkApplicationInfo app = {VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "graphics_app";
  app.apiVersion = VK_API_VERSION_1_3;
  const char* debugUtils = VK_EXT_DEBUG_UTILS_EXTENSION_NAME;
  VkInstanceCreateInfo ici = {VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ici.pApplicationInfo = &app;
  ici.enabledExtensionCount = 1;
  ici.ppEnabledExtensionNames = &debugUtils;
  check(vkCreateInstance(&ici, nullptr, &c.instance), "vkCreateInstance (with VK_EXT_debug_utils)");
  uint32_t count = 1;
  vkEnumeratePhysicalDevices(c.instance, &count, &c.physical);
  if (count == 0) fail("no Vulkan device");
  vkGetPhysicalDeviceMemoryProperties(c.physical, &c.memory);
  uint32_t familyCount = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(c.physical, &familyCount, nullptr);
  std::vector<VkQueueFamilyProperties> families(familyCount);
  vkGetPhysicalDeviceQueueFamilyProperties(c.physical, &familyCount, families.data());
  while (c.family < familyCount && (families[c.family].queueFlags & (VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT)) !=
                                       (VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT)) {
    ++c.family;
  }
  VkPhysicalDeviceGraphicsPipelineLibraryFeaturesEXT gpl = {
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_GRAPHICS_PIPELINE_LIBRARY_FEATURES_EXT};
  VkPhysicalDeviceVulkan13Features v13 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES, &gpl};
  VkPhysicalDeviceVulkan12Features v12 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES, &v13};
  VkPhysicalDeviceFeatures2 features = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &v12};
  vkGetPhysicalDeviceFeatures2(c.physical, &features);
  if (!gpl.graphicsPipelineLibrary || !v13.dynamicRendering || !v12.drawIndirectCount ||
      !features.features.multiDrawIndirect) {
    fail("the device lacks graphicsPipelineLibrary, dynamicRendering, drawIndirectCount or multiDrawIndirect");
  }
  VkPhysicalDeviceFeatures2 enabled = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &v12};
  v12 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES, &v13};
  v12.drawIndirectCount = VK_TRUE;
  enabled.features.multiDrawIndirect = VK_TRUE;
  v13 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES, &gpl};
  v13.dynamicRendering = VK_TRUE;
  v13.synchronization2 = v13.synchronization2 ? VK_TRUE : VK_FALSE;  // for --submit submit2-*
  gpl.graphicsPipelineLibrary = VK_TRUE;
  const char* extensions[] = {VK_KHR_PUSH_DESCRIPTOR_EXTENSION_NAME, VK_KHR_PIPELINE_LIBRARY_EXTENSION_NAME,
                              VK_EXT_GRAPHICS_PIPELINE_LIBRARY_EXTENSION_NAME};
  const float priority = 1.0f;
  VkDeviceQueueCreateInfo qci = {VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qci.queueFamilyIndex = c.family;
  qci.queueCount = 1;
  qci.pQueuePriorities = &priority;
  VkDeviceCreateInfo dci = {VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO, &enabled};
  dci.queueCreateInfoCount = 1;
  dci.pQueueCreateInfos = &qci;
  dci.enabledExtensionCount = 3;
  dci.ppEnabledExtensionNames = extensions;
  check(vkCreateDevice(c.physical, &dci, nullptr, &c.device), "vkCreateDevice");
  vkGetDeviceQueue(c.device, c.family, 0, &c.queue);
  c.setName = reinterpret_cast<PFN_vkSetDebugUtilsObjectNameEXT>(
      vkGetDeviceProcAddr(c.device, "vkSetDebugUtilsObjectNameEXT"));
  c.push = reinterpret_cast<PFN_vkCmdPushDescriptorSetKHR>(vkGetDeviceProcAddr(c.device, "vkCmdPushDescriptorSetKHR"));
  c.pushTemplate = reinterpret_cast<PFN_vkCmdPushDescriptorSetWithTemplateKHR>(
      vkGetDeviceProcAddr(c.device, "vkCmdPushDescriptorSetWithTemplateKHR"));
  return c;
}

void name(const Context& c, VkObjectType type, uint64_t handle, const char* text) {
  VkDebugUtilsObjectNameInfoEXT info = {VK_STRUCTURE_TYPE_DEBUG_UTILS_OBJECT_NAME_INFO_EXT};
  info.objectType = type;
  info.objectHandle = handle;
  info.pObjectName = text;
  if (c.setName != nullptr) c.setName(c.device, &info);
}

uint32_t memoryType(const Context& c, uint32_t bits, VkMemoryPropertyFlags want) {
  for (uint32_t i = 0; i < c.memory.memoryTypeCount; ++i) {
    if ((bits & (1u << i)) && (c.memory.memoryTypes[i].propertyFlags & want) == want) return i;
  }
  fail("no memory type");
  return 0;
}

struct Buffer {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  void* mapped = nullptr;
};

// Host-visible, so the application writes its data in place.
Buffer createBuffer(const Context& c, VkDeviceSize size, VkBufferUsageFlags usage, const char* label,
                    const void* data = nullptr) {
  Buffer b;
  VkBufferCreateInfo info = {VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  info.size = size;
  info.usage = usage;
  check(vkCreateBuffer(c.device, &info, nullptr, &b.buffer), "vkCreateBuffer");
  name(c, VK_OBJECT_TYPE_BUFFER, reinterpret_cast<uint64_t>(b.buffer), label);
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(c.device, b.buffer, &req);
  VkMemoryAllocateInfo alloc = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  alloc.allocationSize = req.size;
  alloc.memoryTypeIndex =
      memoryType(c, req.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
  check(vkAllocateMemory(c.device, &alloc, nullptr, &b.memory), "vkAllocateMemory");
  vkBindBufferMemory(c.device, b.buffer, b.memory, 0);
  vkMapMemory(c.device, b.memory, 0, VK_WHOLE_SIZE, 0, &b.mapped);
  if (data != nullptr) std::memcpy(b.mapped, data, size);
  return b;
}

struct Image {
  VkImage image = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkImageView view = VK_NULL_HANDLE;
};

Image createImage(const Context& c, uint32_t width, uint32_t height, VkImageUsageFlags usage, const char* label) {
  Image im;
  VkImageCreateInfo info = {VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  info.imageType = VK_IMAGE_TYPE_2D;
  info.format = VK_FORMAT_R8G8B8A8_UNORM;
  info.extent = {width, height, 1};
  info.mipLevels = info.arrayLayers = 1;
  info.samples = VK_SAMPLE_COUNT_1_BIT;
  info.usage = usage;
  check(vkCreateImage(c.device, &info, nullptr, &im.image), "vkCreateImage");
  name(c, VK_OBJECT_TYPE_IMAGE, reinterpret_cast<uint64_t>(im.image), label);
  VkMemoryRequirements req;
  vkGetImageMemoryRequirements(c.device, im.image, &req);
  VkMemoryAllocateInfo alloc = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  alloc.allocationSize = req.size;
  alloc.memoryTypeIndex = memoryType(c, req.memoryTypeBits, 0);
  check(vkAllocateMemory(c.device, &alloc, nullptr, &im.memory), "vkAllocateMemory");
  vkBindImageMemory(c.device, im.image, im.memory, 0);
  VkImageViewCreateInfo view = {VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
  view.image = im.image;
  view.viewType = VK_IMAGE_VIEW_TYPE_2D;
  view.format = info.format;
  view.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
  check(vkCreateImageView(c.device, &view, nullptr, &im.view), "vkCreateImageView");
  return im;
}

void transition(VkCommandBuffer cmd, VkImage image, VkImageLayout from, VkImageLayout to, VkPipelineStageFlags srcStage,
                VkAccessFlags srcAccess, VkPipelineStageFlags dstStage, VkAccessFlags dstAccess) {
  VkImageMemoryBarrier barrier = {VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER};
  barrier.srcAccessMask = srcAccess;
  barrier.dstAccessMask = dstAccess;
  barrier.oldLayout = from;
  barrier.newLayout = to;
  barrier.srcQueueFamilyIndex = barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  barrier.image = image;
  barrier.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
  vkCmdPipelineBarrier(cmd, srcStage, dstStage, 0, 0, nullptr, 0, nullptr, 1, &barrier);
}

VkShaderModule moduleOf(const Context& c, const std::vector<uint32_t>& words) {
  VkShaderModuleCreateInfo info = {VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  info.codeSize = words.size() * 4;
  info.pCode = words.data();
  VkShaderModule module;
  check(vkCreateShaderModule(c.device, &info, nullptr, &module), "vkCreateShaderModule");
  return module;
}

VkPipelineLayout pipelineLayout(const Context& c, std::vector<VkDescriptorSetLayout> sets, bool independent) {
  VkPipelineLayoutCreateInfo info = {VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  info.flags = independent ? VK_PIPELINE_LAYOUT_CREATE_INDEPENDENT_SETS_BIT_EXT : 0;
  info.setLayoutCount = uint32_t(sets.size());
  info.pSetLayouts = sets.data();
  VkPipelineLayout layout;
  check(vkCreatePipelineLayout(c.device, &info, nullptr, &layout), "vkCreatePipelineLayout");
  return layout;
}

// One submission of `cmd`, as --submit says: vkQueueSubmit or
// vkQueueSubmit2, with a fence waited for, or with none and the queue waited
// for (as applications that wait on semaphores do: the layer's readback then
// rides in the submission).
void submit(const Context& c, const std::string& how, VkCommandBuffer cmd, VkFence fence) {
  const bool fenced = how == "fence" || how == "submit2-fence";
  if (how == "fence" || how == "none") {
    VkSubmitInfo info = {VK_STRUCTURE_TYPE_SUBMIT_INFO};
    info.commandBufferCount = 1;
    info.pCommandBuffers = &cmd;
    check(vkQueueSubmit(c.queue, 1, &info, fenced ? fence : VK_NULL_HANDLE), "vkQueueSubmit");
  } else {
    VkCommandBufferSubmitInfo buffer = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO};
    buffer.commandBuffer = cmd;
    VkSubmitInfo2 info = {VK_STRUCTURE_TYPE_SUBMIT_INFO_2};
    info.commandBufferInfoCount = 1;
    info.pCommandBufferInfos = &buffer;
    check(vkQueueSubmit2(c.queue, 1, &info, fenced ? fence : VK_NULL_HANDLE), "vkQueueSubmit2");
  }
  if (fenced) {
    check(vkWaitForFences(c.device, 1, &fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
    vkResetFences(c.device, 1, &fence);
  } else {
    check(vkQueueWaitIdle(c.queue), "vkQueueWaitIdle");
  }
}

}  // namespace


namespace {

// The application's resources, named through VK_EXT_debug_utils.
struct Scene {
  Buffer vertices, indices, tint, offset, staging, readback, spec, params, count;
  Image checker, target;
  VkSampler sampler = VK_NULL_HANDLE;
  uint32_t records = 0;  // indirect records: the draws asked for, and one beyond
};

Scene createScene(const Context& c, const Options& o) {
  Scene s;
  const float quad[] = {-1, -1, 1, -1, -1, 1, 1, 1};
  const uint16_t indices[] = {0, 1, 2, 2, 1, 3};
  const float tint[] = {1.0f, 0.5f, 0.25f, 1.0f}, offset[] = {0, 0, 0, 0};
  s.vertices = createBuffer(c, sizeof quad, VK_BUFFER_USAGE_VERTEX_BUFFER_BIT, "quad", quad);
  s.indices = createBuffer(c, sizeof indices, VK_BUFFER_USAGE_INDEX_BUFFER_BIT, "indices", indices);
  s.tint = createBuffer(c, sizeof tint, VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, "tint", tint);
  s.offset = createBuffer(c, sizeof offset, VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, "offset", offset);
  std::vector<uint32_t> texels(64);
  for (uint32_t i = 0; i < 64; ++i) texels[i] = ((i % 8) + (i / 8)) % 2 ? 0xff20c0f0u : 0xff402010u;
  s.staging = createBuffer(c, 256, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, "checker upload", texels.data());
  s.checker = createImage(c, 8, 8, VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT, "checker");
  s.target = createImage(c, o.width, o.height, VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                         "target");
  s.readback = createBuffer(c, VkDeviceSize(o.width) * o.height * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT, "readback");
  s.records = uint32_t(o.indirect.size()) + 1;
  std::vector<uint32_t> spec = {uint32_t(o.indirect.size())};
  for (auto [n, instances] : o.indirect) spec.insert(spec.end(), {n, instances});
  s.spec = createBuffer(c, spec.size() * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "spec", spec.data());
  s.params = createBuffer(c, s.records * sizeof(VkDrawIndexedIndirectCommand),
                          VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT | VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "params");
  s.count = createBuffer(c, 4, VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT | VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "count");
  VkSamplerCreateInfo sci = {VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  check(vkCreateSampler(c.device, &sci, nullptr, &s.sampler), "vkCreateSampler");
  return s;
}

struct FragmentDescriptors {  // a push template's data
  VkDescriptorImageInfo image;
  VkDescriptorBufferInfo tint;
};

// Layouts, pipelines and descriptors.
struct Bindings {
  uint32_t fragmentSet = 0, vertexSet = 1;
  bool pushing = false;
  VkDescriptorSetLayout fragmentSetLayout = VK_NULL_HANDLE, vertexSetLayout = VK_NULL_HANDLE,
                        computeSetLayout = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE, computeLayout = VK_NULL_HANDLE;
  VkPipeline pipeline = VK_NULL_HANDLE, compute = VK_NULL_HANDLE;
  VkDescriptorSet vertexDescriptors = VK_NULL_HANDLE, computeDescriptors = VK_NULL_HANDLE,
                  fragmentDescriptors = VK_NULL_HANDLE;
  FragmentDescriptors fragmentData{};
  VkDescriptorUpdateTemplate pushTemplate = VK_NULL_HANDLE;
};

VkDescriptorSetLayout setLayout(const Context& c, std::vector<VkDescriptorSetLayoutBinding> bindings,
                                VkDescriptorSetLayoutCreateFlags flags = 0) {
  VkDescriptorSetLayoutCreateInfo info = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  info.flags = flags;
  info.bindingCount = uint32_t(bindings.size());
  info.pBindings = bindings.data();
  VkDescriptorSetLayout layout;
  check(vkCreateDescriptorSetLayout(c.device, &info, nullptr, &layout), "vkCreateDescriptorSetLayout");
  return layout;
}

void createPipelines(const Context& c, const Options& o, Bindings& b) {
  b.fragmentSet = o.pushSet;
  b.vertexSet = 1 - o.pushSet;
  b.pushing = o.descriptors != "sets";
  b.fragmentSetLayout = setLayout(c,
                                  {{0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr},
                                   {1, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr}},
                                  b.pushing ? VK_DESCRIPTOR_SET_LAYOUT_CREATE_PUSH_DESCRIPTOR_BIT_KHR : 0);
  b.vertexSetLayout = setLayout(c, {{0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, VK_SHADER_STAGE_VERTEX_BIT, nullptr}});
  const bool independent = o.pipeline == "library-independent";
  // Each library's layout ends at its own set, so their set counts differ.
  std::vector<VkDescriptorSetLayout> both(2), vertexOnly(b.vertexSet + 1, VK_NULL_HANDLE),
      fragmentOnly(b.fragmentSet + 1, VK_NULL_HANDLE);
  both[b.fragmentSet] = fragmentOnly[b.fragmentSet] = b.fragmentSetLayout;
  both[b.vertexSet] = vertexOnly[b.vertexSet] = b.vertexSetLayout;
  b.layout = pipelineLayout(c, both, independent);
  VkPipelineLayout vertexLayout = independent ? pipelineLayout(c, vertexOnly, true) : b.layout;
  VkPipelineLayout fragmentLayout = independent ? pipelineLayout(c, fragmentOnly, true) : b.layout;
  VkShaderModule vs = moduleOf(c, compile(kVertex, tally::spirv::Stage::Vertex, b.vertexSet, b.fragmentSet));
  VkShaderModule fs = moduleOf(c, compile(kFragment, tally::spirv::Stage::Fragment, b.vertexSet, b.fragmentSet));
  b.pipeline = createGraphicsPipeline(c.device, o.pipeline, vs, fs, b.layout, vertexLayout, fragmentLayout,
                                      VK_FORMAT_R8G8B8A8_UNORM);

  // The compute pipeline that writes the indirect parameters.
  std::vector<VkDescriptorSetLayoutBinding> storage;
  for (uint32_t i = 0; i < 3; ++i) {
    storage.push_back({i, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr});
  }
  b.computeSetLayout = setLayout(c, storage);
  b.computeLayout = pipelineLayout(c, {b.computeSetLayout}, false);
  VkComputePipelineCreateInfo cpci = {VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
  cpci.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_COMPUTE_BIT,
                moduleOf(c, compile(kParameters, tally::spirv::Stage::Compute, 0, 0)), "main", nullptr};
  cpci.layout = b.computeLayout;
  check(vkCreateComputePipelines(c.device, VK_NULL_HANDLE, 1, &cpci, nullptr, &b.compute), "vkCreateComputePipelines");
}

// The fragment set's two writes (to push, or to update a set with).
std::vector<VkWriteDescriptorSet> fragmentWrites(const Bindings& b, VkDescriptorSet set) {
  std::vector<VkWriteDescriptorSet> writes(2, {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET});
  for (uint32_t i = 0; i < 2; ++i) {
    writes[i].dstSet = set;
    writes[i].dstBinding = i;
    writes[i].descriptorCount = 1;
  }
  writes[0].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  writes[0].pImageInfo = &b.fragmentData.image;
  writes[1].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
  writes[1].pBufferInfo = &b.fragmentData.tint;
  return writes;
}

// The vertex and compute sets always, the fragment set unless pushed; the push template.
void createDescriptors(const Context& c, const Options& o, const Scene& s, Bindings& b) {
  VkDescriptorPoolSize sizes[] = {{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 2},
                                  {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1},
                                  {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 3}};
  VkDescriptorPoolCreateInfo dpci = {VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  dpci.maxSets = 3;
  dpci.poolSizeCount = 3;
  dpci.pPoolSizes = sizes;
  VkDescriptorPool pool;
  check(vkCreateDescriptorPool(c.device, &dpci, nullptr, &pool), "vkCreateDescriptorPool");
  VkDescriptorSetLayout layouts[] = {b.vertexSetLayout, b.computeSetLayout, b.fragmentSetLayout};
  VkDescriptorSetAllocateInfo dsai = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  dsai.descriptorPool = pool;
  dsai.descriptorSetCount = b.pushing ? 2 : 3;
  dsai.pSetLayouts = layouts;
  VkDescriptorSet sets[3] = {};
  check(vkAllocateDescriptorSets(c.device, &dsai, sets), "vkAllocateDescriptorSets");
  b.vertexDescriptors = sets[0];
  b.computeDescriptors = sets[1];
  b.fragmentDescriptors = sets[2];
  b.fragmentData = {{s.sampler, s.checker.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL}, {s.tint.buffer, 0, VK_WHOLE_SIZE}};
  VkDescriptorBufferInfo offsetInfo = {s.offset.buffer, 0, VK_WHOLE_SIZE};
  VkDescriptorBufferInfo computeInfos[] = {
      {s.spec.buffer, 0, VK_WHOLE_SIZE}, {s.params.buffer, 0, VK_WHOLE_SIZE}, {s.count.buffer, 0, VK_WHOLE_SIZE}};
  std::vector<VkWriteDescriptorSet> writes(2, {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET});
  writes[0].dstSet = b.vertexDescriptors;
  writes[0].descriptorCount = 1;
  writes[0].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
  writes[0].pBufferInfo = &offsetInfo;
  writes[1].dstSet = b.computeDescriptors;
  writes[1].descriptorCount = 3;
  writes[1].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  writes[1].pBufferInfo = computeInfos;
  if (!b.pushing) {
    for (const auto& w : fragmentWrites(b, b.fragmentDescriptors)) writes.push_back(w);
  }
  vkUpdateDescriptorSets(c.device, uint32_t(writes.size()), writes.data(), 0, nullptr);
  if (o.descriptors == "push-template") {
    VkDescriptorUpdateTemplateEntry entries[] = {
        {0, 0, 1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, offsetof(FragmentDescriptors, image), 0},
        {1, 0, 1, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, offsetof(FragmentDescriptors, tint), 0}};
    VkDescriptorUpdateTemplateCreateInfo info = {VK_STRUCTURE_TYPE_DESCRIPTOR_UPDATE_TEMPLATE_CREATE_INFO};
    info.descriptorUpdateEntryCount = 2;
    info.pDescriptorUpdateEntries = entries;
    info.templateType = VK_DESCRIPTOR_UPDATE_TEMPLATE_TYPE_PUSH_DESCRIPTORS_KHR;
    info.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
    info.pipelineLayout = b.layout;
    info.set = b.fragmentSet;
    check(vkCreateDescriptorUpdateTemplate(c.device, &info, nullptr, &b.pushTemplate),
          "vkCreateDescriptorUpdateTemplate");
  }
}

void upload(VkCommandBuffer cmd, const Scene& s) {
  transition(cmd, s.checker.image, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
             VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, 0, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT);
  VkBufferImageCopy region = {};
  region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.imageExtent = {8, 8, 1};
  vkCmdCopyBufferToImage(cmd, s.staging.buffer, s.checker.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
  transition(cmd, s.checker.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
             VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT,
             VK_ACCESS_SHADER_READ_BIT);
}

void drawQuad(const Context& c, const Options& o, const Scene& s, const Bindings& b, VkCommandBuffer cmd) {
  VkViewport viewport = {0, 0, float(o.width), float(o.height), 0, 1};
  VkRect2D scissor = {{0, 0}, {o.width, o.height}};
  vkCmdSetViewport(cmd, 0, 1, &viewport);
  vkCmdSetScissor(cmd, 0, 1, &scissor);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, b.pipeline);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, b.layout, b.vertexSet, 1, &b.vertexDescriptors, 0,
                          nullptr);
  if (o.descriptors == "sets") {
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, b.layout, b.fragmentSet, 1, &b.fragmentDescriptors,
                            0, nullptr);
  } else if (o.descriptors == "push") {
    const auto writes = fragmentWrites(b, VK_NULL_HANDLE);
    c.push(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, b.layout, b.fragmentSet, uint32_t(writes.size()), writes.data());
  } else {
    c.pushTemplate(cmd, b.pushTemplate, b.layout, b.fragmentSet, &b.fragmentData);
  }
  VkDeviceSize zero = 0;
  vkCmdBindVertexBuffers(cmd, 0, 1, &s.vertices.buffer, &zero);
  vkCmdBindIndexBuffer(cmd, s.indices.buffer, 0, VK_INDEX_TYPE_UINT16);
  const uint32_t stride = sizeof(VkDrawIndexedIndirectCommand);
  if (o.draw == "direct") {
    vkCmdDrawIndexed(cmd, 6, 1, 0, 0, 0);
  } else if (o.draw == "indirect") {
    vkCmdDrawIndexedIndirect(cmd, s.params.buffer, 0, s.records - 1, stride);
  } else {
    vkCmdDrawIndexedIndirectCount(cmd, s.params.buffer, 0, s.count.buffer, 0, s.records, stride);
  }
}

// One frame: the indirect parameters (where drawn indirectly), the quad, the target read back.
void recordFrame(const Context& c, const Options& o, const Scene& s, const Bindings& b, VkCommandBuffer cmd) {
  if (o.draw != "direct") {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, b.compute);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, b.computeLayout, 0, 1, &b.computeDescriptors, 0,
                            nullptr);
    vkCmdDispatch(cmd, 1, 1, 1);
    VkMemoryBarrier written = {VK_STRUCTURE_TYPE_MEMORY_BARRIER, nullptr, VK_ACCESS_SHADER_WRITE_BIT,
                               VK_ACCESS_INDIRECT_COMMAND_READ_BIT};
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT, 0, 1,
                         &written, 0, nullptr, 0, nullptr);
  }
  transition(cmd, s.target.image, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
             VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, 0, VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT,
             VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT);
  VkRenderingAttachmentInfo color = {VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  color.imageView = s.target.view;
  color.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  color.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  color.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  VkRenderingInfo rendering = {VK_STRUCTURE_TYPE_RENDERING_INFO};
  rendering.renderArea = {{0, 0}, {o.width, o.height}};
  rendering.layerCount = 1;
  rendering.colorAttachmentCount = 1;
  rendering.pColorAttachments = &color;
  vkCmdBeginRendering(cmd, &rendering);
  drawQuad(c, o, s, b, cmd);
  vkCmdEndRendering(cmd);
  transition(cmd, s.target.image, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
             VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT,
             VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_READ_BIT);
  VkBufferImageCopy back = {};
  back.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  back.imageExtent = {o.width, o.height, 1};
  vkCmdCopyImageToBuffer(cmd, s.target.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, s.readback.buffer, 1, &back);
  VkMemoryBarrier host = {VK_STRUCTURE_TYPE_MEMORY_BARRIER, nullptr, VK_ACCESS_TRANSFER_WRITE_BIT,
                          VK_ACCESS_HOST_READ_BIT};
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &host, 0, nullptr, 0,
                       nullptr);
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parseOptions(argc, argv);
  Context c = createContext();
  const Scene scene = createScene(c, o);
  Bindings bindings;
  createPipelines(c, o, bindings);
  createDescriptors(c, o, scene, bindings);

  VkCommandPoolCreateInfo poolInfo = {VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  poolInfo.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  poolInfo.queueFamilyIndex = c.family;
  VkCommandPool commandPool;
  check(vkCreateCommandPool(c.device, &poolInfo, nullptr, &commandPool), "vkCreateCommandPool");
  VkCommandBufferAllocateInfo cbai = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  cbai.commandPool = commandPool;
  cbai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  cbai.commandBufferCount = 1;
  VkCommandBuffer cmd;
  check(vkAllocateCommandBuffers(c.device, &cbai, &cmd), "vkAllocateCommandBuffers");
  VkFenceCreateInfo fci = {VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  VkFence fence;
  check(vkCreateFence(c.device, &fci, nullptr, &fence), "vkCreateFence");
  // Each recording is one submission; the texture's upload has no draw, so no frame of its own.
  for (uint32_t frame = 0; frame <= o.frames; ++frame) {
    VkCommandBufferBeginInfo begin = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    vkBeginCommandBuffer(cmd, &begin);
    if (frame == 0) upload(cmd, scene);
    else recordFrame(c, o, scene, bindings, cmd);
    check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
    submit(c, o.submit, cmd, fence);
  }
  // FNV-1a of the last frame's pixels.
  uint64_t hash = 1469598103934665603ull;
  const auto* bytes = static_cast<const uint8_t*>(scene.readback.mapped);
  for (VkDeviceSize i = 0; i < VkDeviceSize(o.width) * o.height * 4; ++i) hash = (hash ^ bytes[i]) * 1099511628211ull;
  vkDeviceWaitIdle(c.device);
  vkDestroyDevice(c.device, nullptr);  // the layer writes its output here; the rest goes with the process
  vkDestroyInstance(c.instance, nullptr);
  std::printf("graphics_app: %u frames, image hash %016llx\n", o.frames, static_cast<unsigned long long>(hash));
  return 0;
}
