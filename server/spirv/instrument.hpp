// Counter injection: rewrites a SPIR-V module so that every memory access
// site increments a 64-bit counter in a storage buffer. See docs/measurement.md.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/result.hpp"
#include "spirv/arith.hpp"
#include "spirv/sites.hpp"
#include "spirv/validate.hpp"

namespace tally::spirv {

enum class CountMode {
  Exact,       // one atomic per access
  Subgroup,    // reduce across the subgroup, one atomic per subgroup and slot
  Sampled,     // count in 1 of N pixels/invocations (stratified), scale by N
  Accumulate,  // add in a per-invocation register; flush once where the invocation ends
};

// How the accumulate mode flushes its per-invocation registers.
enum class Flush {
  Auto,      // per lane in InstrumentOptions::autoLaneStages, else reduced where the stage has subgroup arithmetic
  Subgroup,  // a subgroup reduction and one atomic per slot, in every stage with subgroup arithmetic
  Lane,      // one atomic per lane and non-zero slot
};

struct Mode {
  CountMode kind = CountMode::Exact;
  uint32_t sampleRate = 1;  // N for Sampled, 1 otherwise
  Flush flush = Flush::Auto;  // Accumulate only
};

// "exact", "subgroup", "sampled:N" (N in [2, 65536]), "accumulate",
// "accumulate:subgroup", "accumulate:lane".
Result<Mode> parseMode(std::string_view text);
std::string toString(const Mode& mode);

// What footprint marks skip before the bitmap's atomic OR (docs/measurement.md,
// "Footprint"). Each choice leaves the bits set, and so every count, unchanged.
struct FootprintDedup {
  // Lanes of a subgroup marking the same bitmap word combine their bits and
  // one of them marks for all, in stages with subgroup arithmetic.
  bool subgroup = false;
  // Each invocation remembers the last two words it marked and their bits,
  // and skips a block it marked already. Off by default: on the H200 it
  // made Sponza's footprint frames slower, x3.01-3.29 of plain against
  // x2.74-2.90 without (docs/measurement.md, "What a mark skips").
  bool cache = false;
  // A buffer access in a counted loop whose offset moves by at most a block
  // each iteration marks, where the loop is entered, the range of blocks
  // its iterations cover, and nothing inside the loop (docs/measurement.md,
  // "Loops: one range instead of a mark per iteration").
  bool loops = true;
  // A texel mark (a fetch, a storage image, an attachment read) is left to
  // the first lane of the subgroup that marks the same block: the lanes are
  // partitioned by block where the device can (VK_NV_shader_subgroup_partitioned),
  // else compared within quads. Pixel-addressed passes (lighting, tonemap)
  // then issue one load and atomic per block instead of one per lane
  // (docs/measurement.md, "What a mark costs"). In stages with subgroup ballots.
  bool lanes = true;
  bool operator==(const FootprintDedup&) const = default;
};

// "none", "all", or a comma-separated list of "subgroup", "cache", "loops" and "lanes".
Result<FootprintDedup> parseFootprintDedup(std::string_view text);
std::string toString(const FootprintDedup& dedup);

constexpr uint32_t kStudyNoAdds = 1, kStudyNoFlush = 2, kStudyInlineFlush = 4, kStudyElectedAdds = 8,
                   kStudySplitReductions = 16, kStudyWaterfallEach = 32, kStudyPartitioned = 64,
                   kStudyEvictAlways = 128;
Result<uint32_t> parseStudy(std::string_view text);

// How a 64-bit counter is incremented.
enum class CounterWidth {
  Int64,       // OpAtomicIAdd on uint64 (needs shaderInt64 + shaderBufferInt64Atomics)
  Uint32Pair,  // 32-bit add on the low word, carry into the high word on wrap
};

// Bit per Stage (1u << int(Stage)).
constexpr uint32_t stageBit(Stage s) { return 1u << static_cast<uint32_t>(s); }
constexpr uint32_t kAllStages = 0xffffffffu;

struct InstrumentOptions {
  Mode mode;
  uint32_t set = 7;      // descriptor set of the counter buffer (7: the last of lavapipe's 8)
  uint32_t binding = 0;  // binding of the counter buffer
  uint32_t firstSlot = 0;  // slots start here, so several modules can share one buffer
  CounterWidth width = CounterWidth::Int64;
  // Stages whose subgroup operations the device supports; Subgroup mode falls
  // back to Exact elsewhere (lavapipe: fragment and compute only).
  uint32_t subgroupStages = kAllStages;
  // Accumulate's Auto flush goes per lane in these stages: where the device
  // combines a warp's same-address atomics itself (NVIDIA's graphics
  // stages, gpu::instrumentOptionsFor), an explicit reduction costs more.
  // Elsewhere it reduces where the stage has subgroup arithmetic.
  uint32_t autoLaneStages = stageBit(Stage::Vertex) | stageBit(Stage::TessControl) | stageBit(Stage::TessEval) |
                            stageBit(Stage::Geometry) | stageBit(Stage::Fragment);
  // accumulate mode: compute flushes stripe each slot over this many copies
  // (a power of two in [1, 256]; 1 turns striping off). See CopyLayout.
  uint32_t computeCopies = 16;
  // accumulate mode, for the study of what its parts cost (docs/measurement.md,
  // "The accumulate mode's cost, part by part"): kStudyNoAdds leaves out
  // every add in the shader (sites, trip counters, cached arrays, executed
  // arithmetic), kStudyNoFlush every flush (the counts are then not the
  // mode's, and the module's notes say so); kStudyInlineFlush asks the
  // driver to inline the flush function; kStudyElectedAdds flushes as before
  // the flush in rounds (one elected lane adds each register in turn), and
  // kStudySplitReductions reduces every register in two 16-bit halves, as
  // before the one-reduction flush, and kStudyWaterfallEach flushes each
  // cached descriptor array in a waterfall of its own, as before they shared
  // one (accumulate_rounds.cpp); kStudyPartitioned flushes cached arrays by
  // partitioning the subgroup instead of a waterfall, in partitionedStages.
  // 0 here: $TALLY_ACCUMULATE_STUDY where set (no-adds, no-flush,
  // inline-flush, elected-adds, split-reductions, waterfall-each,
  // partitioned, comma-separated).
  uint32_t study = 0;
  // Stages whose subgroups the device can partition by value
  // (VK_NV_shader_subgroup_partitioned, enabled on the device), for
  // kStudyPartitioned: long descriptor arrays' caches then flush with one
  // partition of the lanes by element instead of a waterfall over the
  // distinct elements. Only within subgroupStages. Not the default: on the
  // H200 it cost more than the waterfall (docs/accuracy.md).
  uint32_t partitionedStages = 0;
  // Footprint (spirv/footprint.hpp, docs/measurement.md): 0 off, else the
  // block size in bytes (32, 64 or 128). Every access also marks the blocks
  // it covers in the bitmap of its slot's resource; the table at
  // footprintTableBinding (an Entry per slot, bound with a dynamic offset
  // per draw where bindings change) says where that bitmap lies in the
  // buffer at footprintBitmapBinding and what is bound. Both in `set`.
  uint32_t footprintBlockBytes = 0;
  uint32_t footprintTableBinding = 1;
  uint32_t footprintBitmapBinding = 2;
  // Unset: $TALLY_FOOTPRINT_DEDUP where set (parseFootprintDedup),
  // so that one capture's spec compares the choices; else FootprintDedup's defaults.
  std::optional<FootprintDedup> footprintDedup;
  // Buffer device addresses: a physical-storage-buffer access counts into
  // the slot of the buffer whose address range holds its address, found in
  // the host's table (spirv/address_table.hpp) at addressTableBinding of
  // `set`; kAddressSlots slots per site (Site::byAddress). Needs the
  // device's shaderInt64. Off, such accesses share one slot per width.
  bool addressTable = false;
  uint32_t addressTableBinding = 3;
  // accumulate mode: sites that run exactly once in every invocation are
  // derived from the entry point's invocation counter (Instrumented::derived)
  // instead of counted in the shader, and so are sites that run once per
  // loop iteration, from a trip counter per loop (spirv/loops.hpp). Off,
  // every site adds in the shader:
  // for tests of the shader's own adds (counter overflow).
  bool deriveOnceSites = true;
  // Each access site gets counter slots of its own (Site::slot), and its
  // function, instruction and disassembly: the reader sums a resource line
  // over its sites, and keeps each site's count (bytes per source line).
  // Off, sites of one resource and stage share their slots.
  bool perSite = false;
  // accumulate mode: also count the arithmetic the invocations execute
  // (each block adds its operations, as spirv/arith.hpp counts them, to a
  // register flushed with the others into Instrumented::arithmeticSlot).
  bool countArithmetic = false;
  // Validate input and output with SPIRV-Tools, for this device: a layer
  // validates for the application's device (its Vulkan version and the
  // block layouts it enabled); the default is the strictest reading.
  bool validate = true;
  ValidationTarget target;
  // Fragment entry points without EarlyFragmentTests get it where adding it
  // changes nothing the shader does (no discard or demote, no depth,
  // stencil or sample-mask output, no stores or atomics of its own): the
  // counters' atomics would otherwise move the depth and stencil tests after
  // the shader, and fragments they reject would run and be counted.
  // Elsewhere a note says why the mode was not added.
  bool earlyFragmentTests = false;
};

// A count the reader derives rather than the shader: counters[to] +=
// times * counters[from]. Accumulate mode counts a site that runs exactly
// once in every invocation of its entry point (on every path to a return,
// outside loops, in an entry point that cannot end other than by
// returning) by the entry point's invocation counter, `from`: `times` such
// sites share slot `to`. A site that runs once in every iteration of a loop
// is counted by the loop's trip counter, `from`: a slot of its own after
// the sites' (within slotCount), which no site names.
struct DerivedCount {
  uint32_t from = 0;
  uint32_t to = 0;
  uint32_t times = 0;
  bool operator==(const DerivedCount&) const = default;
};

// Where a module's counters lie in the counter buffer, and what the reader
// does before using them (settleCounters). Slot s (in [firstSlot, firstSlot
// + slotCount)) has `copies` copies, copy k at s + k * stride; the count is
// their sum. Unstriped modules have one copy and reserve slotCount slots.
struct CopyLayout {
  uint32_t firstSlot = 0;
  uint32_t slotCount = 0;
  uint32_t copies = 1;
  uint32_t stride = 0;
  std::vector<DerivedCount> derived;  // slots absolute, like firstSlot
  // Slots the module needs in the buffer, from firstSlot.
  uint32_t reserved() const { return copies > 1 ? stride * copies : slotCount; }
  // Whether the counters read back need settleCounters.
  bool needsSettling() const { return copies > 1 || !derived.empty(); }
};

// Adds every copy into the first one (counters is the whole buffer, from slot 0).
void foldCopies(std::span<uint64_t> counters, const CopyLayout& layout);

// What a reader does to a module's counters as read back: folds the copies,
// then adds the derived counts (counters is the whole buffer, from slot 0).
void settleCounters(std::span<uint64_t> counters, const CopyLayout& layout);

struct Instrumented {
  std::vector<uint32_t> words;   // the rewritten module
  std::vector<Site> sites;       // every site found, in module order
  uint32_t slotCount = 0;        // slots used: [firstSlot, firstSlot + slotCount)
  uint32_t firstSlot = 0;        // options.firstSlot
  uint32_t copies = 1;           // >1: compute counters striped (CopyLayout)
  uint32_t copyStride = 0;       // slots between copies when copies > 1
  uint32_t versionIn = 0;        // SPIR-V version word of the input (0x00010000 = 1.0)
  uint32_t versionOut = 0;       // raised to 1.3 when subgroup mode needs it
  bool inlined = false;          // functions were inlined to resolve resources
  bool earlyTestsAdded = false;  // a fragment entry point was given EarlyFragmentTests (options.earlyFragmentTests)
  std::vector<std::string> notes;  // fallbacks taken, for the user
  // Arithmetic per invocation of each entry point, counted on the input
  // module (the counters' own instructions excluded): spirv/arith.hpp.
  std::vector<EntryArithmetic> arithmetic;
  // countArithmetic: the slot holding the executed operations of every
  // invocation of the module (all entry points); -1 where not counted.
  int64_t arithmeticSlot = -1;
  // accumulate mode: counts the reader derives from invocation counters (settleCounters).
  std::vector<DerivedCount> derived;
  // Footprint on: what its marks skip (the subgroup's only where the stage has subgroup arithmetic).
  std::optional<FootprintDedup> footprintDedup;

