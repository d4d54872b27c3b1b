// Index reads of indexed indirect draws (vkCmdDrawIndexedIndirect[Count]):
// their parameters are on the GPU, written by the application's shaders or
// its host, so the layer copies each draw's (indexCount, instanceCount) pairs
// and its draw count into a buffer of the command buffer once the draw's pass
// has ended (copies are not allowed inside a render pass), reads that buffer
// back with the submission's counters, and derives indices x instances x the
// index size per index buffer, as for direct indexed draws (docs/layer.md).
#include <algorithm>
#include <cstring>

#include "state.hpp"

namespace tally::layer {

namespace {

// 32768 draws' pairs per command buffer; draws beyond are not derived (a note says so).
constexpr VkDeviceSize kIndirectBufferBytes = 256 * 1024;
constexpr uint32_t kIndexedCommandBytes = sizeof(VkDrawIndexedIndirectCommand);

bool createIndirectBuffer(DeviceState& dev, CommandBufferState& cb) {
  VkBufferCreateInfo info = {VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  info.size = kIndirectBufferBytes;
  info.usage = VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  if (dev.d.CreateBuffer(dev.device, &info, nullptr, &cb.indirectBuffer) != VK_SUCCESS) return false;
  VkMemoryRequirements req{};
  dev.d.GetBufferMemoryRequirements(dev.device, cb.indirectBuffer, &req);
  uint32_t type = UINT32_MAX;  // device-local where there is one
  for (uint32_t i = 0; i < dev.memory.memoryTypeCount; ++i) {
    if (!(req.memoryTypeBits & (1u << i))) continue;
    if (type == UINT32_MAX || (dev.memory.memoryTypes[i].propertyFlags & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT &&
                               !(dev.memory.memoryTypes[type].propertyFlags & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT))) {
      type = i;
    }
  }
  VkMemoryAllocateInfo alloc = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  alloc.allocationSize = req.size;
  alloc.memoryTypeIndex = type;
  if (type == UINT32_MAX || dev.d.AllocateMemory(dev.device, &alloc, nullptr, &cb.indirectMemory) != VK_SUCCESS) {
    dev.d.DestroyBuffer(dev.device, cb.indirectBuffer, nullptr);
    cb.indirectBuffer = VK_NULL_HANDLE;
    return false;
  }
  dev.d.BindBufferMemory(dev.device, cb.indirectBuffer, cb.indirectMemory, 0);
  return true;
}

}  // namespace

void noteIndexedIndirect(DeviceState& dev, CommandBufferState& cb, VkBuffer buffer, VkDeviceSize offset,
                         uint32_t maxDraws, uint32_t stride, VkBuffer countBuffer, VkDeviceSize countOffset) {
  if (!dev.counting || cb.currentPass < 0 || maxDraws == 0) return;
  if (cb.secondary) {
    // A secondary's draws run inside the primary's render pass, which the
    // secondary cannot end to copy.
    dev.notes.insert("indexed indirect draws in secondary command buffers: their index reads are not derived");
    return;
  }
  const VkDeviceSize bytes = VkDeviceSize(maxDraws) * 8 + (countBuffer != VK_NULL_HANDLE ? 8 : 0);
  if (cb.indirectUsed + bytes > kIndirectBufferBytes) {
    dev.notes.insert("a command buffer's indexed indirect draws hold more than " +
                     std::to_string(kIndirectBufferBytes / 8) + " draws: the index reads of the rest are not derived");
    return;
  }
  if (cb.indirectBuffer == VK_NULL_HANDLE && !createIndirectBuffer(dev, cb)) {
    dev.notes.insert("indexed indirect draws: no buffer for their parameters, their index reads are not derived");
    return;
  }
  IndirectDraw draw;
  draw.pass = uint32_t(cb.currentPass);
  draw.indexBuffer = cb.indexBuffer;
  draw.indexBytes = cb.indexBytes;
  draw.source = buffer;
  draw.offset = offset;
  draw.stride = maxDraws > 1 ? stride : kIndexedCommandBytes;  // one draw's stride is ignored by Vulkan
  draw.maxDraws = maxDraws;
  draw.paramsAt = cb.indirectUsed;
  if (countBuffer != VK_NULL_HANDLE) {
    draw.countSource = countBuffer;
    draw.countOffset = countOffset;
    draw.countAt = cb.indirectUsed + VkDeviceSize(maxDraws) * 8;
  }
  cb.indirectUsed += bytes;
  cb.indirectDraws.push_back(draw);
}

void recordIndirectCopies(DeviceState& dev, CommandBufferState& cb, bool end) {
  auto pending = std::find_if(cb.indirectDraws.begin(), cb.indirectDraws.end(), [](const IndirectDraw& d) { return !d.copied; });
  if (pending == cb.indirectDraws.end()) return;
  if (cb.inRenderPass || cb.renderingSuspended) {
    if (end) {
      dev.notes.insert("a command buffer ended inside a suspended rendering scope: the index reads of its indexed "
                       "indirect draws there are not derived");
    }
    return;
  }
  // The parameters were written before the draws read them (by a shader, a
  // transfer or the host): every earlier write is visible to the copies.
  VkMemoryBarrier before = {VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  before.srcAccessMask = VK_ACCESS_MEMORY_WRITE_BIT;
  before.dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
  dev.d.CmdPipelineBarrier(cb.handle, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 1, &before,
                           0, nullptr, 0, nullptr);
  for (auto it = pending; it != cb.indirectDraws.end(); ++it) {
    if (it->copied) continue;
    std::vector<VkBufferCopy> pairs(it->maxDraws);
    for (uint32_t d = 0; d < it->maxDraws; ++d) {
      // indexCount and instanceCount, the first two words of VkDrawIndexedIndirectCommand.
      pairs[d] = {it->offset + VkDeviceSize(d) * it->stride, it->paramsAt + VkDeviceSize(d) * 8, 8};
    }
    dev.d.CmdCopyBuffer(cb.handle, it->source, cb.indirectBuffer, uint32_t(pairs.size()), pairs.data());
    if (it->countSource != VK_NULL_HANDLE) {
      const VkBufferCopy count = {it->countOffset, it->countAt, 4};
      dev.d.CmdCopyBuffer(cb.handle, it->countSource, cb.indirectBuffer, 1, &count);
    }
    it->copied = true;
  }
  // The application's later writes to its parameters wait for the copies; its
  // own barriers name the indirect stage only.
  VkMemoryBarrier after = {VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  after.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
  after.dstAccessMask = VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT;
  dev.d.CmdPipelineBarrier(cb.handle, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, 0, 1, &after,
                           0, nullptr, 0, nullptr);
}

void destroyIndirect(DeviceState& dev, CommandBufferState& cb) {
  if (cb.indirectBuffer != VK_NULL_HANDLE) dev.d.DestroyBuffer(dev.device, cb.indirectBuffer, nullptr);
  if (cb.indirectMemory != VK_NULL_HANDLE) dev.d.FreeMemory(dev.device, cb.indirectMemory, nullptr);
  cb.indirectBuffer = VK_NULL_HANDLE;
  cb.indirectMemory = VK_NULL_HANDLE;
}

void addIndirectReads(Harvest::Part& part, const uint8_t* base) {
  for (const auto& draw : part.indirectDraws) {
    if (draw.pass >= part.passes.size()) continue;
    const uint8_t* at = base + part.indirectAt;
    uint32_t draws = draw.maxDraws;
    if (draw.countSource != VK_NULL_HANDLE) {
      uint32_t count = 0;
      std::memcpy(&count, at + draw.countAt, 4);
      draws = std::min(draws, count);
    }
    uint64_t indices = 0;
    for (uint32_t d = 0; d < draws; ++d) {
      uint32_t pair[2];
      std::memcpy(pair, at + draw.paramsAt + VkDeviceSize(d) * 8, 8);
      indices += uint64_t(pair[0]) * pair[1];
    }
    if (indices > 0) part.passes[draw.pass].indexReads[{draw.indexBuffer, draw.indexBytes}] += indices;
  }
}

}  // namespace tally::layer
