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

#include "descriptor_buffers_layer.hpp"
#include "device_objects.hpp"
#include "names.hpp"
#include "state.hpp"

namespace tally::layer {

namespace {

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
  if (const char* sites = std::getenv("TALLY_LAYER_SITES"); sites != nullptr && *sites != '\0' && error.empty()) {
    const std::string value = sites;
    if (value == "1") {
      c.sites = true;
    } else if (value != "0") {
      error = "TALLY_LAYER_SITES: '" + value + "' is not 0 or 1";
    }
  }
  if (const char* draws = std::getenv("TALLY_LAYER_DRAWS"); draws != nullptr && *draws != '\0' && error.empty()) {
    const std::string value = draws;
    if (value == "1") {
      c.draws = true;
    } else if (value != "0") {
      error = "TALLY_LAYER_DRAWS: '" + value + "' is not 0 or 1";
    }
  }
  // Per-site counts come with per-draw ones, as a spec's "sites" gives both built in.
  c.draws = c.draws || c.sites;
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
  if (const char* frames = std::getenv("TALLY_LAYER_STATISTICS_FRAMES"); frames != nullptr && *frames != '\0' &&
                                                                         error.empty()) {
    if (std::string_view(frames) == "all") {
      c.statisticsFrames = UINT32_MAX;
    } else {
      parseCount("TALLY_LAYER_STATISTICS_FRAMES", 0, 100000, c.statisticsFrames, error);
      if (!error.empty()) error += " (or all)";
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
  // 64-bit atomics where the layer could enable them (CreateDevice), else 32-bit ones in pairs.
  o.width = dev.int64Atomics ? spirv::CounterWidth::Int64 : spirv::CounterWidth::Uint32Pair;
  // The application's shaders keep their early depth and stencil tests where that is safe (docs/layer.md).
  o.earlyFragmentTests = true;
  if (dev.instance->getProperties2 != nullptr) {
    VkPhysicalDeviceSubgroupProperties subgroup = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
    VkPhysicalDeviceProperties2 props2 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, &subgroup};
    dev.instance->getProperties2(dev.physical, &props2);
    constexpr VkSubgroupFeatureFlags kNeeded =
        VK_SUBGROUP_FEATURE_BASIC_BIT | VK_SUBGROUP_FEATURE_VOTE_BIT | VK_SUBGROUP_FEATURE_BALLOT_BIT |
        VK_SUBGROUP_FEATURE_ARITHMETIC_BIT;
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
  // Buffer device addresses: the table the accesses search, one binding more (addresses.hpp).
  const VkDescriptorSetLayoutBinding bindings[2] = {
      binding, {kAddressTableBinding, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_ALL, nullptr}};
  const uint32_t bindingCount = dev.addresses.enabled ? 2 : 1;
  VkDescriptorSetLayoutCreateInfo layoutInfo = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  layoutInfo.bindingCount = bindingCount;
  layoutInfo.pBindings = bindings;
  dev.d.CreateDescriptorSetLayout(dev.device, &layoutInfo, nullptr, &dev.counterSetLayout);
  VkDescriptorSetLayoutCreateInfo emptyInfo = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  dev.d.CreateDescriptorSetLayout(dev.device, &emptyInfo, nullptr, &dev.emptySetLayout);
  const VkDescriptorPoolSize sizes[2] = {{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER_DYNAMIC, 1},
                                         {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1}};
  VkDescriptorPoolCreateInfo poolInfo = {VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  poolInfo.maxSets = 1;
  poolInfo.poolSizeCount = bindingCount;
  poolInfo.pPoolSizes = sizes;
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
                        VK_BUFFER_USAGE_TRANSFER_DST_BIT | counterBufferAddressUsage(dev),
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
  o.addressTable = setupAddressTable(dev, dev.counterDescriptorSet, kAddressTableBinding) && dev.addresses.enabled;
  o.addressTableBinding = kAddressTableBinding;
  setupDescriptorBuffers(dev);

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
  destroyAddressTable(dev);
  destroyDescriptorBuffers(dev);
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

void beforeDraw(DeviceState& dev, CommandBufferState& cb, uint32_t bindPointIndex, bool isDispatch, uint32_t draw) {
  auto& bp = cb.bind[bindPointIndex];
  if (!bp.pipeline || !bp.pipeline->counted || !descriptorBuffersReady(dev, cb, bindPointIndex)) return;
  const PipelineInfo& pipeline = *bp.pipeline;
  std::vector<Bound> slots(pipeline.slots);
  std::vector<uint64_t> key;
  key.reserve(pipeline.slots * 2);
  std::vector<bool> seen(pipeline.slots, false);
  std::vector<DescriptorPlace> descriptorAt;
  for (const auto& site : pipeline.sites) {
    if (site.kind == spirv::SiteKind::Invocation) continue;
    for (uint32_t i = 0; i < std::max(site.slotCount, 1u); ++i) {
      const uint32_t slot = site.slot + i;
      if (slot >= slots.size() || seen[slot]) continue;
      seen[slot] = true;
      slots[slot] = resolveSlot(dev, cb, bp, pipeline, site, i);
      // A descriptor buffer's bytes are named at submission: the region is the descriptor's place.
      const auto at = slots[slot].resource == 0 ? descriptorBufferAddress(dev, cb, bindPointIndex, pipeline, site, i)
                                                : std::nullopt;
      if (at) descriptorAt.push_back({slot, at->address, at->type});
      key.push_back(slot);
      key.push_back(at ? ~at->address : slots[slot].resource);
      key.push_back(uint64_t(slots[slot].format) << 32 | slots[slot].aspect);
    }
  }
  const uint32_t pass = cb.secondary ? 0 : uint32_t(std::max(cb.currentPass, 0));
  // Config::draws: a region per draw command, up to kMaxDrawRegions a
  // recording; the draws beyond share regions as without it.
  if (draw != kNoDraw) {
    if (cb.drawRegions < kMaxDrawRegions) {
      ++cb.drawRegions;
    } else {
      draw = kRestDraws;
    }
    key.push_back(draw);
  }
  auto index = std::make_tuple(pass, pipeline.handle, std::move(key));
  VkDeviceSize offset = 0;
  if (auto it = cb.regionIndex.find(index); it != cb.regionIndex.end()) {
    offset = cb.regions[it->second].offset;
    cb.regions[it->second].drawCommands += draw == kRestDraws ? 1 : 0;
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
      region.descriptorAt = std::move(descriptorAt);
      region.pass = pass;
      region.draw = draw;
      region.drawCommands = draw == kNoDraw ? 0 : 1;
      region.label = draw != kNoDraw && !cb.labels.empty() ? cb.labels.back() : "";
      cb.regions.push_back(std::move(region));
      cb.regionIndex.emplace(std::move(index), cb.regions.size() - 1);
    }
  }
  if (bp.dirty || bp.boundOffset != offset) {
    // The sink (0) holds every slot: shader objects' bands land inside it unshifted.
    const VkDeviceSize shifted = offset == 0 ? 0 : offset - pipeline.regionShift;
    if (!bindCounterDescriptor(dev, cb, bindPointIndex, pipeline, shifted)) {
      const uint32_t dynamicOffset = uint32_t(shifted);
      dev.d.CmdBindDescriptorSets(cb.handle, isDispatch ? VK_PIPELINE_BIND_POINT_COMPUTE : VK_PIPELINE_BIND_POINT_GRAPHICS,
                                  pipeline.layout, dev.counterSet, 1, &dev.counterDescriptorSet, 1, &dynamicOffset);
    }
    bp.boundOffset = offset;
    bp.dirty = false;
  }
}

}  // namespace tally::layer
