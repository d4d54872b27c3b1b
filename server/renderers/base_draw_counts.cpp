// RendererBase: counts per draw and per material (RendererOptions::draws).
// Every scene draw counts into a region of the counter buffer of its own
// (the counter set bound with a dynamic offset per draw, drawScene); after
// readback each region is settled and attributed as a whole frame's
// counters would be. Settling and attribution are linear in the counters,
// so the regions' sum gives every pass exactly the lines it has without
// draws, and a pass's draws sum to its counted lines.
#include <algorithm>
#include <cstring>
#include <map>

#include "renderers/material_split.hpp"
#include "renderers/renderer_base.hpp"
#include "shared.h"

namespace tally::renderers {

namespace {

// The counter buffer with draws stays under this (regions beyond it fold
// into the shared one): the readback of a frame stays bounded whatever the
// scene's draw count and the shaders' slot count.
constexpr uint64_t kMaxRegionBytes = 256ull << 20;

void addTo(MaterialCount& m, const DrawCount& d) {
  m.draws += d.draws;
  m.count += d.count;
  m.bytesRead += d.bytesRead;
  m.bytesWritten += d.bytesWritten;
}

}  // namespace

uint32_t RendererBase::drawRegion(uint32_t draw) const { return 1 + std::min(draw, countedDraws_); }

void RendererBase::sizeCounterRegions() {
  regionSlots_ = std::max(slotCount_, 1u);
  regionCount_ = 1;
  countedDraws_ = 0;
  if (!countsDraws()) return;
  // Each region starts at a valid dynamic offset.
  const uint64_t alignment = std::max<uint64_t>(ctx_->properties.limits.minStorageBufferOffsetAlignment, 8) / 8;
  regionSlots_ = uint32_t((uint64_t(regionSlots_) + alignment - 1) / alignment * alignment);
  const uint64_t regionBytes = uint64_t(regionSlots_) * sizeof(uint64_t);
  const uint64_t fitting = std::max<uint64_t>(kMaxRegionBytes / regionBytes, 3) - 2;  // less region 0 and the rest
  const uint64_t draws = scene_->draws().size();
  countedDraws_ = uint32_t(std::min<uint64_t>({draws, options_.maxCountedDraws, fitting}));
  regionCount_ = 1 + countedDraws_ + (draws > countedDraws_ ? 1 : 0);
}

std::vector<uint64_t> RendererBase::readCounters(std::vector<std::vector<uint64_t>>& regions) {
  regions.clear();
  const uint32_t count = countsDraws() ? regionCount_ : 1;
  const uint32_t stride = countsDraws() ? regionSlots_ : slotCount_;
  auto bytes = gpu::readBuffer(*ctx_, counters_, 0, VkDeviceSize(stride) * count * sizeof(uint64_t));
  std::vector<uint64_t> total(slotCount_, 0);
  std::vector<uint64_t> region(slotCount_);
  for (uint32_t r = 0; r < count; ++r) {
    std::memcpy(region.data(), bytes.data() + size_t(r) * stride * sizeof(uint64_t),
                region.size() * sizeof(uint64_t));  // little-endian hosts
    for (const auto& layout : copyLayouts_) spirv::settleCounters(region, layout);
    for (size_t s = 0; s < region.size(); ++s) total[s] += region[s];
    if (countsDraws()) regions.push_back(region);
  }
  return total;
}

void RendererBase::attributeDraws(uint32_t passIndex, PassResult& result,
                                  const std::vector<std::vector<uint64_t>>& regions) const {
  const Pass& p = passes_[passIndex];
  if (!countsDraws() || p.drawsRecorded.empty()) return;
  const auto& draws = scene_->draws();
  std::map<uint32_t, DrawCount> byRegion;  // each region once (a draw of two subsets is one draw)
  std::vector<uint32_t> order;
  for (uint32_t d : p.drawsRecorded) {
    const uint32_t region = drawRegion(d);
    auto [it, inserted] = byRegion.try_emplace(region);
    if (!inserted) {
      if (region == drawRegion(countedDraws_)) ++it->second.draws;
      continue;
    }
    order.push_back(region);
    it->second.index = d;
    it->second.mesh = scene_->meshName(d);
    it->second.material = scene_->materialName(draws[d].material);
    if (region >= regions.size()) continue;
    for (const Access& a : attributeCounters(p.sites, regions[region], p.bindings, resources_).accesses) {
      it->second.count += a.count;
      (a.write ? it->second.bytesWritten : it->second.bytesRead) += a.bytes;
    }
  }
  std::map<std::string, MaterialCount> materials;
  for (uint32_t region : order) {
    DrawCount& d = byRegion[region];
    if (region == drawRegion(countedDraws_)) {  // the draws beyond the cap: materials unknown
      MaterialCount& m = materials["(draws beyond " + std::to_string(countedDraws_) + ")"];
      addTo(m, d);
      result.drawsRest = d;
      continue;
    }
    addTo(materials[d.material], d);
    result.draws.push_back(d);
  }
  for (auto& [name, m] : materials) {
    m.material = name;
    result.materials.push_back(m);
  }
}

void RendererBase::splitMaterialMaps(uint32_t passIndex, PassResult& result, const PassCounts& counts) const {
  const Pass& p = passes_[passIndex];
  if (!countsDraws() || !p.drawsRecorded.empty()) return;
  const std::pair<int64_t, int64_t> maps = {shaders::kSetMaterial, shaders::kBindingMaterialMaps};
  const auto bound = p.bindings.bindings.find(maps);
  const auto& users = scene_->indexedMapMaterials();
  if (bound == p.bindings.bindings.end() || bound->second.size() < 2 || users.empty()) return;
  std::vector<std::string> names;
  for (uint32_t m = 0; m < scene_->materialCount(); ++m) names.push_back(scene_->materialName(m));
  std::vector<uint32_t> drawsOf(names.size(), 0);
  for (const auto& d : scene_->draws()) ++drawsOf[std::min<size_t>(d.material, drawsOf.size() - 1)];
  result.materials = materialMapSplit(counts.elements, maps, users, names, drawsOf, scenes::kMapSlotCount);
}

std::vector<MaterialCount> materialMapSplit(const std::vector<PassCounts::Element>& elements,
                                            std::pair<int64_t, int64_t> binding,
                                            const std::vector<std::vector<uint32_t>>& users,
                                            const std::vector<std::string>& materialNames,
                                            const std::vector<uint32_t>& drawsOf, uint32_t dummies) {
  std::map<std::string, MaterialCount> byName;
  for (const auto& e : elements) {
    if (std::make_pair(e.set, e.binding) != binding || e.count == 0) continue;
    const std::vector<uint32_t> none;
    const auto& sampledBy = e.element < users.size() ? users[e.element] : none;
    std::string name = e.element < dummies ? std::string("no ") + mapKindName(e.element) + " map" : "";
    uint32_t draws = 0;
    for (uint32_t m : sampledBy) {
      if (e.element >= dummies && m < materialNames.size()) name += (name.empty() ? "" : " + ") + materialNames[m];
      draws += m < drawsOf.size() ? drawsOf[m] : 0;
    }
    if (name.empty()) name = "element " + std::to_string(e.element);  // bound, sampled by no material
    MaterialCount& m = byName[name];
    m.material = name;
    m.draws = draws;
    m.count += e.count;
    (e.write ? m.bytesWritten : m.bytesRead) += e.bytes;
  }
  std::vector<MaterialCount> out;
  for (auto& [name, m] : byName) out.push_back(std::move(m));
  return out;
}

}  // namespace tally::renderers
