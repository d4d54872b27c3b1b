// Footprint in the renderers (docs/measurement.md, "Footprint"): the table
// banks, built from the passes' sites and what the descriptor sets they bind
// hold, and the attribution of the marked blocks to the passes' lines.
#include <algorithm>

#include "gpu/resources.hpp"
#include "gpu/vk_check.hpp"
#include "renderers/renderer_base.hpp"

namespace tally::renderers {
namespace {

namespace fp = spirv::footprint;

std::string lineKey(uint32_t pass, const std::string& resource, bool write) {
  return std::to_string(pass) + "\t" + resource + "\t" + (write ? "w" : "r");
}

bool writes(spirv::SiteKind kind) {
  using K = spirv::SiteKind;
  return kind == K::BufferWrite || kind == K::ImageWrite || kind == K::ImageAtomic || kind == K::OutputWrite;
}

std::string handleKey(const char* what, const void* handle) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%s:%p", what, handle);
  return buf;
}

}  // namespace

void RendererBase::discoverFootprint() {
  footprint_.configure(options_.footprintBlockBytes, std::max(slotCount_, 1u));
  footprint_.addBank();  // bank 0: every slot off (bindings the first frame did not see)
  banks_.clear();
  footprintRegions_.clear();
  unmeasuredLines_.clear();
  // Lines with a site the instrumentation could not mark have no footprint.
  for (uint32_t p = 0; p < passes_.size(); ++p) {
    const Pass& pass = passes_[p];
    for (const auto& s : pass.sites) {
      if (s.kind == spirv::SiteKind::Invocation || s.footprint) continue;
      for (const auto& n : lineNames(s, pass.bindings)) unmeasuredLines_.insert(lineKey(p, n, writes(s.kind)));
    }
  }
  // Record once, unsubmitted: every bind of the counter set creates its bank.
  footprintDiscovering_ = true;
  VkCommandBufferAllocateInfo alloc = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  alloc.commandPool = ctx_->commandPool;
  alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  alloc.commandBufferCount = 1;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  VK_CHECK(vkAllocateCommandBuffers(ctx_->device, &alloc, &cmd));
  VkCommandBufferBeginInfo begin = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  VK_CHECK(vkBeginCommandBuffer(cmd, &begin));
  recordAll(cmd);
  VK_CHECK(vkEndCommandBuffer(cmd));
  vkFreeCommandBuffers(ctx_->device, ctx_->commandPool, 1, &cmd);
  footprintDiscovering_ = false;

  footprint_.create(*ctx_);
  auto writes = footprint_.descriptorWrites(1, 2);
  gpu::updateDescriptorSet(*ctx_, counterDescriptorSet_, writes);
  footprintReady_ = true;
}

uint32_t RendererBase::footprintBank(VkPipelineBindPoint point) {
  const auto& bound = boundSets_[point == VK_PIPELINE_BIND_POINT_COMPUTE ? 1 : 0];
  auto key = std::make_pair(recordingPass_, bound);
  if (auto it = banks_.find(key); it != banks_.end()) return it->second;
  if (!footprintDiscovering_) return 0;  // not seen in the first frame: nothing marked
  uint32_t bank = footprint_.addBank();
  banks_.emplace(key, bank);
  fillFootprintBank(bank, recordingPass_, point);
  return bank;
}

