// VK_LAYER_TALLY_counters: the loader interface, instances, devices, queues
// and submissions. The other intercepted calls are in one file per area
// (intercepts.hpp); what each records, and how the counts are attributed, is
// described in docs/layer.md. counters.cpp holds the counter regions,
// readback.cpp the readback and the output.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string_view>
#include <utility>

#include "descriptor_buffers_layer.hpp"
#include "early_tests_twin.hpp"
#include "intercepts.hpp"
#include "libraries.hpp"
#include "names.hpp"
#include "shader_objects.hpp"
#include "shader_options.hpp"
#include "state.hpp"
#include "uncounted.hpp"

namespace tally::layer {
namespace {

std::mutex g_mutex;  // guards the two maps below (each device has its own mutex for its state)
std::unordered_map<void*, std::unique_ptr<InstanceState>> g_instances;
std::unordered_map<void*, std::unique_ptr<DeviceState>> g_devices;

InstanceState* instanceOf(const void* handle) {
  std::lock_guard lock(g_mutex);
  auto it = g_instances.find(dispatchKey(handle));
  return it == g_instances.end() ? nullptr : it->second.get();
}

}  // namespace

void log(const std::string& line) { std::fprintf(stderr, "tally layer: %s\n", line.c_str()); }

DeviceState* deviceOf(const void* handle) {
  std::lock_guard lock(g_mutex);
  auto it = g_devices.find(dispatchKey(handle));
  return it == g_devices.end() ? nullptr : it->second.get();
}
CommandBufferState* commandBufferOf(DeviceState& dev, VkCommandBuffer cb) {
  auto it = dev.commandBuffers.find(cb);
  return it == dev.commandBuffers.end() ? nullptr : it->second.get();
}

namespace {

// ---------------------------------------------------------------- instance

VKAPI_ATTR VkResult VKAPI_CALL CreateInstance(const VkInstanceCreateInfo* info, const VkAllocationCallbacks* alloc,
                                              VkInstance* instance) {
  auto* chain = static_cast<const VkLayerInstanceCreateInfo*>(info->pNext);
  while (chain != nullptr && !(chain->sType == VK_STRUCTURE_TYPE_LOADER_INSTANCE_CREATE_INFO &&
                               chain->function == VK_LAYER_LINK_INFO)) {
    chain = static_cast<const VkLayerInstanceCreateInfo*>(chain->pNext);
  }
  if (chain == nullptr) return VK_ERROR_INITIALIZATION_FAILED;
  PFN_vkGetInstanceProcAddr gipa = chain->u.pLayerInfo->pfnNextGetInstanceProcAddr;
  const_cast<VkLayerInstanceCreateInfo*>(chain)->u.pLayerInfo = chain->u.pLayerInfo->pNext;
  auto create = reinterpret_cast<PFN_vkCreateInstance>(gipa(VK_NULL_HANDLE, "vkCreateInstance"));

  // Counting needs Vulkan 1.1 (subgroup operations, SPIR-V 1.3): a 1.0
  // application gets a 1.1 instance, which changes nothing it can observe.
  VkApplicationInfo app = {VK_STRUCTURE_TYPE_APPLICATION_INFO};
  if (info->pApplicationInfo != nullptr) app = *info->pApplicationInfo;
  if (app.apiVersion < VK_API_VERSION_1_1) app.apiVersion = VK_API_VERSION_1_1;
  VkInstanceCreateInfo patched = *info;
  patched.pApplicationInfo = &app;
  VkResult result = create(&patched, alloc, instance);
  if (result != VK_SUCCESS) return result;

  auto state = std::make_unique<InstanceState>();
  state->instance = *instance;
  state->gipa = gipa;
  state->apiVersion = app.apiVersion;
  if (app.pApplicationName != nullptr) state->applicationName = app.pApplicationName;
  if (app.pEngineName != nullptr) state->engineName = app.pEngineName;
#define TALLY_LOAD(member, name) state->member = reinterpret_cast<decltype(state->member)>(gipa(*instance, name))
  TALLY_LOAD(destroyInstance, "vkDestroyInstance");
  TALLY_LOAD(getProperties, "vkGetPhysicalDeviceProperties");
  TALLY_LOAD(getProperties2, "vkGetPhysicalDeviceProperties2");
  TALLY_LOAD(getFeatures, "vkGetPhysicalDeviceFeatures");
  TALLY_LOAD(getFeatures2, "vkGetPhysicalDeviceFeatures2");
  TALLY_LOAD(getMemoryProperties, "vkGetPhysicalDeviceMemoryProperties");
  TALLY_LOAD(getQueueFamilies, "vkGetPhysicalDeviceQueueFamilyProperties");
#undef TALLY_LOAD
  std::lock_guard lock(g_mutex);
  g_instances[dispatchKey(*instance)] = std::move(state);
  return VK_SUCCESS;
}

VKAPI_ATTR void VKAPI_CALL DestroyInstance(VkInstance instance, const VkAllocationCallbacks* alloc) {
  if (instance == VK_NULL_HANDLE) return;
  std::unique_ptr<InstanceState> state;
  {
    std::lock_guard lock(g_mutex);
    auto it = g_instances.find(dispatchKey(instance));
    if (it == g_instances.end()) return;
    state = std::move(it->second);
    g_instances.erase(it);
  }
  state->destroyInstance(instance, alloc);
}

// ---------------------------------------------------------------- device

// The next layer's device functions, and the names a 1.2 device offers
// some of them under.
void loadDispatch(DeviceState* dev, PFN_vkGetInstanceProcAddr gipa, PFN_vkGetDeviceProcAddr gdpa) {
  const VkDevice device = dev->device;
  const InstanceState* inst = dev->instance;
#define TALLY_LAYER_LOAD(name) dev->d.name = reinterpret_cast<PFN_vk##name>(gdpa(device, "vk" #name));
  TALLY_LAYER_DEVICE_FUNCTIONS(TALLY_LAYER_LOAD)
  TALLY_LAYER_DYNAMIC_STATE_FUNCTIONS(TALLY_LAYER_LOAD)
#undef TALLY_LAYER_LOAD
  // Dynamic rendering and submit2 under their extension names on 1.2 devices.
  if (dev->d.CmdBeginRendering == nullptr) {
    dev->d.CmdBeginRendering = reinterpret_cast<PFN_vkCmdBeginRendering>(gdpa(device, "vkCmdBeginRenderingKHR"));
    dev->d.CmdEndRendering = reinterpret_cast<PFN_vkCmdEndRendering>(gdpa(device, "vkCmdEndRenderingKHR"));
  }
  if (dev->d.CmdBindVertexBuffers2 == nullptr) {
    dev->d.CmdBindVertexBuffers2 =
        reinterpret_cast<PFN_vkCmdBindVertexBuffers2>(gdpa(device, "vkCmdBindVertexBuffers2EXT"));
  }
  if (dev->d.CmdSetRasterizerDiscardEnable == nullptr) {
    dev->d.CmdSetRasterizerDiscardEnable = reinterpret_cast<PFN_vkCmdSetRasterizerDiscardEnable>(
        gdpa(device, "vkCmdSetRasterizerDiscardEnableEXT"));
  }
  if (dev->d.QueueSubmit2 == nullptr) {
    dev->d.QueueSubmit2 = reinterpret_cast<PFN_vkQueueSubmit2>(gdpa(device, "vkQueueSubmit2KHR"));
  }
  // VK_EXT_debug_utils is an instance extension: the loader fills a device's
  // entries for its commands through vkGetInstanceProcAddr, and the layer below
  // may answer only there (validation does when the application did not enable
  // the extension, and reports each call). The layer calls what the loader would.
#define TALLY_LAYER_FROM_INSTANCE(name)                                                              \
  if (dev->d.name == nullptr) {                                                                      \
    dev->d.name = reinterpret_cast<PFN_vk##name>(gipa(inst->instance, "vk" #name));                  \
  }
  TALLY_LAYER_FROM_INSTANCE(SetDebugUtilsObjectNameEXT)
  TALLY_LAYER_FROM_INSTANCE(CmdBeginDebugUtilsLabelEXT)
  TALLY_LAYER_FROM_INSTANCE(CmdEndDebugUtilsLabelEXT)
#undef TALLY_LAYER_FROM_INSTANCE
}

// What the layer needs to know of the device: its properties, memory,
// queue families, the features it enabled and its driver.
void describeDevice(DeviceState* dev, const VkDeviceCreateInfo& info, const VkPhysicalDeviceFeatures& enabled) {
  const InstanceState* inst = dev->instance;
  VkPhysicalDevice physical = dev->physical;
  inst->getProperties(physical, &dev->properties);
  dev->instrumentOptions.target = validationTarget(info, inst->apiVersion, dev->properties.apiVersion);
  inst->getMemoryProperties(physical, &dev->memory);
  uint32_t familyCount = 0;
  inst->getQueueFamilies(physical, &familyCount, nullptr);
  dev->families.resize(familyCount);
  inst->getQueueFamilies(physical, &familyCount, dev->families.data());
  dev->fragmentStores = enabled.fragmentStoresAndAtomics;
  dev->vertexStores = enabled.vertexPipelineStoresAndAtomics;
  dev->statistics = enabled.pipelineStatisticsQuery && dev->config.statistics;
  if (inst->getProperties2 != nullptr) {
    VkPhysicalDeviceDriverProperties driver = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES};
    VkPhysicalDeviceProperties2 props2 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, &driver};
    inst->getProperties2(physical, &props2);
    dev->driverInfo = std::string(driver.driverName) + " " + driver.driverInfo;
    dev->llvmpipe = driver.driverID == VK_DRIVER_ID_MESA_LLVMPIPE;
  }
}

