// Counter attribution: reduces a frame's counter buffer to a pass's Access
// lines, from its shaders' site tables and a map of what the pass bound where.
// Bytes per event come from the ResourceInfo of the resource (its real
// format) for images and attachments, and from the site's type for buffers.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "renderers/renderer.hpp"
#include "spirv/sites.hpp"

namespace tally::renderers {

// What one pass bound: (set, binding) -> resource name(s). One name: the
// binding (all of an array's elements); several: one per array element, so
// that a dynamic index into a descriptor array attributes each element's
// count to the texture bound there.
struct PassBindings {
  std::map<std::pair<int64_t, int64_t>, std::vector<std::string>> bindings;
  std::map<uint32_t, std::string> outputs;  // fragment output Location -> attachment
  std::string vertexInputs = "vertices";    // the vertex buffer behind every vertex attribute ...
  std::map<uint32_t, std::string> vertexInputsAt;  // ... but these Locations' (glTF's second vertex buffer)
  // Bytes per read where the bound view differs from the resource's format
  // (the depth aspect of D32_S8: 4).
  std::map<std::pair<int64_t, int64_t>, uint32_t> elementBytes;

  void bind(int64_t set, int64_t binding, std::string name) { bindings[{set, binding}] = {std::move(name)}; }
};

struct PassCounts {
  std::vector<Access> accesses;
  uint64_t fragmentInvocations = 0;
  uint64_t vertexInvocations = 0;
  uint64_t computeInvocations = 0;
  // The largest single slot of the pass and what it counts (a resource line's
  // name, or "fragment invocations"): how close a counter came to wrapping.
  uint64_t maxSlotCount = 0;
  std::string maxSlotResource;
  std::vector<SiteCount> sites;  // with perSite: each site's share of the lines
  // Every counted element of a dynamically indexed descriptor array (a
  // site with several slots): what it added to its line, by element.
  struct Element {
    int64_t set = 0, binding = 0;
    uint32_t element = 0;
    bool write = false;
    uint64_t count = 0, bytes = 0;
  };
  std::vector<Element> elements;
};

// The line names a site's slots count for: the attachment at an output's
// Location, the vertex buffer behind an attribute, the resources bound at
// the site's (set, binding) (one per array element where the pass named
// them so), else the site's own resource name.
std::vector<std::string> lineNames(const spirv::Site& site, const PassBindings& bindings);
// The name of descriptor array element `element` among lineNames().
const std::string& elementName(const std::vector<std::string>& names, size_t element);

// `counters` is the whole counter buffer (a site's slots index it directly).
// Resources missing from `resources` fall back to the site's element bytes.
// With `perSite` (sites counted with spirv::InstrumentOptions::perSite),
// PassCounts::sites gets every site's count: the lines are then the sums
// over their sites.
PassCounts attributeCounters(const std::vector<spirv::Site>& sites, const std::vector<uint64_t>& counters,
                             const PassBindings& bindings, const std::vector<ResourceInfo>& resources,
                             bool perSite = false);

// Adds (or merges into) a line.
void addAccess(std::vector<Access>& accesses, const std::string& resource, bool write, uint64_t count,
               uint64_t elementBytes, const std::string& source, const std::string& kind = "");

}  // namespace tally::renderers
