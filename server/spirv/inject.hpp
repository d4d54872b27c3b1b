// The counter-injection pass: adds the counter buffer, one helper function per
// stage and counting mode, and a call to it after every access site.
#pragma once

#include <string>
#include <vector>

#include "common/result.hpp"
#include "spirv/find_sites.hpp"
#include "spirv/instrument.hpp"
#include "spirv/module.hpp"
#include "spirv/types.hpp"

namespace tally::spirv {

// Runtime-sized descriptor arrays indexed dynamically get this many slots;
// larger indices are clamped into the last one.
constexpr uint32_t kRuntimeArraySlots = 128;

// accumulate mode: a descriptor array indexed at run time accumulates into a
// Private u32 array of its length up to this many elements (64 bytes per
// invocation, which drivers keep in registers or in L1-resident local
// memory, and a flush of 16 unrolled reductions). Longer arrays (runtime-
// sized ones: 128 slots) would cost more local memory and flush work per
// invocation than the atomics they save in the usual few accesses per
// invocation: their sites are counted per access, with a note.
constexpr uint32_t kAccumulateArrayMax = 16;

// Sampling tile for sampled:N: th = largest divisor of N with th*th <= N,
// tw = N / th. One invocation per tile of tw x th pixels (or invocations) counts.
struct TileShape {
  uint32_t width;
  uint32_t height;
};
TileShape sampledTileShape(uint32_t n);

// Copies of a striped counter block start on 128-byte boundaries, so that
// no two copies of a slot share a cache line.
constexpr uint32_t kCopyAlignSlots = 16;

// Rewrites `module` in place. `slots[i]` is the first slot of scan.sites[i];
// result.slotCount is already set. Fails with a one-line reason; appends
// fallbacks to result.notes and sets result.copies and result.copyStride
// when compute counters are striped.
Result<bool> injectCounters(Module& module, const DefIndex& defs, const Types& types, const SiteScan& scan,
                            const std::vector<uint32_t>& slots, const InstrumentOptions& options,
                            Instrumented& result);

}  // namespace tally::spirv
