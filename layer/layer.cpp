// VK_LAYER_TALLY_counters: the loader interface and every intercepted call.
// What each call records, and how the counts are attributed, is described in
// docs/layer.md; capture.cpp holds the counter regions, the readback and the
// output.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string_view>
#include <utility>

#include "early_tests_twin.hpp"
#include "libraries.hpp"
#include "names.hpp"
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
CommandBufferState* cbState(DeviceState& dev, VkCommandBuffer cb) {
  auto it = dev.commandBuffers.find(cb);
  return it == dev.commandBuffers.end() ? nullptr : it->second.get();
}

void log(const std::string& line) { std::fprintf(stderr, "tally layer: %s\n", line.c_str()); }

}  // namespace

DeviceState* deviceOf(const void* handle) {
  std::lock_guard lock(g_mutex);
  auto it = g_devices.find(dispatchKey(handle));
  return it == g_devices.end() ? nullptr : it->second.get();
}
CommandBufferState* commandBufferOf(DeviceState& dev, VkCommandBuffer cb) { return cbState(dev, cb); }

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
  const VkPhysicalDeviceFeatures enabled = *features;
  VkResult result = create(physical, &patched, alloc, device);
  if (features != &own) *features = saved;
  if (result != VK_SUCCESS) return result;

  auto dev = std::make_unique<DeviceState>();
  dev->device = *device;
  dev->physical = physical;
  dev->instance = inst;
  dev->setLoaderData = setLoaderData;
  dev->config = std::move(config);
#define TALLY_LAYER_LOAD(name) dev->d.name = reinterpret_cast<PFN_vk##name>(gdpa(*device, "vk" #name));
  TALLY_LAYER_DEVICE_FUNCTIONS(TALLY_LAYER_LOAD)
  TALLY_LAYER_DYNAMIC_STATE_FUNCTIONS(TALLY_LAYER_LOAD)
#undef TALLY_LAYER_LOAD
  // Dynamic rendering and submit2 under their extension names on 1.2 devices.
  if (dev->d.CmdBeginRendering == nullptr) {
    dev->d.CmdBeginRendering = reinterpret_cast<PFN_vkCmdBeginRendering>(gdpa(*device, "vkCmdBeginRenderingKHR"));
    dev->d.CmdEndRendering = reinterpret_cast<PFN_vkCmdEndRendering>(gdpa(*device, "vkCmdEndRenderingKHR"));
  }
  if (dev->d.CmdBindVertexBuffers2 == nullptr) {
    dev->d.CmdBindVertexBuffers2 =
        reinterpret_cast<PFN_vkCmdBindVertexBuffers2>(gdpa(*device, "vkCmdBindVertexBuffers2EXT"));
  }
  if (dev->d.CmdSetRasterizerDiscardEnable == nullptr) {
    dev->d.CmdSetRasterizerDiscardEnable = reinterpret_cast<PFN_vkCmdSetRasterizerDiscardEnable>(
        gdpa(*device, "vkCmdSetRasterizerDiscardEnableEXT"));
  }
  if (dev->d.QueueSubmit2 == nullptr) {
    dev->d.QueueSubmit2 = reinterpret_cast<PFN_vkQueueSubmit2>(gdpa(*device, "vkQueueSubmit2KHR"));
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
  inst->getProperties(physical, &dev->properties);
  dev->instrumentOptions.target = validationTarget(*info, inst->apiVersion, dev->properties.apiVersion);
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

// ---------------------------------------------------------------- resources

VKAPI_ATTR VkResult VKAPI_CALL CreateImage(VkDevice device, const VkImageCreateInfo* info,
                                           const VkAllocationCallbacks* alloc, VkImage* image) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.CreateImage(device, info, alloc, image);
  if (result != VK_SUCCESS) return result;
  Resource r;
  r.handle = u64(*image);
  r.image = true;
  r.kind = (info->usage & VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT) ? Kind::Depth
           : (info->usage & VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT)       ? Kind::Attachment
                                                                        : Kind::Texture;
  r.imageUsage = info->usage;
  r.format = info->format;
  r.width = info->extent.width;
  r.height = info->extent.height;
  r.samples = info->samples;
  r.usage = imageUsageName(info->usage);
  VkMemoryRequirements req{};
  dev->d.GetImageMemoryRequirements(device, *image, &req);
  r.size = req.size;
  std::lock_guard lock(dev->mutex);
  dev->resources[r.handle] = r;
  return result;
}

VKAPI_ATTR VkResult VKAPI_CALL CreateBuffer(VkDevice device, const VkBufferCreateInfo* info,
                                            const VkAllocationCallbacks* alloc, VkBuffer* buffer) {
  DeviceState* dev = deviceOf(device);
  // Indirect parameters are copied after their draws (indirect.cpp).
  VkBufferCreateInfo patched = *info;
  if (dev->counting && (info->usage & VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT)) patched.usage |= VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
  VkResult result = dev->d.CreateBuffer(device, &patched, alloc, buffer);
  if (result != VK_SUCCESS) return result;
  Resource r;
  r.handle = u64(*buffer);
  r.size = info->size;
  r.usage = bufferUsageName(info->usage);
  std::lock_guard lock(dev->mutex);
  dev->resources[r.handle] = r;
  return result;
}

VKAPI_ATTR VkResult VKAPI_CALL CreateImageView(VkDevice device, const VkImageViewCreateInfo* info,
                                               const VkAllocationCallbacks* alloc, VkImageView* view) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.CreateImageView(device, info, alloc, view);
  if (result != VK_SUCCESS) return result;
  std::lock_guard lock(dev->mutex);
  dev->views[u64(*view)] = {u64(info->image), info->format, info->subresourceRange.aspectMask};
  return result;
}

VKAPI_ATTR VkResult VKAPI_CALL CreateBufferView(VkDevice device, const VkBufferViewCreateInfo* info,
                                                const VkAllocationCallbacks* alloc, VkBufferView* view) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.CreateBufferView(device, info, alloc, view);
  if (result != VK_SUCCESS) return result;
  std::lock_guard lock(dev->mutex);
  dev->bufferViews[u64(*view)] = u64(info->buffer);
  return result;
}

// What the layer forgets of destroyed objects (lifetimes.cpp): views and
// framebuffers at once (a recorded draw keeps what it resolved), resources
// once no readback can name them.
template <class Handle, class Forget, class CallDown>
void destroyObject(VkDevice device, Handle handle, Forget forget, CallDown callDown) {
  DeviceState* dev = deviceOf(device);
  if (handle != VK_NULL_HANDLE) {
    std::lock_guard lock(dev->mutex);
    forget(*dev, u64(handle));
  }
  callDown(*dev);
}

VKAPI_ATTR void VKAPI_CALL DestroyImage(VkDevice device, VkImage image, const VkAllocationCallbacks* alloc) {
  destroyObject(device, image, retireResource, [&](DeviceState& dev) { dev.d.DestroyImage(device, image, alloc); });
}
VKAPI_ATTR void VKAPI_CALL DestroyBuffer(VkDevice device, VkBuffer buffer, const VkAllocationCallbacks* alloc) {
  destroyObject(device, buffer, retireResource, [&](DeviceState& dev) { dev.d.DestroyBuffer(device, buffer, alloc); });
}
VKAPI_ATTR void VKAPI_CALL DestroyImageView(VkDevice device, VkImageView view, const VkAllocationCallbacks* alloc) {
  destroyObject(device, view, [](DeviceState& dev, uint64_t h) { dev.views.erase(h); },
                [&](DeviceState& dev) { dev.d.DestroyImageView(device, view, alloc); });
}
VKAPI_ATTR void VKAPI_CALL DestroyBufferView(VkDevice device, VkBufferView view, const VkAllocationCallbacks* alloc) {
  destroyObject(device, view, [](DeviceState& dev, uint64_t h) { dev.bufferViews.erase(h); },
                [&](DeviceState& dev) { dev.d.DestroyBufferView(device, view, alloc); });
}
VKAPI_ATTR void VKAPI_CALL DestroyFramebuffer(VkDevice device, VkFramebuffer framebuffer,
                                              const VkAllocationCallbacks* alloc) {
  destroyObject(device, framebuffer, [](DeviceState& dev, uint64_t h) { dev.framebuffers.erase(h); },
                [&](DeviceState& dev) { dev.d.DestroyFramebuffer(device, framebuffer, alloc); });
}

VKAPI_ATTR VkResult VKAPI_CALL SetDebugUtilsObjectNameEXT(VkDevice device, const VkDebugUtilsObjectNameInfoEXT* info) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.SetDebugUtilsObjectNameEXT != nullptr ? dev->d.SetDebugUtilsObjectNameEXT(device, info)
                                                                  : VK_SUCCESS;
  std::lock_guard lock(dev->mutex);
  const std::string name = info->pObjectName != nullptr ? info->pObjectName : "";
  if (auto it = dev->resources.find(info->objectHandle); it != dev->resources.end()) it->second.name = name;
  if (auto it = dev->shaders.find(info->objectHandle); it != dev->shaders.end()) it->second.name = name;
  return result;
}

VKAPI_ATTR VkResult VKAPI_CALL CreateSwapchainKHR(VkDevice device, const VkSwapchainCreateInfoKHR* info,
                                                  const VkAllocationCallbacks* alloc, VkSwapchainKHR* swapchain) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.CreateSwapchainKHR(device, info, alloc, swapchain);
  if (result != VK_SUCCESS) return result;
  std::lock_guard lock(dev->mutex);
  dev->swapchains[u64(*swapchain)] = {info->imageFormat, info->imageExtent};
  dev->extent = info->imageExtent;
  return result;
}

VKAPI_ATTR VkResult VKAPI_CALL GetSwapchainImagesKHR(VkDevice device, VkSwapchainKHR swapchain, uint32_t* count,
                                                     VkImage* images) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.GetSwapchainImagesKHR(device, swapchain, count, images);
  if (images == nullptr || (result != VK_SUCCESS && result != VK_INCOMPLETE)) return result;
  std::lock_guard lock(dev->mutex);
  auto [format, extent] = dev->swapchains[u64(swapchain)];
  for (uint32_t i = 0; i < *count; ++i) {
    Resource r;
    r.handle = u64(images[i]);
    r.image = true;
    r.kind = Kind::Attachment;
    r.format = format;
    r.width = extent.width;
    r.height = extent.height;
    r.size = uint64_t(extent.width) * extent.height * formatBytes(format);
    r.usage = "swapchain";
    r.name = "swapchain";  // every image of the chain is one line
    dev->resources[r.handle] = r;
  }
  return result;
}

// ---------------------------------------------------------------- render passes

// Each subpass's colour attachment references (their Locations' attachments).
template <class Info>
std::vector<std::vector<uint32_t>> subpassColors(const Info& info) {
  std::vector<std::vector<uint32_t>> subpasses;
  for (uint32_t s = 0; s < info.subpassCount; ++s) {
    std::vector<uint32_t> colors;
    for (uint32_t c = 0; c < info.pSubpasses[s].colorAttachmentCount; ++c) {
      colors.push_back(info.pSubpasses[s].pColorAttachments[c].attachment);
    }
    subpasses.push_back(std::move(colors));
  }
  return subpasses;
}

void recordRenderPass(DeviceState& dev, VkRenderPass pass, std::vector<std::vector<uint32_t>> subpasses,
                      std::vector<uint32_t> viewMasks) {
  std::lock_guard lock(dev.mutex);
  dev.renderPasses[u64(pass)] = std::move(subpasses);
  dev.subpassViewMasks.erase(u64(pass));  // a later render pass may reuse the handle
  if (!viewMasks.empty()) dev.subpassViewMasks[u64(pass)] = std::move(viewMasks);
}

