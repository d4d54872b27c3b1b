// The layer's intercepts for what a command buffer binds and runs: pipelines,
// vertex and index buffers, draws, dispatches and secondaries.
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
  unbindShaderObjects(*cb, point == VK_PIPELINE_BIND_POINT_COMPUTE);
  // A counted pipeline always finds the counter set bound: at the sink (never
  // read) until a draw the layer sees binds the draw's region, so a draw
  // command the layer does not intercept runs uncounted, not unbound.
  // A descriptor-buffer pipeline's counter set lives in the layer's
  // descriptor buffer: its sink is set by offset, not bound as a set.
  if (bp.pipeline && bp.pipeline->counted && dev->counting &&
      !bindCounterDescriptor(*dev, *cb, point == VK_PIPELINE_BIND_POINT_COMPUTE ? 1 : 0, *bp.pipeline, 0)) {
    const uint32_t sink = 0;
    dev->d.CmdBindDescriptorSets(cmd, point, bp.pipeline->layout, dev->counterSet, 1, &dev->counterDescriptorSet, 1,
                                 &sink);
    bp.boundOffset = 0;
  } else if (bp.pipeline && bp.pipeline->counted && dev->counting) {
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
    // At once, not at the next draw: a draw the layer does not intercept must not run the twin with it on.
    bindForCoverage(*dev, *cb);
  }
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
  // A draw's place: in its pass (a secondary's: in the secondary, numbered
  // on from the executing pass's draws at vkCmdExecuteCommands).
  uint32_t draw = dispatch ? kNoDraw : cb->drawCommands;
  if (!dispatch) ++cb->drawCommands;
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
    if (!dispatch) draw = pass.draws;
    (dispatch ? pass.dispatches : pass.draws) += 1;
    if (indices > 0) pass.indexReads[{cb->indexBuffer, cb->indexBytes}] += indices;
  }
  if (!dispatch) bindForCoverage(dev, *cb);
  beforeDraw(dev, *cb, dispatch ? 1 : 0, dispatch, dev.config.draws ? draw : kNoDraw);
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
  PassScope& pass = cb->passes[size_t(cb->currentPass)];
  for (uint32_t i = 0; i < count; ++i) {
    CommandBufferState* s = cbState(*dev, secondaries[i]);
    if (s == nullptr) continue;
    cb->uncountedSecondaries = cb->uncountedSecondaries || (s->work && !s->counted);
    for (Region r : s->regions) {
      if (!have.insert(r.offset).second) continue;
      resolveInherited(*cb, r);
      r.pass = uint32_t(cb->currentPass);
      if (r.draw < kRestDraws) {
        r.draw += pass.draws;
        if (r.label.empty() && !cb->labels.empty()) r.label = cb->labels.back();
      }
      cb->regions.push_back(std::move(r));
    }
    pass.draws += s->drawCommands;
  }
  if (!cb->inRenderPass) {
    closePass(*dev, *cb);
    cb->secondaryContents = false;
  }
}

}  // namespace

PFN_vkVoidFunction interceptedDraws(std::string_view name) {
  TALLY_INTERCEPT(CmdBindPipeline)
  TALLY_INTERCEPT(CmdBindVertexBuffers)
  TALLY_INTERCEPT(CmdBindIndexBuffer)
  TALLY_INTERCEPT(CmdBindVertexBuffers2)
  TALLY_INTERCEPT_ALIAS(CmdBindVertexBuffers2EXT, CmdBindVertexBuffers2)
  TALLY_INTERCEPT(CmdDrawMultiEXT)
  TALLY_INTERCEPT(CmdSetAlphaToCoverageEnableEXT)
  TALLY_INTERCEPT(CmdDrawMultiIndexedEXT)
  TALLY_INTERCEPT(CmdDrawMeshTasksEXT)
  TALLY_INTERCEPT(CmdDrawMeshTasksIndirectEXT)
  TALLY_INTERCEPT(CmdDrawMeshTasksIndirectCountEXT)
  TALLY_INTERCEPT(CmdDraw)
  TALLY_INTERCEPT(CmdDrawIndexed)
  TALLY_INTERCEPT(CmdDrawIndirect)
  TALLY_INTERCEPT(CmdDrawIndexedIndirect)
  TALLY_INTERCEPT(CmdDrawIndirectCount)
  TALLY_INTERCEPT_ALIAS(CmdDrawIndirectCountKHR, CmdDrawIndirectCount)
  TALLY_INTERCEPT(CmdDrawIndexedIndirectCount)
  TALLY_INTERCEPT_ALIAS(CmdDrawIndexedIndirectCountKHR, CmdDrawIndexedIndirectCount)
  TALLY_INTERCEPT(CmdDispatch)
  TALLY_INTERCEPT(CmdDispatchBase)
  TALLY_INTERCEPT_ALIAS(CmdDispatchBaseKHR, CmdDispatchBase)
  TALLY_INTERCEPT(CmdDispatchIndirect)
  TALLY_INTERCEPT(CmdExecuteCommands)
  return nullptr;
}

}  // namespace tally::layer