// 64-bit counters where the device has 64-bit buffer atomics (Vulkan 1.2):
// one atomic add per count, as the built-in renderers do, instead of a pair
// of 32-bit adds whose carry needs the first add's result (on the H200 the
// full-screen passes' counters cost about twice as much so). Enabled in the
// application's own feature structure where it chains one, else in the
// layer's, chained first; the application's is restored after the call.
struct Int64Patch {
  VkPhysicalDeviceShaderAtomicInt64Features own = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SHADER_ATOMIC_INT64_FEATURES};
  VkBool32* field = nullptr;  // the application's shaderBufferInt64Atomics
  VkBool32 saved = VK_FALSE;
};

bool int64AtomicsSupported(const InstanceState& inst, VkPhysicalDevice physical) {
  if (inst.getFeatures2 == nullptr || inst.apiVersion < VK_API_VERSION_1_2) return false;
  VkPhysicalDeviceProperties properties{};
  inst.getProperties(physical, &properties);
  if (properties.apiVersion < VK_API_VERSION_1_2) return false;
  VkPhysicalDeviceShaderAtomicInt64Features atomics = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SHADER_ATOMIC_INT64_FEATURES};
  VkPhysicalDeviceFeatures2 features = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &atomics};
  inst.getFeatures2(physical, &features);
  return features.features.shaderInt64 && atomics.shaderBufferInt64Atomics;
}

