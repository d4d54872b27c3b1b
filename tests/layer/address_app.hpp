// What address_app.cpp and address_search.cpp share: a Vulkan 1.2
// instance and device with bufferDeviceAddress, buffers reached by address,
// and the kernel both run (address_app.cpp's header says what it reads and
// writes).
#pragma once

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "app_support.hpp"

namespace address {

constexpr uint32_t kWords = 256;  // per buffer, and invocations per dispatch

inline constexpr const char* kShader = R"(#version 460
#extension GL_EXT_buffer_reference : require
layout(local_size_x = 64) in;
layout(buffer_reference, std430, buffer_reference_align = 4) buffer Words { uint w[]; };
layout(push_constant) uniform Push { Words src; Words dst; Words both; Words middle; Words scratch; } pc;
void main() {
  uint i = gl_GlobalInvocationID.x;
  uint v = pc.src.w[i];
  pc.dst.w[i] = v * 2u;
  pc.both.w[i] += v;
  if (i < 64u) {
    pc.both.w[i] += pc.middle.w[i];
    pc.scratch.w[i] = i;
  }
}
)";

struct Pointers {
  VkDeviceAddress src, dst, both, middle, scratch;
};

// Vulkan 1.2, for bufferDeviceAddress in core; VK_EXT_debug_utils to name the buffers.
inline app::Instance createInstance() {
  app::Instance out;
  uint32_t count = 0;
  vkEnumerateInstanceExtensionProperties(nullptr, &count, nullptr);
  std::vector<VkExtensionProperties> available(count);
  vkEnumerateInstanceExtensionProperties(nullptr, &count, available.data());
  std::vector<const char*> extensions;
  for (const auto& e : available) {
    if (std::strcmp(e.extensionName, VK_EXT_DEBUG_UTILS_EXTENSION_NAME) == 0) out.debugUtils = true;
  }
  if (out.debugUtils) extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  VkApplicationInfo info = {VK_STRUCTURE_TYPE_APPLICATION_INFO};
  info.pApplicationName = "address_app";
  info.apiVersion = VK_API_VERSION_1_2;
  VkInstanceCreateInfo ici = {VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ici.pApplicationInfo = &info;
  ici.enabledExtensionCount = uint32_t(extensions.size());
  ici.ppEnabledExtensionNames = extensions.data();
  app::check(vkCreateInstance(&ici, nullptr, &out.instance), "vkCreateInstance");
  uint32_t physicalCount = 1;
  vkEnumeratePhysicalDevices(out.instance, &physicalCount, &out.physical);
  return out;
}

inline app::Device createDevice(const app::Instance& instance, bool int64 = false) {
  app::Device out;
  out.physical = instance.physical;
  VkPhysicalDeviceVulkan12Features v12 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
  VkPhysicalDeviceFeatures2 supported = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &v12};
  vkGetPhysicalDeviceFeatures2(instance.physical, &supported);
  if (!v12.bufferDeviceAddress) {
    std::fprintf(stderr, "address_app: the device has no bufferDeviceAddress\n");
    std::exit(1);
  }
  VkPhysicalDeviceVulkan12Features enable = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
  enable.bufferDeviceAddress = VK_TRUE;
  const float priority = 1.0f;
  VkDeviceQueueCreateInfo qci = {VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qci.queueFamilyIndex = 0;
  qci.queueCount = 1;
  qci.pQueuePriorities = &priority;
  // The search's own test instruments the kernel itself: 64-bit addresses need shaderInt64.
  VkPhysicalDeviceFeatures2 features = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &enable};
  features.features.shaderInt64 = int64 ? VK_TRUE : VK_FALSE;
  VkDeviceCreateInfo dci = {VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO, &features};
  dci.queueCreateInfoCount = 1;
  dci.pQueueCreateInfos = &qci;
  app::check(vkCreateDevice(instance.physical, &dci, nullptr, &out.device), "vkCreateDevice");
  out.queues.resize(1);
  vkGetDeviceQueue(out.device, 0, 0, &out.queues[0]);
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

// A host-visible buffer reached by address; `bind2`: bound with vkBindBufferMemory2.
inline app::Buffer addressed(const app::Device& device, const std::string& text, bool bind2,
                             VkDeviceAddress& address) {
  app::Buffer out;
  VkBufferCreateInfo bci = {VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bci.size = kWords * 4;
  bci.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT;
  app::check(vkCreateBuffer(device.device, &bci, nullptr, &out.buffer), "vkCreateBuffer");
  app::name(device, VK_OBJECT_TYPE_BUFFER, reinterpret_cast<uint64_t>(out.buffer), text);
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(device.device, out.buffer, &req);
  VkMemoryAllocateFlagsInfo flags = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_FLAGS_INFO};
  flags.flags = VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT;
  VkMemoryAllocateInfo mai = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO, &flags};
  mai.allocationSize = req.size;
  mai.memoryTypeIndex = app::hostMemoryType(device, req.memoryTypeBits);
  app::check(vkAllocateMemory(device.device, &mai, nullptr, &out.memory), "vkAllocateMemory");
  if (bind2) {
    VkBindBufferMemoryInfo bind = {VK_STRUCTURE_TYPE_BIND_BUFFER_MEMORY_INFO};
    bind.buffer = out.buffer;
    bind.memory = out.memory;
    app::check(vkBindBufferMemory2(device.device, 1, &bind), "vkBindBufferMemory2");
  } else {
    app::check(vkBindBufferMemory(device.device, out.buffer, out.memory, 0), "vkBindBufferMemory");
  }
  app::check(
      vkMapMemory(device.device, out.memory, 0, VK_WHOLE_SIZE, 0, reinterpret_cast<void**>(&out.mapped)),
      "vkMapMemory");
  std::memset(out.mapped, 0, kWords * 4);
  VkBufferDeviceAddressInfo info = {VK_STRUCTURE_TYPE_BUFFER_DEVICE_ADDRESS_INFO};
  info.buffer = out.buffer;
  address = vkGetBufferDeviceAddress(device.device, &info);
  return out;
}

