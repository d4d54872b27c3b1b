#include "descriptor_buffers_layer.hpp"

#include <algorithm>
#include <array>
#include <unordered_map>

#include "descriptor_buffers.hpp"
#include "device_objects.hpp"
#include "intercepts.hpp"

namespace tally::layer {

// What the layer keeps of descriptor buffers, per device.
struct DescriptorBufferDevice {
  bool enabled = false;  // the application enabled descriptorBuffer and bufferDeviceAddress
  bool robust = false;   // robustBufferAccess: buffer descriptors take their robust sizes
  VkPhysicalDeviceDescriptorBufferPropertiesEXT props = {
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DESCRIPTOR_BUFFER_PROPERTIES_EXT};
  PFN_vkGetDescriptorEXT getDescriptor = nullptr;
  PFN_vkGetDescriptorSetLayoutBindingOffsetEXT bindingOffset = nullptr;
  PFN_vkGetDescriptorSetLayoutSizeEXT layoutSize = nullptr;
  PFN_vkCmdBindDescriptorBuffersEXT bindBuffers = nullptr;
  PFN_vkCmdSetDescriptorBufferOffsetsEXT setOffsets = nullptr;
  PFN_vkCmdBindDescriptorBufferEmbeddedSamplersEXT embeddedSamplers = nullptr;
  PFN_vkGetBufferDeviceAddress bufferAddress = nullptr;
  PFN_vkBindBufferMemory2 bindMemory2 = nullptr;

  DescriptorCatalog catalog;
  AddressPlaces places;
  std::map<VkDescriptorType, size_t> seenSizes;
  std::unordered_map<uint64_t, VkBufferUsageFlags> bufferUsage;
  std::unordered_map<uint64_t, DescriptorSetLayoutOffsets> setLayouts;  // descriptor-buffer set layouts
  std::unordered_map<uint64_t, std::vector<uint64_t>> pipelineLayouts;  // descriptor-buffer pipeline layouts' sets

  // The layer's own: the counter set layout and the empty one between, and
  // its descriptor buffer, one counter descriptor per region offset in use.
  VkDescriptorSetLayout counterLayout = VK_NULL_HANDLE, emptyLayout = VK_NULL_HANDLE;
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  uint8_t* mapped = nullptr;
  VkDeviceAddress address = 0, counterAddress = 0;
  VkDeviceSize slotBytes = 0, bindingOffset0 = 0;
  std::unordered_map<VkDeviceSize, uint32_t> slotOf;  // region offset -> slot
  static constexpr uint32_t kMostSlots = 16384;  // regions are reused: a recording's few hundred, a frame's few thousand
  uint32_t slots = 0;  // within maxResourceDescriptorBufferRange

