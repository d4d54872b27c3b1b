#include "renderers/pass_counters.hpp"

#include <algorithm>
#include <set>

namespace tally::renderers {
namespace {

const ResourceInfo* findResource(const std::vector<ResourceInfo>& resources, const std::string& name) {
  for (const auto& r : resources) {
    if (r.name == name) return &r;
  }
  return nullptr;
}

uint64_t slotValue(const std::vector<uint64_t>& counters, uint32_t slot) {
  return slot < counters.size() ? counters[slot] : 0;
}

}  // namespace

std::vector<std::string> lineNames(const spirv::Site& site, const PassBindings& bindings) {
  if (site.kind == spirv::SiteKind::OutputWrite) {
    auto it = site.location ? bindings.outputs.find(*site.location) : bindings.outputs.end();
    return {it != bindings.outputs.end() ? it->second : "output " + std::to_string(site.location.value_or(0))};
  }
  if (site.kind == spirv::SiteKind::BufferRead && site.location) {  // a vertex attribute
    auto at = bindings.vertexInputsAt.find(uint32_t(*site.location));
    return {at != bindings.vertexInputsAt.end() ? at->second : bindings.vertexInputs};
  }
  std::vector<std::string> names;
  if (auto it = bindings.bindings.find({site.set, site.binding}); it != bindings.bindings.end()) names = it->second;
  if (names.empty()) names.push_back(site.resource.empty() ? "unresolved" : site.resource);
  return names;
}

const std::string& elementName(const std::vector<std::string>& names, size_t element) {
  return names.size() > 1 ? names[std::min(element, names.size() - 1)] : names[0];
}

void addAccess(std::vector<Access>& accesses, const std::string& resource, bool write, uint64_t count,
               uint64_t elementBytes, const std::string& source, const std::string& kind) {
  auto it = std::find_if(accesses.begin(), accesses.end(), [&](const Access& a) {
    return a.resource == resource && a.write == write && a.source == source;
  });
  if (it == accesses.end()) {
    Access a;
    a.resource = resource;
    a.write = write;
    a.source = source;
    a.kind = kind;
    accesses.push_back(a);
    it = accesses.end() - 1;
  }
  it->count += count;
  it->bytes += count * elementBytes;
}

PassCounts attributeCounters(const std::vector<spirv::Site>& sites, const std::vector<uint64_t>& counters,
                             const PassBindings& bindings, const std::vector<ResourceInfo>& resources,
                             bool perSite) {
  PassCounts out;
  // A counted access: to its line, and with perSite to its site's own entry.
  auto count = [&](size_t siteIndex, const std::string& name, bool write, uint64_t n, uint64_t elementBytes,
                   const std::string& kind) {
    addAccess(out.accesses, name, write, n, elementBytes, "counter", kind);
    if (!perSite) return;
    SiteCount c;
    c.site = sites[siteIndex];
    c.resource = name;
    c.kind = kind;
    c.write = write;
    c.count = n;
    c.bytes = n * elementBytes;
    out.sites.push_back(std::move(c));
  };
  // The line's kind from the site's use; a texel buffer is a buffer, an
  // input attachment of a depth target a depth read.
  auto kindOf = [&](const spirv::Site& site, const std::string& name) -> std::string {
    const ResourceInfo* r = findResource(resources, name);
    if (r != nullptr && r->kind == ResourceKind::Buffer) return "buffer";
    if (r != nullptr && r->kind == ResourceKind::Depth && site.kind == spirv::SiteKind::AttachmentRead) return "depth";
    return std::string(spirv::useKind(site));
  };
  auto bytesOf = [&](const std::string& name, uint32_t fallback) -> uint64_t {
    const ResourceInfo* r = findResource(resources, name);
    return r != nullptr && r->elementBytes != 0 ? r->elementBytes : fallback;
  };
  // Sites of one (stage, kind, resource, width) share their slots: count each slot range once.
  std::set<uint32_t> seen;
  auto noteSlot = [&](uint64_t n, const std::string& name) {
    if (n > out.maxSlotCount) {
      out.maxSlotCount = n;
      out.maxSlotResource = name;
    }
  };
  for (size_t siteIndex = 0; siteIndex < sites.size(); ++siteIndex) {
    const spirv::Site& site = sites[siteIndex];
    using spirv::SiteKind;
    if (!seen.insert(site.slot).second) continue;
    if (site.kind == SiteKind::Invocation) {
      uint64_t n = slotValue(counters, site.slot);
      if (site.stage == spirv::Stage::Fragment) out.fragmentInvocations += n;
      if (site.stage == spirv::Stage::Vertex) out.vertexInvocations += n;
      if (site.stage == spirv::Stage::Compute) out.computeInvocations += n;
      noteSlot(n, std::string(spirv::toString(site.stage)) + " invocations");
      continue;
    }
    if (site.kind == SiteKind::OutputWrite) {
      const std::string name = lineNames(site, bindings)[0];
      count(siteIndex, name, true, slotValue(counters, site.slot), bytesOf(name, site.elementBytes), kindOf(site, name));
      noteSlot(slotValue(counters, site.slot), name);
      continue;
    }
    const bool write = site.kind == SiteKind::BufferWrite || site.kind == SiteKind::ImageWrite ||
                       site.kind == SiteKind::ImageAtomic;
    const bool isBuffer = site.kind == SiteKind::BufferRead || site.kind == SiteKind::BufferWrite;
    if (site.kind == SiteKind::BufferRead && site.location) {  // a vertex attribute
      const std::string buffer = lineNames(site, bindings)[0];
      count(siteIndex, buffer, false, slotValue(counters, site.slot), site.elementBytes, "buffer");
      noteSlot(slotValue(counters, site.slot), buffer);
      continue;
    }
    const std::vector<std::string> names = lineNames(site, bindings);
    for (uint32_t i = 0; i < std::max(site.slotCount, 1u); ++i) {
      uint64_t n = slotValue(counters, site.slot + i);
      if (n == 0 && site.slotCount > 1) continue;
      // A dynamic index: element i; a constant index: that element; else the binding.
      size_t element = site.slotCount > 1 ? i : site.index.value_or(0);
      const std::string& name = elementName(names, element);
      uint64_t bytes = isBuffer ? site.elementBytes : bytesOf(name, site.elementBytes);
      if (auto o = bindings.elementBytes.find({site.set, site.binding}); o != bindings.elementBytes.end()) {
        bytes = o->second;
      }
      count(siteIndex, name, write, n, bytes, kindOf(site, name));
      noteSlot(n, name);
      if (site.slotCount > 1) out.elements.push_back({site.set, site.binding, i, write, n, n * bytes});
    }
  }
  return out;
}

}  // namespace tally::renderers
