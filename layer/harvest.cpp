// What a readback brings: each region's counters attributed to its pass's
// lines, and the queries' times and statistics to its passes (docs/layer.md,
// "How counts are attributed").
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "device_objects.hpp"
#include "names.hpp"
#include "state.hpp"

namespace tally::layer {

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
  for (const auto& layout : pipeline.foldLayouts) spirv::settleCounters(counters, layout);
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
      // An access by address: the buffer the address table gave this slot (addresses.hpp).
      const Bound bound = site.byAddress                          ? Bound{addressedResource(dev, i)}
                          : slot < region.slotResources.size() ? region.slotResources[slot]
                                                                : Bound{};
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
      } else if (site.byAddress) {
        name = bound.resource == kOtherBuffers ? "other buffers" : "unknown address";
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
      addDrawCount(dev, region, write, n, bytes, pass);
      if (dev.config.sites) {
        auto [at, inserted] = pass.sites.try_emplace({site.shader, site.instruction, name, write});
        if (inserted) {
          at->second.site = site;
          at->second.kind = kind;
        }
        at->second.count += n;
        at->second.bytes += n * bytes;
      }
    }
  }
}

}  // namespace

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
        noteDraw(dev, region, frame->second.passes[first + region.pass]);
        attributeRegion(dev, region, std::move(counters), frame->second.passes[first + region.pass]);
      }
    }
  }
}

}  // namespace tally::layer
