// Reading counters and queries back after each submission: a ring of
// host-visible buffers, one readback submission after each of the
// application's, read when its fence has signalled, never waited for; frames,
// and the output file once the window's frames are read (docs/layer.md).
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
          changeFrame(dev, f->second, [](FrameRecord& r) { --r.pendingHarvests; });
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
      changeFrame(dev, f->second, [](FrameRecord& r) { --r.pendingHarvests; });
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

// The readback of a submission: a command buffer that copies the submitted
// command buffers' counter regions and query results into a host-visible
// buffer of the ring and zeroes the regions; its harvest's fence signals
// when it has run. Recorded here, submitted by sendReadback.
Harvest* recordReadback(DeviceState& dev, VkQueue queue, std::vector<Harvest::Part> parts,
                        const std::vector<const CommandBufferState*>& sources, VkDeviceSize at) {
  auto family = dev.queueFamilies.find(queue);
  Harvest* h = family == dev.queueFamilies.end() ? nullptr : takeHarvest(dev, std::max<VkDeviceSize>(at, 8), family->second);
  if (h == nullptr) {
    dev.notes.insert("a submission's counters could not be read back (no readback buffer)");
    return nullptr;
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
  h->parts = std::move(parts);
  return h;
}

// After the readback was submitted (`submitted`), or its submission failed.
void readbackSent(DeviceState& dev, Harvest* h, bool submitted) {
  if (!submitted) {
    dev.notes.insert("a readback submission failed");
    auto it = std::find_if(dev.pending.begin(), dev.pending.end(), [&](const auto& p) { return p.get() == h; });
    if (it != dev.pending.end()) {
      (*it)->parts.clear();
      dev.idle.push_back(std::move(*it));
      dev.pending.erase(it);
    }
    return;
  }
  if (inWindow(dev, dev.frame)) {
    auto& frame = dev.frames[dev.frame];
    frame.index = dev.frame;
    frame.submissions += 1;
    changeFrame(dev, frame, [](FrameRecord& r) { ++r.pendingHarvests; });
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
  changeFrame(dev, frame, [](FrameRecord& r) { r.leftOut = true; });
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

PreparedSubmit prepareSubmit(DeviceState& dev, VkQueue queue, const std::vector<VkCommandBuffer>& submitted) {
  PreparedSubmit prepared;
  if (!dev.counting) return prepared;
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
    nameDescriptorBufferSlots(dev, part.regions);
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
  if (!parts.empty()) prepared.readback = recordReadback(dev, queue, std::move(parts), sources, at);
  prepared.work = work;
  return prepared;
}

void finishSubmit(DeviceState& dev, VkQueue queue, const PreparedSubmit& prepared, VkResult rodeAlong) {
  if (!dev.counting) return;
  if (prepared.readback != nullptr) {
    bool sent = rodeAlong == VK_SUCCESS;
    if (sent) ++dev.readbacksRiding;
    if (rodeAlong == VK_NOT_READY) {  // not in the application's submission: one of its own
      VkSubmitInfo submit = {VK_STRUCTURE_TYPE_SUBMIT_INFO};
      submit.commandBufferCount = 1;
      submit.pCommandBuffers = &prepared.readback->cmd;
      sent = dev.d.QueueSubmit(queue, 1, &submit, prepared.readback->fence) == VK_SUCCESS;
    }
    readbackSent(dev, prepared.readback, sent);
  }
  if (rodeAlong != VK_SUCCESS && rodeAlong != VK_NOT_READY) return;  // the application's submission failed
  // Submissions without a draw, a dispatch or a pass (uploads) are no frame's work.
  if (prepared.work && dev.config.frameSubmits > 0 && ++dev.frameWorkSubmits >= dev.config.frameSubmits) endFrame(dev);
}

void afterSubmit(DeviceState& dev, VkQueue queue, const std::vector<VkCommandBuffer>& submitted) {
  finishSubmit(dev, queue, prepareSubmit(dev, queue, submitted), VK_NOT_READY);
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
  if (auto f = dev.frames.find(dev.frame); f != dev.frames.end()) {
    changeFrame(dev, f->second, [](FrameRecord& r) { r.closed = true; });
  }
  ++dev.frame;
  dev.frameWorkSubmits = 0;
  pollReadbacks(dev);
}

void finish(DeviceState& dev, bool complete) {
  if (!dev.counting && dev.config.output.empty()) return;
  collect(dev, UINT64_MAX);
  if (auto f = dev.frames.find(dev.frame); f != dev.frames.end() && dev.config.frameSubmits == 0) {
    // the last frame, cut short by the application's end
    changeFrame(dev, f->second, [](FrameRecord& r) { r.closed = true; });
  }
  if (dev.written) return;
  writeOutput(dev, complete || framesCounted(dev) >= dev.config.frames);
}

}  // namespace tally::layer