  // Per command buffer: the application's bound buffers and set offsets.
  struct Binds {
    std::vector<VkDeviceAddress> buffers;
    bool counterBound = false;   // the layer's buffer is appended, at index buffers.size()
    bool noRoom = false;         // the application bound as many as the device allows
    std::array<std::array<std::pair<uint32_t, VkDeviceSize>, 32>, 2> offsets{};
    std::array<uint32_t, 2> offsetsSet{};  // bit per set
    std::array<bool, 2> applicationPipeline{};  // its own pipeline bound in place of the twin (no room)
  };
  std::unordered_map<VkCommandBuffer, Binds> commandBuffers;
};

namespace {

DescriptorBufferDevice* state(const DeviceState& dev) { return dev.descriptorBuffers.get(); }

// The layer's descriptor buffer's creation usage, which its binding repeats.
constexpr VkBufferUsageFlags kOwnBufferUsage =
    VK_BUFFER_USAGE_RESOURCE_DESCRIPTOR_BUFFER_BIT_EXT | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT;

// Whether the layer counts descriptor-buffer pipelines: the bookkeeping
// below is kept only then, so an application that is not counted pays nothing.
bool active(const DeviceState& dev) {
  const DescriptorBufferDevice* s = state(dev);
  return s != nullptr && s->buffer != VK_NULL_HANDLE;
}

template <class T>
const T* findChained(const void* next, VkStructureType type) {
  for (auto* p = static_cast<const VkBaseInStructure*>(next); p != nullptr; p = p->pNext) {
    if (p->sType == type) return reinterpret_cast<const T*>(p);
  }
  return nullptr;
}

void note(DeviceState& dev, const std::string& line) {
  if (dev.notes.insert(line).second) log(line);
}

DescriptorTarget targetOf(DeviceState& dev, VkImageView view) {
  const Bound b = boundImage(dev, view);
  return {b.resource, b.format, b.aspect};
}

// What the descriptor vkGetDescriptorEXT made names; none for samplers (they read nothing counted).
std::optional<DescriptorTarget> describedTarget(DeviceState& dev, const VkDescriptorGetInfoEXT& info) {
  const auto& d = info.data;
  auto image = [&](const VkDescriptorImageInfo* i) -> std::optional<DescriptorTarget> {
    if (i == nullptr) return std::nullopt;
    return targetOf(dev, i->imageView);
  };
  auto address = [&](const VkDescriptorAddressInfoEXT* a) -> std::optional<DescriptorTarget> {
    if (a == nullptr) return std::nullopt;
    auto found = state(dev)->places.find(a->address);
    if (!found) return std::nullopt;
    return DescriptorTarget{found->second.buffer};
  };
  switch (info.type) {
    case VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER: return image(d.pCombinedImageSampler);
    case VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE: return image(d.pSampledImage);
    case VK_DESCRIPTOR_TYPE_STORAGE_IMAGE: return image(d.pStorageImage);
    case VK_DESCRIPTOR_TYPE_INPUT_ATTACHMENT: return image(d.pInputAttachmentImage);
    case VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER: return address(d.pUniformBuffer);
    case VK_DESCRIPTOR_TYPE_STORAGE_BUFFER: return address(d.pStorageBuffer);
    case VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER: return address(d.pUniformTexelBuffer);
    case VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER: return address(d.pStorageTexelBuffer);
    default: return std::nullopt;
  }
}

// ---------------------------------------------------------------- intercepted calls

VKAPI_ATTR void VKAPI_CALL GetDescriptorEXT(VkDevice device, const VkDescriptorGetInfoEXT* info, size_t size,
                                            void* descriptor) {
  DeviceState* dev = deviceOf(device);
  DescriptorBufferDevice* s = state(*dev);
  s->getDescriptor(device, info, size, descriptor);
  if (!active(*dev)) return;
  std::lock_guard lock(dev->mutex);
  s->seenSizes[info->type] = size;
  if (auto target = describedTarget(*dev, *info)) s->catalog.remember(info->type, descriptor, size, *target);
}

VKAPI_ATTR VkResult VKAPI_CALL MapMemory(VkDevice device, VkDeviceMemory memory, VkDeviceSize offset,
                                         VkDeviceSize size, VkMemoryMapFlags flags, void** data) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.MapMemory(device, memory, offset, size, flags, data);
  if (result != VK_SUCCESS || !active(*dev)) return result;
  std::lock_guard lock(dev->mutex);
  state(*dev)->places.mapped(memory, offset, size == VK_WHOLE_SIZE ? ~VkDeviceSize(0) - offset : size, *data);
  return result;
}

VKAPI_ATTR void VKAPI_CALL UnmapMemory(VkDevice device, VkDeviceMemory memory) {
  DeviceState* dev = deviceOf(device);
  if (active(*dev)) {
    std::lock_guard lock(dev->mutex);
    state(*dev)->places.unmapped(memory);
  }
  dev->d.UnmapMemory(device, memory);
}

VKAPI_ATTR void VKAPI_CALL FreeMemory(VkDevice device, VkDeviceMemory memory, const VkAllocationCallbacks* alloc) {
  DeviceState* dev = deviceOf(device);
  if (active(*dev)) {
    std::lock_guard lock(dev->mutex);
    state(*dev)->places.freed(memory);
  }
  dev->d.FreeMemory(device, memory, alloc);
}

// The application's buffers, and the layer's after them where the command
// buffer counts and the device has room for one more.
VKAPI_ATTR void VKAPI_CALL CmdBindDescriptorBuffersEXT(VkCommandBuffer cmd, uint32_t count,
                                                       const VkDescriptorBufferBindingInfoEXT* infos) {
  DeviceState* dev = deviceOf(cmd);
  DescriptorBufferDevice* s = state(*dev);
  if (!active(*dev)) return s->bindBuffers(cmd, count, infos);
  std::vector<VkDescriptorBufferBindingInfoEXT> all(infos, infos + count);
  {
    std::lock_guard lock(dev->mutex);
    CommandBufferState* cb = cbState(*dev, cmd);
    auto& binds = s->commandBuffers[cmd];
    binds.buffers.clear();
    uint32_t resource = 0;
    for (uint32_t i = 0; i < count; ++i) {
      binds.buffers.push_back(infos[i].address);
      resource += (infos[i].usage & VK_BUFFER_USAGE_RESOURCE_DESCRIPTOR_BUFFER_BIT_EXT) ? 1 : 0;
    }
    binds.counterBound = false;
    binds.noRoom = false;
    if (cb != nullptr && cb->counted && s->buffer != VK_NULL_HANDLE) {
      if (roomForCounterBuffer(s->props, count, resource)) {
        all.push_back({VK_STRUCTURE_TYPE_DESCRIPTOR_BUFFER_BINDING_INFO_EXT, nullptr, s->address,
                       kOwnBufferUsage});
        binds.counterBound = true;
      } else {
        binds.noRoom = true;
        note(*dev, "descriptor buffers: the application binds as many descriptor buffers as the device allows "
                   "(maxDescriptorBufferBindings, maxResourceDescriptorBufferBindings), leaving none for the "
                   "layer's counters: its draws run the application's own pipelines, uncounted");
      }
      for (auto& bp : cb->bind) bp.dirty = true;
    }
  }
  s->bindBuffers(cmd, uint32_t(all.size()), all.data());
}

VKAPI_ATTR void VKAPI_CALL CmdSetDescriptorBufferOffsetsEXT(VkCommandBuffer cmd, VkPipelineBindPoint point,
                                                            VkPipelineLayout layout, uint32_t first, uint32_t count,
                                                            const uint32_t* indices, const VkDeviceSize* offsets) {
  DeviceState* dev = deviceOf(cmd);
  DescriptorBufferDevice* s = state(*dev);
  s->setOffsets(cmd, point, layout, first, count, indices, offsets);
  if (!active(*dev) || (point != VK_PIPELINE_BIND_POINT_GRAPHICS && point != VK_PIPELINE_BIND_POINT_COMPUTE)) return;
  std::lock_guard lock(dev->mutex);
  const uint32_t bindPoint = point == VK_PIPELINE_BIND_POINT_COMPUTE ? 1 : 0;
  auto& binds = s->commandBuffers[cmd];
  for (uint32_t i = 0; i < count && first + i < 32; ++i) {
    binds.offsets[bindPoint][first + i] = {indices[i], offsets[i]};
    binds.offsetsSet[bindPoint] |= 1u << (first + i);
  }
  // Sets of an incompatible layout disturb the ones after them, the counter set among them.
  if (CommandBufferState* cb = cbState(*dev, cmd)) cb->bind[bindPoint].dirty = true;
}

VKAPI_ATTR void VKAPI_CALL CmdBindDescriptorBufferEmbeddedSamplersEXT(VkCommandBuffer cmd, VkPipelineBindPoint point,
                                                                      VkPipelineLayout layout, uint32_t set) {
  DeviceState* dev = deviceOf(cmd);
  state(*dev)->embeddedSamplers(cmd, point, layout, set);
  if (!active(*dev) || (point != VK_PIPELINE_BIND_POINT_GRAPHICS && point != VK_PIPELINE_BIND_POINT_COMPUTE)) return;
  std::lock_guard lock(dev->mutex);
  const uint32_t bindPoint = point == VK_PIPELINE_BIND_POINT_COMPUTE ? 1 : 0;
  if (set < 32) state(*dev)->commandBuffers[cmd].offsetsSet[bindPoint] &= ~(1u << set);
  if (CommandBufferState* cb = cbState(*dev, cmd)) cb->bind[bindPoint].dirty = true;
}

}  // namespace