void enableInt64Atomics(VkDeviceCreateInfo& patched, Int64Patch& patch) {
  for (auto* p = static_cast<VkBaseOutStructure*>(const_cast<void*>(patched.pNext)); p != nullptr; p = p->pNext) {
    if (p->sType == VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES) {
      patch.field = &reinterpret_cast<VkPhysicalDeviceVulkan12Features*>(p)->shaderBufferInt64Atomics;
    } else if (p->sType == VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SHADER_ATOMIC_INT64_FEATURES) {
      patch.field = &reinterpret_cast<VkPhysicalDeviceShaderAtomicInt64Features*>(p)->shaderBufferInt64Atomics;
    }
  }
  if (patch.field != nullptr) {
    patch.saved = *patch.field;
    *patch.field = VK_TRUE;
    return;
  }
  patch.own.shaderBufferInt64Atomics = VK_TRUE;
  patch.own.pNext = const_cast<void*>(patched.pNext);
  patched.pNext = &patch.own;
}

VKAPI_ATTR VkResult VKAPI_CALL CreateDevice(VkPhysicalDevice physical, const VkDeviceCreateInfo* info,
                                            const VkAllocationCallbacks* alloc, VkDevice* device) {
  InstanceState* inst = instanceOf(physical);
  if (inst == nullptr) return VK_ERROR_INITIALIZATION_FAILED;
  auto* link = static_cast<const VkLayerDeviceCreateInfo*>(info->pNext);
  while (link != nullptr && !(link->sType == VK_STRUCTURE_TYPE_LOADER_DEVICE_CREATE_INFO &&
                              link->function == VK_LAYER_LINK_INFO)) {
    link = static_cast<const VkLayerDeviceCreateInfo*>(link->pNext);
  }
  if (link == nullptr) return VK_ERROR_INITIALIZATION_FAILED;
  PFN_vkGetInstanceProcAddr gipa = link->u.pLayerInfo->pfnNextGetInstanceProcAddr;
  PFN_vkGetDeviceProcAddr gdpa = link->u.pLayerInfo->pfnNextGetDeviceProcAddr;
  const_cast<VkLayerDeviceCreateInfo*>(link)->u.pLayerInfo = link->u.pLayerInfo->pNext;
  PFN_vkSetDeviceLoaderData setLoaderData = nullptr;
  for (auto* p = static_cast<const VkLayerDeviceCreateInfo*>(info->pNext); p != nullptr;
       p = static_cast<const VkLayerDeviceCreateInfo*>(p->pNext)) {
    if (p->sType == VK_STRUCTURE_TYPE_LOADER_DEVICE_CREATE_INFO && p->function == VK_LOADER_DATA_CALLBACK) {
      setLoaderData = p->u.pfnSetDeviceLoaderData;
    }
  }
  auto create = reinterpret_cast<PFN_vkCreateDevice>(gipa(inst->instance, "vkCreateDevice"));

  // The features counting needs, where the device has them: stores and
  // atomics in fragment and vertex stages, and pipeline statistics. Patched
  // in place for the call and restored after it; not at all where nothing
  // will be counted (no output asked for).
  Config config = Config::fromEnvironment();
  VkPhysicalDeviceFeatures supported{};
  if (!config.output.empty() && config.error.empty()) inst->getFeatures(physical, &supported);
  VkPhysicalDeviceFeatures* features = const_cast<VkPhysicalDeviceFeatures*>(info->pEnabledFeatures);
  for (auto* p = static_cast<VkBaseOutStructure*>(const_cast<void*>(info->pNext)); p != nullptr; p = p->pNext) {
    if (p->sType == VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2) {
      features = &reinterpret_cast<VkPhysicalDeviceFeatures2*>(p)->features;
    }
  }
  VkPhysicalDeviceFeatures own{};
  VkDeviceCreateInfo patched = *info;
  if (features == nullptr) {
    features = &own;
    patched.pEnabledFeatures = &own;
  }
  const VkPhysicalDeviceFeatures saved = *features;
  features->fragmentStoresAndAtomics |= supported.fragmentStoresAndAtomics;
  features->vertexPipelineStoresAndAtomics |= supported.vertexPipelineStoresAndAtomics;
  features->pipelineStatisticsQuery |= supported.pipelineStatisticsQuery;
  Int64Patch int64;
  const bool int64Atomics = !config.output.empty() && config.error.empty() && int64AtomicsSupported(*inst, physical);
  if (int64Atomics) {
    features->shaderInt64 = VK_TRUE;
    enableInt64Atomics(patched, int64);
  }
  const VkPhysicalDeviceFeatures enabled = *features;
  VkResult result = create(physical, &patched, alloc, device);
  if (features != &own) *features = saved;
  if (int64.field != nullptr) *int64.field = int64.saved;
  if (result != VK_SUCCESS) return result;

  auto dev = std::make_unique<DeviceState>();
  dev->device = *device;
  dev->physical = physical;
  dev->instance = inst;
  dev->setLoaderData = setLoaderData;
  dev->config = std::move(config);
  loadDispatch(dev.get(), gipa, gdpa);
  describeDevice(dev.get(), *info, enabled);
  dev->int64Atomics = int64Atomics;
  enableAddresses(*dev, *info);
  prepareDescriptorBuffers(*dev, *info);
  // A queue the application asked for, for the layer's own set-up work.
  VkQueue setupQueue = VK_NULL_HANDLE;
  uint32_t setupFamily = 0;
  for (uint32_t i = 0; i < info->queueCreateInfoCount && setupQueue == VK_NULL_HANDLE; ++i) {
    const auto& q = info->pQueueCreateInfos[i];
    if (q.flags != 0 || q.queueCount == 0) continue;  // protected queues come from vkGetDeviceQueue2 only
    if (!(dev->families[q.queueFamilyIndex].queueFlags & (VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT))) continue;
    dev->d.GetDeviceQueue(*device, q.queueFamilyIndex, 0, &setupQueue);
    setupFamily = q.queueFamilyIndex;
  }
  DeviceState* raw = dev.get();
  {
    std::lock_guard lock(g_mutex);
    g_devices[dispatchKey(*device)] = std::move(dev);
  }
  if (setupQueue != VK_NULL_HANDLE) {
    if (raw->setLoaderData != nullptr) raw->setLoaderData(*device, setupQueue);
    raw->queueFamilies[setupQueue] = setupFamily;
  }
  setupCounting(*raw);
  return VK_SUCCESS;
}

