// Plain Vulkan set-up shared by the layer's test applications
// (robust_app.cpp, swapchain_app.cpp): an instance, a device with one or two
// queues, host-visible buffers named through VK_EXT_debug_utils, and the
// compute kernel whose counts the tests derive by hand: "fill" writes
// out[i] = 3i + 1, one 4-byte write per invocation, 64 invocations a group.
#pragma once

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

#include "gpu/glsl.hpp"

namespace app {

inline void check(VkResult r, const char* what) {
  if (r != VK_SUCCESS) {
    std::fprintf(stderr, "test app: %s failed (VkResult %d)\n", what, int(r));
    std::exit(1);
  }
}

inline std::vector<uint32_t> compile(const char* source, tally::spirv::Stage stage) {
  auto words = tally::glsl::compile(source, stage, {tally::glsl::Target::Vulkan11, false, "test_app.glsl", {}});
  if (!words) {
    std::fprintf(stderr, "test app: %s\n", words.error().c_str());
    std::exit(1);
  }
  return *words;
}

struct Instance {
  VkInstance instance = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  bool debugUtils = false;
};

inline Instance createInstance(const char* name, std::vector<const char*> extensions) {
  Instance out;
  uint32_t count = 0;
  vkEnumerateInstanceExtensionProperties(nullptr, &count, nullptr);
  std::vector<VkExtensionProperties> available(count);
  vkEnumerateInstanceExtensionProperties(nullptr, &count, available.data());
  for (const auto& e : available) {
    out.debugUtils = out.debugUtils || std::strcmp(e.extensionName, VK_EXT_DEBUG_UTILS_EXTENSION_NAME) == 0;
  }
  if (out.debugUtils) extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  VkApplicationInfo info = {VK_STRUCTURE_TYPE_APPLICATION_INFO};
  info.pApplicationName = name;
  info.apiVersion = VK_API_VERSION_1_1;
  VkInstanceCreateInfo ici = {VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ici.pApplicationInfo = &info;
  ici.enabledExtensionCount = uint32_t(extensions.size());
  ici.ppEnabledExtensionNames = extensions.data();
  check(vkCreateInstance(&ici, nullptr, &out.instance), "vkCreateInstance");
  uint32_t physicalCount = 1;
  vkEnumeratePhysicalDevices(out.instance, &physicalCount, &out.physical);
  return out;
}

struct Device {
  VkDevice device = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  uint32_t family = 0;
  std::vector<VkQueue> queues;  // as many as asked for, at most the family's count
  VkPhysicalDeviceMemoryProperties memory{};
  PFN_vkSetDebugUtilsObjectNameEXT setName = nullptr;
  PFN_vkCmdBeginDebugUtilsLabelEXT beginLabel = nullptr;
  PFN_vkCmdEndDebugUtilsLabelEXT endLabel = nullptr;
};

// A graphics and compute family's device with up to `queues` queues.
inline Device createDevice(const Instance& instance, uint32_t queues, std::vector<const char*> extensions = {}) {
  Device out;
  out.physical = instance.physical;
  uint32_t familyCount = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(instance.physical, &familyCount, nullptr);
  std::vector<VkQueueFamilyProperties> families(familyCount);
  vkGetPhysicalDeviceQueueFamilyProperties(instance.physical, &familyCount, families.data());
  const VkQueueFlags want = VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT;
  while (out.family < familyCount && (families[out.family].queueFlags & want) != want) ++out.family;
  if (out.family == familyCount) {
    std::fprintf(stderr, "test app: no graphics and compute queue family\n");
    std::exit(1);
  }
  const uint32_t count = std::min(queues, families[out.family].queueCount);
  const std::vector<float> priorities(count, 1.0f);
  VkDeviceQueueCreateInfo qci = {VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qci.queueFamilyIndex = out.family;
  qci.queueCount = count;
  qci.pQueuePriorities = priorities.data();
  VkDeviceCreateInfo dci = {VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  dci.queueCreateInfoCount = 1;
  dci.pQueueCreateInfos = &qci;
  dci.enabledExtensionCount = uint32_t(extensions.size());
  dci.ppEnabledExtensionNames = extensions.data();
  check(vkCreateDevice(instance.physical, &dci, nullptr, &out.device), "vkCreateDevice");
  out.queues.resize(count);
  for (uint32_t i = 0; i < count; ++i) vkGetDeviceQueue(out.device, out.family, i, &out.queues[i]);
  vkGetPhysicalDeviceMemoryProperties(instance.physical, &out.memory);
  if (instance.debugUtils) {
    out.setName = reinterpret_cast<PFN_vkSetDebugUtilsObjectNameEXT>(
        vkGetDeviceProcAddr(out.device, "vkSetDebugUtilsObjectNameEXT"));
    out.beginLabel = reinterpret_cast<PFN_vkCmdBeginDebugUtilsLabelEXT>(
        vkGetDeviceProcAddr(out.device, "vkCmdBeginDebugUtilsLabelEXT"));
    out.endLabel = reinterpret_cast<PFN_vkCmdEndDebugUtilsLabelEXT>(
        vkGetDeviceProcAddr(out.device, "vkCmdEndDebugUtilsLabelEXT"));
  }
  return out;
}

inline void name(const Device& device, VkObjectType type, uint64_t handle, const std::string& text) {
  if (device.setName == nullptr) return;
  VkDebugUtilsObjectNameInfoEXT info = {VK_STRUCTURE_TYPE_DEBUG_UTILS_OBJECT_NAME_INFO_EXT};
  info.objectType = type;
  info.objectHandle = handle;
  info.pObjectName = text.c_str();
  device.setName(device.device, &info);
}

inline void label(const Device& device, VkCommandBuffer cmd, const std::string& text) {
  if (device.beginLabel == nullptr) return;
  VkDebugUtilsLabelEXT l = {VK_STRUCTURE_TYPE_DEBUG_UTILS_LABEL_EXT};
  l.pLabelName = text.c_str();
  device.beginLabel(cmd, &l);
}
inline void unlabel(const Device& device, VkCommandBuffer cmd) {
  if (device.endLabel != nullptr) device.endLabel(cmd);
}

struct Buffer {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  uint32_t* mapped = nullptr;
};

inline uint32_t hostMemoryType(const Device& device, uint32_t bits) {
  const VkMemoryPropertyFlags want = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
  for (uint32_t t = 0; t < device.memory.memoryTypeCount; ++t) {
    if ((bits & (1u << t)) && (device.memory.memoryTypes[t].propertyFlags & want) == want) return t;
  }
  std::fprintf(stderr, "test app: no host-visible coherent memory\n");
  std::exit(1);
}

inline Buffer createBuffer(const Device& device, VkDeviceSize size, VkBufferUsageFlags usage, const std::string& text) {
  Buffer out;
  VkBufferCreateInfo bci = {VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bci.size = size;
  bci.usage = usage;
  check(vkCreateBuffer(device.device, &bci, nullptr, &out.buffer), "vkCreateBuffer");
  if (!text.empty()) name(device, VK_OBJECT_TYPE_BUFFER, reinterpret_cast<uint64_t>(out.buffer), text);
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(device.device, out.buffer, &req);
  VkMemoryAllocateInfo mai = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  mai.allocationSize = req.size;
  mai.memoryTypeIndex = hostMemoryType(device, req.memoryTypeBits);
  check(vkAllocateMemory(device.device, &mai, nullptr, &out.memory), "vkAllocateMemory");
  vkBindBufferMemory(device.device, out.buffer, out.memory, 0);
  check(vkMapMemory(device.device, out.memory, 0, VK_WHOLE_SIZE, 0, reinterpret_cast<void**>(&out.mapped)),
        "vkMapMemory");
  return out;
}

inline void destroyBuffer(const Device& device, Buffer& buffer) {
  vkDestroyBuffer(device.device, buffer.buffer, nullptr);
  vkFreeMemory(device.device, buffer.memory, nullptr);
  buffer = Buffer{};
}

constexpr const char* kFill = R"(#version 450
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) buffer Out { uint v[]; };
void main() { v[gl_GlobalInvocationID.x] = gl_GlobalInvocationID.x * 3u + 1u; }
)";

// The fill kernel: one pipeline, and a descriptor set per output buffer.
struct Fill {
  VkDescriptorSetLayout setLayout = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkPipeline pipeline = VK_NULL_HANDLE;
  VkDescriptorPool pool = VK_NULL_HANDLE;
};

inline Fill createFill(const Device& device, uint32_t maxSets) {
  Fill out;
  VkDescriptorSetLayoutBinding binding = {0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  VkDescriptorSetLayoutCreateInfo dslci = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  dslci.bindingCount = 1;
  dslci.pBindings = &binding;
  check(vkCreateDescriptorSetLayout(device.device, &dslci, nullptr, &out.setLayout), "vkCreateDescriptorSetLayout");
  VkPipelineLayoutCreateInfo plci = {VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  plci.setLayoutCount = 1;
  plci.pSetLayouts = &out.setLayout;
  check(vkCreatePipelineLayout(device.device, &plci, nullptr, &out.layout), "vkCreatePipelineLayout");
  const auto words = compile(kFill, tally::spirv::Stage::Compute);
  VkShaderModuleCreateInfo smci = {VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  smci.codeSize = words.size() * 4;
  smci.pCode = words.data();
  VkShaderModule module;
  check(vkCreateShaderModule(device.device, &smci, nullptr, &module), "vkCreateShaderModule");
  VkComputePipelineCreateInfo cpci = {VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
  cpci.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_COMPUTE_BIT, module,
                "main", nullptr};
  cpci.layout = out.layout;
  check(vkCreateComputePipelines(device.device, VK_NULL_HANDLE, 1, &cpci, nullptr, &out.pipeline),
        "vkCreateComputePipelines");
  vkDestroyShaderModule(device.device, module, nullptr);
  VkDescriptorPoolSize size = {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, maxSets};
  VkDescriptorPoolCreateInfo dpci = {VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  dpci.maxSets = maxSets;
  dpci.poolSizeCount = 1;
  dpci.pPoolSizes = &size;
  check(vkCreateDescriptorPool(device.device, &dpci, nullptr, &out.pool), "vkCreateDescriptorPool");
  return out;
}

inline VkDescriptorSet fillSet(const Device& device, const Fill& fill, VkBuffer buffer) {
  VkDescriptorSetAllocateInfo dsai = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  dsai.descriptorPool = fill.pool;
  dsai.descriptorSetCount = 1;
  dsai.pSetLayouts = &fill.setLayout;
  VkDescriptorSet set;
  check(vkAllocateDescriptorSets(device.device, &dsai, &set), "vkAllocateDescriptorSets");
  VkDescriptorBufferInfo dbi = {buffer, 0, VK_WHOLE_SIZE};
  VkWriteDescriptorSet write = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
  write.dstSet = set;
  write.descriptorCount = 1;
  write.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  write.pBufferInfo = &dbi;
  vkUpdateDescriptorSets(device.device, 1, &write, 0, nullptr);
  return set;
}

inline void destroyFill(const Device& device, Fill& fill) {
  vkDestroyDescriptorPool(device.device, fill.pool, nullptr);
  vkDestroyPipeline(device.device, fill.pipeline, nullptr);
  vkDestroyPipelineLayout(device.device, fill.layout, nullptr);
  vkDestroyDescriptorSetLayout(device.device, fill.setLayout, nullptr);
}

// A labelled dispatch of `invocations` (a multiple of 64) into the set's
// buffer, then its writes made visible to the host.
inline void recordFill(const Device& device, VkCommandBuffer cmd, const Fill& fill, VkDescriptorSet set,
                       uint32_t invocations, const std::string& text) {
  label(device, cmd, text);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, fill.pipeline);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, fill.layout, 0, 1, &set, 0, nullptr);
  vkCmdDispatch(cmd, invocations / 64, 1, 1);
  unlabel(device, cmd);
  VkMemoryBarrier host = {VK_STRUCTURE_TYPE_MEMORY_BARRIER, nullptr, VK_ACCESS_SHADER_WRITE_BIT, VK_ACCESS_HOST_READ_BIT};
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &host, 0, nullptr,
                       0, nullptr);
}

// Whether the kernel's `invocations` results are in `out` (the application
// checks its own work: a layer that changed it fails the test).
inline bool filled(const uint32_t* out, uint32_t invocations, const char* what) {
  for (uint32_t i = 0; i < invocations; ++i) {
    if (out[i] != i * 3 + 1) {
      std::fprintf(stderr, "test app: %s: out[%u] = %u, expected %u\n", what, i, out[i], i * 3 + 1);
      return false;
    }
  }
  return true;
}

inline VkCommandPool createPool(const Device& device) {
  VkCommandPoolCreateInfo info = {VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  info.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  info.queueFamilyIndex = device.family;
  VkCommandPool pool;
  check(vkCreateCommandPool(device.device, &info, nullptr, &pool), "vkCreateCommandPool");
  return pool;
}

inline VkCommandBuffer allocate(const Device& device, VkCommandPool pool) {
  VkCommandBufferAllocateInfo info = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  info.commandPool = pool;
  info.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  info.commandBufferCount = 1;
  VkCommandBuffer cmd;
  check(vkAllocateCommandBuffers(device.device, &info, &cmd), "vkAllocateCommandBuffers");
  return cmd;
}

inline VkFence createFence(const Device& device, bool signalled = false) {
  VkFenceCreateInfo info = {VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  if (signalled) info.flags = VK_FENCE_CREATE_SIGNALED_BIT;
  VkFence fence;
  check(vkCreateFence(device.device, &info, nullptr, &fence), "vkCreateFence");
  return fence;
}

inline void submit(VkQueue queue, VkCommandBuffer cmd, VkFence fence) {
  VkSubmitInfo info = {VK_STRUCTURE_TYPE_SUBMIT_INFO};
  info.commandBufferCount = 1;
  info.pCommandBuffers = &cmd;
  check(vkQueueSubmit(queue, 1, &info, fence), "vkQueueSubmit");
}

inline void wait(const Device& device, VkFence fence) {
  check(vkWaitForFences(device.device, 1, &fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
  vkResetFences(device.device, 1, &fence);
}

}  // namespace app
