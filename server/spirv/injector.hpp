// The injector's parts: ModuleBuilder makes types, constants, variables,
// instructions and functions in the module being rewritten, and holds what
// every transformation shares; Injector adds the transformations (per-site
// counting, accumulate's registers and flushes, executed arithmetic,
// footprint marks), each defined in a file of its own. Internal to
// server/spirv: inject.hpp is the interface.
#pragma once

#include <bit>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "spirv/inject.hpp"
#include "spirv/loops.hpp"

namespace tally::spirv {

// Scope and semantics words (SPIR-V spec 3.27, 3.25).
constexpr uint32_t kScopeDevice = 1;
constexpr uint32_t kScopeSubgroup = 3;
constexpr uint32_t kScopeQueueFamily = 5;
constexpr uint32_t kSemanticsRelaxed = 0;
constexpr uint32_t kGroupReduce = 0;
constexpr uint32_t kMemoryModelVulkan = 3;

// The helper functions the injected calls go to.
// Subgroup helpers come in two forms: for a slot that is the same in every
// lane (a constant: most sites) one reduction suffices; a run-time slot
// (dynamic descriptor index) needs the waterfall loop over distinct slots.
enum class Helper {
  Exact,
  Subgroup,
  SubgroupFragment,
  SubgroupUniform,
  SubgroupUniformFragment,
  SampledFragment,
  SampledCompute,
  SampledVertex
};

const char* helperName(Helper h);

class ModuleBuilder {
 public:
  ModuleBuilder(Module& m, const DefIndex& defs, const Types& types, const InstrumentOptions& options,
                Instrumented& result);

  void noteOnce(const std::string& note);

  // ---- types, constants, declarations ----------------------------------

  uint32_t type(spv::Op op, std::vector<uint32_t> operands);

  uint32_t tVoid() { return type(spv::Op::OpTypeVoid, {}); }
  uint32_t tBool() { return type(spv::Op::OpTypeBool, {}); }
  uint32_t tU32() { return type(spv::Op::OpTypeInt, {32, 0}); }
  uint32_t tI32() { return type(spv::Op::OpTypeInt, {32, 1}); }
  uint32_t tU64() { return type(spv::Op::OpTypeInt, {64, 0}); }
  uint32_t tF32() { return type(spv::Op::OpTypeFloat, {32}); }
  uint32_t tVec(uint32_t component, uint32_t n) { return type(spv::Op::OpTypeVector, {component, n}); }

  uint32_t tPtr(spv::StorageClass sc, uint32_t pointee);

  uint32_t tElement() { return options_.width == CounterWidth::Int64 ? tU64() : tU32(); }

  uint32_t constant(uint32_t typeId, std::vector<uint32_t> value);

  uint32_t constantU32(uint32_t v) { return constant(tU32(), {v}); }

  void addCapability(spv::Capability cap);
  void addExtension(const std::string& extension);

  void decorate(uint32_t id, spv::Decoration d, std::vector<uint32_t> extra = {});

  void name(uint32_t id, const std::string& text);

  // An Input builtin variable of the given type, reusing the module's own.
  uint32_t builtin(Stage stage, spv::BuiltIn b, uint32_t valueType, bool anyInt32 = false);

  // ---- instruction emission ---------------------------------------------

  struct Body {
    std::vector<Instruction>& insts;
  };

  uint32_t op(Body& b, spv::Op o, uint32_t resultType, std::vector<uint32_t> operands);

  void opNoResult(Body& b, spv::Op o, std::vector<uint32_t> operands) { b.insts.emplace_back(o, std::move(operands)); }
  void label(Body& b, uint32_t id) { b.insts.emplace_back(spv::Op::OpLabel, std::vector<uint32_t>{id}); }
  void branch(Body& b, uint32_t target) { opNoResult(b, spv::Op::OpBranch, {target}); }

  void selection(Body& b, uint32_t cond, uint32_t yes, uint32_t no, uint32_t merge);