VKAPI_ATTR void VKAPI_CALL DestroyDevice(VkDevice device, const VkAllocationCallbacks* alloc) {
  if (device == VK_NULL_HANDLE) return;
  DeviceState* dev = deviceOf(device);
  if (dev == nullptr) return;
  dev->d.DeviceWaitIdle(device);
  {
    std::lock_guard lock(dev->mutex);
    finish(*dev, false);
    destroyShaderObjects(*dev);
    destroyCounting(*dev);
  }
  PFN_vkDestroyDevice destroy = dev->d.DestroyDevice;
  {
    std::lock_guard lock(g_mutex);
    g_devices.erase(dispatchKey(device));
  }
  destroy(device, alloc);
}

VKAPI_ATTR void VKAPI_CALL GetDeviceQueue(VkDevice device, uint32_t family, uint32_t index, VkQueue* queue) {
  DeviceState* dev = deviceOf(device);
  dev->d.GetDeviceQueue(device, family, index, queue);
  std::lock_guard lock(dev->mutex);
  dev->queueFamilies[*queue] = family;
}

VKAPI_ATTR void VKAPI_CALL GetDeviceQueue2(VkDevice device, const VkDeviceQueueInfo2* info, VkQueue* queue) {
  DeviceState* dev = deviceOf(device);
  dev->d.GetDeviceQueue2(device, info, queue);
  std::lock_guard lock(dev->mutex);
  dev->queueFamilies[*queue] = info->queueFamilyIndex;
}