PFN_vkVoidFunction interceptedDescriptorBuffers(std::string_view name) {
  TALLY_INTERCEPT(GetDescriptorEXT)
  TALLY_INTERCEPT(MapMemory)
  TALLY_INTERCEPT(UnmapMemory)
  TALLY_INTERCEPT(FreeMemory)
  TALLY_INTERCEPT(CmdBindDescriptorBuffersEXT)
  TALLY_INTERCEPT(CmdSetDescriptorBufferOffsetsEXT)
  TALLY_INTERCEPT(CmdBindDescriptorBufferEmbeddedSamplersEXT)
  return nullptr;
}

// ---------------------------------------------------------------- set-up

namespace {
uint32_t counterSlot(DeviceState& dev, DescriptorBufferDevice& s, VkDeviceSize offset);  // below
}  // namespace

void prepareDescriptorBuffers(DeviceState& dev, const VkDeviceCreateInfo& info) {
  auto s = std::make_shared<DescriptorBufferDevice>();
  dev.descriptorBuffers = s;
  auto load = [&](const char* name) { return dev.d.GetDeviceProcAddr(dev.device, name); };
  s->getDescriptor = reinterpret_cast<PFN_vkGetDescriptorEXT>(load("vkGetDescriptorEXT"));
  s->bindingOffset = reinterpret_cast<PFN_vkGetDescriptorSetLayoutBindingOffsetEXT>(
      load("vkGetDescriptorSetLayoutBindingOffsetEXT"));
  s->layoutSize = reinterpret_cast<PFN_vkGetDescriptorSetLayoutSizeEXT>(load("vkGetDescriptorSetLayoutSizeEXT"));
  s->bindBuffers = reinterpret_cast<PFN_vkCmdBindDescriptorBuffersEXT>(load("vkCmdBindDescriptorBuffersEXT"));
  s->setOffsets = reinterpret_cast<PFN_vkCmdSetDescriptorBufferOffsetsEXT>(load("vkCmdSetDescriptorBufferOffsetsEXT"));
  s->embeddedSamplers = reinterpret_cast<PFN_vkCmdBindDescriptorBufferEmbeddedSamplersEXT>(
      load("vkCmdBindDescriptorBufferEmbeddedSamplersEXT"));
  s->bindMemory2 = reinterpret_cast<PFN_vkBindBufferMemory2>(load("vkBindBufferMemory2"));
  if (s->bindMemory2 == nullptr) s->bindMemory2 = reinterpret_cast<PFN_vkBindBufferMemory2>(load("vkBindBufferMemory2KHR"));
  for (const char* name : {"vkGetBufferDeviceAddress", "vkGetBufferDeviceAddressKHR", "vkGetBufferDeviceAddressEXT"}) {
    if (s->bufferAddress == nullptr) s->bufferAddress = reinterpret_cast<PFN_vkGetBufferDeviceAddress>(load(name));
  }
  auto* features = findChained<VkPhysicalDeviceDescriptorBufferFeaturesEXT>(
      info.pNext, VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DESCRIPTOR_BUFFER_FEATURES_EXT);
  auto* v12 = findChained<VkPhysicalDeviceVulkan12Features>(info.pNext,
                                                            VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES);
  auto* bda = findChained<VkPhysicalDeviceBufferDeviceAddressFeatures>(
      info.pNext, VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_BUFFER_DEVICE_ADDRESS_FEATURES);
  const bool addresses = (v12 != nullptr && v12->bufferDeviceAddress) || (bda != nullptr && bda->bufferDeviceAddress);
  const bool functions = s->getDescriptor != nullptr && s->bindingOffset != nullptr && s->layoutSize != nullptr &&
                         s->bindBuffers != nullptr && s->setOffsets != nullptr && s->embeddedSamplers != nullptr &&
                         s->bufferAddress != nullptr && s->bindMemory2 != nullptr;
  s->enabled = features != nullptr && features->descriptorBuffer && addresses && functions &&
               dev.instance->getProperties2 != nullptr;
  if (!s->enabled) return;
  VkPhysicalDeviceProperties2 props2 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, &s->props};
  dev.instance->getProperties2(dev.physical, &props2);
  s->props.pNext = nullptr;
  const VkPhysicalDeviceFeatures* core = info.pEnabledFeatures;
  if (auto* f2 = findChained<VkPhysicalDeviceFeatures2>(info.pNext, VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2)) {
    core = &f2->features;
  }
  s->robust = core != nullptr && core->robustBufferAccess;
}