  uint32_t atomicScope() { return constantU32(vulkanMemoryModel_ ? kScopeQueueFamily : kScopeDevice); }

  uint32_t loadIntAsU32(Body& b, uint32_t var);

  // A Function variable of `type` (made before the call), declared in `b`:
  // the first block of the function being built, before anything else.
  uint32_t functionVariable(Body& b, uint32_t type) { return declareVariable(b, m_.newId(), type); }
  // The same for an id allocated already.
  uint32_t declareVariable(Body& b, uint32_t id, uint32_t type) {
    b.insts.emplace_back(spv::Op::OpVariable, std::vector<uint32_t>{tPtr(spv::StorageClass::Function, type), id,
                                                                     static_cast<uint32_t>(spv::StorageClass::Function)});
    return id;
  }

  // Where code counted at entry goes: after the entry block's label and its
  // OpVariables (and debug lines).
  static size_t entryStart(const std::vector<Instruction>& insts);

  uint32_t tF32v(uint32_t n) { return tVec(tF32(), n); }
  uint32_t constantI32(int32_t v) { return constant(tI32(), {static_cast<uint32_t>(v)}); }
  uint32_t constantF32(float v) { return constant(tF32(), {std::bit_cast<uint32_t>(v)}); }

  uint32_t glslImport();

  // GLSL.std.450 instruction numbers.
  enum Glsl : uint32_t { RoundEven = 2, Floor = 8, Ceil = 9, Log2 = 30, UMin = 38, FMax = 40, UMax = 41, FindILsb = 73,
                         FClamp = 43, SClamp = 45, Length = 66 };
  uint32_t ext(Body& b, uint32_t resultType, Glsl inst, std::vector<uint32_t> args);

  struct FnBuild {
    Function fn;
    uint32_t id = 0;
    std::vector<uint32_t> params;
  };

  // A void function of the given parameter types, its first block open.
  std::unique_ptr<FnBuild> beginFunction(const std::vector<uint32_t>& paramTypes);

  uint32_t endFunction(std::unique_ptr<FnBuild> f, const std::string& fnName);

  // if (cond) return; the rest of the function continues in a new block.
  void returnIf(Body& b, uint32_t cond);

  // if (cond) { body(b) } and continue after it.
  template <class F>
  void when(Body& b, uint32_t cond, F&& body) {
    uint32_t yes = m_.newId(), merge = m_.newId();
    selection(b, cond, yes, merge, merge);
    label(b, yes);
    body(b);
    branch(b, merge);
    label(b, merge);
  }

  uint32_t fnCall(Body& b, uint32_t fn, std::vector<uint32_t> args);

  // while (cond(b)) { body(b); step(b); } as a structured loop: cond(b)
  // emits the test in the loop's test block and returns its bool, which (and
  // what it loaded) dominates body(b); step(b) is the continue block.
  template <class Cond, class Do, class Step>
  void whileLoop(Body& b, Cond&& cond, Do&& body, Step&& step) {
    uint32_t header = m_.newId(), test = m_.newId(), inside = m_.newId(), cont = m_.newId(), exit = m_.newId();
    branch(b, header);
    label(b, header);
    opNoResult(b, spv::Op::OpLoopMerge, {exit, cont, 0});
    branch(b, test);
    label(b, test);
    opNoResult(b, spv::Op::OpBranchConditional, {cond(b), inside, exit});
    label(b, inside);
    body(b);
    branch(b, cont);
    label(b, cont);
    step(b);
    branch(b, header);
    label(b, exit);
  }