// ---------------------------------------------------------------- submission and frames

std::vector<VkCommandBuffer> collectBuffers(uint32_t count, const VkSubmitInfo* submits) {
  std::vector<VkCommandBuffer> out;
  for (uint32_t i = 0; i < count; ++i) {
    out.insert(out.end(), submits[i].pCommandBuffers, submits[i].pCommandBuffers + submits[i].commandBufferCount);
  }
  return out;
}

// A submission without a fence of its own carries the readback in its last
// batch, with the readback's fence: one submission where there were two, for
// applications that never pass a fence (zink waits on timeline semaphores).
// The batch's signal semaphores then signal after the readback's copies, a
// few microseconds later. A batch whose extensions count its command buffers
// (device groups) or that is protected keeps the readback to itself.
bool readbackRides(VkFence fence, uint32_t count, const void* next) {
  if (fence != VK_NULL_HANDLE || count == 0) return false;
  for (auto* s = static_cast<const VkBaseInStructure*>(next); s != nullptr; s = s->pNext) {
    if (s->sType != VK_STRUCTURE_TYPE_TIMELINE_SEMAPHORE_SUBMIT_INFO) return false;
  }
  return true;
}

VKAPI_ATTR VkResult VKAPI_CALL QueueSubmit(VkQueue queue, uint32_t count, const VkSubmitInfo* submits, VkFence fence) {
  DeviceState* dev = deviceOf(queue);
  if (dev->addresses.enabled) {
    std::lock_guard lock(dev->mutex);
    uploadAddresses(*dev, queue);
  }
  if (dev->counting && readbackRides(fence, count, submits[count - 1].pNext)) {
    std::lock_guard lock(dev->mutex);
    PreparedSubmit prepared = prepareSubmit(*dev, queue, collectBuffers(count, submits));
    if (prepared.readback == nullptr) {
      VkResult result = dev->d.QueueSubmit(queue, count, submits, fence);
      if (result == VK_SUCCESS) finishSubmit(*dev, queue, prepared, VK_SUCCESS);
      return result;
    }
    std::vector<VkSubmitInfo> batches(submits, submits + count);
    VkSubmitInfo& last = batches.back();
    std::vector<VkCommandBuffer> buffers(last.pCommandBuffers, last.pCommandBuffers + last.commandBufferCount);
    buffers.push_back(prepared.readback->cmd);
    last.commandBufferCount = uint32_t(buffers.size());
    last.pCommandBuffers = buffers.data();
    VkResult result = dev->d.QueueSubmit(queue, count, batches.data(), prepared.readback->fence);
    finishSubmit(*dev, queue, prepared, result == VK_SUCCESS ? VK_SUCCESS : VK_ERROR_UNKNOWN);
    return result;
  }
  VkResult result = dev->d.QueueSubmit(queue, count, submits, fence);
  if (result != VK_SUCCESS) return result;
  std::lock_guard lock(dev->mutex);
  afterSubmit(*dev, queue, collectBuffers(count, submits));
  return result;
}