VKAPI_ATTR VkResult VKAPI_CALL CreateRenderPass(VkDevice device, const VkRenderPassCreateInfo* info,
                                                const VkAllocationCallbacks* alloc, VkRenderPass* pass) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.CreateRenderPass(device, info, alloc, pass);
  if (result != VK_SUCCESS) return result;
  std::vector<uint32_t> viewMasks;
  for (auto* p = static_cast<const VkBaseInStructure*>(info->pNext); p != nullptr; p = p->pNext) {
    if (p->sType != VK_STRUCTURE_TYPE_RENDER_PASS_MULTIVIEW_CREATE_INFO) continue;
    const auto* multiview = reinterpret_cast<const VkRenderPassMultiviewCreateInfo*>(p);
    viewMasks.assign(multiview->pViewMasks, multiview->pViewMasks + multiview->subpassCount);
  }
  recordRenderPass(*dev, *pass, subpassColors(*info), std::move(viewMasks));
  return result;
}

VKAPI_ATTR VkResult VKAPI_CALL CreateRenderPass2(VkDevice device, const VkRenderPassCreateInfo2* info,
                                                 const VkAllocationCallbacks* alloc, VkRenderPass* pass) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.CreateRenderPass2(device, info, alloc, pass);
  if (result != VK_SUCCESS) return result;
  std::vector<uint32_t> viewMasks;
  for (uint32_t s = 0; s < info->subpassCount; ++s) viewMasks.push_back(info->pSubpasses[s].viewMask);
  recordRenderPass(*dev, *pass, subpassColors(*info), std::move(viewMasks));
  return result;
}

VKAPI_ATTR VkResult VKAPI_CALL CreateFramebuffer(VkDevice device, const VkFramebufferCreateInfo* info,
                                                 const VkAllocationCallbacks* alloc, VkFramebuffer* framebuffer) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.CreateFramebuffer(device, info, alloc, framebuffer);
  if (result != VK_SUCCESS) return result;
  std::vector<uint64_t> views;
  if (!(info->flags & VK_FRAMEBUFFER_CREATE_IMAGELESS_BIT)) {
    for (uint32_t i = 0; i < info->attachmentCount; ++i) views.push_back(u64(info->pAttachments[i]));
  }
  std::lock_guard lock(dev->mutex);
  dev->framebuffers[u64(*framebuffer)] = std::move(views);
  return result;
}

// ---------------------------------------------------------------- descriptors

VKAPI_ATTR VkResult VKAPI_CALL AllocateDescriptorSets(VkDevice device, const VkDescriptorSetAllocateInfo* info,
                                                      VkDescriptorSet* sets) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.AllocateDescriptorSets(device, info, sets);
  if (result != VK_SUCCESS) return result;
  std::lock_guard lock(dev->mutex);
  for (uint32_t i = 0; i < info->descriptorSetCount; ++i) {
    dev->sets[u64(sets[i])] = DescriptorSetState{};
    dev->poolSets[u64(info->descriptorPool)].insert(u64(sets[i]));
  }
  return result;
}

VKAPI_ATTR VkResult VKAPI_CALL FreeDescriptorSets(VkDevice device, VkDescriptorPool pool, uint32_t count,
                                                  const VkDescriptorSet* sets) {
  DeviceState* dev = deviceOf(device);
  {
    std::lock_guard lock(dev->mutex);
    for (uint32_t i = 0; i < count; ++i) {
      dev->sets.erase(u64(sets[i]));
      dev->poolSets[u64(pool)].erase(u64(sets[i]));
    }
  }
  return dev->d.FreeDescriptorSets(device, pool, count, sets);
}

void forgetPoolSets(DeviceState& dev, VkDescriptorPool pool) {
  std::lock_guard lock(dev.mutex);
  for (uint64_t s : dev.poolSets[u64(pool)]) dev.sets.erase(s);
  dev.poolSets.erase(u64(pool));
}

VKAPI_ATTR VkResult VKAPI_CALL ResetDescriptorPool(VkDevice device, VkDescriptorPool pool,
                                                   VkDescriptorPoolResetFlags flags) {
  DeviceState* dev = deviceOf(device);
  forgetPoolSets(*dev, pool);
  return dev->d.ResetDescriptorPool(device, pool, flags);
}

VKAPI_ATTR void VKAPI_CALL DestroyDescriptorPool(VkDevice device, VkDescriptorPool pool,
                                                 const VkAllocationCallbacks* alloc) {
  DeviceState* dev = deviceOf(device);
  forgetPoolSets(*dev, pool);
  dev->d.DestroyDescriptorPool(device, pool, alloc);
}

// What one descriptor of `type` refers to.
Bound boundImage(DeviceState& dev, VkImageView view) {
  auto it = dev.views.find(u64(view));
  if (it == dev.views.end()) return {};
  return {it->second.image, it->second.format, it->second.aspect};
}
Bound boundOf(DeviceState& dev, VkDescriptorType type, const void* element) {
  switch (type) {
    case VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER:
    case VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE:
    case VK_DESCRIPTOR_TYPE_STORAGE_IMAGE:
    case VK_DESCRIPTOR_TYPE_INPUT_ATTACHMENT:
      return boundImage(dev, static_cast<const VkDescriptorImageInfo*>(element)->imageView);
    case VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER:
    case VK_DESCRIPTOR_TYPE_STORAGE_BUFFER:
    case VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER_DYNAMIC:
    case VK_DESCRIPTOR_TYPE_STORAGE_BUFFER_DYNAMIC:
      return {u64(static_cast<const VkDescriptorBufferInfo*>(element)->buffer)};
    case VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER:
    case VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER: {
      auto it = dev.bufferViews.find(u64(*static_cast<const VkBufferView*>(element)));
      return {it == dev.bufferViews.end() ? 0 : it->second};
    }
    default: return {};  // samplers, inline uniform blocks, acceleration structures
  }
}

void writeElement(DescriptorSetState& set, uint32_t binding, uint32_t element, Bound bound) {
  auto& elements = set.bindings[binding];
  if (elements.size() <= element) elements.resize(element + 1);
  elements[element] = bound;
}

// One write of vkUpdateDescriptorSets or vkCmdPushDescriptorSetKHR.
void applyWrite(DeviceState& dev, DescriptorSetState& set, const VkWriteDescriptorSet& write) {
  for (uint32_t i = 0; i < write.descriptorCount; ++i) {
    const void* element = nullptr;
    if (write.pImageInfo != nullptr &&
        (write.descriptorType == VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER ||
         write.descriptorType == VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE ||
         write.descriptorType == VK_DESCRIPTOR_TYPE_STORAGE_IMAGE ||
         write.descriptorType == VK_DESCRIPTOR_TYPE_INPUT_ATTACHMENT)) {
      element = &write.pImageInfo[i];
    } else if (write.pBufferInfo != nullptr &&
               (write.descriptorType == VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER ||
                write.descriptorType == VK_DESCRIPTOR_TYPE_STORAGE_BUFFER ||
                write.descriptorType == VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER_DYNAMIC ||
                write.descriptorType == VK_DESCRIPTOR_TYPE_STORAGE_BUFFER_DYNAMIC)) {
      element = &write.pBufferInfo[i];
    } else if (write.pTexelBufferView != nullptr &&
               (write.descriptorType == VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER ||
                write.descriptorType == VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER)) {
      element = &write.pTexelBufferView[i];
    }
    if (element == nullptr) continue;
    writeElement(set, write.dstBinding, write.dstArrayElement + i, boundOf(dev, write.descriptorType, element));
  }
}

// A descriptor update template's entries applied to `data`.
void applyTemplate(DeviceState& dev, DescriptorSetState& set, const std::vector<VkDescriptorUpdateTemplateEntry>& entries,
                   const void* data) {
  for (const auto& entry : entries) {
    if (entry.descriptorType == VK_DESCRIPTOR_TYPE_INLINE_UNIFORM_BLOCK) continue;
    for (uint32_t i = 0; i < entry.descriptorCount; ++i) {
      const void* element = static_cast<const uint8_t*>(data) + entry.offset + size_t(i) * entry.stride;
      writeElement(set, entry.dstBinding, entry.dstArrayElement + i, boundOf(dev, entry.descriptorType, element));
    }
  }
}

VKAPI_ATTR void VKAPI_CALL UpdateDescriptorSets(VkDevice device, uint32_t writeCount, const VkWriteDescriptorSet* writes,
                                                uint32_t copyCount, const VkCopyDescriptorSet* copies) {
  DeviceState* dev = deviceOf(device);
  {
    std::lock_guard lock(dev->mutex);
    for (uint32_t w = 0; w < writeCount; ++w) {
      auto it = dev->sets.find(u64(writes[w].dstSet));
      if (it != dev->sets.end()) applyWrite(*dev, it->second, writes[w]);
    }
    for (uint32_t c = 0; c < copyCount; ++c) {
      const auto& copy = copies[c];
      auto src = dev->sets.find(u64(copy.srcSet));
      auto dst = dev->sets.find(u64(copy.dstSet));
      if (src == dev->sets.end() || dst == dev->sets.end()) continue;
      const auto& from = src->second.bindings[copy.srcBinding];
      for (uint32_t i = 0; i < copy.descriptorCount; ++i) {
        uint32_t e = copy.srcArrayElement + i;
        writeElement(dst->second, copy.dstBinding, copy.dstArrayElement + i, e < from.size() ? from[e] : Bound{});
      }
    }
  }
  dev->d.UpdateDescriptorSets(device, writeCount, writes, copyCount, copies);
}

VKAPI_ATTR VkResult VKAPI_CALL CreateDescriptorUpdateTemplate(VkDevice device,
                                                              const VkDescriptorUpdateTemplateCreateInfo* info,
                                                              const VkAllocationCallbacks* alloc,
                                                              VkDescriptorUpdateTemplate* handle) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.CreateDescriptorUpdateTemplate(device, info, alloc, handle);
  if (result != VK_SUCCESS) return result;
  std::lock_guard lock(dev->mutex);
  if (info->templateType == VK_DESCRIPTOR_UPDATE_TEMPLATE_TYPE_DESCRIPTOR_SET) {
    dev->templates[u64(*handle)].assign(info->pDescriptorUpdateEntries,
                                         info->pDescriptorUpdateEntries + info->descriptorUpdateEntryCount);
  } else if (info->templateType == VK_DESCRIPTOR_UPDATE_TEMPLATE_TYPE_PUSH_DESCRIPTORS_KHR) {
    dev->pushTemplates[u64(*handle)] = {info->pipelineBindPoint,
                                        {info->pDescriptorUpdateEntries,
                                         info->pDescriptorUpdateEntries + info->descriptorUpdateEntryCount}};
  }
  return result;
}

VKAPI_ATTR void VKAPI_CALL UpdateDescriptorSetWithTemplate(VkDevice device, VkDescriptorSet set,
                                                           VkDescriptorUpdateTemplate handle, const void* data) {
  DeviceState* dev = deviceOf(device);
  {
    std::lock_guard lock(dev->mutex);
    auto t = dev->templates.find(u64(handle));
    auto s = dev->sets.find(u64(set));
    if (t != dev->templates.end() && s != dev->sets.end()) applyTemplate(*dev, s->second, t->second, data);
  }
  dev->d.UpdateDescriptorSetWithTemplate(device, set, handle, data);
}

// ---------------------------------------------------------------- shaders and pipelines

VKAPI_ATTR VkResult VKAPI_CALL CreateShaderModule(VkDevice device, const VkShaderModuleCreateInfo* info,
                                                  const VkAllocationCallbacks* alloc, VkShaderModule* module) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.CreateShaderModule(device, info, alloc, module);
  if (result != VK_SUCCESS) return result;
  std::lock_guard lock(dev->mutex);
  ShaderInfo shader;
  shader.words.assign(info->pCode, info->pCode + info->codeSize / 4);
  dev->shaders[u64(*module)] = std::move(shader);
  return result;
}

VKAPI_ATTR void VKAPI_CALL DestroyShaderModule(VkDevice device, VkShaderModule module,
                                               const VkAllocationCallbacks* alloc) {
  DeviceState* dev = deviceOf(device);
  {
    std::lock_guard lock(dev->mutex);
    dev->shaders.erase(u64(module));
  }
  dev->d.DestroyShaderModule(device, module, alloc);
}