VkBufferUsageFlags counterBufferAddressUsage(const DeviceState& dev) {
  return state(dev) != nullptr && state(dev)->enabled ? VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT : 0;
}

void setupDescriptorBuffers(DeviceState& dev) {
  DescriptorBufferDevice* s = state(dev);
  if (s == nullptr || !s->enabled) return;
  auto refuse = [&](const std::string& why) {
    note(dev, "descriptor buffers: " + why + ": pipelines whose layouts use them run unchanged, uncounted");
  };
  VkDescriptorSetLayoutBinding binding = {0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_ALL, nullptr};
  VkDescriptorSetLayoutCreateInfo info = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  info.flags = VK_DESCRIPTOR_SET_LAYOUT_CREATE_DESCRIPTOR_BUFFER_BIT_EXT;
  info.bindingCount = 1;
  info.pBindings = &binding;
  dev.d.CreateDescriptorSetLayout(dev.device, &info, nullptr, &s->counterLayout);
  info.bindingCount = 0;
  dev.d.CreateDescriptorSetLayout(dev.device, &info, nullptr, &s->emptyLayout);
  if (s->counterLayout == VK_NULL_HANDLE || s->emptyLayout == VK_NULL_HANDLE) {
    return refuse("the counter set layout for descriptor buffers could not be created");
  }
  VkDeviceSize layoutBytes = 0;
  s->layoutSize(dev.device, s->counterLayout, &layoutBytes);
  s->bindingOffset(dev.device, s->counterLayout, 0, &s->bindingOffset0);
  const VkDeviceSize align = std::max<VkDeviceSize>(s->props.descriptorBufferOffsetAlignment, 1);
  s->slotBytes = std::max<VkDeviceSize>((layoutBytes + align - 1) / align * align, align);
  s->slots = uint32_t(std::min<VkDeviceSize>(DescriptorBufferDevice::kMostSlots,
                                             s->props.maxResourceDescriptorBufferRange / s->slotBytes));
  if (s->slots == 0) return refuse("the device's descriptor buffers cannot hold the layer's counter descriptor");
  if (!createBuffer(dev, s->slotBytes * s->slots, kOwnBufferUsage,
                    VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                    VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, s->buffer, s->memory)) {
    return refuse("the layer's descriptor buffer could not be allocated");
  }
  void* host = nullptr;
  if (dev.d.MapMemory(dev.device, s->memory, 0, VK_WHOLE_SIZE, 0, &host) != VK_SUCCESS) {
    dev.d.DestroyBuffer(dev.device, s->buffer, nullptr);
    dev.d.FreeMemory(dev.device, s->memory, nullptr);
    s->buffer = VK_NULL_HANDLE;
    s->memory = VK_NULL_HANDLE;
    return refuse("the layer's descriptor buffer could not be mapped");
  }
  s->mapped = static_cast<uint8_t*>(host);
  VkBufferDeviceAddressInfo at = {VK_STRUCTURE_TYPE_BUFFER_DEVICE_ADDRESS_INFO, nullptr, s->buffer};
  s->address = s->bufferAddress(dev.device, &at);
  at.buffer = dev.counterBuffer;
  s->counterAddress = s->bufferAddress(dev.device, &at);
  counterSlot(dev, *s, 0);  // the sink's, slot 0
}