VKAPI_ATTR VkResult VKAPI_CALL QueueSubmit2(VkQueue queue, uint32_t count, const VkSubmitInfo2* submits, VkFence fence) {
  DeviceState* dev = deviceOf(queue);
  if (dev->addresses.enabled) {
    std::lock_guard lock(dev->mutex);
    uploadAddresses(*dev, queue);
  }
  std::vector<VkCommandBuffer> buffers;
  for (uint32_t i = 0; i < count; ++i) {
    for (uint32_t c = 0; c < submits[i].commandBufferInfoCount; ++c) {
      buffers.push_back(submits[i].pCommandBufferInfos[c].commandBuffer);
    }
  }
  // VkSubmitInfo2 carries timeline values in its semaphore infos; a
  // protected batch (flags) keeps the readback to itself.
  if (dev->counting && readbackRides(fence, count, submits[count - 1].pNext) && submits[count - 1].flags == 0) {
    std::lock_guard lock(dev->mutex);
    PreparedSubmit prepared = prepareSubmit(*dev, queue, buffers);
    if (prepared.readback == nullptr) {
      VkResult result = dev->d.QueueSubmit2(queue, count, submits, fence);
      if (result == VK_SUCCESS) finishSubmit(*dev, queue, prepared, VK_SUCCESS);
      return result;
    }
    std::vector<VkSubmitInfo2> batches(submits, submits + count);
    VkSubmitInfo2& last = batches.back();
    std::vector<VkCommandBufferSubmitInfo> infos(last.pCommandBufferInfos, last.pCommandBufferInfos + last.commandBufferInfoCount);
    infos.push_back({VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO, nullptr, prepared.readback->cmd, 0});
    last.commandBufferInfoCount = uint32_t(infos.size());
    last.pCommandBufferInfos = infos.data();
    VkResult result = dev->d.QueueSubmit2(queue, count, batches.data(), prepared.readback->fence);
    finishSubmit(*dev, queue, prepared, result == VK_SUCCESS ? VK_SUCCESS : VK_ERROR_UNKNOWN);
    return result;
  }
  VkResult result = dev->d.QueueSubmit2(queue, count, submits, fence);
  if (result != VK_SUCCESS) return result;
  std::lock_guard lock(dev->mutex);
  afterSubmit(*dev, queue, buffers);
  return result;
}