VKAPI_ATTR VkResult VKAPI_CALL CreatePipelineLayout(VkDevice device, const VkPipelineLayoutCreateInfo* info,
                                                    const VkAllocationCallbacks* alloc, VkPipelineLayout* layout) {
  DeviceState* dev = deviceOf(device);
  std::vector<VkDescriptorSetLayout> sets;
  {
    std::lock_guard lock(dev->mutex);
    const std::string uncounted = layoutRefusal(*dev, *info);
    if (!uncounted.empty()) {
      if (dev->notes.insert(uncounted).second) log(uncounted);
      ++dev->layoutsRefused;
    } else if (dev->counting && info->setLayoutCount <= dev->counterSet) {
      sets.assign(info->pSetLayouts, info->pSetLayouts + info->setLayoutCount);
      sets.resize(dev->counterSet, dev->emptySetLayout);
      sets.push_back(dev->counterSetLayout);
    } else if (dev->counting) {
      const std::string refused = "a pipeline layout uses " + std::to_string(info->setLayoutCount) +
                                  " descriptor sets; the device allows " +
                                  std::to_string(dev->properties.limits.maxBoundDescriptorSets) +
                                  " and the layer needs set " + std::to_string(dev->counterSet) +
                                  ": its pipelines run unchanged, uncounted";
      dev->notes.insert(refused);
      ++dev->layoutsRefused;
      log(refused);
    }
  }
  if (sets.empty()) return dev->d.CreatePipelineLayout(device, info, alloc, layout);
  VkPipelineLayoutCreateInfo extended = *info;
  extended.setLayoutCount = uint32_t(sets.size());
  extended.pSetLayouts = sets.data();
  // Independent sets (graphics pipeline libraries): the application's
  // handle leaves the sets between null, as a library's layout may lack a set
  // another library of the same pipeline defines; complete pipelines get a
  // twin with empty sets there, through which the counter set is bound
  // (lavapipe cannot bind past a null set layout).
  VkPipelineLayout twin = VK_NULL_HANDLE;
  if (info->flags & VK_PIPELINE_LAYOUT_CREATE_INDEPENDENT_SETS_BIT_EXT) {
    if (dev->d.CreatePipelineLayout(device, &extended, alloc, &twin) != VK_SUCCESS) twin = VK_NULL_HANDLE;
    for (size_t s = info->setLayoutCount; s < dev->counterSet; ++s) sets[s] = VK_NULL_HANDLE;
  }
  VkResult result = dev->d.CreatePipelineLayout(device, &extended, alloc, layout);
  if (result != VK_SUCCESS) {
    if (twin != VK_NULL_HANDLE) dev->d.DestroyPipelineLayout(device, twin, alloc);
    return result;
  }
  std::lock_guard lock(dev->mutex);
  dev->countedLayouts.insert(u64(*layout));
  if (twin != VK_NULL_HANDLE) {
    dev->countedLayouts.insert(u64(twin));
    dev->completeLayouts[u64(*layout)] = twin;
  }
  return result;
}

VKAPI_ATTR void VKAPI_CALL DestroyPipelineLayout(VkDevice device, VkPipelineLayout layout,
                                                const VkAllocationCallbacks* alloc) {
  DeviceState* dev = deviceOf(device);
  VkPipelineLayout twin = VK_NULL_HANDLE;
  {
    std::lock_guard lock(dev->mutex);
    dev->countedLayouts.erase(u64(layout));  // a later layout may reuse the handle
    if (auto it = dev->completeLayouts.find(u64(layout)); it != dev->completeLayouts.end()) {
      twin = it->second;
      dev->countedLayouts.erase(u64(twin));
      dev->completeLayouts.erase(it);
    }
  }
  dev->d.DestroyPipelineLayout(device, layout, alloc);
  if (twin != VK_NULL_HANDLE) dev->d.DestroyPipelineLayout(device, twin, alloc);
}

spirv::Stage stageOf(VkShaderStageFlagBits stage) {
  switch (stage) {
    case VK_SHADER_STAGE_VERTEX_BIT: return spirv::Stage::Vertex;
    case VK_SHADER_STAGE_TESSELLATION_CONTROL_BIT: return spirv::Stage::TessControl;
    case VK_SHADER_STAGE_TESSELLATION_EVALUATION_BIT: return spirv::Stage::TessEval;
    case VK_SHADER_STAGE_GEOMETRY_BIT: return spirv::Stage::Geometry;
    case VK_SHADER_STAGE_FRAGMENT_BIT: return spirv::Stage::Fragment;
    case VK_SHADER_STAGE_COMPUTE_BIT: return spirv::Stage::Compute;
    case VK_SHADER_STAGE_TASK_BIT_EXT: return spirv::Stage::Task;
    case VK_SHADER_STAGE_MESH_BIT_EXT: return spirv::Stage::Mesh;
    default: return spirv::Stage::Other;
  }
}

// Instruments a pipeline's stages into `modules` (temporary modules to
// destroy after creation) and fills `info`. Stages that cannot be
// instrumented keep the application's module; each is reported. `split`:
// a pipeline made of libraries, whose fragment stages count from
// kPreRasterizationSlots (libraries.hpp). `plan`: whether the fragment shader
// may be given early tests (graphics pipelines).
void instrumentStages(DeviceState& dev, std::vector<VkPipelineShaderStageCreateInfo>& stages, PipelineInfo& info,
                      std::vector<VkShaderModule>& modules, bool split = false, EarlyTestsPlan* plan = nullptr) {
  uint32_t nextSlot = 0, fragmentSlot = kPreRasterizationSlots;
  const uint32_t maxSlots = uint32_t(dev.regionRange / 8);
  for (auto& stage : stages) {
    if (!stageInParts(stage.stage, info.libraryParts)) continue;  // a library ignores the parts it does not define
    const spirv::Stage s = stageOf(stage.stage);
    uint32_t& next = split && s == spirv::Stage::Fragment ? fragmentSlot : nextSlot;
    const uint32_t limit = split && s != spirv::Stage::Fragment ? kPreRasterizationSlots : maxSlots;
    if (s == spirv::Stage::Fragment) info.hasFragment = true;
    nlohmann::json report = {{"stage", std::string(spirv::toString(s))}, {"instrumented", false}, {"sites", 0}};
    auto shader = dev.shaders.find(u64(stage.module));
    std::string why;
    if (stage.module == VK_NULL_HANDLE || shader == dev.shaders.end()) {
      why = "the stage's SPIR-V is not in a shader module the layer saw (VkShaderModuleCreateInfo in the stage's pNext, or a module identifier)";
    } else if (s == spirv::Stage::Fragment && !dev.fragmentStores) {
      why = "the device has no fragmentStoresAndAtomics";
    } else if ((s == spirv::Stage::Vertex || s == spirv::Stage::TessControl || s == spirv::Stage::TessEval ||
                s == spirv::Stage::Geometry) &&
               !dev.vertexStores) {
      why = "the device has no vertexPipelineStoresAndAtomics";
    }
    report["name"] = shader != dev.shaders.end() && !shader->second.name.empty()
                         ? shader->second.name
                         : "shader " + hexHandle(u64(stage.module));
    if (why.empty()) {
      spirv::InstrumentOptions options = dev.instrumentOptions;
      options.firstSlot = next;
      if (s == spirv::Stage::Fragment && plan != nullptr && !plan->early()) options.earlyFragmentTests = false;
      // Lavapipe cannot compile the subgroup flush in modules that demote
      // (as gpu::instrumentOptionsFor): those flush per lane there.
      if (dev.llvmpipe && spirv::usesDemote(shader->second.words)) {
        options.subgroupStages &= ~spirv::stageBit(spirv::Stage::Fragment);
      }
      auto result = spirv::instrument(shader->second.words, options);
      if (!result) {
        why = result.error();
      } else if (next + result->layout().reserved() > limit) {
        why = "needs " + std::to_string(result->layout().reserved()) + " counter slots; the layer's region holds " +
              std::to_string(limit - next) + (limit < maxSlots ? " (a pre-rasterization library's share)" : "");
      } else {
        VkShaderModuleCreateInfo moduleInfo = {VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
        moduleInfo.codeSize = result->words.size() * 4;
        moduleInfo.pCode = result->words.data();
        VkShaderModule module = VK_NULL_HANDLE;
        if (dev.d.CreateShaderModule(dev.device, &moduleInfo, nullptr, &module) != VK_SUCCESS) {
          why = "the driver refused the instrumented module";
        } else {
          modules.push_back(module);
          stage.module = module;
          next += result->layout().reserved();
          if (result->copies > 1) info.foldLayouts.push_back(result->layout());
          for (auto& site : result->sites) info.sites.push_back(std::move(site));
          report["instrumented"] = true;
          report["sites"] = result->sites.size();
          std::vector<std::string> notes = result->notes;
          if (s == spirv::Stage::Fragment && plan != nullptr && plan->twin) {
            plan->earlyFragment = earlyTestsFragment(dev, shader->second.words, options, *result, notes);
          }
          for (const auto& note : notes) {
            dev.notes.insert(note);
            if (plan != nullptr && !plan->lateWhy.empty() && note.find("early_fragment_tests") != std::string::npos) {
              dev.notes.insert("a pipeline keeps its fragment shader's late depth and stencil tests (" + plan->lateWhy +
                               "): early tests would write depth and stencil for samples it removes");
            }
          }
        }
      }
    }
    report["reason"] = why;
    dev.shaderReports.push_back(report);
  }
  info.slots = std::max({info.slots, nextSlot, fragmentSlot > kPreRasterizationSlots ? fragmentSlot : 0});
  info.counted = info.slots > 0;
}

bool layoutCounted(DeviceState& dev, VkPipelineLayout layout) {
  return dev.countedLayouts.count(u64(layout)) > 0;
}

void registerPipelines(DeviceState& dev, uint32_t count, const VkPipeline* pipelines,
                       const std::vector<std::shared_ptr<PipelineInfo>>& states) {
  std::lock_guard lock(dev.mutex);
  for (uint32_t i = 0; i < count; ++i) {
    if (pipelines[i] == VK_NULL_HANDLE) {  // a failed creation in a batch
      if (states[i]->instrumented != VK_NULL_HANDLE) dev.d.DestroyPipeline(dev.device, states[i]->instrumented, nullptr);
      continue;
    }
    states[i]->handle = u64(pipelines[i]);
    if (states[i]->library) {  // counted once linked, as part of the pipelines it makes
      dev.libraries[u64(pipelines[i])] = states[i];
      ++dev.librariesCreated;
      continue;
    }
    dev.pipelines[u64(pipelines[i])] = states[i];
    dev.pipelinesLinked += states[i]->linked ? 1 : 0;
    ++dev.pipelinesCreated;
    dev.pipelinesCounted += states[i]->counted ? 1 : 0;
  }
}

using Clock = std::chrono::steady_clock;
void addPipelineTimes(DeviceState& dev, Clock::time_point start, Clock::time_point twins) {
  const auto ms = [](auto d) { return std::chrono::duration<double, std::milli>(d).count(); };
  std::lock_guard lock(dev.mutex);
  dev.pipelineMsInstrumented += ms(twins - start);
  dev.pipelineMsApplication += ms(Clock::now() - twins);
}

VKAPI_ATTR VkResult VKAPI_CALL CreateGraphicsPipelines(VkDevice device, VkPipelineCache cache, uint32_t count,
                                                       const VkGraphicsPipelineCreateInfo* infos,
                                                       const VkAllocationCallbacks* alloc, VkPipeline* pipelines) {
  DeviceState* dev = deviceOf(device);
  std::vector<VkGraphicsPipelineCreateInfo> patched(infos, infos + count);
  std::vector<std::vector<VkPipelineShaderStageCreateInfo>> stages(count);
  std::vector<std::shared_ptr<PipelineInfo>> states(count);
  std::vector<VkShaderModule> modules, earlyFragments(count, VK_NULL_HANDLE);
  const auto start = Clock::now();
  {
    std::lock_guard lock(dev->mutex);
    for (uint32_t i = 0; i < count; ++i) {
      auto state = std::make_shared<PipelineInfo>();
      state->layout = infos[i].layout;
      // Graphics pipeline libraries: a library's stages are instrumented as
      // a pipeline's are; a pipeline linked from libraries counts their sites.
      const LibraryUse use = libraryUse(infos[i]);
      state->library = use.library;
      state->libraryParts = use.parts;
      // A library's create info holds the state of its own parts only: the
      // other pointers may be garbage.
      VkGraphicsPipelineCreateInfo held = infos[i];
      if (!(use.parts & VK_GRAPHICS_PIPELINE_LIBRARY_VERTEX_INPUT_INTERFACE_BIT_EXT)) held.pVertexInputState = nullptr;
      if (!(use.parts & VK_GRAPHICS_PIPELINE_LIBRARY_PRE_RASTERIZATION_SHADERS_BIT_EXT)) {
        held.pRasterizationState = nullptr;
      }
      if (!(use.parts & VK_GRAPHICS_PIPELINE_LIBRARY_FRAGMENT_OUTPUT_INTERFACE_BIT_EXT)) held.pColorBlendState = nullptr;
      state->fixed = fixedFunctionOf(*dev, held);
      state->libraryParts |= mergeLibraries(*dev, use.linked, *state);
      state->linked = !use.linked.empty();
      if (windowAhead(*dev) && layoutCounted(*dev, infos[i].layout) && infos[i].stageCount > 0 &&
          (use.parts & (VK_GRAPHICS_PIPELINE_LIBRARY_PRE_RASTERIZATION_SHADERS_BIT_EXT |
                        VK_GRAPHICS_PIPELINE_LIBRARY_FRAGMENT_SHADER_BIT_EXT))) {
        stages[i].assign(infos[i].pStages, infos[i].pStages + infos[i].stageCount);
        EarlyTestsPlan plan = earlyTestsPlan(infos[i]);
        instrumentStages(*dev, stages[i], *state, modules, use.split(), &plan);
        earlyFragments[i] = plan.earlyFragment;
        patched[i].pStages = stages[i].data();
      }
      // The counter set is bound through the pipeline's layout.
      if (auto twin = dev->completeLayouts.find(u64(state->layout)); !use.library && twin != dev->completeLayouts.end()) {
        state->layout = twin->second;
        if (patched[i].layout != VK_NULL_HANDLE) patched[i].layout = twin->second;
      }
      state->counted = state->counted && dev->counting && layoutCounted(*dev, state->layout);
      states[i] = state;
    }
  }
  // Graphics pipeline libraries, and pipelines linked from them, are created
  // instrumented in the application's place: a linked pipeline names its
  // libraries by the application's handles, so they can have no twins.
  std::vector<VkGraphicsPipelineCreateInfo> own(infos, infos + count);
  for (uint32_t i = 0; i < count; ++i) {
    if (states[i]->library || states[i]->linked) {
      own[i] = patched[i];
      states[i]->inPlace = true;
    }
  }
  createGraphicsTwins(*dev, patched, states);
  const auto twins = Clock::now();
  // Last, so that what the application's pNext receives (creation feedback) is its own pipeline's.
  VkResult result = dev->d.CreateGraphicsPipelines(device, cache, count, own.data(), alloc, pipelines);
  addPipelineTimes(*dev, start, twins);
  for (uint32_t i = 0; i < count; ++i) {
    if (states[i]->inPlace && states[i]->counted) states[i]->instrumented = pipelines[i];
  }
  createEarlyTestsTwins(*dev, cache, patched, earlyFragments, pipelines, states);
  for (VkShaderModule m : modules) dev->d.DestroyShaderModule(device, m, nullptr);
  registerPipelines(*dev, count, pipelines, states);
  return result;
}

VKAPI_ATTR VkResult VKAPI_CALL CreateComputePipelines(VkDevice device, VkPipelineCache cache, uint32_t count,
                                                      const VkComputePipelineCreateInfo* infos,
                                                      const VkAllocationCallbacks* alloc, VkPipeline* pipelines) {
  DeviceState* dev = deviceOf(device);
  std::vector<VkComputePipelineCreateInfo> patched(infos, infos + count);
  std::vector<std::shared_ptr<PipelineInfo>> states(count);
  std::vector<VkShaderModule> modules;
  const auto start = Clock::now();
  {
    std::lock_guard lock(dev->mutex);
    for (uint32_t i = 0; i < count; ++i) {
      auto state = std::make_shared<PipelineInfo>();
      state->layout = infos[i].layout;
      if (windowAhead(*dev) && layoutCounted(*dev, infos[i].layout)) {
        std::vector<VkPipelineShaderStageCreateInfo> stage = {infos[i].stage};
        instrumentStages(*dev, stage, *state, modules);
        patched[i].stage = stage[0];
      }
      states[i] = state;
    }
  }
  createComputeTwins(*dev, patched, states);
  for (VkShaderModule m : modules) dev->d.DestroyShaderModule(device, m, nullptr);
  const auto twins = Clock::now();
  VkResult result = dev->d.CreateComputePipelines(device, cache, count, infos, alloc, pipelines);
  addPipelineTimes(*dev, start, twins);
  registerPipelines(*dev, count, pipelines, states);
  return result;
}

VKAPI_ATTR void VKAPI_CALL DestroyPipeline(VkDevice device, VkPipeline pipeline, const VkAllocationCallbacks* alloc) {
  DeviceState* dev = deviceOf(device);
  VkPipeline twin = VK_NULL_HANDLE, early = VK_NULL_HANDLE;
  {
    std::lock_guard lock(dev->mutex);
    if (auto it = dev->pipelines.find(u64(pipeline)); it != dev->pipelines.end()) {
      if (!it->second->inPlace) twin = it->second->instrumented;
      early = std::exchange(it->second->earlyTestsTwin, VK_NULL_HANDLE);
    }
    dev->pipelines.erase(u64(pipeline));  // recorded regions keep their own reference
    dev->libraries.erase(u64(pipeline));  // pipelines linked from it keep its sites
  }
  if (twin != VK_NULL_HANDLE) dev->d.DestroyPipeline(device, twin, nullptr);
  if (early != VK_NULL_HANDLE) dev->d.DestroyPipeline(device, early, nullptr);
  dev->d.DestroyPipeline(device, pipeline, alloc);
}

// ---------------------------------------------------------------- command buffers

VKAPI_ATTR VkResult VKAPI_CALL CreateCommandPool(VkDevice device, const VkCommandPoolCreateInfo* info,
                                                 const VkAllocationCallbacks* alloc, VkCommandPool* pool) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.CreateCommandPool(device, info, alloc, pool);
  if (result != VK_SUCCESS) return result;
  std::lock_guard lock(dev->mutex);
  dev->poolFamilies[u64(*pool)] = info->queueFamilyIndex;
  return result;
}