void destroyDescriptorBuffers(DeviceState& dev) {
  DescriptorBufferDevice* s = state(dev);
  if (s == nullptr) return;
  if (s->buffer != VK_NULL_HANDLE) dev.d.DestroyBuffer(dev.device, s->buffer, nullptr);
  if (s->memory != VK_NULL_HANDLE) dev.d.FreeMemory(dev.device, s->memory, nullptr);
  if (s->counterLayout != VK_NULL_HANDLE) dev.d.DestroyDescriptorSetLayout(dev.device, s->counterLayout, nullptr);
  if (s->emptyLayout != VK_NULL_HANDLE) dev.d.DestroyDescriptorSetLayout(dev.device, s->emptyLayout, nullptr);
  s->buffer = VK_NULL_HANDLE;
  s->memory = VK_NULL_HANDLE;
  s->counterLayout = s->emptyLayout = VK_NULL_HANDLE;
}

// ---------------------------------------------------------------- layouts

void noteBufferMemory(DeviceState& dev, VkBuffer buffer, VkDeviceMemory memory, VkDeviceSize offset) {
  DescriptorBufferDevice* s = state(dev);
  if (!active(dev)) return;
  auto usage = s->bufferUsage.find(u64(buffer));
  if (usage == s->bufferUsage.end() || !(usage->second & VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT)) return;
  auto resource = dev.resources.find(u64(buffer));
  if (resource == dev.resources.end()) return;
  VkBufferDeviceAddressInfo info = {VK_STRUCTURE_TYPE_BUFFER_DEVICE_ADDRESS_INFO, nullptr, buffer};
  s->places.add(s->bufferAddress(dev.device, &info), {u64(buffer), resource->second.size, memory, offset});
}


