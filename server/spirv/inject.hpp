// The counter-injection pass: adds the counter buffer, one helper function per
// stage and counting mode, and a call to it after every access site.
#pragma once

#include <string>
#include <vector>

#include "spirv/find_sites.hpp"
#include "spirv/instrument.hpp"
#include "spirv/module.hpp"
#include "spirv/types.hpp"

namespace tally::spirv {

// Runtime-sized descriptor arrays indexed dynamically get this many slots;
// larger indices are clamped into the last one.
constexpr uint32_t kRuntimeArraySlots = 128;

// Sampling tile for sampled:N: th = largest divisor of N with th*th <= N,
// tw = N / th. One invocation per tile of tw x th pixels (or invocations) counts.
struct TileShape {
  uint32_t width;
  uint32_t height;
};
TileShape sampledTileShape(uint32_t n);

// Rewrites `module` in place. `slots[i]` is the first slot of scan.sites[i].
// Returns an error message, or "" on success; appends fallbacks to notes.
std::string injectCounters(Module& module, const DefIndex& defs, const Types& types, const SiteScan& scan,
                           const std::vector<uint32_t>& slots, const InstrumentOptions& options,
                           std::vector<std::string>& notes);

}  // namespace tally::spirv
