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

// Footprint's parts, for the study of what each costs (TALLY_ACCUMULATE_STUDY
// names them fp-*; docs/measurement.md, "What a mark costs"). Altering the
// footprint (the notes then say it is not the mode's): kStudyFpNoMarks
// leaves tally_fp_mark empty, kStudyFpNoBitmap works the blocks out and
// never reads or writes the bitmap, kStudyFpNoOutputs and kStudyFpNoSamples
// leave fragment outputs and filtered reads unmarked. The same footprint,
// marked otherwise: kStudyFpAliased without the table's NonWritable and the
// buffers' Restrict; with FootprintDedup::lanes, kStudyFpQuad combines texel
// marks within quads and kStudyFpFirst with the subgroup's first lane
// instead of a partition; kStudyFpOwnOutputs leaves every fragment output's
// mark to its own lane, kStudyFpMatchSamples combines every mark of a
// filtered read and kStudyFpMatchBytes every buffer mark (by partition
// only); kStudyFpRed sets every bit with an atomic and no load first, and
// kStudyFpLoadSamples loads a filtered read's word first, as marks did
// before 2026-11-29 (now its atomic goes without: faster on the H200).
constexpr uint32_t kStudyFpNoMarks = 1u << 8, kStudyFpNoBitmap = 1u << 9, kStudyFpNoOutputs = 1u << 10,
                   kStudyFpNoSamples = 1u << 11, kStudyFpAliased = 1u << 12, kStudyFpQuad = 1u << 13,
                   kStudyFpFirst = 1u << 14, kStudyFpOwnOutputs = 1u << 15, kStudyFpMatchSamples = 1u << 16,
                   kStudyFpMatchBytes = 1u << 17, kStudyFpRed = 1u << 18, kStudyFpLoadSamples = 1u << 19;
constexpr uint32_t kStudyFpAltered = kStudyFpNoMarks | kStudyFpNoBitmap | kStudyFpNoOutputs | kStudyFpNoSamples;

// Rewrites `module` in place. `slots[i]` is the first slot of scan.sites[i];
// result.slotCount is already set. Fails with a one-line reason; appends
// fallbacks to result.notes and sets result.copies and result.copyStride
// when compute counters are striped.
Result<bool> injectCounters(Module& module, const DefIndex& defs, const Types& types, const SiteScan& scan,
                            const std::vector<uint32_t>& slots, const InstrumentOptions& options,
                            Instrumented& result);

}  // namespace tally::spirv