void destroyCommandBufferState(DeviceState& dev, CommandBufferState& cb) {
  releaseRegions(dev, cb);
  retireQueryPools(dev, cb);  // kept for later recordings once the readbacks copying them are read
  waitForIndirectReadbacks(dev, cb);
  destroyIndirect(dev, cb);
}

VKAPI_ATTR void VKAPI_CALL DestroyCommandPool(VkDevice device, VkCommandPool pool, const VkAllocationCallbacks* alloc) {
  DeviceState* dev = deviceOf(device);
  {
    std::lock_guard lock(dev->mutex);
    for (auto it = dev->commandBuffers.begin(); it != dev->commandBuffers.end();) {
      if (it->second->pool == pool) {
        destroyCommandBufferState(*dev, *it->second);
        it = dev->commandBuffers.erase(it);
      } else {
        ++it;
      }
    }
  }
  dev->d.DestroyCommandPool(device, pool, alloc);
}

VKAPI_ATTR VkResult VKAPI_CALL AllocateCommandBuffers(VkDevice device, const VkCommandBufferAllocateInfo* info,
                                                      VkCommandBuffer* buffers) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.AllocateCommandBuffers(device, info, buffers);
  if (result != VK_SUCCESS) return result;
  std::lock_guard lock(dev->mutex);
  const uint32_t family = dev->poolFamilies[u64(info->commandPool)];
  const auto& props = dev->families[family];
  for (uint32_t i = 0; i < info->commandBufferCount; ++i) {
    auto cb = std::make_unique<CommandBufferState>();
    cb->handle = buffers[i];
    cb->pool = info->commandPool;
    cb->secondary = info->level == VK_COMMAND_BUFFER_LEVEL_SECONDARY;
    cb->graphicsOrCompute = (props.queueFlags & (VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT)) != 0;
    cb->timestamps = props.timestampValidBits > 0 && cb->graphicsOrCompute && dev->config.timestamps;
    dev->commandBuffers[buffers[i]] = std::move(cb);
  }
  return result;
}

VKAPI_ATTR void VKAPI_CALL FreeCommandBuffers(VkDevice device, VkCommandPool pool, uint32_t count,
                                              const VkCommandBuffer* buffers) {
  DeviceState* dev = deviceOf(device);
  {
    std::lock_guard lock(dev->mutex);
    for (uint32_t i = 0; i < count; ++i) {
      if (CommandBufferState* cb = cbState(*dev, buffers[i])) {
        destroyCommandBufferState(*dev, *cb);
        dev->commandBuffers.erase(buffers[i]);
      }
    }
  }
  dev->d.FreeCommandBuffers(device, pool, count, buffers);
}

constexpr uint32_t kQueriesPerCommandBuffer = 512;
constexpr VkQueryPipelineStatisticFlags kStatistics = VK_QUERY_PIPELINE_STATISTIC_VERTEX_SHADER_INVOCATIONS_BIT |
                                                      VK_QUERY_PIPELINE_STATISTIC_FRAGMENT_SHADER_INVOCATIONS_BIT |
                                                      VK_QUERY_PIPELINE_STATISTIC_COMPUTE_SHADER_INVOCATIONS_BIT;

void resetRecording(DeviceState& dev, CommandBufferState& cb) {
  releaseRegions(dev, cb);
  cb.passes.clear();
  cb.regions.clear();
  cb.regionIndex.clear();
  cb.timestampsUsed = cb.statisticsUsed = 0;
  cb.currentPass = -1;
  cb.inRenderPass = false;
  cb.openStatistic = false;
  cb.appStatisticsActive = false;
  cb.labels.clear();
  cb.colorAttachments.clear();
  cb.dynamic = {};
  cb.views = 1;
  cb.secondaryContents = cb.suspending = false;
  cb.owedEnd = -1;
  cb.bind = {};
  cb.coverage = {};
  cb.vertexBuffers.clear();
  cb.indexBuffer = 0;
  cb.renderingSuspended = false;
  cb.indirectDraws.clear();
  cb.indirectUsed = 0;
  cb.work = cb.uncountedSecondaries = false;
}

