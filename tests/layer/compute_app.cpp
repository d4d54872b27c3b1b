// A plain Vulkan application for the layer's tests (tests/layer/layer_test.py):
// it never presents, names its buffer and labels its dispatches through
// VK_EXT_debug_utils, and each frame (one submission) runs two compute passes:
//   "fill": out[i] = 3i + 1, with a pipeline layout of one set;
//   "bump": out[i] += 1000, with a pipeline layout of every set the device
//           allows (maxBoundDescriptorSets), which the layer cannot extend.
// It checks its own results, so a layer that changed what the application
// computes fails the test. --crash-after N: SIGSEGV after N frames;
// --hang-after N: sleeps forever after N frames; --all-sets-only 1: "fill"
// uses the full layout too, so the layer can count nothing; --debug-utils 0:
// the instance does not enable VK_EXT_debug_utils, yet the application names
// its buffer every frame through vkSetDebugUtilsObjectNameEXT (a misuse some
// applications commit, which the validation layer reports each time).
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include <vulkan/vulkan.h>

#include "gpu/glsl.hpp"

namespace {

void check(VkResult r, const char* what) {
  if (r != VK_SUCCESS) {
    std::fprintf(stderr, "compute_app: %s failed (VkResult %d)\n", what, int(r));
    std::exit(1);
  }
}

std::vector<uint32_t> compile(const char* source) {
  auto words = tally::glsl::compile(source, tally::spirv::Stage::Compute,
                                    {tally::glsl::Target::Vulkan11, false, "compute_app.comp", {}});
  if (!words) {
    std::fprintf(stderr, "compute_app: %s\n", words.error().c_str());
    std::exit(1);
  }
  return *words;
}

constexpr const char* kFill = R"(#version 450
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) buffer Out { uint v[]; };
void main() { v[gl_GlobalInvocationID.x] = gl_GlobalInvocationID.x * 3u + 1u; }
)";
constexpr const char* kBump = R"(#version 450
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) buffer Out { uint v[]; };
void main() { v[gl_GlobalInvocationID.x] += 1000u; }
)";

}  // namespace