bool isDescriptorBufferLayout(const DeviceState& dev, VkPipelineLayout layout) {
  const DescriptorBufferDevice* s = state(dev);
  return s != nullptr && s->pipelineLayouts.count(u64(layout)) != 0;
}

void noteDescriptorSetLayout(DeviceState& dev, VkDescriptorSetLayout layout, const VkDescriptorSetLayoutCreateInfo& info) {
  DescriptorBufferDevice* s = state(dev);
  if (s == nullptr) return;
  DescriptorSetLayoutOffsets offsets;
  const bool forBuffers = (info.flags & VK_DESCRIPTOR_SET_LAYOUT_CREATE_DESCRIPTOR_BUFFER_BIT_EXT) != 0;
  if (forBuffers && active(dev)) {
    for (uint32_t i = 0; i < info.bindingCount; ++i) {
      const auto& b = info.pBindings[i];
      DescriptorBinding entry{0, b.descriptorType, b.descriptorCount};
      s->bindingOffset(dev.device, layout, b.binding, &entry.offset);
      offsets[b.binding] = entry;
    }
  }
  std::lock_guard lock(dev.mutex);
  // Always: a handle the driver gives again may have been a descriptor-buffer layout's.
  if (forBuffers) {
    s->setLayouts[u64(layout)] = std::move(offsets);
  } else {
    s->setLayouts.erase(u64(layout));
  }
}

void noteBufferUsage(DeviceState& dev, VkBuffer buffer, VkBufferUsageFlags usage) {
  DescriptorBufferDevice* s = state(dev);
  if (!active(dev)) return;
  s->places.remove(u64(buffer));
  s->bufferUsage[u64(buffer)] = usage;
}

bool countsDescriptorBuffers(const DeviceState& dev) { return active(dev); }