  // The waterfall loop over the distinct values of the u32 `key` among the
  // active lanes: each pass takes the lanes whose key equals the first
  // active lane's, reduces across exactly those (reduce(b) returns the
  // reduction), lets one of them apply(b, key, reduced), and lets them leave.
  template <class Reduce, class Apply>
  void waterfall(Body& b, uint32_t key, Reduce&& reduce, Apply&& apply) {
    uint32_t scope = constantU32(kScopeSubgroup);
    uint32_t header = m_.newId(), loop = m_.newId(), cont = m_.newId(), exit = m_.newId();
    uint32_t take = m_.newId(), took = m_.newId(), one = m_.newId(), skip = m_.newId();
    branch(b, header);
    label(b, header);
    opNoResult(b, spv::Op::OpLoopMerge, {exit, cont, 0});
    branch(b, loop);
    label(b, loop);
    uint32_t first = op(b, spv::Op::OpGroupNonUniformBroadcastFirst, tU32(), {scope, key});
    uint32_t mine = op(b, spv::Op::OpIEqual, tBool(), {key, first});
    selection(b, mine, take, skip, skip);
    label(b, take);
    uint32_t reduced = reduce(b);
    uint32_t elected = op(b, spv::Op::OpGroupNonUniformElect, tBool(), {scope});
    selection(b, elected, one, took, took);
    label(b, one);
    apply(b, first, reduced);
    branch(b, took);
    label(b, took);
    branch(b, skip);
    label(b, skip);
    branch(b, cont);
    label(b, cont);
    opNoResult(b, spv::Op::OpBranchConditional, {mine, exit, header});
    label(b, exit);
  }

  // A u32 (or i32 with `asSigned`) from an integer value of any width and signedness.
  uint32_t intAs(Body& b, uint32_t value, bool asSigned);
  uint32_t intOfType(Body& b, uint32_t value, uint32_t type, bool asSigned);

  // Component k of a scalar or vector value (the scalar itself for k = 0).
  uint32_t component(Body& b, uint32_t value, uint32_t k, uint32_t scalarType);
  // Component k of an integer scalar or vector, as i32 (u32 without `asSigned`).
  uint32_t intComponent(Body& b, uint32_t value, uint32_t k, bool asSigned);

  uint32_t componentCount(uint32_t value);

  Instruction call(uint32_t helper, uint32_t slot);

  Module& m_;
  const DefIndex& defs_;
  const Types& types_;
  const InstrumentOptions& options_;
  Instrumented& result_;
  std::vector<std::string>& notes_;
  bool vulkanMemoryModel_ = false;
  bool demotes_ = false;  // the module uses OpDemoteToHelperInvocation
  spv::StorageClass storageClass_ = spv::StorageClass::StorageBuffer;
  std::map<std::vector<uint32_t>, uint32_t> types_by_key_;
  std::map<std::vector<uint32_t>, uint32_t> constants_;
  std::vector<uint32_t> variables_;
  std::vector<std::pair<uint32_t, uint32_t>> createdBuiltins_;
  std::map<Stage, std::set<uint32_t>> stageBuiltins_;
  // What the transformations add, placed into the module at the end of Injector::run.
  std::vector<Instruction> newGlobals_, newAnnotations_, newNames_;
  std::vector<Instruction> ablated_;  // code left out (addsInto)
  std::vector<Function> newFunctions_;
  uint32_t glsl_ = 0;  // the GLSL.std.450 import
};

class Injector : public ModuleBuilder {
 public:
  using ModuleBuilder::ModuleBuilder;

  Result<bool> run(const SiteScan& scan, const std::vector<uint32_t>& slots);

  Helper helperFor(Stage stage);

  // The counter buffer: struct { uint64_t c[]; } (or uint32 pairs), 8 bytes a slot.
  void declareCounters();

  // counters[slot] += amount (a u32 value). Leaves the current block open.
  void emitAdd(Body& b, uint32_t slot, uint32_t amount);

  // A 32-bit integer hash (lowbias32), for choosing the counted invocation of a tile.
  uint32_t hash(Body& b, uint32_t x, uint32_t y);

  // True in the one invocation per tw x th tile that counts for the tile.
  uint32_t tileSelect2D(Body& b, uint32_t x, uint32_t y, uint32_t z);