// The kernel as GLSL compiles it.
inline std::vector<uint32_t> kernelWords() {
  auto words = tally::glsl::compile(kShader, tally::spirv::Stage::Compute,
                                    {tally::glsl::Target::Vulkan12, false, "address_app.comp", {}});
  if (!words) {
    std::fprintf(stderr, "address test: %s\n", words.error().c_str());
    std::exit(1);
  }
  return *words;
}

struct Kernel {
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkPipeline pipeline = VK_NULL_HANDLE;
};

// The kernel's pipeline from `words`, its pointers in push constants and,
// where `setLayout` is given, one descriptor set.
inline Kernel createKernel(const app::Device& device, const std::vector<uint32_t>& words,
                           VkDescriptorSetLayout setLayout) {
  Kernel k;
  VkPushConstantRange range = {VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(Pointers)};
  VkPipelineLayoutCreateInfo plci = {VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  plci.setLayoutCount = setLayout != VK_NULL_HANDLE ? 1 : 0;
  plci.pSetLayouts = &setLayout;
  plci.pushConstantRangeCount = 1;
  plci.pPushConstantRanges = &range;
  app::check(vkCreatePipelineLayout(device.device, &plci, nullptr, &k.layout), "vkCreatePipelineLayout");
  VkShaderModuleCreateInfo smci = {VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  smci.codeSize = words.size() * 4;
  smci.pCode = words.data();
  VkShaderModule module;
  app::check(vkCreateShaderModule(device.device, &smci, nullptr, &module), "vkCreateShaderModule");
  VkComputePipelineCreateInfo cpci = {VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
  cpci.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
  cpci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  cpci.stage.module = module;
  cpci.stage.pName = "main";
  cpci.layout = k.layout;
  app::check(vkCreateComputePipelines(device.device, VK_NULL_HANDLE, 1, &cpci, nullptr, &k.pipeline),
             "vkCreateComputePipelines");
  vkDestroyShaderModule(device.device, module, nullptr);
  return k;
}

}  // namespace address
