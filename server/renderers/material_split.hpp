// The material-map reads of a shading pass split per material
// (RendererOptions::draws; base_draw_counts.cpp), apart from RendererBase so
// that it can be checked on the host.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "renderers/pass_counters.hpp"
#include "renderers/renderer.hpp"

namespace tally::renderers {

// The reads of a dynamically indexed map array split per material
// (RendererOptions::draws, the visibility buffers' shading passes): the
// counted `elements` of the array at `binding`; `users[e]` the materials that
// sample element e, the first `dummies` elements each kind's 1x1 dummy
// ("no <kind> map"); a texture several materials share is one entry naming
// them all ("a + b"). `draws` is the sum of `drawsOf` over the entry's
// materials. Sorted by name.
std::vector<MaterialCount> materialMapSplit(const std::vector<PassCounts::Element>& elements,
                                            std::pair<int64_t, int64_t> binding,
                                            const std::vector<std::vector<uint32_t>>& users,
                                            const std::vector<std::string>& materialNames,
                                            const std::vector<uint32_t>& drawsOf, uint32_t dummies);

}  // namespace tally::renderers