  uint32_t sampledSelect(Body& b, Helper h, Stage stage);

  // Opens a block that only non-helper lanes enter; returns the merge label
  // the caller branches to (and opens) when the block ends.
  uint32_t skipHelperLanes(Body& b, Stage stage);

  uint32_t helperFunction(Helper h, Stage stage);

  static bool accumulates(Stage stage) { return stage != Stage::Other; }

  // Auto: per lane in options_.autoLaneStages, else reduced (docs/measurement.md,
  // "Which flush", with the figures that chose it).
  bool subgroupFlush(Stage stage) const;

  // A Private u32 (or u32[n]) variable initialised to zero.
  uint32_t privateVariable(uint32_t valueType, uint32_t zero, const std::string& varName);

  uint32_t scalarAccumulator(uint32_t slot);

  struct ArrayAccumulator {
    uint32_t variable, length;
  };

  uint32_t arrayAccumulator(uint32_t base, uint32_t length);

  // acc += 1 through a Private pointer.
  void increment(Body& b, uint32_t pointer);

  // min(index, length - 1) of a run-time descriptor index, as a u32.
  uint32_t clampedIndex(Body& b, const FoundSite& s, uint32_t length);

  // Buffer device addresses (address_sites.cpp): a physical-storage-buffer
  // access whose slot its address picks in the host's table.
  bool addressed(const FoundSite& s) const { return options_.addressTable && s.address != 0; }
  // Whether the site's slot is chosen at run time: a descriptor index or an address.
  bool dynamicSlot(const FoundSite& s) const { return s.dynamicIndex != 0 || addressed(s); }
  // The slots such a site has from its first.
  uint32_t dynamicSlots(const FoundSite& s) const;
  // The index of the slot from the site's first: clampedIndex, or the address's slot in the table.
  uint32_t slotIndex(Body& b, const FoundSite& s, uint32_t length);
  // The table: u64 words at options_.addressTableBinding (spirv/address_table.hpp).
  void declareAddressTable();
  // tally_address_slot(u64 address) -> u32: the binary search over the table.
  uint32_t addressSlotFn();

  // Whether the site runs at most once per invocation of its entry point:
  // counted at entry or at the return, or outside every loop of a function
  // that runs once.
  bool runsOnce(const FoundSite& s, const EntryPoint& ep);

  // Whether the site runs exactly once in every invocation of its entry
  // point that returns: at entry or at the returns of the entry function,
  // or on every return path, outside loops, of a function that runs
  // exactly once (cfg.hpp).
  bool runsExactlyOnce(const FoundSite& s, const EntryPoint& ep);

  // The entry points whose invocation counter can stand for such sites:
  // their own function, and no way to end but returning.
  void findInvocationSlots(const SiteScan& scan, const std::vector<uint32_t>& slots);

  // Records the site as derived from its entry point's invocation counter
  // (Instrumented::derived) where it runs exactly once; false otherwise.
  bool deriveSite(const FoundSite& s, const EntryPoint& ep, uint32_t slot);

  // Sites that run once per loop iteration (accumulate_loops.cpp): derived
  // from a trip counter per loop and class, added once before a counted loop.
  void countLoops(const SiteScan& scan, std::vector<std::map<size_t, std::vector<Instruction>>>& before,
                  const std::vector<uint32_t>& slots);
  uint32_t tripCount(Body& b, const Function& f, const CountedLoop& c, uint32_t phiValue);
  // The induction variable's value where the loop is entered (`phiValue`, or a load of the variable).
  uint32_t inductionStart(Body& b, const CountedLoop& c, uint32_t phiValue);
  // The structured loops of a function, found once per module (loops.hpp).
  const FunctionLoops& loopsOf(int function);
  uint32_t repeatLoad(Body& b, const Function& f, size_t at);
  std::optional<uint32_t> constantTrips(const Function& f, const CountedLoop& c, size_t branch, uint32_t phiValue) const;
  std::optional<uint32_t> entryParent(const FunctionLoops& fl, size_t self, uint32_t entry, int function, size_t branch,
                                      const EntryPoint& ep);