bool descriptorBufferLayouts(const DeviceState& dev, const VkPipelineLayoutCreateInfo& info,
                             VkDescriptorSetLayout& counter, VkDescriptorSetLayout& empty) {
  const DescriptorBufferDevice* s = state(dev);
  if (s == nullptr) return false;
  for (uint32_t i = 0; i < info.setLayoutCount; ++i) {
    if (s->setLayouts.count(u64(info.pSetLayouts[i])) > 0) {
      counter = s->counterLayout;
      empty = s->emptyLayout;
      return true;
    }
  }
  return false;
}

void notePipelineLayout(DeviceState& dev, VkPipelineLayout layout, const VkPipelineLayoutCreateInfo& info) {
  DescriptorBufferDevice* s = state(dev);
  if (s == nullptr) return;
  VkDescriptorSetLayout counter = VK_NULL_HANDLE, empty = VK_NULL_HANDLE;
  if (!descriptorBufferLayouts(dev, info, counter, empty)) {
    s->pipelineLayouts.erase(u64(layout));
    return;
  }
  std::vector<uint64_t> sets;
  for (uint32_t i = 0; i < info.setLayoutCount; ++i) sets.push_back(u64(info.pSetLayouts[i]));
  s->pipelineLayouts[u64(layout)] = std::move(sets);
}

// ---------------------------------------------------------------- draws

std::optional<DescriptorPlace> descriptorBufferAddress(const DeviceState& dev, const CommandBufferState& cb,
                                                       uint32_t bindPoint, const PipelineInfo& pipeline,
                                                       const spirv::Site& site, uint32_t element) {
  const DescriptorBufferDevice* s = state(dev);
  if (s == nullptr || site.set < 0 || site.set >= 32 || site.binding < 0) return std::nullopt;
  auto layout = s->pipelineLayouts.find(u64(pipeline.layout));
  if (layout == s->pipelineLayouts.end() || size_t(site.set) >= layout->second.size()) return std::nullopt;
  auto setLayout = s->setLayouts.find(layout->second[size_t(site.set)]);
  if (setLayout == s->setLayouts.end()) return std::nullopt;
  auto binding = setLayout->second.find(uint32_t(site.binding));
  auto binds = s->commandBuffers.find(cb.handle);
  if (binding == setLayout->second.end() || binds == s->commandBuffers.end()) return std::nullopt;
  if (!(binds->second.offsetsSet[bindPoint] & (1u << site.set))) return std::nullopt;
  const auto [index, offset] = binds->second.offsets[bindPoint][size_t(site.set)];
  const uint32_t at = site.slotCount > 1 ? element : site.index.value_or(0);
  const VkDeviceSize size = descriptorSize(s->props, s->robust, s->seenSizes, binding->second.type);
  auto address = descriptorAddress(binds->second.buffers, index, offset, binding->second, at, size);
  if (!address) return std::nullopt;
  return DescriptorPlace{0, *address, binding->second.type};
}

bool descriptorBuffersReady(DeviceState& dev, CommandBufferState& cb, uint32_t bindPoint) {
  DescriptorBufferDevice* s = state(dev);
  const auto& bp = cb.bind[bindPoint];
  if (s == nullptr || !bp.pipeline || s->pipelineLayouts.count(u64(bp.pipeline->layout)) == 0) return true;
  auto& binds = s->commandBuffers[cb.handle];
  const VkPipelineBindPoint point = bindPoint == 1 ? VK_PIPELINE_BIND_POINT_COMPUTE : VK_PIPELINE_BIND_POINT_GRAPHICS;
  // Once a draw of this recording ran the application's own pipeline, each
  // later one binds the pipeline it needs: the layer sees no draw's end.
  if (!binds.counterBound) {
    dev.d.CmdBindPipeline(cb.handle, point, reinterpret_cast<VkPipeline>(bp.pipeline->handle));
    binds.applicationPipeline[bindPoint] = true;
    if (!binds.noRoom) {
      note(dev, "descriptor buffers: a draw used a descriptor-buffer pipeline with no descriptor buffer bound "
                "by vkCmdBindDescriptorBuffersEXT in its command buffer: it ran uncounted");
    }
    return false;
  }
  if (binds.applicationPipeline[bindPoint]) dev.d.CmdBindPipeline(cb.handle, point, bp.pipeline->instrumented);
  return true;
}