VKAPI_ATTR VkResult VKAPI_CALL BeginCommandBuffer(VkCommandBuffer cmd, const VkCommandBufferBeginInfo* info) {
  DeviceState* dev = deviceOf(cmd);
  VkResult result = dev->d.BeginCommandBuffer(cmd, info);
  if (result != VK_SUCCESS) return result;
  std::lock_guard lock(dev->mutex);
  CommandBufferState* cb = cbState(*dev, cmd);
  if (cb == nullptr) return result;
  resetRecording(*dev, *cb);
  if (cb->secondary) inheritTargets(*dev, *cb, *info);
  cb->counted = recordForCounting(*dev, *cb, info->flags);
  if (cb->secondary || !cb->graphicsOrCompute || !dev->counting || !cb->counted) return result;
  if (cb->timestamps && cb->timestampPool == VK_NULL_HANDLE) cb->timestampPool = takeQueryPool(*dev, false);
  if (dev->statistics && cb->statisticsPool == VK_NULL_HANDLE) cb->statisticsPool = takeQueryPool(*dev, true);
  if (cb->timestamps && cb->timestampPool == VK_NULL_HANDLE) {
    VkQueryPoolCreateInfo q = {VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    q.queryType = VK_QUERY_TYPE_TIMESTAMP;
    q.queryCount = kQueriesPerCommandBuffer;
    if (dev->d.CreateQueryPool(dev->device, &q, nullptr, &cb->timestampPool) != VK_SUCCESS) cb->timestamps = false;
    ++dev->queryPoolsCreated;
  }
  if (dev->statistics && cb->statisticsPool == VK_NULL_HANDLE) {
    VkQueryPoolCreateInfo q = {VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    q.queryType = VK_QUERY_TYPE_PIPELINE_STATISTICS;
    q.queryCount = kQueriesPerCommandBuffer;
    q.pipelineStatistics = kStatistics;
    dev->d.CreateQueryPool(dev->device, &q, nullptr, &cb->statisticsPool);
    ++dev->queryPoolsCreated;
  }
  if (cb->timestamps) dev->d.CmdResetQueryPool(cmd, cb->timestampPool, 0, kQueriesPerCommandBuffer);
  if (cb->statisticsPool != VK_NULL_HANDLE) dev->d.CmdResetQueryPool(cmd, cb->statisticsPool, 0, kQueriesPerCommandBuffer);
  return result;
}

VKAPI_ATTR VkResult VKAPI_CALL ResetCommandBuffer(VkCommandBuffer cmd, VkCommandBufferResetFlags flags) {
  DeviceState* dev = deviceOf(cmd);
  {
    std::lock_guard lock(dev->mutex);
    if (CommandBufferState* cb = cbState(*dev, cmd)) resetRecording(*dev, *cb);
  }
  return dev->d.ResetCommandBuffer(cmd, flags);
}

VKAPI_ATTR VkResult VKAPI_CALL ResetCommandPool(VkDevice device, VkCommandPool pool, VkCommandPoolResetFlags flags) {
  DeviceState* dev = deviceOf(device);
  {
    std::lock_guard lock(dev->mutex);
    for (auto& [handle, cb] : dev->commandBuffers) {
      if (cb->pool == pool) resetRecording(*dev, *cb);
    }
  }
  return dev->d.ResetCommandPool(device, pool, flags);
}

// Statistics queries begin and end inside the render pass (lavapipe crashes
// on a query around one), once per subpass.
void beginStatistic(DeviceState& dev, CommandBufferState& cb) {
  if (cb.statisticsPool == VK_NULL_HANDLE || cb.currentPass < 0 || cb.openStatistic || cb.appStatisticsActive) return;
  // No query may be active while secondaries execute (without inheritedQueries).
  if (cb.secondaryContents) return;
  // Under multiview a query takes one index per view, each holding a view's
  // share or the first the whole: the pass sums them all.
  const uint32_t views = cb.inRenderPass ? cb.views : 1;
  if (cb.statisticsUsed + views > kQueriesPerCommandBuffer) return;
  const uint32_t q = cb.statisticsUsed;
  cb.statisticsUsed += views;
  dev.d.CmdBeginQuery(cb.handle, cb.statisticsPool, q, 0);
  for (uint32_t v = 0; v < views; ++v) cb.passes[size_t(cb.currentPass)].statisticQueries.push_back(q + v);
  cb.openStatistic = true;
}
void endStatistic(DeviceState& dev, CommandBufferState& cb) {
  if (!cb.openStatistic) return;
  const auto& queries = cb.passes[size_t(cb.currentPass)].statisticQueries;
  const uint32_t views = cb.inRenderPass ? cb.views : 1;
  dev.d.CmdEndQuery(cb.handle, cb.statisticsPool, queries[queries.size() - views]);
  cb.openStatistic = false;
}

// A subpass whose contents are secondary command buffers takes no commands
// but theirs: a scope there has its timestamps outside (capture.cpp waits on
// every index it allocates, so each one is written).
bool canWriteTimestamp(const CommandBufferState& cb, uint32_t views) {
  return !cb.inRenderPass || (!cb.secondaryContents && cb.views == views);
}
// The end timestamp of a scope that closed where none could be written.
void settleEnd(DeviceState& dev, CommandBufferState& cb) {
  if (cb.owedEnd < 0 || cb.owedEnd >= int(cb.passes.size()) || cb.suspending) return;
  const PassScope& pass = cb.passes[size_t(cb.owedEnd)];
  if (!canWriteTimestamp(cb, pass.views)) return;
  dev.d.CmdWriteTimestamp(cb.handle, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, cb.timestampPool,
                          pass.timestampBegin + pass.views);
  cb.owedEnd = -1;
}

void openPass(DeviceState& dev, CommandBufferState& cb, const char* kind) {
  settleEnd(dev, cb);
  PassScope pass;
  pass.kind = kind;
  pass.label = cb.labels.empty() ? "" : cb.labels.back();
  // Under multiview a timestamp takes one index per view: begin's, then end's.
  pass.views = cb.inRenderPass ? cb.views : 1;
  if (cb.timestamps && cb.timestampsUsed + 2 * pass.views <= kQueriesPerCommandBuffer &&
      canWriteTimestamp(cb, pass.views) && cb.owedEnd < 0) {
    pass.timestampBegin = cb.timestampsUsed;
    cb.timestampsUsed += 2 * pass.views;
    dev.d.CmdWriteTimestamp(cb.handle, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, cb.timestampPool, pass.timestampBegin);
  }
  cb.passes.push_back(std::move(pass));
  cb.currentPass = int(cb.passes.size()) - 1;
  beginStatistic(dev, cb);
}

void closePass(DeviceState& dev, CommandBufferState& cb) {
  if (cb.currentPass < 0) return;
  endStatistic(dev, cb);
  const PassScope& pass = cb.passes[size_t(cb.currentPass)];
  if (pass.timestampBegin != UINT32_MAX && (cb.suspending || !canWriteTimestamp(cb, pass.views))) {
    cb.owedEnd = cb.currentPass;  // written once the scope is out of the secondaries' subpass, or not resumed
  } else if (pass.timestampBegin != UINT32_MAX) {
    dev.d.CmdWriteTimestamp(cb.handle, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, cb.timestampPool,
                            pass.timestampBegin + pass.views);
  }
  cb.currentPass = -1;
}

bool tracked(DeviceState& dev, CommandBufferState* cb) {
  return cb != nullptr && !cb->secondary && dev.counting && cb->counted;
}

// Each subpass is a scope of its own, so that a label per subpass names it a
// pass; an unlabelled later subpass takes the first one's name (one pass).
int subpassScopeStart(const CommandBufferState& cb) {
  if (cb.currentPass < 0) return -1;
  const PassScope& pass = cb.passes[size_t(cb.currentPass)];
  return pass.continues >= 0 ? pass.continues : cb.currentPass;
}
void openSubpass(DeviceState& dev, CommandBufferState& cb, int first) {
  openPass(dev, cb, "render pass");
  cb.passes.back().continues = first;
}

VKAPI_ATTR VkResult VKAPI_CALL EndCommandBuffer(VkCommandBuffer cmd) {
  DeviceState* dev = deviceOf(cmd);
  {
    std::lock_guard lock(dev->mutex);
    CommandBufferState* cb = cbState(*dev, cmd);
    if (tracked(*dev, cb) && !cb->inRenderPass) {
      closePass(*dev, *cb);
      cb->suspending = false;  // a scope suspended here is resumed elsewhere: its end is now
      settleEnd(*dev, *cb);
    }
    if (tracked(*dev, cb)) recordIndirectCopies(*dev, *cb, true);
  }
  return dev->d.EndCommandBuffer(cmd);
}

void beginRenderPassCommon(DeviceState& dev, CommandBufferState& cb, VkRenderPass pass, VkFramebuffer framebuffer,
                           const void* next) {
  cb.passAttachments.clear();
  cb.subpassColors.clear();
  cb.subpass = 0;
  cb.subpassViewMasks.clear();
  if (auto m = dev.subpassViewMasks.find(u64(pass)); m != dev.subpassViewMasks.end()) cb.subpassViewMasks = m->second;
  cb.views = viewCount(cb.subpassViewMasks.empty() ? 0 : cb.subpassViewMasks[0]);
  std::vector<uint64_t> views;
  if (auto f = dev.framebuffers.find(u64(framebuffer)); f != dev.framebuffers.end()) views = f->second;
  for (auto* p = static_cast<const VkBaseInStructure*>(next); p != nullptr; p = p->pNext) {
    if (p->sType == VK_STRUCTURE_TYPE_RENDER_PASS_ATTACHMENT_BEGIN_INFO) {  // imageless framebuffers
      const auto* a = reinterpret_cast<const VkRenderPassAttachmentBeginInfo*>(p);
      views.assign(reinterpret_cast<const uint64_t*>(a->pAttachments),
                   reinterpret_cast<const uint64_t*>(a->pAttachments) + a->attachmentCount);
    }
  }
  cb.work = true;
  for (uint64_t v : views) cb.passAttachments.push_back(boundImage(dev, reinterpret_cast<VkImageView>(v)));
  if (auto r = dev.renderPasses.find(u64(pass)); r != dev.renderPasses.end()) cb.subpassColors = r->second;
  cb.colorAttachments.clear();
  if (!cb.subpassColors.empty()) cb.colorAttachments = subpassTargets(cb.passAttachments, cb.subpassColors[0]);
}

void nextSubpassCommon(CommandBufferState& cb) {
  ++cb.subpass;
  cb.colorAttachments.clear();
  if (cb.subpass < cb.subpassColors.size()) {
    cb.colorAttachments = subpassTargets(cb.passAttachments, cb.subpassColors[cb.subpass]);
  }
  cb.views = viewCount(cb.subpass < cb.subpassViewMasks.size() ? cb.subpassViewMasks[cb.subpass] : 0);
}

// The render pass commands: the layer's work around the call down.
// A first subpass of secondaries opens its scope before the render pass, so
// that its begin timestamp lies outside.
template <class CallDown>
void beginRenderPass(VkCommandBuffer cmd, const VkRenderPassBeginInfo* info, VkSubpassContents contents,
                     CallDown callDown) {
  DeviceState* dev = deviceOf(cmd);
  std::lock_guard lock(dev->mutex);
  CommandBufferState* cb = cbState(*dev, cmd);
  if (tracked(*dev, cb)) closePass(*dev, *cb);
  if (cb != nullptr) cb->secondaryContents = contents == VK_SUBPASS_CONTENTS_SECONDARY_COMMAND_BUFFERS;
  if (tracked(*dev, cb) && cb->secondaryContents) openPass(*dev, *cb, "render pass");
  callDown(*dev);
  if (cb == nullptr) return;
  beginRenderPassCommon(*dev, *cb, info->renderPass, info->framebuffer, info->pNext);
  cb->inRenderPass = true;
  if (tracked(*dev, cb) && !cb->secondaryContents) openPass(*dev, *cb, "render pass");
}
template <class CallDown>
void nextSubpass(VkCommandBuffer cmd, VkSubpassContents contents, CallDown callDown) {
  DeviceState* dev = deviceOf(cmd);
  std::lock_guard lock(dev->mutex);
  CommandBufferState* cb = cbState(*dev, cmd);
  const int first = tracked(*dev, cb) ? subpassScopeStart(*cb) : -1;
  if (tracked(*dev, cb)) closePass(*dev, *cb);
  callDown(*dev);
  if (cb == nullptr) return;
  nextSubpassCommon(*cb);
  cb->secondaryContents = contents == VK_SUBPASS_CONTENTS_SECONDARY_COMMAND_BUFFERS;
  if (tracked(*dev, cb)) openSubpass(*dev, *cb, first);
}
// Also the end of a dynamic-rendering scope.
template <class CallDown>
void endRenderPass(VkCommandBuffer cmd, CallDown callDown) {
  DeviceState* dev = deviceOf(cmd);
  std::lock_guard lock(dev->mutex);
  CommandBufferState* cb = cbState(*dev, cmd);
  if (tracked(*dev, cb)) closePass(*dev, *cb);
  callDown(*dev);
  if (cb == nullptr) return;
  cb->inRenderPass = false;
  if (tracked(*dev, cb)) settleEnd(*dev, *cb);
  cb->secondaryContents = false;
  // The pass's indirect parameters are copied once it has ended, unless a
  // suspended rendering scope forbids any command until it resumes.
  if (tracked(*dev, cb)) recordIndirectCopies(*dev, *cb, false);
}

VKAPI_ATTR void VKAPI_CALL CmdBeginRenderPass(VkCommandBuffer cmd, const VkRenderPassBeginInfo* info,
                                              VkSubpassContents contents) {
  beginRenderPass(cmd, info, contents, [&](DeviceState& dev) { dev.d.CmdBeginRenderPass(cmd, info, contents); });
}
VKAPI_ATTR void VKAPI_CALL CmdBeginRenderPass2(VkCommandBuffer cmd, const VkRenderPassBeginInfo* info,
                                               const VkSubpassBeginInfo* begin) {
  beginRenderPass(cmd, info, begin->contents,
                  [&](DeviceState& dev) { dev.d.CmdBeginRenderPass2(cmd, info, begin); });
}
VKAPI_ATTR void VKAPI_CALL CmdNextSubpass(VkCommandBuffer cmd, VkSubpassContents contents) {
  nextSubpass(cmd, contents, [&](DeviceState& dev) { dev.d.CmdNextSubpass(cmd, contents); });
}
VKAPI_ATTR void VKAPI_CALL CmdNextSubpass2(VkCommandBuffer cmd, const VkSubpassBeginInfo* begin,
                                           const VkSubpassEndInfo* end) {
  nextSubpass(cmd, begin->contents, [&](DeviceState& dev) { dev.d.CmdNextSubpass2(cmd, begin, end); });
}
VKAPI_ATTR void VKAPI_CALL CmdEndRenderPass(VkCommandBuffer cmd) {
  endRenderPass(cmd, [&](DeviceState& dev) { dev.d.CmdEndRenderPass(cmd); });
}
VKAPI_ATTR void VKAPI_CALL CmdEndRenderPass2(VkCommandBuffer cmd, const VkSubpassEndInfo* end) {
  endRenderPass(cmd, [&](DeviceState& dev) { dev.d.CmdEndRenderPass2(cmd, end); });
}

VKAPI_ATTR void VKAPI_CALL CmdBeginRendering(VkCommandBuffer cmd, const VkRenderingInfo* info) {
  DeviceState* dev = deviceOf(cmd);
  std::lock_guard lock(dev->mutex);
  CommandBufferState* cb = cbState(*dev, cmd);
  if (tracked(*dev, cb)) closePass(*dev, *cb);
  // A resumed scope continues the suspended one's pass, and owes its end
  // timestamp until it ends without suspending. A scope of secondaries opens
  // before the call down, so that its timestamps lie outside.
  const bool resuming = (info->flags & VK_RENDERING_RESUMING_BIT) != 0 && cb != nullptr && !cb->passes.empty() &&
                        cb->passes.back().kind == "rendering";
  if (cb != nullptr) {
    cb->secondaryContents = (info->flags & VK_RENDERING_CONTENTS_SECONDARY_COMMAND_BUFFERS_BIT) != 0;
    cb->suspending = false;
  }
  if (tracked(*dev, cb) && !resuming && cb->secondaryContents) openPass(*dev, *cb, "rendering");
  dev->d.CmdBeginRendering(cmd, info);
  if (cb == nullptr) return;
  cb->work = true;
  cb->colorAttachments = renderingTargets(*dev, *info);
  cb->views = viewCount(info->viewMask);
  cb->renderingSuspends = (info->flags & VK_RENDERING_SUSPENDING_BIT) != 0;
  cb->renderingSuspended = false;
  cb->inRenderPass = true;
  if (tracked(*dev, cb) && !resuming && !cb->secondaryContents) {
    openPass(*dev, *cb, "rendering");
  } else if (tracked(*dev, cb) && resuming) {
    cb->currentPass = int(cb->passes.size()) - 1;
    if (cb->owedEnd == cb->currentPass) cb->owedEnd = -1;
    beginStatistic(*dev, *cb);
  }
  cb->suspending = (info->flags & VK_RENDERING_SUSPENDING_BIT) != 0;
}

VKAPI_ATTR void VKAPI_CALL CmdEndRendering(VkCommandBuffer cmd) {
  endRenderPass(cmd, [&](DeviceState& dev) {
    if (CommandBufferState* cb = cbState(dev, cmd)) cb->renderingSuspended = cb->renderingSuspends;
    dev.d.CmdEndRendering(cmd);
  });
}

VKAPI_ATTR void VKAPI_CALL CmdBeginDebugUtilsLabelEXT(VkCommandBuffer cmd, const VkDebugUtilsLabelEXT* label) {
  DeviceState* dev = deviceOf(cmd);
  if (dev->d.CmdBeginDebugUtilsLabelEXT != nullptr) dev->d.CmdBeginDebugUtilsLabelEXT(cmd, label);
  std::lock_guard lock(dev->mutex);
  CommandBufferState* cb = cbState(*dev, cmd);
  if (cb == nullptr) return;
  cb->labels.push_back(label->pLabelName ? label->pLabelName : "");
  // A label begun inside a render pass before its first draw names the pass
  // where none was open at its start, and names a later subpass.
  if (tracked(*dev, cb) && cb->inRenderPass && cb->currentPass >= 0) {
    PassScope& pass = cb->passes[size_t(cb->currentPass)];
    if (pass.draws == 0 && (pass.label.empty() || pass.continues >= 0)) pass.label = cb->labels.back();
  }
}

VKAPI_ATTR void VKAPI_CALL CmdEndDebugUtilsLabelEXT(VkCommandBuffer cmd) {
  DeviceState* dev = deviceOf(cmd);
  if (dev->d.CmdEndDebugUtilsLabelEXT != nullptr) dev->d.CmdEndDebugUtilsLabelEXT(cmd);
  std::lock_guard lock(dev->mutex);
  CommandBufferState* cb = cbState(*dev, cmd);
  if (cb == nullptr) return;
  if (!cb->labels.empty()) cb->labels.pop_back();
  // A compute scope ends with the label that named it.
  if (tracked(*dev, cb) && !cb->inRenderPass && cb->currentPass >= 0 &&
      cb->passes[size_t(cb->currentPass)].kind == "compute") {
    closePass(*dev, *cb);
  }
}

VKAPI_ATTR void VKAPI_CALL CmdBeginQuery(VkCommandBuffer cmd, VkQueryPool pool, uint32_t query,
                                         VkQueryControlFlags flags) {
  DeviceState* dev = deviceOf(cmd);
  std::lock_guard lock(dev->mutex);
  CommandBufferState* cb = cbState(*dev, cmd);
  // The application's own statistics query: only one may be active, so the layer's yields.
  if (cb != nullptr && cb->statisticsPool != pool) {
    if (cb->openStatistic) endStatistic(*dev, *cb);
    cb->appStatisticsActive = true;
  }
  dev->d.CmdBeginQuery(cmd, pool, query, flags);
}

VKAPI_ATTR void VKAPI_CALL CmdEndQuery(VkCommandBuffer cmd, VkQueryPool pool, uint32_t query) {
  DeviceState* dev = deviceOf(cmd);
  std::lock_guard lock(dev->mutex);
  dev->d.CmdEndQuery(cmd, pool, query);
  if (CommandBufferState* cb = cbState(*dev, cmd)) cb->appStatisticsActive = false;
}

VKAPI_ATTR void VKAPI_CALL CmdBindPipeline(VkCommandBuffer cmd, VkPipelineBindPoint point, VkPipeline pipeline) {
  DeviceState* dev = deviceOf(cmd);
  if (point != VK_PIPELINE_BIND_POINT_GRAPHICS && point != VK_PIPELINE_BIND_POINT_COMPUTE) {
    dev->d.CmdBindPipeline(cmd, point, pipeline);
    return;
  }
  std::lock_guard lock(dev->mutex);
  CommandBufferState* cb = cbState(*dev, cmd);
  // The instrumented twin only where the command buffer counts (twins.cpp).
  std::shared_ptr<PipelineInfo> info;
  // With counting off only pipelines instrumented in place (libraries) count:
  // they have no uninstrumented twin to bind.
  if (cb != nullptr && cb->counted) {
    auto it = dev->pipelines.find(u64(pipeline));
    if (it != dev->pipelines.end() && it->second->instrumented != VK_NULL_HANDLE &&
        (dev->config.counts || it->second->inPlace)) {
      info = it->second;
    }
  }
  dev->d.CmdBindPipeline(cmd, point, info ? info->instrumented : pipeline);
  if (cb == nullptr || !cb->counted) return;
  auto& bp = cb->bind[point == VK_PIPELINE_BIND_POINT_COMPUTE ? 1 : 0];
  if (point == VK_PIPELINE_BIND_POINT_GRAPHICS) {
    cb->coverage.pipeline = info ? info->instrumented : pipeline;
    cb->coverage.twinBound = false;
  }
  bp.pipeline = info;
  bp.dirty = true;
  // A counted pipeline always finds the counter set bound: at the sink (never
  // read) until a draw the layer sees binds the draw's region, so a draw
  // command the layer does not intercept runs uncounted, not unbound.
  if (bp.pipeline && bp.pipeline->counted && dev->counting) {
    const uint32_t sink = 0;
    dev->d.CmdBindDescriptorSets(cmd, point, bp.pipeline->layout, dev->counterSet, 1, &dev->counterDescriptorSet, 1,
                                 &sink);
    bp.boundOffset = 0;
  }
}

VKAPI_ATTR void VKAPI_CALL CmdSetAlphaToCoverageEnableEXT(VkCommandBuffer cmd, VkBool32 enable) {
  DeviceState* dev = deviceOf(cmd);
  dev->d.CmdSetAlphaToCoverageEnableEXT(cmd, enable);
  std::lock_guard lock(dev->mutex);
  if (CommandBufferState* cb = cbState(*dev, cmd)) {
    cb->coverage.known = true;
    cb->coverage.alphaToCoverage = enable == VK_TRUE;
  }
}

VKAPI_ATTR void VKAPI_CALL CmdBindDescriptorSets(VkCommandBuffer cmd, VkPipelineBindPoint point, VkPipelineLayout layout,
                                                 uint32_t first, uint32_t count, const VkDescriptorSet* sets,
                                                 uint32_t dynamicCount, const uint32_t* dynamicOffsets) {
  DeviceState* dev = deviceOf(cmd);
  dev->d.CmdBindDescriptorSets(cmd, point, layout, first, count, sets, dynamicCount, dynamicOffsets);
  if (point != VK_PIPELINE_BIND_POINT_GRAPHICS && point != VK_PIPELINE_BIND_POINT_COMPUTE) return;
  std::lock_guard lock(dev->mutex);
  CommandBufferState* cb = cbState(*dev, cmd);
  if (cb == nullptr) return;
  auto& bp = cb->bind[point == VK_PIPELINE_BIND_POINT_COMPUTE ? 1 : 0];
  for (uint32_t i = 0; i < count && first + i < bp.sets.size(); ++i) {
    bp.sets[first + i] = u64(sets[i]);
    bp.pushed.erase(first + i);
  }
  bp.dirty = true;
}

// Push descriptors resolve as bound sets do: the command buffer holds the
// pushed set's descriptors, updated incrementally, until a bind replaces it.
template <class Update>
void pushDescriptors(VkCommandBuffer cmd, VkPipelineBindPoint point, uint32_t set, Update update) {
  if (point != VK_PIPELINE_BIND_POINT_GRAPHICS && point != VK_PIPELINE_BIND_POINT_COMPUTE) return;
  DeviceState* dev = deviceOf(cmd);
  std::lock_guard lock(dev->mutex);
  CommandBufferState* cb = cbState(*dev, cmd);
  if (cb == nullptr) return;
  auto& bp = cb->bind[point == VK_PIPELINE_BIND_POINT_COMPUTE ? 1 : 0];
  if (set >= bp.sets.size()) return;
  update(*dev, bp.pushed[set]);
  bp.sets[set] = 0;
  bp.dirty = true;
}

VKAPI_ATTR void VKAPI_CALL CmdPushDescriptorSetKHR(VkCommandBuffer cmd, VkPipelineBindPoint point,
                                                   VkPipelineLayout layout, uint32_t set, uint32_t count,
                                                   const VkWriteDescriptorSet* writes) {
  deviceOf(cmd)->d.CmdPushDescriptorSetKHR(cmd, point, layout, set, count, writes);
  pushDescriptors(cmd, point, set, [&](DeviceState& dev, DescriptorSetState& pushed) {
    for (uint32_t i = 0; i < count; ++i) applyWrite(dev, pushed, writes[i]);
  });
}

VKAPI_ATTR void VKAPI_CALL CmdPushDescriptorSetWithTemplateKHR(VkCommandBuffer cmd, VkDescriptorUpdateTemplate handle,
                                                               VkPipelineLayout layout, uint32_t set, const void* data) {
  DeviceState* dev = deviceOf(cmd);
  dev->d.CmdPushDescriptorSetWithTemplateKHR(cmd, handle, layout, set, data);
  VkPipelineBindPoint point = VK_PIPELINE_BIND_POINT_MAX_ENUM;
  {
    std::lock_guard lock(dev->mutex);
    if (auto t = dev->pushTemplates.find(u64(handle)); t != dev->pushTemplates.end()) point = t->second.first;
  }
  pushDescriptors(cmd, point, set, [&](DeviceState& device, DescriptorSetState& pushed) {
    applyTemplate(device, pushed, device.pushTemplates[u64(handle)].second, data);
  });
}

VKAPI_ATTR void VKAPI_CALL CmdBindVertexBuffers(VkCommandBuffer cmd, uint32_t first, uint32_t count,
                                                const VkBuffer* buffers, const VkDeviceSize* offsets) {
  DeviceState* dev = deviceOf(cmd);
  dev->d.CmdBindVertexBuffers(cmd, first, count, buffers, offsets);
  std::lock_guard lock(dev->mutex);
  if (CommandBufferState* cb = cbState(*dev, cmd)) {
    for (uint32_t i = 0; i < count; ++i) cb->vertexBuffers[first + i] = u64(buffers[i]);
  }
}

VKAPI_ATTR void VKAPI_CALL CmdBindVertexBuffers2(VkCommandBuffer cmd, uint32_t first, uint32_t count,
                                                 const VkBuffer* buffers, const VkDeviceSize* offsets,
                                                 const VkDeviceSize* sizes, const VkDeviceSize* strides) {
  DeviceState* dev = deviceOf(cmd);
  dev->d.CmdBindVertexBuffers2(cmd, first, count, buffers, offsets, sizes, strides);
  std::lock_guard lock(dev->mutex);
  if (CommandBufferState* cb = cbState(*dev, cmd)) {
    for (uint32_t i = 0; i < count; ++i) cb->vertexBuffers[first + i] = u64(buffers[i]);
  }
}

VKAPI_ATTR void VKAPI_CALL CmdBindIndexBuffer(VkCommandBuffer cmd, VkBuffer buffer, VkDeviceSize offset,
                                              VkIndexType type) {
  DeviceState* dev = deviceOf(cmd);
  dev->d.CmdBindIndexBuffer(cmd, buffer, offset, type);
  std::lock_guard lock(dev->mutex);
  if (CommandBufferState* cb = cbState(*dev, cmd)) {
    cb->indexBuffer = u64(buffer);
    cb->indexBytes = type == VK_INDEX_TYPE_UINT16 ? 2 : type == VK_INDEX_TYPE_UINT8_EXT ? 1 : 4;
  }
}

// Every draw and dispatch: the pass it belongs to, its counter region.
void prepareDraw(DeviceState& dev, VkCommandBuffer cmd, bool dispatch, uint64_t indices = 0) {
  std::lock_guard lock(dev.mutex);
  CommandBufferState* cb = cbState(dev, cmd);
  if (cb == nullptr || !dev.counting) return;
  cb->work = true;
  if (!cb->counted) return;
  if (!cb->secondary) {
    if (dispatch) {
      const std::string label = cb->labels.empty() ? "" : cb->labels.back();
      if (cb->currentPass < 0 || cb->passes[size_t(cb->currentPass)].label != label) {
        closePass(dev, *cb);
        openPass(dev, *cb, "compute");
      }
    } else if (cb->currentPass < 0) {
      return;  // a draw outside any pass cannot happen in valid usage
    }
    PassScope& pass = cb->passes[size_t(cb->currentPass)];
    (dispatch ? pass.dispatches : pass.draws) += 1;
    if (indices > 0) pass.indexReads[{cb->indexBuffer, cb->indexBytes}] += indices;
  }
  if (!dispatch) bindForCoverage(dev, *cb);
  beforeDraw(dev, *cb, dispatch ? 1 : 0, dispatch);
}

VKAPI_ATTR void VKAPI_CALL CmdDraw(VkCommandBuffer cmd, uint32_t vertices, uint32_t instances, uint32_t firstVertex,
                                   uint32_t firstInstance) {
  DeviceState* dev = deviceOf(cmd);
  prepareDraw(*dev, cmd, false);
  dev->d.CmdDraw(cmd, vertices, instances, firstVertex, firstInstance);
}

VKAPI_ATTR void VKAPI_CALL CmdDrawIndexed(VkCommandBuffer cmd, uint32_t indices, uint32_t instances, uint32_t firstIndex,
                                          int32_t vertexOffset, uint32_t firstInstance) {
  DeviceState* dev = deviceOf(cmd);
  prepareDraw(*dev, cmd, false, uint64_t(indices) * instances);
  dev->d.CmdDrawIndexed(cmd, indices, instances, firstIndex, vertexOffset, firstInstance);
}

VKAPI_ATTR void VKAPI_CALL CmdDrawIndirect(VkCommandBuffer cmd, VkBuffer buffer, VkDeviceSize offset, uint32_t count,
                                           uint32_t stride) {
  DeviceState* dev = deviceOf(cmd);
  prepareDraw(*dev, cmd, false);
  dev->d.CmdDrawIndirect(cmd, buffer, offset, count, stride);
}

// Indexed indirect draws: their parameters are read back after their pass (indirect.cpp).
void noteIndirect(DeviceState& dev, VkCommandBuffer cmd, VkBuffer buffer, VkDeviceSize offset, uint32_t maxDraws,
                  uint32_t stride, VkBuffer countBuffer = VK_NULL_HANDLE, VkDeviceSize countOffset = 0) {
  std::lock_guard lock(dev.mutex);
  if (CommandBufferState* cb = cbState(dev, cmd)) {
    noteIndexedIndirect(dev, *cb, buffer, offset, maxDraws, stride, countBuffer, countOffset);
  }
}

VKAPI_ATTR void VKAPI_CALL CmdDrawIndexedIndirect(VkCommandBuffer cmd, VkBuffer buffer, VkDeviceSize offset,
                                                  uint32_t count, uint32_t stride) {
  DeviceState* dev = deviceOf(cmd);
  prepareDraw(*dev, cmd, false);
  noteIndirect(*dev, cmd, buffer, offset, count, stride);
  dev->d.CmdDrawIndexedIndirect(cmd, buffer, offset, count, stride);
}

VKAPI_ATTR void VKAPI_CALL CmdDrawIndirectCount(VkCommandBuffer cmd, VkBuffer buffer, VkDeviceSize offset,
                                                VkBuffer countBuffer, VkDeviceSize countOffset, uint32_t maxCount,
                                                uint32_t stride) {
  DeviceState* dev = deviceOf(cmd);
  prepareDraw(*dev, cmd, false);
  dev->d.CmdDrawIndirectCount(cmd, buffer, offset, countBuffer, countOffset, maxCount, stride);
}

VKAPI_ATTR void VKAPI_CALL CmdDrawIndexedIndirectCount(VkCommandBuffer cmd, VkBuffer buffer, VkDeviceSize offset,
                                                       VkBuffer countBuffer, VkDeviceSize countOffset,
                                                       uint32_t maxCount, uint32_t stride) {
  DeviceState* dev = deviceOf(cmd);
  prepareDraw(*dev, cmd, false);
  noteIndirect(*dev, cmd, buffer, offset, maxCount, stride, countBuffer, countOffset);
  dev->d.CmdDrawIndexedIndirectCount(cmd, buffer, offset, countBuffer, countOffset, maxCount, stride);
}

VKAPI_ATTR void VKAPI_CALL CmdDrawMultiEXT(VkCommandBuffer cmd, uint32_t count, const VkMultiDrawInfoEXT* info,
                                           uint32_t instances, uint32_t firstInstance, uint32_t stride) {
  DeviceState* dev = deviceOf(cmd);
  prepareDraw(*dev, cmd, false);
  dev->d.CmdDrawMultiEXT(cmd, count, info, instances, firstInstance, stride);
}

VKAPI_ATTR void VKAPI_CALL CmdDrawMultiIndexedEXT(VkCommandBuffer cmd, uint32_t count,
                                                  const VkMultiDrawIndexedInfoEXT* info, uint32_t instances,
                                                  uint32_t firstInstance, uint32_t stride, const int32_t* vertexOffset) {
  DeviceState* dev = deviceOf(cmd);
  uint64_t indices = 0;
  for (uint32_t i = 0; i < count; ++i) {
    indices += reinterpret_cast<const VkMultiDrawIndexedInfoEXT*>(reinterpret_cast<const uint8_t*>(info) +
                                                                  size_t(i) * stride)->indexCount;
  }
  prepareDraw(*dev, cmd, false, indices * instances);
  dev->d.CmdDrawMultiIndexedEXT(cmd, count, info, instances, firstInstance, stride, vertexOffset);
}

VKAPI_ATTR void VKAPI_CALL CmdDrawMeshTasksEXT(VkCommandBuffer cmd, uint32_t x, uint32_t y, uint32_t z) {
  DeviceState* dev = deviceOf(cmd);
  prepareDraw(*dev, cmd, false);
  dev->d.CmdDrawMeshTasksEXT(cmd, x, y, z);
}

VKAPI_ATTR void VKAPI_CALL CmdDrawMeshTasksIndirectEXT(VkCommandBuffer cmd, VkBuffer buffer, VkDeviceSize offset,
                                                       uint32_t count, uint32_t stride) {
  DeviceState* dev = deviceOf(cmd);
  prepareDraw(*dev, cmd, false);
  dev->d.CmdDrawMeshTasksIndirectEXT(cmd, buffer, offset, count, stride);
}

VKAPI_ATTR void VKAPI_CALL CmdDrawMeshTasksIndirectCountEXT(VkCommandBuffer cmd, VkBuffer buffer, VkDeviceSize offset,
                                                            VkBuffer countBuffer, VkDeviceSize countOffset,
                                                            uint32_t maxCount, uint32_t stride) {
  DeviceState* dev = deviceOf(cmd);
  prepareDraw(*dev, cmd, false);
  dev->d.CmdDrawMeshTasksIndirectCountEXT(cmd, buffer, offset, countBuffer, countOffset, maxCount, stride);
}

VKAPI_ATTR void VKAPI_CALL CmdDispatch(VkCommandBuffer cmd, uint32_t x, uint32_t y, uint32_t z) {
  DeviceState* dev = deviceOf(cmd);
  prepareDraw(*dev, cmd, true);
  dev->d.CmdDispatch(cmd, x, y, z);
}

VKAPI_ATTR void VKAPI_CALL CmdDispatchBase(VkCommandBuffer cmd, uint32_t bx, uint32_t by, uint32_t bz, uint32_t x,
                                           uint32_t y, uint32_t z) {
  DeviceState* dev = deviceOf(cmd);
  prepareDraw(*dev, cmd, true);
  dev->d.CmdDispatchBase(cmd, bx, by, bz, x, y, z);
}

VKAPI_ATTR void VKAPI_CALL CmdDispatchIndirect(VkCommandBuffer cmd, VkBuffer buffer, VkDeviceSize offset) {
  DeviceState* dev = deviceOf(cmd);
  prepareDraw(*dev, cmd, true);
  dev->d.CmdDispatchIndirect(cmd, buffer, offset);
}

// A primary recorded outside the window that executes secondaries recorded
// for counting: their regions are read only to zero them.
void drainSecondaries(DeviceState& dev, CommandBufferState& cb, uint32_t count, const VkCommandBuffer* secondaries) {
  std::set<VkDeviceSize> have;
  for (const auto& r : cb.regions) have.insert(r.offset);
  for (uint32_t i = 0; i < count; ++i) {
    CommandBufferState* s = cbState(dev, secondaries[i]);
    if (s == nullptr) continue;
    for (Region r : s->regions) {
      if (!have.insert(r.offset).second) continue;
      r.pass = kDrainOnly;
      cb.regions.push_back(std::move(r));
    }
  }
}

VKAPI_ATTR void VKAPI_CALL CmdExecuteCommands(VkCommandBuffer cmd, uint32_t count, const VkCommandBuffer* secondaries) {
  DeviceState* dev = deviceOf(cmd);
  std::lock_guard lock(dev->mutex);
  CommandBufferState* cb = cbState(*dev, cmd);
  // Outside a render pass the secondaries are a pass of their own, timed
  // around them, with no query active while they run.
  if (tracked(*dev, cb) && cb->counted && !cb->inRenderPass) {
    closePass(*dev, *cb);
    cb->secondaryContents = true;
    openPass(*dev, *cb, "secondary");
  }
  dev->d.CmdExecuteCommands(cmd, count, secondaries);
  if (cb == nullptr || cb->secondary || !dev->counting) return;
  cb->work = true;
  if (!cb->counted) return drainSecondaries(*dev, *cb, count, secondaries);
  if (cb->currentPass < 0) return;
  // The secondaries' regions count for the pass that executes them; a region
  // executed twice in one primary is read back once.
  std::set<VkDeviceSize> have;
  for (const auto& r : cb->regions) have.insert(r.offset);
  for (uint32_t i = 0; i < count; ++i) {
    CommandBufferState* s = cbState(*dev, secondaries[i]);
    if (s == nullptr) continue;
    cb->uncountedSecondaries = cb->uncountedSecondaries || (s->work && !s->counted);
    for (Region r : s->regions) {
      if (!have.insert(r.offset).second) continue;
      resolveInherited(*cb, r);
      r.pass = uint32_t(cb->currentPass);
      cb->regions.push_back(std::move(r));
    }
    cb->passes[size_t(cb->currentPass)].draws += uint32_t(s->regions.size());
  }
  if (!cb->inRenderPass) {
    closePass(*dev, *cb);
    cb->secondaryContents = false;
  }
}

// ---------------------------------------------------------------- submission and frames

std::vector<VkCommandBuffer> collectBuffers(uint32_t count, const VkSubmitInfo* submits) {
  std::vector<VkCommandBuffer> out;
  for (uint32_t i = 0; i < count; ++i) {
    out.insert(out.end(), submits[i].pCommandBuffers, submits[i].pCommandBuffers + submits[i].commandBufferCount);
  }
  return out;
}

VKAPI_ATTR VkResult VKAPI_CALL QueueSubmit(VkQueue queue, uint32_t count, const VkSubmitInfo* submits, VkFence fence) {
  DeviceState* dev = deviceOf(queue);
  VkResult result = dev->d.QueueSubmit(queue, count, submits, fence);
  if (result != VK_SUCCESS) return result;
  std::lock_guard lock(dev->mutex);
  afterSubmit(*dev, queue, collectBuffers(count, submits));
  return result;
}

VKAPI_ATTR VkResult VKAPI_CALL QueueSubmit2(VkQueue queue, uint32_t count, const VkSubmitInfo2* submits, VkFence fence) {
  DeviceState* dev = deviceOf(queue);
  VkResult result = dev->d.QueueSubmit2(queue, count, submits, fence);
  if (result != VK_SUCCESS) return result;
  std::vector<VkCommandBuffer> buffers;
  for (uint32_t i = 0; i < count; ++i) {
    for (uint32_t c = 0; c < submits[i].commandBufferInfoCount; ++c) {
      buffers.push_back(submits[i].pCommandBufferInfos[c].commandBuffer);
    }
  }
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

PFN_vkVoidFunction interceptedDevice(std::string_view n) {
#define TALLY_DEVICE(fn) \
  if (n == "vk" #fn) return reinterpret_cast<PFN_vkVoidFunction>(fn);
#define TALLY_DEVICE_ALIAS(alias, fn) \
  if (n == "vk" #alias) return reinterpret_cast<PFN_vkVoidFunction>(fn);
  TALLY_DEVICE(GetDeviceProcAddr)
  TALLY_DEVICE(DestroyDevice)
  TALLY_DEVICE(DeviceWaitIdle)
  TALLY_DEVICE(QueueWaitIdle)
  TALLY_DEVICE(GetDeviceQueue)
  TALLY_DEVICE(GetDeviceQueue2)
  TALLY_DEVICE(CreateImage)
  TALLY_DEVICE(CreateBuffer)
  TALLY_DEVICE(CreateImageView)
  TALLY_DEVICE(CreateBufferView)
  TALLY_DEVICE(DestroyImage)
  TALLY_DEVICE(DestroyBuffer)
  TALLY_DEVICE(DestroyImageView)
  TALLY_DEVICE(DestroyBufferView)
  TALLY_DEVICE(DestroyFramebuffer)
  TALLY_DEVICE(SetDebugUtilsObjectNameEXT)
  TALLY_DEVICE(CreateSwapchainKHR)
  TALLY_DEVICE(GetSwapchainImagesKHR)
  TALLY_DEVICE(CreateRenderPass)
  TALLY_DEVICE(CreateRenderPass2)
  TALLY_DEVICE_ALIAS(CreateRenderPass2KHR, CreateRenderPass2)
  TALLY_DEVICE(CreateFramebuffer)
  TALLY_DEVICE(AllocateDescriptorSets)
  TALLY_DEVICE(FreeDescriptorSets)
  TALLY_DEVICE(ResetDescriptorPool)
  TALLY_DEVICE(DestroyDescriptorPool)
  TALLY_DEVICE(UpdateDescriptorSets)
  TALLY_DEVICE(CreateDescriptorUpdateTemplate)
  TALLY_DEVICE_ALIAS(CreateDescriptorUpdateTemplateKHR, CreateDescriptorUpdateTemplate)
  TALLY_DEVICE(UpdateDescriptorSetWithTemplate)
  TALLY_DEVICE_ALIAS(UpdateDescriptorSetWithTemplateKHR, UpdateDescriptorSetWithTemplate)
  TALLY_DEVICE(CreateShaderModule)
  TALLY_DEVICE(DestroyShaderModule)
  TALLY_DEVICE(CreatePipelineLayout)
  TALLY_DEVICE(DestroyPipelineLayout)
  TALLY_DEVICE(CreateGraphicsPipelines)
  TALLY_DEVICE(CreateComputePipelines)
  TALLY_DEVICE(DestroyPipeline)
  TALLY_DEVICE(CreateCommandPool)
  TALLY_DEVICE(DestroyCommandPool)
  TALLY_DEVICE(ResetCommandPool)
  TALLY_DEVICE(AllocateCommandBuffers)
  TALLY_DEVICE(FreeCommandBuffers)
  TALLY_DEVICE(BeginCommandBuffer)
  TALLY_DEVICE(EndCommandBuffer)
  TALLY_DEVICE(ResetCommandBuffer)
  TALLY_DEVICE(CmdBeginRenderPass)
  TALLY_DEVICE(CmdBeginRenderPass2)
  TALLY_DEVICE_ALIAS(CmdBeginRenderPass2KHR, CmdBeginRenderPass2)
  TALLY_DEVICE(CmdNextSubpass)
  TALLY_DEVICE(CmdNextSubpass2)
  TALLY_DEVICE_ALIAS(CmdNextSubpass2KHR, CmdNextSubpass2)
  TALLY_DEVICE(CmdEndRenderPass)
  TALLY_DEVICE(CmdEndRenderPass2)
  TALLY_DEVICE_ALIAS(CmdEndRenderPass2KHR, CmdEndRenderPass2)
  TALLY_DEVICE(CmdBeginRendering)
  TALLY_DEVICE_ALIAS(CmdBeginRenderingKHR, CmdBeginRendering)
  TALLY_DEVICE(CmdEndRendering)
  TALLY_DEVICE_ALIAS(CmdEndRenderingKHR, CmdEndRendering)
  TALLY_DEVICE(CmdBeginDebugUtilsLabelEXT)
  TALLY_DEVICE(CmdEndDebugUtilsLabelEXT)
  TALLY_DEVICE(CmdBeginQuery)
  TALLY_DEVICE(CmdEndQuery)
  TALLY_DEVICE(CmdBindPipeline)
  TALLY_DEVICE(CmdBindDescriptorSets)
  TALLY_DEVICE(CmdPushDescriptorSetKHR)
  TALLY_DEVICE(CmdPushDescriptorSetWithTemplateKHR)
  TALLY_DEVICE(CmdBindVertexBuffers)
  TALLY_DEVICE(CmdBindIndexBuffer)
  TALLY_DEVICE(CmdBindVertexBuffers2)
  TALLY_DEVICE_ALIAS(CmdBindVertexBuffers2EXT, CmdBindVertexBuffers2)
  TALLY_DEVICE(CmdDrawMultiEXT)
  TALLY_DEVICE(CmdSetAlphaToCoverageEnableEXT)
  TALLY_DEVICE(CmdDrawMultiIndexedEXT)
  TALLY_DEVICE(CmdDrawMeshTasksEXT)
  TALLY_DEVICE(CmdDrawMeshTasksIndirectEXT)
  TALLY_DEVICE(CmdDrawMeshTasksIndirectCountEXT)
  TALLY_DEVICE(CmdDraw)
  TALLY_DEVICE(CmdDrawIndexed)
  TALLY_DEVICE(CmdDrawIndirect)
  TALLY_DEVICE(CmdDrawIndexedIndirect)
  TALLY_DEVICE(CmdDrawIndirectCount)
  TALLY_DEVICE_ALIAS(CmdDrawIndirectCountKHR, CmdDrawIndirectCount)
  TALLY_DEVICE(CmdDrawIndexedIndirectCount)
  TALLY_DEVICE_ALIAS(CmdDrawIndexedIndirectCountKHR, CmdDrawIndexedIndirectCount)
  TALLY_DEVICE(CmdDispatch)
  TALLY_DEVICE(CmdDispatchBase)
  TALLY_DEVICE_ALIAS(CmdDispatchBaseKHR, CmdDispatchBase)
  TALLY_DEVICE(CmdDispatchIndirect)
  TALLY_DEVICE(CmdExecuteCommands)
  TALLY_DEVICE(QueueSubmit)
  TALLY_DEVICE(QueueSubmit2)
  TALLY_DEVICE_ALIAS(QueueSubmit2KHR, QueueSubmit2)
  TALLY_DEVICE(QueuePresentKHR)
#undef TALLY_DEVICE
#undef TALLY_DEVICE_ALIAS
  if (PFN_vkVoidFunction f = interceptedDynamicState(n)) return f;
  return interceptedUncounted(n);
}

}  // namespace

DeviceState* deviceFor(const void* handle) { return deviceOf(handle); }
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