  // Descriptor arrays past kAccumulateArrayMax (accumulate_arrays.cpp): a
  // one-entry cache per site, flushed per element across the subgroup.
  struct CachedArray {
    uint32_t base, length, element, count;  // first slot, elements, the two Private registers
  };
  bool accumulateCachedArray(const FoundSite& s, const EntryPoint& ep, uint32_t slot, uint32_t length,
                             std::vector<std::map<size_t, std::vector<Instruction>>>& after);
  void flushCachedArrays(Body& b, Stage stage, const std::vector<CachedArray>& caches, uint32_t copyOffset);
  void flushCachedElements(Body& b, const CachedArray& cache, uint32_t copyOffset);
  void flushCachesTogether(Body& b, Stage stage, const std::vector<CachedArray>& caches, uint32_t copyOffset,
                           uint32_t counter);
  uint32_t loadCacheKeys(Body& b, const std::vector<CachedArray>& caches, std::vector<uint32_t>& counts,
                         std::vector<uint32_t>& keys);
  // Where the device partitions a subgroup by value (options_.partitionedStages):
  // no waterfall, one partition of the lanes by every cache's element,
  // reduced within each part and added by its lowest lane.
  bool partitioned(Stage stage) const;
  void flushCachesPartitioned(Body& b, const std::vector<CachedArray>& caches, uint32_t copyOffset);

  // Emits the site's increment; false when the site is counted per access instead.
  bool accumulateSite(const FoundSite& s, const EntryPoint& ep, uint32_t slot,
                      std::vector<std::map<size_t, std::vector<Instruction>>>& after,
                      std::vector<std::map<size_t, std::vector<Instruction>>>& before);

  // counters[slot] += hi * 65536 + lo, both u32 below 2^32 / 65536 * subgroup size.
  void emitAddWide(Body& b, uint32_t slot, uint32_t lo, uint32_t hi);

  // Flushes one accumulator (a Private u32 pointer) into counter `slot` (of
  // this invocation's copy), then zeroes it.
  void flushOne(Body& b, Stage stage, uint32_t pointer, uint32_t slot, uint32_t copyOffset);
  // Every (Private pointer, slot) reduced first, then added together
  // (accumulate_rounds.cpp); `counter` a Function u32 for the rounds.
  void flushInRounds(Body& b, const std::vector<std::pair<uint32_t, uint32_t>>& registers, uint32_t copyOffset,
                     uint32_t counter);
  // `partition` (a ballot of OpGroupNonUniformPartitionNV) or 0: the whole subgroup.
  void reduceAll(Body& b, const std::vector<uint32_t>& values, std::vector<uint32_t>& lo, std::vector<uint32_t>& hi,
                 uint32_t partition = 0);
  void addInRounds(Body& b, const std::vector<uint32_t>& slots, const std::vector<uint32_t>& lo,
                   const std::vector<uint32_t>& hi, uint32_t counter);

  // Compute flushes stripe each slot over result_.copies copies: every
  // workgroup (and subgroup) of a dispatch flushing into one address
  // serialises on it, and a compute pass has no fixed-function work to hide
  // that behind. The reader sums the copies (foldCopies).
  bool stripes(Stage stage) const { return stage == Stage::Compute && result_.copies > 1; }

  // copy * copyStride, the copy chosen by workgroup and by subgroup (or by
  // lane, where the flush is per lane). Workgroups resident together are
  // consecutive in x, so x + 3y + 5z spreads them over the copies.
  uint32_t copyOffsetOf(Body& b, Stage stage);

  // The stage's flush function: every accumulator its sites use.
  uint32_t flushFunction(Stage stage);