namespace {

// The slot of the descriptor of the counters at `offset`, written the first
// time: a region's offset keeps its slot. Slot 0 is the arena's sink (offset
// 0), where regions count once the slots run out, as when the arena is full.
uint32_t counterSlot(DeviceState& dev, DescriptorBufferDevice& s, VkDeviceSize offset) {
  if (auto slot = s.slotOf.find(offset); slot != s.slotOf.end()) return slot->second;
  if (s.slotOf.size() >= s.slots) {
    note(dev, "descriptor buffers: the layer's descriptor buffer is full: some draws were not counted");
    return 0;
  }
  const uint32_t slot = uint32_t(s.slotOf.size());
  s.slotOf.emplace(offset, slot);
  VkDescriptorAddressInfoEXT range = {VK_STRUCTURE_TYPE_DESCRIPTOR_ADDRESS_INFO_EXT};
  range.address = s.counterAddress + offset;
  range.range = dev.regionRange;
  VkDescriptorGetInfoEXT info = {VK_STRUCTURE_TYPE_DESCRIPTOR_GET_INFO_EXT};
  info.type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  info.data.pStorageBuffer = &range;
  const size_t size = s.robust ? s.props.robustStorageBufferDescriptorSize : s.props.storageBufferDescriptorSize;
  s.getDescriptor(dev.device, &info, size, s.mapped + slot * s.slotBytes + s.bindingOffset0);
  return slot;
}

}  // namespace

bool bindCounterDescriptor(DeviceState& dev, CommandBufferState& cb, uint32_t bindPoint, const PipelineInfo& pipeline,
                           VkDeviceSize offset) {
  DescriptorBufferDevice* s = state(dev);
  if (s == nullptr || s->pipelineLayouts.count(u64(pipeline.layout)) == 0) return false;
  auto& binds = s->commandBuffers[cb.handle];
  if (!binds.counterBound) return true;  // descriptorBuffersReady kept the draw uncounted
  const uint32_t slot = counterSlot(dev, *s, offset);
  const uint32_t index = uint32_t(binds.buffers.size());
  const VkDeviceSize at = slot * s->slotBytes;
  s->setOffsets(cb.handle, bindPoint == 1 ? VK_PIPELINE_BIND_POINT_COMPUTE : VK_PIPELINE_BIND_POINT_GRAPHICS,
                pipeline.layout, dev.counterSet, 1, &index, &at);
  return true;
}

// ---------------------------------------------------------------- submissions

void nameDescriptorBufferSlots(DeviceState& dev, std::vector<Region>& regions) {
  DescriptorBufferDevice* s = state(dev);
  if (s == nullptr) return;
  for (Region& region : regions) {
    for (const DescriptorPlace& place : region.descriptorAt) {
      if (place.slot >= region.slotResources.size()) continue;
      size_t available = 0;
      const uint8_t* bytes = s->places.host(place.address, available);
      if (bytes == nullptr) {
        note(dev, "descriptor buffers: a descriptor lies in memory the application has not mapped, which the "
                  "layer cannot read: its line is named by set and binding");
        continue;
      }
      auto target = s->catalog.lookup(place.type, bytes, available);
      if (!target) {
        note(dev, std::string("descriptor buffers: a descriptor's bytes match none that vkGetDescriptorEXT "
                              "returned while the layer was loaded") +
                      (s->catalog.forgotSome() ? " (the layer forgot the oldest past its bound)" : "") +
                      ": its line is named by set and binding");
        continue;
      }
      region.slotResources[place.slot] = {target->resource, target->format, target->aspect};
    }
  }
}

}  // namespace tally::layer