void RendererBase::fillFootprintBank(uint32_t bank, uint32_t passIndex, VkPipelineBindPoint point) {
  const Pass& pass = passes_[passIndex];
  const auto& bound = boundSets_[point == VK_PIPELINE_BIND_POINT_COMPUTE ? 1 : 0];
  const uint32_t block = footprint_.blockBytes();
  const gpu::ResourceLog& log = *ctx_->log;
  auto info = [&](const std::string& name) -> const ResourceInfo* {
    for (const auto& r : resources_)
      if (r.name == name) return &r;
    return nullptr;
  };
  auto addRegion = [&](const std::string& line, const std::string& physical, uint64_t blocks) {
    std::string region = line + "\t" + physical;
    footprintRegions_[line].insert(region);
    return footprint_.region(region, blocks);
  };
  for (const auto& s : pass.sites) {
    if (!s.footprint) continue;
    const bool write = writes(s.kind);
    const std::vector<std::string> names = lineNames(s, pass.bindings);
    if (s.kind == spirv::SiteKind::OutputWrite) {
      const ResourceInfo* r = info(names[0]);
      if (r == nullptr || r->width == 0) continue;
      fp::ImageGeometry g{r->width, r->height, 1, 1, r->elementBytes * std::max(r->samples, 1u), 0, 1, 0};
      std::string line = lineKey(passIndex, names[0], true);
      footprint_.set(bank, s.slot, fp::imageEntry(g, block, addRegion(line, "target", fp::imageBlocks(g, block))));
      continue;
    }
    if (s.location) {  // a vertex attribute
      auto inputs = vertexInputs_.find(passIndex);
      if (inputs == vertexInputs_.end()) continue;
      auto in = inputs->second.find(*s.location);
      if (in == inputs->second.end()) continue;
      const gpu::Buffer& buffer = in->second.binding == 0 ? vertexBuffer() : scene_->attributeBuffer();
      auto bytes = log.buffer(buffer.buffer);
      if (!bytes) continue;
      std::string line = lineKey(passIndex, names[0], false);
      uint32_t base = addRegion(line, handleKey("buffer", buffer.buffer), fp::bufferBlocks(*bytes, block));
      footprint_.set(bank, s.slot, fp::vertexInputEntry(*bytes, in->second.stride, in->second.offset, block, base));
      continue;
    }
    if (s.set < 0 || size_t(s.set) >= bound.size() || bound[size_t(s.set)] == VK_NULL_HANDLE) continue;
    VkDescriptorSet set = bound[size_t(s.set)];
    for (uint32_t i = 0; i < std::max(s.slotCount, 1u); ++i) {
      uint32_t element = s.slotCount > 1 ? i : s.index.value_or(0);
      const std::string& name = elementName(names, element);
      const gpu::LoggedDescriptor* d = log.written(set, uint32_t(s.binding), element);
      if (d == nullptr) continue;
      std::string line = lineKey(passIndex, name, write);
      if (d->view != VK_NULL_HANDLE) {
        const gpu::ViewInfo* v = log.view(d->view);
        if (v == nullptr) continue;
        const gpu::SamplerInfo* sampler = d->sampler != VK_NULL_HANDLE ? log.sampler(d->sampler) : nullptr;
        fp::ImageGeometry g{v->width, v->height, v->imageLevels, v->layers, v->texelBytes,
                            v->baseLevel, v->levels, sampler != nullptr ? sampler->bits : 0};
        uint32_t base = addRegion(line, handleKey("view", d->view), fp::imageBlocks(g, block));
        footprint_.set(bank, s.slot + (s.slotCount > 1 ? i : 0), fp::imageEntry(g, block, base));
      } else if (d->buffer != VK_NULL_HANDLE) {
        auto size = log.buffer(d->buffer);
        if (!size) continue;
        VkDeviceSize bytes = d->range == VK_WHOLE_SIZE ? *size - std::min(*size, d->offset) : d->range;
        uint32_t base = addRegion(line, handleKey("buffer", d->buffer) + "+" + std::to_string(d->offset),
                                  fp::bufferBlocks(bytes, block));
        footprint_.set(bank, s.slot + (s.slotCount > 1 ? i : 0), fp::bufferEntry(bytes, block, base));
      }
    }
  }
}

void RendererBase::indexFootprint(const Pass& pass, std::vector<Access>& accesses) const {
  // Every index of a drawn range is fetched (32-bit indices): the blocks of
  // the union of the byte ranges.
  const uint64_t block = footprint_.blockBytes();
  std::vector<std::pair<uint64_t, uint64_t>> blocks;  // [first, last] block of each range
  for (const auto& [first, count] : pass.indexRanges) {
    if (count == 0) continue;
    uint64_t begin = uint64_t(first) * 4, end = (uint64_t(first) + count) * 4 - 1;
    blocks.emplace_back(begin / block, end / block);
  }
  std::sort(blocks.begin(), blocks.end());
  uint64_t total = 0, next = 0;  // blocks counted, and the first block not yet counted
  for (const auto& [a, b] : blocks) {
    uint64_t from = std::max(a, next);
    if (b >= from) total += b - from + 1;
    next = std::max(next, b + 1);
  }
  for (auto& a : accesses) {
    if (a.resource != "indices" || a.write || a.source != "derived") continue;
    a.footprintBlocks = int64_t(total);
    a.footprintBytes = int64_t(std::min<uint64_t>(total * block, a.bytes));
    a.footprintClamped = total * block > a.bytes;
  }
}

void RendererBase::attributeFootprint(uint32_t passIndex, std::vector<Access>& accesses,
                                      const std::vector<uint32_t>& bitmap) const {
  for (auto& a : accesses) {
    if (a.source != "counter") continue;
    std::string line = lineKey(passIndex, a.resource, a.write);
    auto regions = footprintRegions_.find(line);
    if (unmeasuredLines_.count(line) || regions == footprintRegions_.end()) continue;
    uint64_t blocks = 0;
    for (const auto& r : regions->second) blocks += footprint_.blocks(bitmap, r);
    // The smaller of the two: a line that touches a block for fewer bytes
    // than it holds reports the bytes it requested (docs/measurement.md).
    a.footprintBytes = int64_t(std::min<uint64_t>(blocks * footprint_.blockBytes(), a.bytes));
    a.footprintBlocks = int64_t(blocks);
    a.footprintClamped = blocks * footprint_.blockBytes() > a.bytes;
  }
}

}  // namespace tally::renderers
