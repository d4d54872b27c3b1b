// The layer's counting: the counter buffer and its regions, binding the
// counter set at each draw, reading counters and queries back after each
// submission, frames, and writing the output file (docs/layer.md; its
// contents are output.cpp's).
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "names.hpp"
#include "state.hpp"

namespace tally::layer {

namespace {

void log(const std::string& line) { std::fprintf(stderr, "tally layer: %s\n", line.c_str()); }

bool parseCount(const char* name, uint32_t low, uint32_t high, uint32_t& out, std::string& error) {
  const char* text = std::getenv(name);
  if (text == nullptr || *text == '\0') return true;
  char* end = nullptr;
  const unsigned long long v = std::strtoull(text, &end, 10);
  if (*end != '\0' || v < low || v > high) {
    error = std::string(name) + ": must be an integer between " + std::to_string(low) + " and " +
            std::to_string(high) + ", got '" + text + "'";
    return false;
  }
  out = uint32_t(v);
  return true;
}

uint32_t stageMask(VkShaderStageFlags stages) {
  using spirv::Stage;
  uint32_t mask = 0;
  const std::pair<VkShaderStageFlagBits, Stage> map[] = {
      {VK_SHADER_STAGE_VERTEX_BIT, Stage::Vertex},
      {VK_SHADER_STAGE_TESSELLATION_CONTROL_BIT, Stage::TessControl},
      {VK_SHADER_STAGE_TESSELLATION_EVALUATION_BIT, Stage::TessEval},
      {VK_SHADER_STAGE_GEOMETRY_BIT, Stage::Geometry},
      {VK_SHADER_STAGE_FRAGMENT_BIT, Stage::Fragment},
      {VK_SHADER_STAGE_COMPUTE_BIT, Stage::Compute},
      {VK_SHADER_STAGE_TASK_BIT_EXT, Stage::Task},
      {VK_SHADER_STAGE_MESH_BIT_EXT, Stage::Mesh}};
  for (const auto& [bit, stage] : map) {
    if (stages & bit) mask |= spirv::stageBit(stage);
  }
  return mask;
}

uint32_t memoryType(const DeviceState& dev, uint32_t bits, VkMemoryPropertyFlags required,
                    VkMemoryPropertyFlags preferred) {
  uint32_t fallback = UINT32_MAX;
  for (uint32_t i = 0; i < dev.memory.memoryTypeCount; ++i) {
    const auto flags = dev.memory.memoryTypes[i].propertyFlags;
    if (!(bits & (1u << i)) || (flags & required) != required) continue;
    if ((flags & preferred) == preferred) return i;
    if (fallback == UINT32_MAX) fallback = i;
  }
  return fallback;
}

bool createBuffer(DeviceState& dev, VkDeviceSize size, VkBufferUsageFlags usage, VkMemoryPropertyFlags required,
                  VkMemoryPropertyFlags preferred, VkBuffer& buffer, VkDeviceMemory& memory) {
  VkBufferCreateInfo info = {VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  info.size = size;
  info.usage = usage;
  if (dev.d.CreateBuffer(dev.device, &info, nullptr, &buffer) != VK_SUCCESS) return false;
  VkMemoryRequirements req{};
  dev.d.GetBufferMemoryRequirements(dev.device, buffer, &req);
  VkMemoryAllocateInfo alloc = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  alloc.allocationSize = req.size;
  alloc.memoryTypeIndex = memoryType(dev, req.memoryTypeBits, required, preferred);
  if (alloc.memoryTypeIndex == UINT32_MAX || dev.d.AllocateMemory(dev.device, &alloc, nullptr, &memory) != VK_SUCCESS) {
    dev.d.DestroyBuffer(dev.device, buffer, nullptr);
    buffer = VK_NULL_HANDLE;
    return false;
  }
  dev.d.BindBufferMemory(dev.device, buffer, memory, 0);
  return true;
}

VkCommandPool ownPool(DeviceState& dev, uint32_t family) {
  auto it = dev.ownPools.find(family);
  if (it != dev.ownPools.end()) return it->second;
  VkCommandPoolCreateInfo info = {VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  info.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  info.queueFamilyIndex = family;
  VkCommandPool pool = VK_NULL_HANDLE;
  dev.d.CreateCommandPool(dev.device, &info, nullptr, &pool);
  dev.ownPools[family] = pool;
  return pool;
}

VkCommandBuffer ownCommandBuffer(DeviceState& dev, VkCommandPool pool) {
  VkCommandBufferAllocateInfo info = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  info.commandPool = pool;
  info.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  info.commandBufferCount = 1;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  if (dev.d.AllocateCommandBuffers(dev.device, &info, &cmd) != VK_SUCCESS) return VK_NULL_HANDLE;
  // A command buffer the layer made itself carries no dispatch pointer until the loader sets it.
  if (dev.setLoaderData != nullptr) dev.setLoaderData(dev.device, cmd);
  return cmd;
}

void memoryBarrier(DeviceState& dev, VkCommandBuffer cmd, VkPipelineStageFlags src, VkAccessFlags srcAccess,
                   VkPipelineStageFlags dst, VkAccessFlags dstAccess) {
  VkMemoryBarrier barrier = {VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  barrier.srcAccessMask = srcAccess;
  barrier.dstAccessMask = dstAccess;
  dev.d.CmdPipelineBarrier(cmd, src, dst, 0, 1, &barrier, 0, nullptr, 0, nullptr);
}

}  // namespace

const char* toString(Kind kind) {
  switch (kind) {
    case Kind::Texture: return "texture";
    case Kind::Attachment: return "attachment";
    case Kind::Depth: return "depth";
    case Kind::Buffer: return "buffer";
  }
  return "buffer";
}

std::string Resource::displayName() const {
  if (!name.empty()) return name;
  if (!image) return "buffer " + hexHandle(handle) + " (" + std::to_string(size) + " B)";
  return imageRole(imageUsage, kind) + " " + hexHandle(handle) + " " + formatName(format) + " " +
         std::to_string(width) + "x" + std::to_string(height);
}

Config Config::fromEnvironment() {
  Config c;
  if (const char* out = std::getenv("TALLY_LAYER_OUTPUT")) c.output = out;
  std::string error;
  parseCount("TALLY_LAYER_FRAMES", 1, 100000, c.frames, error) &&
      parseCount("TALLY_LAYER_SKIP_FRAMES", 0, 10000000, c.skipFrames, error) &&
      parseCount("TALLY_LAYER_FRAME_SUBMITS", 0, 100000, c.frameSubmits, error);
  if (const char* mode = std::getenv("TALLY_LAYER_COUNTING"); mode != nullptr && *mode != '\0' && error.empty()) {
    auto parsed = spirv::parseMode(mode);
    if (std::string_view(mode) == "off") {
      c.counts = false;
    } else if (!parsed) {
      error = std::string("TALLY_LAYER_COUNTING: ") + parsed.error();
    } else if (parsed->kind == spirv::CountMode::Sampled) {
      error = "TALLY_LAYER_COUNTING: sampled modes are not offered by the layer (exact or accumulate)";
    } else {
      c.mode = *parsed;
    }
  }
  if (const char* timing = std::getenv("TALLY_LAYER_TIMING"); timing != nullptr && *timing != '\0' && error.empty()) {
    const std::string value = timing;
    if (value == "timestamps") {
      c.statistics = false;
    } else if (value == "none") {
      c.timestamps = c.statistics = false;
    } else if (value != "all") {
      error = "TALLY_LAYER_TIMING: '" + value + "' is not all, timestamps or none";
    }
  }
  c.error = error;
  return c;
}

void setupCounting(DeviceState& dev) {
  std::lock_guard lock(dev.mutex);
  auto refuse = [&](const std::string& why) {
    dev.counting = false;
    dev.notCounting = why;
    log("not counting: " + why);
  };
  assignOutput(dev);
  if (!dev.config.error.empty()) return refuse(dev.config.error);
  // Nothing would be read: the layer leaves the application's calls alone.
  if (dev.config.output.empty()) return refuse("TALLY_LAYER_OUTPUT is not set: nothing is counted");
  if (dev.properties.apiVersion < VK_API_VERSION_1_1) return refuse("the device offers Vulkan 1.0; counting needs 1.1");
  if (dev.queueFamilies.empty()) return refuse("the application created no graphics or compute queue");

  dev.counterSet = std::min<uint32_t>(dev.properties.limits.maxBoundDescriptorSets, 32) - 1;
  auto& o = dev.instrumentOptions;
  o.mode = dev.config.mode;
  o.set = dev.counterSet;
  o.binding = 0;
  // 32-bit atomics in pairs: no 64-bit features asked of the application's device.
  o.width = spirv::CounterWidth::Uint32Pair;
  // The application's shaders keep their early depth and stencil tests where that is safe (docs/layer.md).
  o.earlyFragmentTests = true;
  if (dev.instance->getProperties2 != nullptr) {
    VkPhysicalDeviceSubgroupProperties subgroup = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
    VkPhysicalDeviceProperties2 props2 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, &subgroup};
    dev.instance->getProperties2(dev.physical, &props2);
    constexpr VkSubgroupFeatureFlags kNeeded =
        VK_SUBGROUP_FEATURE_BASIC_BIT | VK_SUBGROUP_FEATURE_BALLOT_BIT | VK_SUBGROUP_FEATURE_ARITHMETIC_BIT;
    o.subgroupStages = (subgroup.supportedOperations & kNeeded) == kNeeded ? stageMask(subgroup.supportedStages) : 0;
  }
  // As the built-in renderers choose (gpu::instrumentOptionsFor): per lane in
  // NVIDIA's graphics stages, reduced elsewhere.
  constexpr uint32_t kNvidia = 0x10DE;
  if (dev.properties.vendorID != kNvidia) o.autoLaneStages = 0;

  VkDescriptorSetLayoutBinding binding = {};
  binding.binding = 0;
  binding.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER_DYNAMIC;
  binding.descriptorCount = 1;
  binding.stageFlags = VK_SHADER_STAGE_ALL;
  VkDescriptorSetLayoutCreateInfo layoutInfo = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  layoutInfo.bindingCount = 1;
  layoutInfo.pBindings = &binding;
  dev.d.CreateDescriptorSetLayout(dev.device, &layoutInfo, nullptr, &dev.counterSetLayout);
  VkDescriptorSetLayoutCreateInfo emptyInfo = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  dev.d.CreateDescriptorSetLayout(dev.device, &emptyInfo, nullptr, &dev.emptySetLayout);
  VkDescriptorPoolSize size = {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER_DYNAMIC, 1};
  VkDescriptorPoolCreateInfo poolInfo = {VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  poolInfo.maxSets = 1;
  poolInfo.poolSizeCount = 1;
  poolInfo.pPoolSizes = &size;
  dev.d.CreateDescriptorPool(dev.device, &poolInfo, nullptr, &dev.descriptorPool);
  VkDescriptorSetAllocateInfo setInfo = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  setInfo.descriptorPool = dev.descriptorPool;
  setInfo.descriptorSetCount = 1;
  setInfo.pSetLayouts = &dev.counterSetLayout;
  if (dev.counterSetLayout == VK_NULL_HANDLE || dev.emptySetLayout == VK_NULL_HANDLE ||
      dev.d.AllocateDescriptorSets(dev.device, &setInfo, &dev.counterDescriptorSet) != VK_SUCCESS) {
    return refuse("could not create the counter descriptor set");
  }

  // The arena of regions (the first is a sink that draws bind when the arena
  // is full: counted there, never read) plus one region's range of slack.
  dev.alignment = std::max<VkDeviceSize>(dev.properties.limits.minStorageBufferOffsetAlignment, 64);
  dev.regionRange = std::min<VkDeviceSize>(1u << 20, dev.properties.limits.maxStorageBufferRange);
  dev.arenaBytes = 64u << 20;
  if (!createBuffer(dev, dev.arenaBytes + dev.regionRange,
                    VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT |
                        VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                    0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, dev.counterBuffer, dev.counterMemory)) {
    return refuse("could not allocate the counter buffer");
  }
  dev.arenaNext = (dev.regionRange + dev.alignment - 1) / dev.alignment * dev.alignment;
  VkDescriptorBufferInfo bufferInfo = {dev.counterBuffer, 0, dev.regionRange};
  VkWriteDescriptorSet write = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
  write.dstSet = dev.counterDescriptorSet;
  write.descriptorCount = 1;
  write.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER_DYNAMIC;
  write.pBufferInfo = &bufferInfo;
  dev.d.UpdateDescriptorSets(dev.device, 1, &write, 0, nullptr);

  // Counters start at zero.
  auto [queue, family] = *dev.queueFamilies.begin();
  VkCommandBuffer cmd = ownCommandBuffer(dev, ownPool(dev, family));
  VkCommandBufferBeginInfo begin = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  dev.d.BeginCommandBuffer(cmd, &begin);
  dev.d.CmdFillBuffer(cmd, dev.counterBuffer, 0, VK_WHOLE_SIZE, 0);
  memoryBarrier(dev, cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT);
  dev.d.EndCommandBuffer(cmd);
  VkSubmitInfo submit = {VK_STRUCTURE_TYPE_SUBMIT_INFO};
  submit.commandBufferCount = 1;
  submit.pCommandBuffers = &cmd;
  dev.d.QueueSubmit(queue, 1, &submit, VK_NULL_HANDLE);
  dev.d.QueueWaitIdle(queue);
  dev.d.FreeCommandBuffers(dev.device, ownPool(dev, family), 1, &cmd);
  dev.counting = true;
  log(std::string("counting ") + spirv::toString(o.mode) + " on " + dev.properties.deviceName + ", descriptor set " +
      std::to_string(dev.counterSet) + (dev.config.output.empty() ? "" : ", output " + dev.config.output));
}

void destroyCounting(DeviceState& dev) {
  for (auto& h : dev.pending) dev.idle.push_back(std::move(h));
  dev.pending.clear();
  for (auto& h : dev.idle) {
    if (h->fence != VK_NULL_HANDLE) dev.d.DestroyFence(dev.device, h->fence, nullptr);
    if (h->buffer != VK_NULL_HANDLE) dev.d.DestroyBuffer(dev.device, h->buffer, nullptr);
    if (h->memory != VK_NULL_HANDLE) dev.d.FreeMemory(dev.device, h->memory, nullptr);
  }
  dev.idle.clear();
  for (auto& [handle, cb] : dev.commandBuffers) {
    if (cb->timestampPool != VK_NULL_HANDLE) dev.d.DestroyQueryPool(dev.device, cb->timestampPool, nullptr);
    if (cb->statisticsPool != VK_NULL_HANDLE) dev.d.DestroyQueryPool(dev.device, cb->statisticsPool, nullptr);
    destroyIndirect(dev, *cb);
  }
  for (const auto& [pool, statistics] : dev.retiringPools) dev.d.DestroyQueryPool(dev.device, pool, nullptr);
  for (VkQueryPool pool : dev.freeTimestampPools) dev.d.DestroyQueryPool(dev.device, pool, nullptr);
  for (VkQueryPool pool : dev.freeStatisticsPools) dev.d.DestroyQueryPool(dev.device, pool, nullptr);
  dev.retiringPools.clear();
  dev.freeTimestampPools.clear();
  dev.freeStatisticsPools.clear();
  for (auto& [family, pool] : dev.ownPools) dev.d.DestroyCommandPool(dev.device, pool, nullptr);
  if (dev.counterBuffer != VK_NULL_HANDLE) dev.d.DestroyBuffer(dev.device, dev.counterBuffer, nullptr);
  if (dev.counterMemory != VK_NULL_HANDLE) dev.d.FreeMemory(dev.device, dev.counterMemory, nullptr);
  if (dev.descriptorPool != VK_NULL_HANDLE) dev.d.DestroyDescriptorPool(dev.device, dev.descriptorPool, nullptr);
  if (dev.counterSetLayout != VK_NULL_HANDLE) dev.d.DestroyDescriptorSetLayout(dev.device, dev.counterSetLayout, nullptr);
  if (dev.emptySetLayout != VK_NULL_HANDLE) dev.d.DestroyDescriptorSetLayout(dev.device, dev.emptySetLayout, nullptr);
  dev.counting = false;
}

void releaseRegions(DeviceState& dev, CommandBufferState& cb) {
  for (const auto& chunk : cb.chunks) dev.freeRegions[chunk.bytes].push_back(chunk.offset);
  cb.chunks.clear();
  cb.chunkNext = cb.chunkEnd = 0;
}

namespace {

// What a site's slot `i` counts at this draw.
Bound resolveSlot(const DeviceState& dev, const CommandBufferState& cb, const CommandBufferState::BindPoint& bp,
                  const PipelineInfo& pipeline, const spirv::Site& site, uint32_t i) {
  using spirv::SiteKind;
  if (site.kind == SiteKind::OutputWrite) return outputTarget(cb, pipeline, site.location.value_or(0));
  if (site.kind == SiteKind::BufferRead && site.location) return vertexSource(cb, pipeline, *site.location);
  if (site.set < 0 || site.binding < 0 || site.set >= int64_t(bp.sets.size())) return {};
  const DescriptorSetState* state = nullptr;
  if (auto pushed = bp.pushed.find(uint32_t(site.set)); pushed != bp.pushed.end()) {
    state = &pushed->second;
  } else if (auto set = dev.sets.find(bp.sets[size_t(site.set)]); set != dev.sets.end()) {
    state = &set->second;
  }
  if (state == nullptr) return {};
  auto binding = state->bindings.find(uint32_t(site.binding));
  if (binding == state->bindings.end()) return {};
  const size_t element = site.slotCount > 1 ? i : site.index.value_or(0);
  return element < binding->second.size() ? binding->second[element] : Bound{};
}

// A region cut from the recording's current chunk; a new chunk, twice the
// last one's size up to 1 MiB, when it is full. 0 when the arena is full.
VkDeviceSize allocateRegion(DeviceState& dev, CommandBufferState& cb, VkDeviceSize bytes) {
  if (cb.chunkNext != 0 && cb.chunkNext + bytes <= cb.chunkEnd) {
    const VkDeviceSize offset = cb.chunkNext;
    cb.chunkNext += bytes;
    return offset;
  }
  constexpr VkDeviceSize kFirstChunk = 16u << 10, kLargestChunk = 1u << 20;
  VkDeviceSize size = cb.chunks.empty() ? kFirstChunk : std::min(cb.chunks.back().bytes * 2, kLargestChunk);
  size = std::max(size, bytes);
  size = (size + dev.alignment - 1) / dev.alignment * dev.alignment;
  VkDeviceSize offset = 0;
  if (auto& free = dev.freeRegions[size]; !free.empty()) {
    offset = free.back();
    free.pop_back();
  } else if (dev.arenaNext + size <= dev.arenaBytes) {
    offset = dev.arenaNext;
    dev.arenaNext += size;
  } else {
    return 0;  // the sink
  }
  cb.chunks.push_back({offset, size});
  cb.chunkNext = offset + bytes;
  cb.chunkEnd = offset + size;
  return offset;
}

}  // namespace

void beforeDraw(DeviceState& dev, CommandBufferState& cb, uint32_t bindPointIndex, bool isDispatch) {
  auto& bp = cb.bind[bindPointIndex];
  if (!bp.pipeline || !bp.pipeline->counted) return;
  const PipelineInfo& pipeline = *bp.pipeline;
  std::vector<Bound> slots(pipeline.slots);
  std::vector<uint64_t> key;
  key.reserve(pipeline.slots * 2);
  std::vector<bool> seen(pipeline.slots, false);
  for (const auto& site : pipeline.sites) {
    if (site.kind == spirv::SiteKind::Invocation) continue;
    for (uint32_t i = 0; i < std::max(site.slotCount, 1u); ++i) {
      const uint32_t slot = site.slot + i;
      if (slot >= slots.size() || seen[slot]) continue;
      seen[slot] = true;
      slots[slot] = resolveSlot(dev, cb, bp, pipeline, site, i);
      key.push_back(slot);
      key.push_back(slots[slot].resource);
      key.push_back(uint64_t(slots[slot].format) << 32 | slots[slot].aspect);
    }
  }
  const uint32_t pass = cb.secondary ? 0 : uint32_t(std::max(cb.currentPass, 0));
  auto index = std::make_tuple(pass, pipeline.handle, std::move(key));
  VkDeviceSize offset = 0;
  if (auto it = cb.regionIndex.find(index); it != cb.regionIndex.end()) {
    offset = cb.regions[it->second].offset;
  } else {
    const VkDeviceSize bytes = (VkDeviceSize(pipeline.slots) * 8 + dev.alignment - 1) / dev.alignment * dev.alignment;
    offset = allocateRegion(dev, cb, bytes);
    if (offset == 0) {
      if (!cb.overflowNoted) dev.notes.insert("the counter arena is full: some draws were not counted");
      cb.overflowNoted = true;
    } else {
      Region region;
      region.offset = offset;
      region.bytes = bytes;
      region.pipeline = bp.pipeline;
      region.slotResources = std::move(slots);
      region.pass = pass;
      cb.regions.push_back(std::move(region));
      cb.regionIndex.emplace(std::move(index), cb.regions.size() - 1);
    }
  }
  if (bp.dirty || bp.boundOffset != offset) {
    const uint32_t dynamicOffset = uint32_t(offset);
    dev.d.CmdBindDescriptorSets(cb.handle, isDispatch ? VK_PIPELINE_BIND_POINT_COMPUTE : VK_PIPELINE_BIND_POINT_GRAPHICS,
                                pipeline.layout, dev.counterSet, 1, &dev.counterDescriptorSet, 1, &dynamicOffset);
    bp.boundOffset = offset;
    bp.dirty = false;
  }
}

namespace {

void addLine(PassRecord& pass, const std::string& name, bool write, const std::string& source, uint64_t count,
             uint64_t bytes, const std::string& kind, const std::string& format) {
  auto& line = pass.lines[{name, write, source}];
  line.count += count;
  line.bytes += count * bytes;
  line.kind = kind;
  line.format = format;
}

// Adds a region's counters to its pass, attributing each slot as the
// built-in renderers do (renderers/pass_counters.cpp): sites sharing a slot
// count once.
void attributeRegion(DeviceState& dev, const Region& region, std::vector<uint64_t> counters, PassRecord& pass) {
  const PipelineInfo& pipeline = *region.pipeline;
  for (const auto& layout : pipeline.foldLayouts) spirv::foldCopies(counters, layout);
  std::set<uint32_t> seen;
  for (const auto& site : pipeline.sites) {
    using spirv::SiteKind;
    if (!seen.insert(site.slot).second) continue;
    auto value = [&](uint32_t slot) { return slot < counters.size() ? counters[slot] : 0; };
    if (site.kind == SiteKind::Invocation) {
      const uint64_t n = value(site.slot);
      if (site.stage == spirv::Stage::Fragment) pass.fragmentInvocations += n;
      if (site.stage == spirv::Stage::Vertex) pass.vertexInvocations += n;
      if (site.stage == spirv::Stage::Compute) pass.computeInvocations += n;
      continue;
    }
    const bool write = site.kind == SiteKind::BufferWrite || site.kind == SiteKind::ImageWrite ||
                       site.kind == SiteKind::ImageAtomic || site.kind == SiteKind::OutputWrite;
    const bool isBuffer = site.kind == SiteKind::BufferRead || site.kind == SiteKind::BufferWrite;
    for (uint32_t i = 0; i < std::max(site.slotCount, 1u); ++i) {
      const uint32_t slot = site.slot + i;
      const uint64_t n = value(slot);
      if (n == 0 && site.slotCount > 1) continue;
      const Bound bound = slot < region.slotResources.size() ? region.slotResources[slot] : Bound{};
      // An output with no attachment, or masked: its counter ran, nothing was written.
      if (site.kind == SiteKind::OutputWrite && bound.resource == kNotWritten) continue;
      auto r = dev.resources.find(bound.resource);
      std::string name, format;
      const std::string kind = lineKind(site, r != dev.resources.end() ? &r->second : nullptr, bound.format);
      uint64_t bytes = site.elementBytes;
      if (isBuffer && site.location && bound.format != VK_FORMAT_UNDEFINED) {
        bytes = vertexElementBytes(site, bound.format);
      }
      if (r != dev.resources.end()) {
        r->second.counted = r->second.counted || n > 0;
        name = r->second.displayName();
        if (r->second.image) {
          const VkFormat f = bound.format != VK_FORMAT_UNDEFINED ? bound.format : r->second.format;
          format = formatName(r->second.format);
          if (!isBuffer && formatBytes(f, bound.aspect) != 0) bytes = formatBytes(f, bound.aspect);
        }
      } else if (site.kind == SiteKind::OutputWrite) {
        name = "output " + std::to_string(site.location.value_or(0));
      } else if (site.location) {
        name = "vertex input " + std::to_string(*site.location);
      } else {
        name = site.set >= 0 ? "set " + std::to_string(site.set) + " binding " + std::to_string(site.binding)
                             : (site.resource.empty() ? "unresolved" : site.resource);
      }
      // A fragment's colour goes to every covered sample of a multisampled
      // target: its writes are counted x the sample count, derived (the
      // built-in renderers' model, renderers/techniques/msaa.cpp).
      if (site.kind == SiteKind::OutputWrite && r != dev.resources.end() && r->second.samples > 1) {
        addLine(pass, name, write, "derived", n * r->second.samples, bytes, kind, format);
        continue;
      }
      addLine(pass, name, write, "counter", n, bytes, kind, format);
    }
  }
}

void processHarvest(DeviceState& dev, Harvest& h) {
  auto frame = dev.frames.find(h.frame);
  if (frame == dev.frames.end() || dev.written) return;
  const auto* base = static_cast<const uint8_t*>(h.mapped);
  const double period = dev.properties.limits.timestampPeriod;
  for (auto& part : h.parts) {
    addIndirectReads(part, base);
    const size_t first = frame->second.passes.size();
    std::vector<uint64_t> timestamps(part.timestamps), statistics(size_t(part.statistics) * 3);
    std::memcpy(timestamps.data(), base + part.timestampsAt, timestamps.size() * 8);
    std::memcpy(statistics.data(), base + part.statisticsAt, statistics.size() * 8);
    for (const auto& scope : part.passes) {
      PassRecord pass;
      pass.name = scope.label;
      pass.draws = scope.draws;
      pass.dispatches = scope.dispatches;
      // Under multiview each timestamp has one index per view: the first is
      // a timestamp, the others the same or zero.
      const size_t views = scope.views;
      if (scope.timestampBegin != UINT32_MAX && scope.timestampBegin + 2 * views - 1 < timestamps.size()) {
        const uint64_t begin = timestamps[scope.timestampBegin];
        uint64_t end = 0;
        for (size_t v = 0; v < views; ++v) end = std::max(end, timestamps[scope.timestampBegin + views + v]);
        pass.gpuMs = end >= begin ? double(end - begin) * period / 1e6 : 0.0;
        pass.timed = true;
      }
      if (!scope.statisticQueries.empty()) {
        pass.vertexStatistic = pass.fragmentStatistic = pass.computeStatistic = 0;
        for (uint32_t q : scope.statisticQueries) {
          if (size_t(q) * 3 + 2 >= statistics.size()) continue;
          pass.vertexStatistic += int64_t(statistics[q * 3]);
          pass.fragmentStatistic += int64_t(statistics[q * 3 + 1]);
          pass.computeStatistic += int64_t(statistics[q * 3 + 2]);
        }
      }
      for (const auto& [key, indices] : scope.indexReads) {
        auto r = dev.resources.find(key.first);
        addLine(pass, r != dev.resources.end() ? r->second.displayName() : "index buffer", false, "derived", indices,
                key.second, "buffer", "");
      }
      // A later subpass under its first one's label (or none) is part of
      // that pass; one labelled on its own is a pass of its own.
      if (scope.continues >= 0 && first + size_t(scope.continues) < frame->second.passes.size() &&
          (scope.label.empty() || scope.label == part.passes[size_t(scope.continues)].label)) {
        pass.name = frame->second.passes[first + size_t(scope.continues)].name;
        pass.joins = int(first) + scope.continues;
      }
      // Unnamed passes take their kind and their place among the frame's passes of that kind.
      if (pass.name.empty()) {
        std::set<std::string> named;
        for (const auto& p : frame->second.passes) {
          if (p.name.rfind(scope.kind + " ", 0) == 0) named.insert(p.name);
        }
        pass.name = scope.kind + " " + std::to_string(named.size());
      }
      frame->second.passes.push_back(std::move(pass));
    }
    for (size_t r = 0; r < part.regions.size(); ++r) {
      const Region& region = part.regions[r];
      std::vector<uint64_t> counters(region.pipeline->slots);
      std::memcpy(counters.data(), base + part.regionAt[r], counters.size() * 8);
      if (first + region.pass < frame->second.passes.size()) {
        attributeRegion(dev, region, std::move(counters), frame->second.passes[first + region.pass]);
      }
    }
  }
}

namespace {

bool readByPending(const DeviceState& dev, VkQueryPool pool) {
  return std::any_of(dev.pending.begin(), dev.pending.end(), [&](const auto& h) {
    return std::find(h->queryPools.begin(), h->queryPools.end(), pool) != h->queryPools.end();
  });
}

// Retiring pools no pending readback reads any more are free again.
void freeRetiredPools(DeviceState& dev) {
  std::erase_if(dev.retiringPools, [&](const std::pair<VkQueryPool, bool>& retiring) {
    if (readByPending(dev, retiring.first)) return false;
    (retiring.second ? dev.freeStatisticsPools : dev.freeTimestampPools).push_back(retiring.first);
    return true;
  });
}

}  // namespace

// Reads back every finished harvest; with `waitFrame`, first waits for those
// of frames up to it.
void collect(DeviceState& dev, std::optional<uint64_t> waitFrame) {
  for (auto it = dev.pending.begin(); it != dev.pending.end();) {
    Harvest& h = **it;
    VkResult status = dev.d.GetFenceStatus(dev.device, h.fence);
    if (status == VK_NOT_READY && waitFrame && h.frame <= *waitFrame) {
      status = dev.d.WaitForFences(dev.device, 1, &h.fence, VK_TRUE, UINT64_MAX);
    }
    if (status != VK_SUCCESS) {
      if (status != VK_NOT_READY) {  // device lost: nothing more will arrive
        dev.notes.insert("a readback failed (VkResult " + std::to_string(int(status)) + ")");
        if (auto f = dev.frames.find(h.frame); f != dev.frames.end() && f->second.pendingHarvests > 0) {
          --f->second.pendingHarvests;
        }
        dev.idle.push_back(std::move(*it));
        it = dev.pending.erase(it);
        continue;
      }
      ++it;
      continue;
    }
    processHarvest(dev, h);
    if (auto f = dev.frames.find(h.frame); f != dev.frames.end() && f->second.pendingHarvests > 0) {
      --f->second.pendingHarvests;
    }
    h.parts.clear();
    dev.idle.push_back(std::move(*it));
    it = dev.pending.erase(it);
  }
  if (!dev.retiringPools.empty()) freeRetiredPools(dev);
}

void writeOutput(DeviceState& dev, bool complete) {
  if (dev.written || dev.config.output.empty()) return;
  dev.written = true;
  const std::string tmp = dev.config.output + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << outputJson(dev, complete).dump(1) << "\n";
    if (!out) {
      log("cannot write " + tmp);
      return;
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, dev.config.output, ec);
  if (ec) log("cannot rename " + tmp + ": " + ec.message());
  log("wrote " + dev.config.output + " (" + std::to_string(framesCounted(dev)) + " frames" +
      (complete ? ")" : ", incomplete)"));
}

// Readbacks in flight at most. An application that waits for its own work
// never has this many; one that runs further ahead of the device than this
// waits for the oldest (counted in the output's readback_waits).
constexpr size_t kReadbackRing = 64;

Harvest* takeHarvest(DeviceState& dev, VkDeviceSize bytes, uint32_t family) {
  if (dev.pending.size() >= kReadbackRing) {
    ++dev.readbackWaits;
    dev.d.WaitForFences(dev.device, 1, &dev.pending.front()->fence, VK_TRUE, UINT64_MAX);
    collect(dev, std::nullopt);
  }
  std::unique_ptr<Harvest> h;
  for (auto it = dev.idle.begin(); it != dev.idle.end(); ++it) {
    if ((*it)->pool == ownPool(dev, family)) {
      h = std::move(*it);
      dev.idle.erase(it);
      break;
    }
  }
  if (!h) {
    h = std::make_unique<Harvest>();
    h->pool = ownPool(dev, family);
    h->cmd = ownCommandBuffer(dev, h->pool);
    VkFenceCreateInfo fence = {VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    dev.d.CreateFence(dev.device, &fence, nullptr, &h->fence);
  } else {
    dev.d.ResetFences(dev.device, 1, &h->fence);
  }
  VkDeviceSize have = 0;
  if (h->buffer != VK_NULL_HANDLE) {
    VkMemoryRequirements req{};
    dev.d.GetBufferMemoryRequirements(dev.device, h->buffer, &req);
    have = req.size;
  }
  if (have < bytes) {
    if (h->buffer != VK_NULL_HANDLE) {
      dev.d.UnmapMemory(dev.device, h->memory);
      dev.d.DestroyBuffer(dev.device, h->buffer, nullptr);
      dev.d.FreeMemory(dev.device, h->memory, nullptr);
    }
    const VkDeviceSize size = std::max<VkDeviceSize>(bytes * 2, 64 * 1024);
    if (!createBuffer(dev, size, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                      VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                      VK_MEMORY_PROPERTY_HOST_CACHED_BIT, h->buffer, h->memory)) {
      h->buffer = VK_NULL_HANDLE;
      dev.idle.push_back(std::move(h));
      return nullptr;
    }
    dev.d.MapMemory(dev.device, h->memory, 0, VK_WHOLE_SIZE, 0, &h->mapped);
  }
  dev.pending.push_back(std::move(h));
  return dev.pending.back().get();
}

}  // namespace

namespace {

// One more submission after the application's: it copies the submitted
// command buffers' counter regions and query results into a host-visible
// buffer of the ring, zeroes the regions and signals the harvest's fence.
void submitReadback(DeviceState& dev, VkQueue queue, std::vector<Harvest::Part> parts,
                    const std::vector<const CommandBufferState*>& sources, VkDeviceSize at) {
  auto family = dev.queueFamilies.find(queue);
  Harvest* h = family == dev.queueFamilies.end() ? nullptr : takeHarvest(dev, std::max<VkDeviceSize>(at, 8), family->second);
  if (h == nullptr) {
    dev.notes.insert("a submission's counters could not be read back (no readback buffer)");
    return;
  }
  h->frame = dev.frame;
  h->serial = dev.nextHarvest++;
  VkCommandBufferBeginInfo begin = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  dev.d.BeginCommandBuffer(h->cmd, &begin);
  // A multiview query leaves its views' indices to the implementation: each
  // view's share, or the whole in the first and zero (or, on lavapipe,
  // nothing) in the others. Zeroed first, every layout sums right.
  for (const auto& part : parts) {
    const bool multiview = std::any_of(part.passes.begin(), part.passes.end(), [](const PassScope& p) { return p.views > 1; });
    const VkDeviceSize queryBytes = VkDeviceSize(part.timestamps) * 8 + VkDeviceSize(part.statistics) * 24;
    if (multiview && queryBytes > 0) dev.d.CmdFillBuffer(h->cmd, h->buffer, part.timestampsAt, queryBytes, 0);
  }
  // Everything the submission wrote is visible to the copies, which then
  // zero the regions for the next submission.
  memoryBarrier(dev, h->cmd, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_MEMORY_WRITE_BIT,
                VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_TRANSFER_WRITE_BIT);
  for (size_t p = 0; p < parts.size(); ++p) {
    const auto& part = parts[p];
    std::vector<VkBufferCopy> copies;
    for (const auto& range : part.ranges) copies.push_back({range.offset, range.at, range.bytes});
    if (!copies.empty()) dev.d.CmdCopyBuffer(h->cmd, dev.counterBuffer, h->buffer, uint32_t(copies.size()), copies.data());
    const CommandBufferState& cb = *sources[p];
    if (part.timestamps > 0) {
      dev.d.CmdCopyQueryPoolResults(h->cmd, cb.timestampPool, 0, part.timestamps, h->buffer, part.timestampsAt, 8,
                                    VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT);
    }
    if (part.statistics > 0) {
      dev.d.CmdCopyQueryPoolResults(h->cmd, cb.statisticsPool, 0, part.statistics, h->buffer, part.statisticsAt, 24,
                                    VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT);
    }
    if (!part.indirectDraws.empty()) {
      const VkBufferCopy copy = {0, part.indirectAt, cb.indirectUsed};
      dev.d.CmdCopyBuffer(h->cmd, cb.indirectBuffer, h->buffer, 1, &copy);
    }
  }
  memoryBarrier(dev, h->cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_READ_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
                VK_ACCESS_TRANSFER_WRITE_BIT);
  for (const auto& part : parts) {
    for (const auto& range : part.ranges) dev.d.CmdFillBuffer(h->cmd, dev.counterBuffer, range.offset, range.bytes, 0);
  }
  memoryBarrier(dev, h->cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                VK_PIPELINE_STAGE_ALL_COMMANDS_BIT | VK_PIPELINE_STAGE_HOST_BIT,
                VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_HOST_READ_BIT);
  dev.d.EndCommandBuffer(h->cmd);
  h->queryPools.clear();
  h->indirectBuffers.clear();
  for (size_t p = 0; p < parts.size(); ++p) {
    if (parts[p].timestamps > 0) h->queryPools.push_back(sources[p]->timestampPool);
    if (parts[p].statistics > 0) h->queryPools.push_back(sources[p]->statisticsPool);
    if (!parts[p].indirectDraws.empty()) h->indirectBuffers.push_back(sources[p]->indirectBuffer);
  }
  VkSubmitInfo submit = {VK_STRUCTURE_TYPE_SUBMIT_INFO};
  submit.commandBufferCount = 1;
  submit.pCommandBuffers = &h->cmd;
  if (dev.d.QueueSubmit(queue, 1, &submit, h->fence) != VK_SUCCESS) {
    dev.notes.insert("a readback submission failed");
    dev.idle.push_back(std::move(dev.pending.back()));
    dev.pending.pop_back();
    return;
  }
  h->parts = std::move(parts);
  if (inWindow(dev, dev.frame)) {
    auto& frame = dev.frames[dev.frame];
    frame.index = dev.frame;
    frame.submissions += 1;
    frame.pendingHarvests += 1;
  }
}


// Reads what has arrived, never waiting, and writes the output once the
// window's frames are all read.
void pollReadbacks(DeviceState& dev) {
  collect(dev, std::nullopt);
  forgetRetired(dev);
  if (!dev.written && framesCounted(dev) >= dev.config.frames) writeOutput(dev, true);
}

// A frame of the window that ran work the layer did not count (a command
// buffer recorded outside the window) is left out, and the window goes on
// one frame longer.
void leaveOut(DeviceState& dev, uint64_t index) {
  auto& frame = dev.frames[index];
  frame.index = index;
  if (frame.leftOut) return;
  frame.leftOut = true;
  ++dev.framesLeftOut;
}

}  // namespace

namespace {

// Where the part's regions go in the harvest's buffer, from `at` on: their
// arena merged into ranges where they are adjacent (a recording's regions
// are, within each chunk), each range copied and zeroed whole. Returns the
// end.
VkDeviceSize placeRegions(Harvest::Part& part, VkDeviceSize at) {
  std::vector<size_t> order(part.regions.size());
  for (size_t r = 0; r < order.size(); ++r) order[r] = r;
  std::sort(order.begin(), order.end(),
            [&](size_t a, size_t b) { return part.regions[a].offset < part.regions[b].offset; });
  part.regionAt.assign(part.regions.size(), 0);
  for (size_t r : order) {
    const Region& region = part.regions[r];
    const VkDeviceSize end = region.offset + region.bytes;
    if (part.ranges.empty() || region.offset > part.ranges.back().offset + part.ranges.back().bytes) {
      if (!part.ranges.empty()) at += part.ranges.back().bytes;
      part.ranges.push_back({region.offset, region.bytes, at});
    } else if (end > part.ranges.back().offset + part.ranges.back().bytes) {
      part.ranges.back().bytes = end - part.ranges.back().offset;
    }
    const ArenaRange& range = part.ranges.back();
    part.regionAt[r] = range.at + (region.offset - range.offset);
  }
  if (!part.ranges.empty()) at += part.ranges.back().bytes;
  return at;
}

}  // namespace

void afterIdle(DeviceState& dev) {
  if (dev.counting) pollReadbacks(dev);
}

void afterSubmit(DeviceState& dev, VkQueue queue, const std::vector<VkCommandBuffer>& submitted) {
  if (!dev.counting) return;
  pollReadbacks(dev);
  std::vector<Harvest::Part> parts;
  VkDeviceSize at = 0;
  std::vector<const CommandBufferState*> sources;
  bool work = false, uncounted = false;
  for (VkCommandBuffer cmd : submitted) {
    auto it = dev.commandBuffers.find(cmd);
    if (it == dev.commandBuffers.end() || it->second->secondary) continue;
    CommandBufferState& cb = *it->second;
    ++cb.submitsOfRecording;
    work = work || cb.work;
    uncounted = uncounted || (cb.work && !cb.counted) || cb.uncountedSecondaries;
    // Once the output is written nothing more is read.
    if ((cb.passes.empty() && cb.regions.empty()) || dev.written) continue;
    Harvest::Part part;
    part.passes = cb.passes;
    part.regions = cb.regions;
    at = placeRegions(part, at);
    part.timestampsAt = at;
    part.timestamps = cb.timestampsUsed;
    at += VkDeviceSize(cb.timestampsUsed) * 8;
    part.statisticsAt = at;
    part.statistics = cb.statisticsUsed;
    at += VkDeviceSize(cb.statisticsUsed) * 24;
    for (const auto& draw : cb.indirectDraws) {
      if (draw.copied) part.indirectDraws.push_back(draw);
    }
    part.indirectAt = at;
    if (!part.indirectDraws.empty()) at += cb.indirectUsed;
    parts.push_back(std::move(part));
    sources.push_back(&cb);
  }
  if (uncounted && inWindow(dev, dev.frame)) leaveOut(dev, dev.frame);
  if (!parts.empty()) submitReadback(dev, queue, std::move(parts), sources, at);
  // Submissions without a draw, a dispatch or a pass (uploads) are no frame's work.
  if (work && dev.config.frameSubmits > 0 && ++dev.frameWorkSubmits >= dev.config.frameSubmits) endFrame(dev);
}


// The application waited for its own submission before freeing the command
// buffer, not for the readback submitted after it, which may still be copying
// from the pools (VUID-vkDestroyQueryPool-queryPool-00793): such a pool is
// kept until that readback is read, then used again, and nobody waits.
void retireQueryPools(DeviceState& dev, CommandBufferState& cb) {
  auto retire = [&](VkQueryPool& pool, bool statistics) {
    if (pool == VK_NULL_HANDLE) return;
    if (readByPending(dev, pool)) {
      dev.retiringPools.emplace_back(pool, statistics);
    } else {
      (statistics ? dev.freeStatisticsPools : dev.freeTimestampPools).push_back(pool);
    }
    pool = VK_NULL_HANDLE;
  };
  retire(cb.timestampPool, false);
  retire(cb.statisticsPool, true);
}

// Before a freed command buffer's indirect-parameter buffer is destroyed:
// the readbacks that still copy it.
void waitForIndirectReadbacks(DeviceState& dev, const CommandBufferState& cb) {
  if (cb.indirectBuffer == VK_NULL_HANDLE) return;
  bool waited = false;
  for (const auto& h : dev.pending) {
    if (std::find(h->indirectBuffers.begin(), h->indirectBuffers.end(), cb.indirectBuffer) != h->indirectBuffers.end()) {
      ++dev.readbackWaits;
      dev.d.WaitForFences(dev.device, 1, &h->fence, VK_TRUE, UINT64_MAX);
      waited = true;
    }
  }
  if (waited) collect(dev, std::nullopt);
}

// A free pool of the kind, or VK_NULL_HANDLE: the caller creates one.
VkQueryPool takeQueryPool(DeviceState& dev, bool statistics) {
  auto& free = statistics ? dev.freeStatisticsPools : dev.freeTimestampPools;
  if (free.empty()) return VK_NULL_HANDLE;
  VkQueryPool pool = free.back();
  free.pop_back();
  return pool;
}

void endFrame(DeviceState& dev) {
  if (!dev.counting) return;
  if (auto f = dev.frames.find(dev.frame); f != dev.frames.end()) f->second.closed = true;
  ++dev.frame;
  dev.frameWorkSubmits = 0;
  pollReadbacks(dev);
}

void finish(DeviceState& dev, bool complete) {
  if (!dev.counting && dev.config.output.empty()) return;
  collect(dev, UINT64_MAX);
  if (auto f = dev.frames.find(dev.frame); f != dev.frames.end() && dev.config.frameSubmits == 0) {
    f->second.closed = true;  // the last frame, cut short by the application's end
  }
  if (dev.written) return;
  writeOutput(dev, complete || framesCounted(dev) >= dev.config.frames);
}

}  // namespace tally::layer