VKAPI_ATTR VkResult VKAPI_CALL QueuePresentKHR(VkQueue queue, const VkPresentInfoKHR* info) {
  DeviceState* dev = deviceOf(queue);
  VkResult result = dev->d.QueuePresentKHR(queue, info);
  std::lock_guard lock(dev->mutex);
  if (dev->config.frameSubmits == 0) endFrame(*dev);
  return result;
}

// After the application waits for the device or a queue, the readbacks
// submitted before are done: read them now. An application that exits
// without vkDestroyDevice then still gets its output once the window's
// frames are read.
VKAPI_ATTR VkResult VKAPI_CALL DeviceWaitIdle(VkDevice device) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.DeviceWaitIdle(device);
  std::lock_guard lock(dev->mutex);
  afterIdle(*dev);
  return result;
}

VKAPI_ATTR VkResult VKAPI_CALL QueueWaitIdle(VkQueue queue) {
  DeviceState* dev = deviceOf(queue);
  VkResult result = dev->d.QueueWaitIdle(queue);
  std::lock_guard lock(dev->mutex);
  afterIdle(*dev);
  return result;
}

// ---------------------------------------------------------------- loader interface

constexpr const char* kLayerName = "VK_LAYER_TALLY_counters";

VKAPI_ATTR VkResult VKAPI_CALL EnumerateInstanceLayerProperties(uint32_t* count, VkLayerProperties* properties) {
  if (properties == nullptr) {
    *count = 1;
    return VK_SUCCESS;
  }
  if (*count < 1) return VK_INCOMPLETE;
  std::memset(properties, 0, sizeof *properties);
  std::snprintf(properties->layerName, sizeof properties->layerName, "%s", kLayerName);
  std::snprintf(properties->description, sizeof properties->description, "%s",
                "Tally: per-pass, per-resource memory traffic of any application");
  properties->implementationVersion = 1;
  properties->specVersion = VK_HEADER_VERSION_COMPLETE;
  *count = 1;
  return VK_SUCCESS;
}

VKAPI_ATTR VkResult VKAPI_CALL EnumerateInstanceExtensionProperties(const char* layer, uint32_t* count,
                                                                    VkExtensionProperties*) {
  if (layer == nullptr || std::strcmp(layer, kLayerName) != 0) return VK_ERROR_LAYER_NOT_PRESENT;
  *count = 0;
  return VK_SUCCESS;
}

PFN_vkVoidFunction interceptedDevice(std::string_view name);

VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL GetDeviceProcAddr(VkDevice device, const char* name) {
  if (PFN_vkVoidFunction f = interceptedDevice(name)) {
    // Functions the device does not have stay null.
    DeviceState* dev = deviceOf(device);
    if (dev != nullptr && dev->d.GetDeviceProcAddr(device, name) == nullptr) return nullptr;
    // A device that counts nothing (no output asked for) calls below the
    // layer directly; the layer keeps only its end, to write the output.
    const std::string_view n = name;
    if (dev != nullptr && !dev->counting && n != "vkGetDeviceProcAddr" && n != "vkDestroyDevice") {
      return dev->d.GetDeviceProcAddr(device, name);
    }
    return f;
  }
  DeviceState* dev = deviceOf(device);
  return dev == nullptr ? nullptr : dev->d.GetDeviceProcAddr(device, name);
}

VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL GetInstanceProcAddr(VkInstance instance, const char* name) {
  const std::string_view n = name;
#define TALLY_INSTANCE(fn) \
  if (n == "vk" #fn) return reinterpret_cast<PFN_vkVoidFunction>(fn);
  TALLY_INSTANCE(CreateInstance)
  TALLY_INSTANCE(DestroyInstance)
  TALLY_INSTANCE(CreateDevice)
  TALLY_INSTANCE(GetInstanceProcAddr)
  TALLY_INSTANCE(GetDeviceProcAddr)
  TALLY_INSTANCE(EnumerateInstanceLayerProperties)
  TALLY_INSTANCE(EnumerateInstanceExtensionProperties)
#undef TALLY_INSTANCE
  if (instance == VK_NULL_HANDLE) return nullptr;
  InstanceState* inst = instanceOf(instance);
  if (inst == nullptr) return nullptr;
  PFN_vkVoidFunction next = inst->gipa(instance, name);
  // A command the chain below does not offer stays null, as without the layer.
  if (PFN_vkVoidFunction f = interceptedDevice(n)) return next == nullptr ? nullptr : f;
  return next;
}

PFN_vkVoidFunction interceptedDevice(std::string_view name) {
  TALLY_INTERCEPT(GetDeviceProcAddr)
  TALLY_INTERCEPT(DestroyDevice)
  TALLY_INTERCEPT(DeviceWaitIdle)
  TALLY_INTERCEPT(QueueWaitIdle)
  TALLY_INTERCEPT(GetDeviceQueue)
  TALLY_INTERCEPT(GetDeviceQueue2)
  TALLY_INTERCEPT(QueueSubmit)
  TALLY_INTERCEPT(QueueSubmit2)
  TALLY_INTERCEPT_ALIAS(QueueSubmit2KHR, QueueSubmit2)
  TALLY_INTERCEPT(QueuePresentKHR)
  for (auto intercepted : {interceptedResources, interceptedDescriptors, interceptedPipelines, interceptedCommands,
                           interceptedDraws, interceptedDynamicState, interceptedShaderObjects,
                           interceptedUncounted, interceptedAddresses, interceptedDescriptorBuffers}) {
    if (PFN_vkVoidFunction f = intercepted(name)) return f;
  }
  return nullptr;
}

}  // namespace

}  // namespace tally::layer

extern "C" {

__attribute__((visibility("default"))) VKAPI_ATTR VkResult VKAPI_CALL
vkNegotiateLoaderLayerInterfaceVersion(VkNegotiateLayerInterface* version) {
  if (version == nullptr || version->sType != LAYER_NEGOTIATE_INTERFACE_STRUCT) return VK_ERROR_INITIALIZATION_FAILED;
  if (version->loaderLayerInterfaceVersion > 2) version->loaderLayerInterfaceVersion = 2;
  version->pfnGetInstanceProcAddr = tally::layer::GetInstanceProcAddr;
  version->pfnGetDeviceProcAddr = tally::layer::GetDeviceProcAddr;
  version->pfnGetPhysicalDeviceProcAddr = nullptr;
  return VK_SUCCESS;
}

__attribute__((visibility("default"))) VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL
vkGetInstanceProcAddr(VkInstance instance, const char* name) {
  return tally::layer::GetInstanceProcAddr(instance, name);
}

__attribute__((visibility("default"))) VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL
vkGetDeviceProcAddr(VkDevice device, const char* name) {
  return tally::layer::GetDeviceProcAddr(device, name);
}

}  // extern "C"