  CopyLayout layout() const { return {firstSlot, slotCount, copies, copyStride, derived}; }
};

// Instruments a module. Fails with a one-line reason on invalid or
// unsupported input, or when the module already uses the counter binding.
Result<Instrumented> instrument(std::span<const uint32_t> words, const InstrumentOptions& options);

// Sites only, without rewriting (same resolution rules, same slots).
Result<Instrumented> analyze(std::span<const uint32_t> words, const InstrumentOptions& options);

nlohmann::json toJson(const Site& site);
// A site's share of a result line (InstrumentOptions::perSite), as a pass's
// "sites" entry carries it (docs/result-schema.md): what the site is, where
// in the source, and its count and bytes per frame.
nlohmann::json countedSiteJson(const Site& site, const std::string& resource, bool write, const std::string& kind,
                               double count, double bytes);
nlohmann::json toJson(const Instrumented& result, const InstrumentOptions& options);

// Whether the module demotes fragments to helpers (OpDemoteToHelperInvocation):
// Mesa 22.3's lavapipe cannot compile subgroup reductions that read
// HelperInvocation volatile in such modules.
bool usesDemote(std::span<const uint32_t> words);

// Bytes read as a little-endian buffer of uint32 words, with a clear error for
// sizes that are not a whole number of words.
Result<std::vector<uint32_t>> wordsFromBytes(std::span<const uint8_t> bytes);

}  // namespace tally::spirv