  // Executed arithmetic: at the top of every block of every function an
  // accumulating entry point reaches, the block's operations (arith.hpp)
  // added to one register, flushed by each stage into the arithmetic slot.
  void countExecutedArithmetic(const SiteScan& scan, std::vector<std::map<size_t, std::vector<Instruction>>>& before);

  // Calls each stage's flush where its invocations end.
  void insertFlushes(const SiteScan& scan, std::vector<std::map<size_t, std::vector<Instruction>>>& before);

  bool footprintOn() const { return options_.footprintBlockBytes != 0; }
  // Where the accumulate mode's adds go: `list`, or nowhere when they are
  // left out for the study of their cost (InstrumentOptions::study).
  std::vector<Instruction>& addsInto(std::vector<Instruction>& list) {
    if ((options_.study & kStudyNoAdds) == 0) return list;
    ablated_.clear();
    return ablated_;
  }

  // Two u32 runtime-array buffers: the table and the bitmaps.
  void declareFootprint();

  uint32_t tableWord(Body& b, uint32_t entry, uint32_t word);

  uint32_t tableWordAt(Body& b, uint32_t entry, uint32_t word, uint32_t dynamicOffset);

  // tally_fp_mark(base, capacity, block): sets the bit, block clamped into
  // the scratch bit past the bitmap (footprint_marks.cpp). Where lanes
  // combine, a lane whose block another lane marks leaves it to that lane:
  // Quad, the first lane of its quad that marks; First, the subgroup's first
  // marking lane; Match, the first of the lanes marking the same block
  // (partitioned by value: SPV_NV_shader_subgroup_partitioned).
  enum class FpCombine { None, Quad, First, Match };
  // `red`: the atomic without a load first (the study's fp-red).
  uint32_t fpMarkFn(FpCombine combine = FpCombine::None, bool red = false);
  // How each kind of mark combines (FootprintDedup::lanes, and the study's fp-* variants).
  enum class FpMarkKind { Texel, Output, Sample, Bytes };
  FpCombine fpCombine(FpMarkKind kind) const;

  // Whether marks combine across the subgroup (InstrumentOptions::footprintDedup);
  // records the dedup the marks use in result_.
  bool footprintSubgroup(const SiteScan& scan);

  // if this invocation marked the word's bit already: return; else remember it.
  void fpSkipCached(Body& b, uint32_t word, uint32_t bit);

  // bitmap[word] |= bits, the atomic only where a bit is new.
  void fpSetBits(Body& b, uint32_t word, uint32_t bits, bool oneBit, bool red = false);

  // The same, once for all the lanes of the subgroup that mark one word.
  void fpSetBitsOfSubgroup(Body& b, uint32_t word, uint32_t bit);

  // tally_fp_bytes(entry, offset, bytes): the blocks of bytes [offset, offset + bytes)
  // of a Buffer entry, or of vertex `offset` (the vertex index) of a VertexInput entry.
  uint32_t fpBytesFn(bool shortRange);

  // tally_fp_texel_level(entry, x, y, layer, imageLevel): one texel of an
  // Image entry; coordinates outside the level mark nothing.
  uint32_t fpTexelLevelFn(FpCombine combine);

  // tally_fp_texel(entry, x, y, layer, lod): a texel at level `lod` of the
  // bound view (fetches, storage images, attachments).
  uint32_t fpTexelFn(FpMarkKind markKind = FpMarkKind::Texel);

  // The texel coordinate after the sampler's address mode; -1 (nothing)
  // outside a clamp-to-border image. `result` is an i32 Function variable
  // of the function being built: only the mode's own arithmetic runs.
  uint32_t wrap(Body& b, uint32_t c, uint32_t size, uint32_t mode, uint32_t result);

