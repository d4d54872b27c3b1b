// The layer's intercepts for command pools and buffers, and the scopes
// recorded in them: render passes, dynamic rendering, labels and queries.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string_view>
#include <utility>

#include "early_tests_twin.hpp"
#include "intercepts.hpp"
#include "libraries.hpp"
#include "names.hpp"
#include "shader_options.hpp"
#include "state.hpp"
#include "uncounted.hpp"

namespace tally::layer {
namespace {

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
  cb.shaders = {};
  cb.coverage = {};
  cb.vertexBuffers.clear();
  cb.indexBuffer = 0;
  cb.renderingSuspended = false;
  cb.indirectDraws.clear();
  cb.indirectUsed = 0;
  cb.work = cb.uncountedSecondaries = false;
  cb.drawCommands = cb.drawRegions = 0;
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
  cb->statistics = dev->statistics && dev->frame < uint64_t(dev->config.skipFrames) + dev->config.statisticsFrames;
  if (cb->statistics && cb->statisticsPool == VK_NULL_HANDLE) cb->statisticsPool = takeQueryPool(*dev, true);
  if (cb->timestamps && cb->timestampPool == VK_NULL_HANDLE) {
    VkQueryPoolCreateInfo q = {VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    q.queryType = VK_QUERY_TYPE_TIMESTAMP;
    q.queryCount = kQueriesPerCommandBuffer;
    if (dev->d.CreateQueryPool(dev->device, &q, nullptr, &cb->timestampPool) != VK_SUCCESS) cb->timestamps = false;
    ++dev->queryPoolsCreated;
  }
  if (cb->statistics && cb->statisticsPool == VK_NULL_HANDLE) {
    VkQueryPoolCreateInfo q = {VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    q.queryType = VK_QUERY_TYPE_PIPELINE_STATISTICS;
    q.queryCount = kQueriesPerCommandBuffer;
    q.pipelineStatistics = kStatistics;
    dev->d.CreateQueryPool(dev->device, &q, nullptr, &cb->statisticsPool);
    ++dev->queryPoolsCreated;
  }
  if (cb->timestamps) dev->d.CmdResetQueryPool(cmd, cb->timestampPool, 0, kQueriesPerCommandBuffer);
  if (cb->statistics && cb->statisticsPool != VK_NULL_HANDLE) {
    dev->d.CmdResetQueryPool(cmd, cb->statisticsPool, 0, kQueriesPerCommandBuffer);
  }
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
  if (!cb.statistics || cb.statisticsPool == VK_NULL_HANDLE || cb.currentPass < 0 || cb.openStatistic ||
      cb.appStatisticsActive) {
    return;
  }
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
// but theirs: a scope there has its timestamps outside (readback.cpp waits on
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

}  // namespace

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

namespace {

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

}  // namespace

PFN_vkVoidFunction interceptedCommands(std::string_view name) {
  TALLY_INTERCEPT(CreateCommandPool)
  TALLY_INTERCEPT(DestroyCommandPool)
  TALLY_INTERCEPT(ResetCommandPool)
  TALLY_INTERCEPT(AllocateCommandBuffers)
  TALLY_INTERCEPT(FreeCommandBuffers)
  TALLY_INTERCEPT(BeginCommandBuffer)
  TALLY_INTERCEPT(EndCommandBuffer)
  TALLY_INTERCEPT(ResetCommandBuffer)
  TALLY_INTERCEPT(CmdBeginRenderPass)
  TALLY_INTERCEPT(CmdBeginRenderPass2)
  TALLY_INTERCEPT_ALIAS(CmdBeginRenderPass2KHR, CmdBeginRenderPass2)
  TALLY_INTERCEPT(CmdNextSubpass)
  TALLY_INTERCEPT(CmdNextSubpass2)
  TALLY_INTERCEPT_ALIAS(CmdNextSubpass2KHR, CmdNextSubpass2)
  TALLY_INTERCEPT(CmdEndRenderPass)
  TALLY_INTERCEPT(CmdEndRenderPass2)
  TALLY_INTERCEPT_ALIAS(CmdEndRenderPass2KHR, CmdEndRenderPass2)
  TALLY_INTERCEPT(CmdBeginRendering)
  TALLY_INTERCEPT_ALIAS(CmdBeginRenderingKHR, CmdBeginRendering)
  TALLY_INTERCEPT(CmdEndRendering)
  TALLY_INTERCEPT_ALIAS(CmdEndRenderingKHR, CmdEndRendering)
  TALLY_INTERCEPT(CmdBeginDebugUtilsLabelEXT)
  TALLY_INTERCEPT(CmdEndDebugUtilsLabelEXT)
  TALLY_INTERCEPT(CmdBeginQuery)
  TALLY_INTERCEPT(CmdEndQuery)
  return nullptr;
}

}  // namespace tally::layer