int main(int argc, char** argv) {
  uint32_t frames = 3, crashAfter = 0, hangAfter = 0, allSetsOnly = 0, enableDebugUtils = 1;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    const uint32_t value = uint32_t(std::strtoul(argv[i + 1], nullptr, 10));
    if (flag == "--frames") frames = value;
    else if (flag == "--crash-after") crashAfter = value;
    else if (flag == "--hang-after") hangAfter = value;
    else if (flag == "--all-sets-only") allSetsOnly = value;
    else if (flag == "--debug-utils") enableDebugUtils = value;
  }
  constexpr uint32_t kCount = 64 * 50;

  VkApplicationInfo app = {VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "compute_app";
  app.apiVersion = VK_API_VERSION_1_1;
  uint32_t extCount = 0;
  vkEnumerateInstanceExtensionProperties(nullptr, &extCount, nullptr);
  std::vector<VkExtensionProperties> exts(extCount);
  vkEnumerateInstanceExtensionProperties(nullptr, &extCount, exts.data());
  bool debugUtils = false;
  for (const auto& e : exts) debugUtils = debugUtils || std::strcmp(e.extensionName, VK_EXT_DEBUG_UTILS_EXTENSION_NAME) == 0;
  debugUtils = debugUtils && enableDebugUtils != 0;
  const char* debugExt = VK_EXT_DEBUG_UTILS_EXTENSION_NAME;
  VkInstanceCreateInfo ici = {VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ici.pApplicationInfo = &app;
  ici.enabledExtensionCount = debugUtils ? 1 : 0;
  ici.ppEnabledExtensionNames = &debugExt;
  VkInstance instance;
  check(vkCreateInstance(&ici, nullptr, &instance), "vkCreateInstance");
  uint32_t physicalCount = 1;
  VkPhysicalDevice physical;
  vkEnumeratePhysicalDevices(instance, &physicalCount, &physical);
  VkPhysicalDeviceProperties props;
  vkGetPhysicalDeviceProperties(physical, &props);
  uint32_t familyCount = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(physical, &familyCount, nullptr);
  std::vector<VkQueueFamilyProperties> families(familyCount);
  vkGetPhysicalDeviceQueueFamilyProperties(physical, &familyCount, families.data());
  uint32_t family = 0;
  while (family < familyCount && !(families[family].queueFlags & VK_QUEUE_COMPUTE_BIT)) ++family;
  const float priority = 1.0f;
  VkDeviceQueueCreateInfo qci = {VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qci.queueFamilyIndex = family;
  qci.queueCount = 1;
  qci.pQueuePriorities = &priority;
  VkDeviceCreateInfo dci = {VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  dci.queueCreateInfoCount = 1;
  dci.pQueueCreateInfos = &qci;
  VkDevice device;
  check(vkCreateDevice(physical, &dci, nullptr, &device), "vkCreateDevice");
  VkQueue queue;
  vkGetDeviceQueue(device, family, 0, &queue);
  auto setName = reinterpret_cast<PFN_vkSetDebugUtilsObjectNameEXT>(
      vkGetInstanceProcAddr(instance, "vkSetDebugUtilsObjectNameEXT"));
  // Without the extension the instance gives none; the device still does (as libplacebo finds it).
  if (!enableDebugUtils) {
    setName = reinterpret_cast<PFN_vkSetDebugUtilsObjectNameEXT>(
        vkGetDeviceProcAddr(device, "vkSetDebugUtilsObjectNameEXT"));
  }
  auto beginLabel = reinterpret_cast<PFN_vkCmdBeginDebugUtilsLabelEXT>(
      vkGetInstanceProcAddr(instance, "vkCmdBeginDebugUtilsLabelEXT"));
  auto endLabel = reinterpret_cast<PFN_vkCmdEndDebugUtilsLabelEXT>(
      vkGetInstanceProcAddr(instance, "vkCmdEndDebugUtilsLabelEXT"));

  // The output buffer, host-visible.
  VkBufferCreateInfo bci = {VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bci.size = kCount * 4;
  bci.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
  VkBuffer buffer;
  check(vkCreateBuffer(device, &bci, nullptr, &buffer), "vkCreateBuffer");
  auto nameBuffer = [&] {
    VkDebugUtilsObjectNameInfoEXT name = {VK_STRUCTURE_TYPE_DEBUG_UTILS_OBJECT_NAME_INFO_EXT};
    name.objectType = VK_OBJECT_TYPE_BUFFER;
    name.objectHandle = reinterpret_cast<uint64_t>(buffer);
    name.pObjectName = "out";
    setName(device, &name);
  };
  if (debugUtils && setName != nullptr) nameBuffer();
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(device, buffer, &req);
  VkPhysicalDeviceMemoryProperties mem;
  vkGetPhysicalDeviceMemoryProperties(physical, &mem);
  uint32_t type = 0;
  const VkMemoryPropertyFlags want = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
  while (type < mem.memoryTypeCount &&
         (!(req.memoryTypeBits & (1u << type)) || (mem.memoryTypes[type].propertyFlags & want) != want)) {
    ++type;
  }
  VkMemoryAllocateInfo mai = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  mai.allocationSize = req.size;
  mai.memoryTypeIndex = type;
  VkDeviceMemory memory;
  check(vkAllocateMemory(device, &mai, nullptr, &memory), "vkAllocateMemory");
  vkBindBufferMemory(device, buffer, memory, 0);
  uint32_t* mapped = nullptr;
  vkMapMemory(device, memory, 0, VK_WHOLE_SIZE, 0, reinterpret_cast<void**>(&mapped));

  // Set 0: the buffer. Every further set of the full layout is empty.
  VkDescriptorSetLayoutBinding binding = {0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  VkDescriptorSetLayoutCreateInfo dslci = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  dslci.bindingCount = 1;
  dslci.pBindings = &binding;
  VkDescriptorSetLayout setLayout, emptyLayout;
  check(vkCreateDescriptorSetLayout(device, &dslci, nullptr, &setLayout), "vkCreateDescriptorSetLayout");
  VkDescriptorSetLayoutCreateInfo empty = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  check(vkCreateDescriptorSetLayout(device, &empty, nullptr, &emptyLayout), "vkCreateDescriptorSetLayout");
  std::vector<VkDescriptorSetLayout> all(props.limits.maxBoundDescriptorSets, emptyLayout);
  all[0] = setLayout;
  VkPipelineLayoutCreateInfo plci = {VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  plci.setLayoutCount = 1;
  plci.pSetLayouts = &setLayout;
  VkPipelineLayout oneSet, everySet;
  check(vkCreatePipelineLayout(device, &plci, nullptr, &oneSet), "vkCreatePipelineLayout");
  plci.setLayoutCount = uint32_t(all.size());
  plci.pSetLayouts = all.data();
  check(vkCreatePipelineLayout(device, &plci, nullptr, &everySet), "vkCreatePipelineLayout (every set)");

  auto pipelineFor = [&](const char* source, VkPipelineLayout layout) {
    const auto words = compile(source);
    VkShaderModuleCreateInfo smci = {VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
    smci.codeSize = words.size() * 4;
    smci.pCode = words.data();
    VkShaderModule module;
    check(vkCreateShaderModule(device, &smci, nullptr, &module), "vkCreateShaderModule");
    VkComputePipelineCreateInfo cpci = {VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
    cpci.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_COMPUTE_BIT, module,
                  "main", nullptr};
    cpci.layout = layout;
    VkPipeline pipeline;
    check(vkCreateComputePipelines(device, VK_NULL_HANDLE, 1, &cpci, nullptr, &pipeline), "vkCreateComputePipelines");
    vkDestroyShaderModule(device, module, nullptr);
    return pipeline;
  };
  // --all-sets-only 1: both pipelines use the full layout, so nothing can be counted.
  VkPipelineLayout fillLayout = allSetsOnly ? everySet : oneSet;
  VkPipeline fill = pipelineFor(kFill, fillLayout), bump = pipelineFor(kBump, everySet);

  VkDescriptorPoolSize size = {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1};
  VkDescriptorPoolCreateInfo dpci = {VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  dpci.maxSets = 1;
  dpci.poolSizeCount = 1;
  dpci.pPoolSizes = &size;
  VkDescriptorPool pool;
  check(vkCreateDescriptorPool(device, &dpci, nullptr, &pool), "vkCreateDescriptorPool");
  VkDescriptorSetAllocateInfo dsai = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  dsai.descriptorPool = pool;
  dsai.descriptorSetCount = 1;
  dsai.pSetLayouts = &setLayout;
  VkDescriptorSet set;
  check(vkAllocateDescriptorSets(device, &dsai, &set), "vkAllocateDescriptorSets");
  VkDescriptorBufferInfo dbi = {buffer, 0, VK_WHOLE_SIZE};
  VkWriteDescriptorSet write = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
  write.dstSet = set;
  write.descriptorCount = 1;
  write.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  write.pBufferInfo = &dbi;
  vkUpdateDescriptorSets(device, 1, &write, 0, nullptr);

  VkCommandPoolCreateInfo cpci = {VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  cpci.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  cpci.queueFamilyIndex = family;
  VkCommandPool commandPool;
  check(vkCreateCommandPool(device, &cpci, nullptr, &commandPool), "vkCreateCommandPool");
  VkCommandBufferAllocateInfo cbai = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  cbai.commandPool = commandPool;
  cbai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  cbai.commandBufferCount = 1;
  VkCommandBuffer cmd;
  check(vkAllocateCommandBuffers(device, &cbai, &cmd), "vkAllocateCommandBuffers");
  VkFenceCreateInfo fci = {VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  VkFence fence;
  check(vkCreateFence(device, &fci, nullptr, &fence), "vkCreateFence");

  for (uint32_t frame = 0; frame < frames; ++frame) {
    if (crashAfter > 0 && frame == crashAfter) std::raise(SIGSEGV);
    if (hangAfter > 0 && frame == hangAfter) {
      for (;;) std::this_thread::sleep_for(std::chrono::seconds(1));
    }
    if (!enableDebugUtils && setName != nullptr) nameBuffer();
    VkCommandBufferBeginInfo begin = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    vkBeginCommandBuffer(cmd, &begin);
    auto label = [&](const char* name) {
      if (beginLabel == nullptr || !debugUtils) return;
      VkDebugUtilsLabelEXT l = {VK_STRUCTURE_TYPE_DEBUG_UTILS_LABEL_EXT};
      l.pLabelName = name;
      beginLabel(cmd, &l);
    };
    auto unlabel = [&] {
      if (endLabel != nullptr && debugUtils) endLabel(cmd);
    };
    label("fill");
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, fill);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, fillLayout, 0, 1, &set, 0, nullptr);
    vkCmdDispatch(cmd, kCount / 64, 1, 1);
    unlabel();
    VkMemoryBarrier barrier = {VK_STRUCTURE_TYPE_MEMORY_BARRIER, nullptr, VK_ACCESS_SHADER_WRITE_BIT,
                               VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT};
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, 0, 1,
                         &barrier, 0, nullptr, 0, nullptr);
    label("bump");
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, bump);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, everySet, 0, 1, &set, 0, nullptr);
    vkCmdDispatch(cmd, kCount / 64, 1, 1);
    unlabel();
    VkMemoryBarrier host = {VK_STRUCTURE_TYPE_MEMORY_BARRIER, nullptr, VK_ACCESS_SHADER_WRITE_BIT,
                            VK_ACCESS_HOST_READ_BIT};
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &host, 0,
                         nullptr, 0, nullptr);
    vkEndCommandBuffer(cmd);
    VkSubmitInfo submit = {VK_STRUCTURE_TYPE_SUBMIT_INFO};
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &cmd;
    check(vkQueueSubmit(queue, 1, &submit, fence), "vkQueueSubmit");
    check(vkWaitForFences(device, 1, &fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
    vkResetFences(device, 1, &fence);
    for (uint32_t i = 0; i < kCount; ++i) {
      if (mapped[i] != i * 3 + 1 + 1000) {
        std::fprintf(stderr, "compute_app: frame %u: out[%u] = %u, expected %u\n", frame, i, mapped[i], i * 3 + 1001);
        return 1;
      }
    }
  }
  vkDeviceWaitIdle(device);
  vkDestroyFence(device, fence, nullptr);
  vkDestroyCommandPool(device, commandPool, nullptr);
  vkDestroyDescriptorPool(device, pool, nullptr);
  vkDestroyPipeline(device, fill, nullptr);
  vkDestroyPipeline(device, bump, nullptr);
  vkDestroyPipelineLayout(device, oneSet, nullptr);
  vkDestroyPipelineLayout(device, everySet, nullptr);
  vkDestroyDescriptorSetLayout(device, setLayout, nullptr);
  vkDestroyDescriptorSetLayout(device, emptyLayout, nullptr);
  vkDestroyBuffer(device, buffer, nullptr);
  vkFreeMemory(device, memory, nullptr);
  vkDestroyDevice(device, nullptr);
  vkDestroyInstance(instance, nullptr);
  std::printf("compute_app: %u frames, results correct\n", frames);
  return 0;
}