  // One level and layer of an Image entry: its size, and where its blocks
  // start, with the tile's shifts (tiles are powers of two: tileFor).
  struct LevelBlocks {
    uint32_t width, height, shiftX, shiftY, tilesX, first, cap, base;
  };
  LevelBlocks levelBlocks(Body& b, uint32_t entry, uint32_t level, uint32_t layer);
  // The block of texel (x, y) (i32) of the level; the scratch block outside it.
  uint32_t blockOf(Body& b, const LevelBlocks& g, uint32_t x, uint32_t y);

  // tally_fp_sample_level(entry, imageLevel, u, v, layer, linear, offsetX, offsetY):
  // the texels a nearest (1) or bilinear (2 x 2) filter reads at one level.
  uint32_t fpSampleLevelFn();

  // How a sampled read's level of detail is known.
  enum class Lod : uint32_t {
    Queried = 0,   // a = OpImageQueryLod's level, b = its lambda (implicit LOD in fragment shaders)
    Explicit = 1,  // a = lambda (an explicit Lod, or computed from explicit gradients)
    Gather = 2,    // the base level, bilinear
  };

  // tally_fp_sample(entry, u, v, layer, lodKind, a, b, offsetX, offsetY):
  // a filtered read, Vulkan's level selection (magnification at lambda <= 0;
  // nearest level ceil(d + 0.5) - 1, or both linear levels where the
  // fraction is non-zero) and filters from the bound sampler.
  uint32_t fpSampleFn();

  // The byte offset of a buffer pointer from the start of its descriptor's
  // buffer (the element of a descriptor array): a constant, and each
  // run-time index of the access chains times its stride, in their order.
  struct OffsetTerms {
    uint64_t constant = 0;
    std::vector<std::pair<uint32_t, uint32_t>> dynamic;  // (index id, stride)
  };
  // nullopt with `why` set where the chain cannot be followed.
  std::optional<OffsetTerms> offsetTerms(uint32_t pointer, int function, std::string& why);
  // The offset as straight-line code, an index in `replace` replaced by its value there.
  uint32_t emitOffset(Body& b, const OffsetTerms& terms, const std::map<uint32_t, uint32_t>& replace = {});
  // The pointer a buffer site accesses.
  uint32_t sitePointer(const FoundSite& s) const;
  // Whether an access of `bytes` covers at most three blocks (tally_fp_bytes_short).
  bool shortBytes(uint32_t bytes) const { return bytes <= 2 * options_.footprintBlockBytes + 1; }

  // tally_fp_range(entry, first, step, trips, bytes): what a buffer access of
  // `bytes` at offsets first + k step, k in [0, trips), marks with
  // tally_fp_bytes, as one range of blocks where |step| <= a block
  // (footprint_loops.cpp).
  uint32_t fpRangeFn(bool shortRange);

  // Marks a buffer site of a counted loop once where the loop is entered,
  // the range of its iterations; false where the site does not qualify.
  bool footprintLoopRange(const FoundSite& s, uint32_t slotBase,
                          std::vector<std::map<size_t, std::vector<Instruction>>>& before);

  // The pixel of a fragment invocation: floor(FragCoord.xy) as i32.
  std::pair<uint32_t, uint32_t> fragmentPixel(Body& b, Stage stage);

  // The image operands of an image instruction from word `at`: operand ids by mask bit.
  static std::map<uint32_t, std::vector<uint32_t>> imageOperands(const Instruction& inst, size_t at);

  // Integer texel coordinates (x, y, layer) of a 1D or 2D image access.
  struct TexelCoords {
    uint32_t x, y, layer;
  };

  TexelCoords texelCoords(Body& b, uint32_t coord, uint32_t dim, bool arrayed);

  // Emits the marking of one site; false (with `why`) where the model does
  // not cover the access.
  bool emitFootprint(Body& b, const FoundSite& s, uint32_t entry, Stage stage, std::string& why);
  bool emitImageFootprint(Body& b, const FoundSite& s, const Instruction& inst, uint32_t entry, Stage stage,
                          std::string& why);
  bool emitFilteredFootprint(Body& b, const FoundSite& s, const Instruction& inst, uint32_t entry, Stage stage,
                             uint32_t coord, const Instruction* imageType, std::string& why);

  // 1D and 2D images (arrayed or not, any sample count); others are not modelled.
  bool texelImage(const Instruction* imageType, std::string& why);

  // Emits the site's marking where its count goes; result_.sites[index].footprint says whether it did.
  void footprintSite(size_t index, const FoundSite& s, const EntryPoint& ep, uint32_t slotBase,
                     std::vector<std::map<size_t, std::vector<Instruction>>>& after,
                     std::vector<std::map<size_t, std::vector<Instruction>>>& before);

  // The slot argument: a constant, or base + min(index, length - 1) for a
  // run-time descriptor index (emitted into `list`, before the call).
  uint32_t slotValue(const FoundSite& s, uint32_t base, std::vector<Instruction>& list);

  uint32_t counters_ = 0;
  uint32_t elementPtr_ = 0;
  uint32_t addressTable_ = 0, addressWordPtr_ = 0, addressSlot_ = 0;
  std::map<std::pair<Helper, Stage>, uint32_t> helpers_;
  // accumulate mode
  struct FlushSlots {
    std::set<uint32_t> scalars;
    std::set<std::pair<uint32_t, uint32_t>> arrays;  // (first slot, length)
    std::vector<size_t> cached;                      // into cachedArrays_
  };
  std::vector<CachedArray> cachedArrays_;
  std::map<Stage, FlushSlots> flushSlots_;
  std::map<uint32_t, uint32_t> scalarAcc_;  // slot -> Private u32
  std::vector<std::pair<uint32_t, ArrayAccumulator>> arrayAcc_;
  std::vector<uint32_t> accumulators_;      // every Private variable added
  std::map<Stage, uint32_t> flushFunctions_;
  std::map<uint32_t, std::vector<bool>> runsOnce_;  // entry index -> functions that run once
  std::map<int, std::vector<bool>> cycles_;         // function -> instructions on a cycle
  std::map<Stage, uint32_t> perAccessOnce_;         // sites counted per access because they run once
  std::map<uint32_t, uint32_t> invocationSlot_;     // entry index -> its invocation counter's slot
  std::map<uint32_t, std::vector<bool>> runsExactly_;  // entry index -> functions that run exactly once
  std::map<int, std::vector<bool>> everyPath_;      // function -> instructions on every return path
  std::map<Stage, uint32_t> derivedSites_;          // sites derived from the invocation count
  std::set<size_t> loopDerived_;                    // sites derived from a loop's trip counter
  struct LoopNote {
    uint32_t sites = 0, counters = 0, counted = 0, fromEnclosing = 0;
  };
  std::map<Stage, LoopNote> loopNotes_;
  using TripKey = std::tuple<uint32_t, int, size_t, int>;  // entry point, function, loop, class
  std::map<TripKey, uint32_t> tripSlots_;                  // -> its trip counter's slot
  std::map<int, FunctionLoops> loops_;                     // function -> its loops (loopsOf)
  // footprint
  uint32_t fpTable_ = 0, fpBitmap_ = 0, fpWordPtr_ = 0;
  Stage fpStage_ = Stage::Other;   // the stage of every entry point, where marks combine across the subgroup
  uint32_t fpCache_[4] = {};       // the cache's Private registers: word0, bits0, word1, bits1
  bool fpCombines_ = false;        // marks may combine across lanes (fpCombine)
  uint32_t fpMarks_[8] = {}, fpTexelLevels_[4] = {}, fpTexels_[4] = {};
  uint32_t fpBytes_ = 0, fpBytesShort_ = 0, fpSampleLevel_ = 0, fpSample_ = 0;
  uint32_t fpRange_ = 0, fpRangeShort_ = 0;
  std::map<Stage, uint32_t> fpLoopSites_; // sites marked once per loop entry
};

}  // namespace tally::spirv
