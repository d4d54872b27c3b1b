#include "spirv/inject.hpp"

#include "spirv/arith.hpp"
#include "spirv/cfg.hpp"

#include <algorithm>
#include <bit>
#include <map>
#include <memory>
#include <set>

#include "spirv/footprint.hpp"

namespace tally::spirv {

TileShape sampledTileShape(uint32_t n) {
  uint32_t height = 1;
  for (uint32_t d = 1; d * d <= n; ++d) {
    if (n % d == 0) height = d;
  }
  return {n / height, height};
}

namespace {

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

const char* helperName(Helper h) {
  switch (h) {
    case Helper::Exact: return "tally_count_exact";
    case Helper::Subgroup: return "tally_count_subgroup";
    case Helper::SubgroupFragment: return "tally_count_subgroup";
    case Helper::SubgroupUniform:
    case Helper::SubgroupUniformFragment: return "tally_count_subgroup_uniform";
    case Helper::SampledFragment:
    case Helper::SampledCompute:
    case Helper::SampledVertex: return "tally_count_sampled";
  }
  return "tally_count";
}

class Injector {
 public:
  Injector(Module& m, const DefIndex& defs, const Types& types, const InstrumentOptions& options,
           Instrumented& result)
      : m_(m), defs_(defs), types_(types), options_(options), result_(result), notes_(result.notes) {
    for (const auto& inst : m_.globals) {
      spv::Op op = inst.opcode();
      if (op == spv::Op::OpConstant) {
        std::vector<uint32_t> key = {static_cast<uint32_t>(op), inst.word(1)};
        key.insert(key.end(), inst.words.begin() + 3, inst.words.end());
        constants_.emplace(key, inst.resultId());
      } else if (op >= spv::Op::OpTypeVoid && op <= spv::Op::OpTypeForwardPointer && op != spv::Op::OpTypeStruct &&
                 op != spv::Op::OpTypeArray && op != spv::Op::OpTypeRuntimeArray &&
                 op != spv::Op::OpTypeForwardPointer) {
        std::vector<uint32_t> key = {static_cast<uint32_t>(op)};
        key.insert(key.end(), inst.words.begin() + 2, inst.words.end());
        types_by_key_.emplace(key, inst.resultId());
      } else if (op == spv::Op::OpVariable) {
        variables_.push_back(inst.resultId());
      }
    }
    vulkanMemoryModel_ = !m_.memoryModel.empty() && m_.memoryModel[0].word(2) == kMemoryModelVulkan;
    for (const auto& f : m_.functions) {
      for (const auto& inst : f.insts) {
        if (inst.opcode() == spv::Op::OpDemoteToHelperInvocation) demotes_ = true;
      }
    }
  }

  std::string run(const SiteScan& scan, const std::vector<uint32_t>& slots) {
    // Which helper each stage uses decides the capabilities and version.
    const bool accumulate = options_.mode.kind == CountMode::Accumulate;
    bool subgroup = false;
    for (const auto& ep : scan.entryPoints) {
      if (accumulate) {
        if (accumulates(ep.stage) && subgroupFlush(ep.stage)) subgroup = true;
        continue;
      }
      Helper h = helperFor(ep.stage);
      if (h != Helper::Exact && options_.mode.kind == CountMode::Subgroup) subgroup = true;
    }
    if (subgroup && m_.version < kVersion13) {
      notes_.push_back("SPIR-V version raised from " + versionString(m_.version) +
                       " to 1.3 for subgroup operations (needs Vulkan 1.1)");
      m_.version = kVersion13;
    }
    if (options_.width == CounterWidth::Int64) {
      addCapability(spv::Capability::Int64);
      addCapability(spv::Capability::Int64Atomics);
    }
    if (subgroup) {
      addCapability(spv::Capability::GroupNonUniform);
      addCapability(spv::Capability::GroupNonUniformArithmetic);
      addCapability(spv::Capability::GroupNonUniformBallot);
    }
    declareCounters();
    if (footprintOn()) declareFootprint();

    // Per-function insertions, keyed by instruction index.
    std::vector<std::map<size_t, std::vector<Instruction>>> after(m_.functions.size());
    std::vector<std::map<size_t, std::vector<Instruction>>> before(m_.functions.size());
    for (size_t i = 0; i < scan.sites.size(); ++i) {
      const FoundSite& s = scan.sites[i];
      const EntryPoint& ep = scan.entryPoints[s.entryIndex];
      if (footprintOn()) footprintSite(i, s, ep, slots[i], after, before);
      if (accumulate && accumulateSite(s, ep, slots[i], after, before)) continue;
      Helper kind = helperFor(ep.stage);
      if (s.dynamicIndex == 0 && kind == Helper::Subgroup) kind = Helper::SubgroupUniform;
      if (s.dynamicIndex == 0 && kind == Helper::SubgroupFragment) kind = Helper::SubgroupUniformFragment;
      uint32_t helper = helperFunction(kind, ep.stage);
      const auto& insts = m_.functions[s.function].insts;
      switch (s.placement) {
        case Placement::AfterInstruction: {
          auto& list = after[s.function][s.instruction];
          uint32_t slot = slotValue(s, slots[i], list);
          list.push_back(call(helper, slot));
          break;
        }
        case Placement::EntryStart:
          before[s.function][entryStart(insts)].push_back(call(helper, constantU32(slots[i])));
          break;
        case Placement::BeforeReturns:
          for (size_t at = 0; at < insts.size(); ++at) {
            if (insts[at].opcode() == spv::Op::OpReturn) before[s.function][at].push_back(call(helper, constantU32(slots[i])));
          }
          break;
      }
    }

    if (accumulate && result_.arithmeticSlot >= 0) countExecutedArithmetic(scan, before);
    if (accumulate && flushSlots_.count(Stage::Compute) && options_.computeCopies > 1) {
      result_.copies = options_.computeCopies;
      result_.copyStride = (result_.slotCount + kCopyAlignSlots - 1) / kCopyAlignSlots * kCopyAlignSlots;
    }
    if (accumulate) insertFlushes(scan, before);
    for (const auto& [stage, sites] : perAccessOnce_) {
      notes_.push_back("accumulate mode: " + std::to_string(sites) + " " + std::string(toString(stage)) + " site" +
                       (sites == 1 ? "" : "s") +
                       " that run at most once per invocation counted per access (their flush would cost as much)");
    }

    // Entry-point interfaces: builtins always, every global from SPIR-V 1.4 on.
    for (const auto& ep : scan.entryPoints) {
      std::set<uint32_t> add(stageBuiltins_[ep.stage].begin(), stageBuiltins_[ep.stage].end());
      if (m_.version >= kVersion14) {
        add.insert(counters_);
        if (footprintOn()) add.insert({fpTable_, fpBitmap_});
        add.insert(accumulators_.begin(), accumulators_.end());
      }
      Instruction& inst = m_.entryPoints[ep.instIndex];
      for (uint32_t id : add) {
        if (std::find(ep.interface.begin(), ep.interface.end(), id) == ep.interface.end()) inst.words.push_back(id);
      }
      inst.words[0] = (static_cast<uint32_t>(inst.words.size()) << 16) | (inst.words[0] & 0xffffu);
    }

    // Apply, now that no more lookups into the old sections are needed.
    for (size_t f = 0; f < m_.functions.size(); ++f) {
      if (after[f].empty() && before[f].empty()) continue;
      auto& insts = m_.functions[f].insts;
      std::vector<Instruction> out;
      out.reserve(insts.size() + 4 * (after[f].size() + before[f].size()));
      for (size_t at = 0; at < insts.size(); ++at) {
        if (auto b = before[f].find(at); b != before[f].end()) out.insert(out.end(), b->second.begin(), b->second.end());
        out.push_back(std::move(insts[at]));
        if (auto a = after[f].find(at); a != after[f].end()) out.insert(out.end(), a->second.begin(), a->second.end());
      }
      insts = std::move(out);
    }
    m_.globals.insert(m_.globals.end(), newGlobals_.begin(), newGlobals_.end());
    m_.annotations.insert(m_.annotations.end(), newAnnotations_.begin(), newAnnotations_.end());
    auto processed = std::find_if(m_.debug.begin(), m_.debug.end(), [](const Instruction& d) {
      return d.opcode() == spv::Op::OpModuleProcessed;
    });
    m_.debug.insert(processed, newNames_.begin(), newNames_.end());
    for (auto& f : newFunctions_) m_.functions.push_back(std::move(f));
    return {};
  }

 private:
  Helper helperFor(Stage stage) {
    switch (options_.mode.kind) {
      case CountMode::Exact:
      case CountMode::Accumulate: return Helper::Exact;  // accumulate: its fall-back per access
      case CountMode::Subgroup:
        if ((options_.subgroupStages & stageBit(stage)) == 0) {
          noteOnce("subgroup mode: " + std::string(toString(stage)) +
                   " stage has no subgroup operations on this device; counted exactly");
          return Helper::Exact;
        }
        return stage == Stage::Fragment ? Helper::SubgroupFragment : Helper::Subgroup;
      case CountMode::Sampled:
        if (stage == Stage::Fragment) return Helper::SampledFragment;
        if (stage == Stage::Compute) return Helper::SampledCompute;
        if (stage == Stage::Vertex) return Helper::SampledVertex;
        noteOnce("sampled mode: " + std::string(toString(stage)) + " stage is counted exactly");
        return Helper::Exact;
    }
    return Helper::Exact;
  }

  void noteOnce(const std::string& note) {
    if (std::find(notes_.begin(), notes_.end(), note) == notes_.end()) notes_.push_back(note);
  }

  // ---- types, constants, declarations ----------------------------------

  uint32_t type(spv::Op op, std::vector<uint32_t> operands) {
    std::vector<uint32_t> key = {static_cast<uint32_t>(op)};
    key.insert(key.end(), operands.begin(), operands.end());
    if (auto it = types_by_key_.find(key); it != types_by_key_.end()) return it->second;
    uint32_t id = m_.newId();
    operands.insert(operands.begin(), id);
    newGlobals_.emplace_back(op, std::move(operands));
    types_by_key_.emplace(key, id);
    return id;
  }

  uint32_t tVoid() { return type(spv::Op::OpTypeVoid, {}); }
  uint32_t tBool() { return type(spv::Op::OpTypeBool, {}); }
  uint32_t tU32() { return type(spv::Op::OpTypeInt, {32, 0}); }
  uint32_t tI32() { return type(spv::Op::OpTypeInt, {32, 1}); }
  uint32_t tU64() { return type(spv::Op::OpTypeInt, {64, 0}); }
  uint32_t tF32() { return type(spv::Op::OpTypeFloat, {32}); }
  uint32_t tVec(uint32_t component, uint32_t n) { return type(spv::Op::OpTypeVector, {component, n}); }
  uint32_t tPtr(spv::StorageClass sc, uint32_t pointee) {
    return type(spv::Op::OpTypePointer, {static_cast<uint32_t>(sc), pointee});
  }
  uint32_t tElement() { return options_.width == CounterWidth::Int64 ? tU64() : tU32(); }

  uint32_t constant(uint32_t typeId, std::vector<uint32_t> value) {
    std::vector<uint32_t> key = {static_cast<uint32_t>(spv::Op::OpConstant), typeId};
    key.insert(key.end(), value.begin(), value.end());
    if (auto it = constants_.find(key); it != constants_.end()) return it->second;
    uint32_t id = m_.newId();
    std::vector<uint32_t> operands = {typeId, id};
    operands.insert(operands.end(), value.begin(), value.end());
    newGlobals_.emplace_back(spv::Op::OpConstant, std::move(operands));
    constants_.emplace(key, id);
    return id;
  }
  uint32_t constantU32(uint32_t v) { return constant(tU32(), {v}); }

  void addCapability(spv::Capability cap) {
    for (const auto& c : m_.capabilities) {
      if (c.word(1) == static_cast<uint32_t>(cap)) return;
    }
    m_.capabilities.emplace_back(spv::Op::OpCapability, std::vector<uint32_t>{static_cast<uint32_t>(cap)});
  }

  void decorate(uint32_t id, spv::Decoration d, std::vector<uint32_t> extra = {}) {
    std::vector<uint32_t> operands = {id, static_cast<uint32_t>(d)};
    operands.insert(operands.end(), extra.begin(), extra.end());
    newAnnotations_.emplace_back(spv::Op::OpDecorate, std::move(operands));
  }

  void name(uint32_t id, const std::string& text) {
    std::vector<uint32_t> operands = {id};
    auto w = stringWords(text);
    operands.insert(operands.end(), w.begin(), w.end());
    newNames_.emplace_back(spv::Op::OpName, std::move(operands));
  }

  // The counter buffer: struct { uint64_t c[]; } (or uint32 pairs), 8 bytes a slot.
  void declareCounters() {
    bool storageBuffer = m_.version >= kVersion13;
    storageClass_ = storageBuffer ? spv::StorageClass::StorageBuffer : spv::StorageClass::Uniform;
    uint32_t element = tElement();
    uint32_t array = m_.newId();
    newGlobals_.emplace_back(spv::Op::OpTypeRuntimeArray, std::vector<uint32_t>{array, element});
    decorate(array, spv::Decoration::ArrayStride, {options_.width == CounterWidth::Int64 ? 8u : 4u});
    uint32_t block = m_.newId();
    newGlobals_.emplace_back(spv::Op::OpTypeStruct, std::vector<uint32_t>{block, array});
    decorate(block, storageBuffer ? spv::Decoration::Block : spv::Decoration::BufferBlock);
    newAnnotations_.emplace_back(spv::Op::OpMemberDecorate,
                                 std::vector<uint32_t>{block, 0, static_cast<uint32_t>(spv::Decoration::Offset), 0});
    uint32_t blockPtr = tPtr(storageClass_, block);
    counters_ = m_.newId();
    newGlobals_.emplace_back(spv::Op::OpVariable,
                             std::vector<uint32_t>{blockPtr, counters_, static_cast<uint32_t>(storageClass_)});
    decorate(counters_, spv::Decoration::DescriptorSet, {options_.set});
    decorate(counters_, spv::Decoration::Binding, {options_.binding});
    name(block, "TallyCounters");
    name(counters_, "tally_counters");
    elementPtr_ = tPtr(storageClass_, element);
  }

  // An Input builtin variable of the given type, reusing the module's own.
  uint32_t builtin(Stage stage, spv::BuiltIn b, uint32_t valueType, bool anyInt32 = false) {
    uint32_t found = 0;
    for (uint32_t var : variables_) {
      auto value = defs_.decorationValue(var, spv::Decoration::BuiltIn);
      if (!value || *value != static_cast<uint32_t>(b)) continue;
      const Instruction* v = defs_.def(var);
      if (static_cast<spv::StorageClass>(v->word(3)) != spv::StorageClass::Input) continue;
      uint32_t pointee = types_.pointee(v->resultType());
      const Instruction* t = defs_.def(pointee);
      bool int32 = t && t->opcode() == spv::Op::OpTypeInt && t->word(2) == 32;
      if (pointee == valueType || (anyInt32 && int32)) found = var;
    }
    for (auto& [key, var] : createdBuiltins_) {
      if (key == static_cast<uint32_t>(b)) found = var;
    }
    if (found == 0) {
      found = m_.newId();
      newGlobals_.emplace_back(spv::Op::OpVariable,
                               std::vector<uint32_t>{tPtr(spv::StorageClass::Input, valueType), found,
                                                     static_cast<uint32_t>(spv::StorageClass::Input)});
      decorate(found, spv::Decoration::BuiltIn, {static_cast<uint32_t>(b)});
      // Only demotion can turn an invocation into a helper mid-shader; then
      // the read must be volatile. (Mesa 22.3's lavapipe aborts on volatile
      // HelperInvocation loads, so they are not emitted without need.)
      if (b == spv::BuiltIn::HelperInvocation && demotes_ && !vulkanMemoryModel_) {
        decorate(found, spv::Decoration::Volatile);
      }
      createdBuiltins_.emplace_back(static_cast<uint32_t>(b), found);
    }
    stageBuiltins_[stage].insert(found);
    return found;
  }

  // ---- instruction emission ---------------------------------------------

  struct Body {
    std::vector<Instruction>& insts;
  };

  uint32_t op(Body& b, spv::Op o, uint32_t resultType, std::vector<uint32_t> operands) {
    uint32_t id = m_.newId();
    operands.insert(operands.begin(), {resultType, id});
    b.insts.emplace_back(o, std::move(operands));
    return id;
  }
  void opNoResult(Body& b, spv::Op o, std::vector<uint32_t> operands) { b.insts.emplace_back(o, std::move(operands)); }
  void label(Body& b, uint32_t id) { b.insts.emplace_back(spv::Op::OpLabel, std::vector<uint32_t>{id}); }
  void branch(Body& b, uint32_t target) { opNoResult(b, spv::Op::OpBranch, {target}); }
  void selection(Body& b, uint32_t cond, uint32_t yes, uint32_t no, uint32_t merge) {
    opNoResult(b, spv::Op::OpSelectionMerge, {merge, 0});
    opNoResult(b, spv::Op::OpBranchConditional, {cond, yes, no});
  }

  uint32_t atomicScope() { return constantU32(vulkanMemoryModel_ ? kScopeQueueFamily : kScopeDevice); }

  // counters[slot] += amount (a u32 value). Leaves the current block open.
  void emitAdd(Body& b, uint32_t slot, uint32_t amount) {
    uint32_t zero = constantU32(0);
    uint32_t semantics = constantU32(kSemanticsRelaxed);
    if (options_.width == CounterWidth::Int64) {
      uint32_t wide = op(b, spv::Op::OpUConvert, tU64(), {amount});
      uint32_t ptr = op(b, spv::Op::OpAccessChain, elementPtr_, {counters_, zero, slot});
      op(b, spv::Op::OpAtomicIAdd, tU64(), {ptr, atomicScope(), semantics, wide});
      return;
    }
    // Low word, then carry into the high word when the low word wraps.
    uint32_t lowIndex = op(b, spv::Op::OpIMul, tU32(), {slot, constantU32(2)});
    uint32_t lowPtr = op(b, spv::Op::OpAccessChain, elementPtr_, {counters_, zero, lowIndex});
    uint32_t old = op(b, spv::Op::OpAtomicIAdd, tU32(), {lowPtr, atomicScope(), semantics, amount});
    uint32_t sum = op(b, spv::Op::OpIAdd, tU32(), {old, amount});
    uint32_t wrapped = op(b, spv::Op::OpULessThan, tBool(), {sum, old});
    uint32_t carry = m_.newId(), merge = m_.newId();
    selection(b, wrapped, carry, merge, merge);
    label(b, carry);
    uint32_t highIndex = op(b, spv::Op::OpIAdd, tU32(), {lowIndex, constantU32(1)});
    uint32_t highPtr = op(b, spv::Op::OpAccessChain, elementPtr_, {counters_, zero, highIndex});
    op(b, spv::Op::OpAtomicIAdd, tU32(), {highPtr, atomicScope(), semantics, constantU32(1)});
    branch(b, merge);
    label(b, merge);
  }

  // A 32-bit integer hash (lowbias32), for choosing the counted invocation of a tile.
  uint32_t hash(Body& b, uint32_t x, uint32_t y) {
    uint32_t u = tU32();
    uint32_t hx = op(b, spv::Op::OpIMul, u, {x, constantU32(73856093u)});
    uint32_t hy = op(b, spv::Op::OpIMul, u, {y, constantU32(19349663u)});
    uint32_t h = op(b, spv::Op::OpBitwiseXor, u, {hx, hy});
    const uint32_t shifts[3] = {16, 15, 16};
    const uint32_t mults[2] = {0x7feb352du, 0x846ca68bu};
    for (int i = 0; i < 3; ++i) {
      uint32_t s = op(b, spv::Op::OpShiftRightLogical, u, {h, constantU32(shifts[i])});
      h = op(b, spv::Op::OpBitwiseXor, u, {h, s});
      if (i < 2) h = op(b, spv::Op::OpIMul, u, {h, constantU32(mults[i])});
    }
    return h;
  }

  // True in the one invocation per tw x th tile that counts for the tile.
  uint32_t tileSelect2D(Body& b, uint32_t x, uint32_t y, uint32_t z) {
    uint32_t u = tU32();
    TileShape tile = sampledTileShape(options_.mode.sampleRate);
    uint32_t tw = constantU32(tile.width), th = constantU32(tile.height);
    uint32_t tx = op(b, spv::Op::OpUDiv, u, {x, tw});
    uint32_t ty = op(b, spv::Op::OpUDiv, u, {y, th});
    uint32_t lx = op(b, spv::Op::OpUMod, u, {x, tw});
    uint32_t ly = op(b, spv::Op::OpUMod, u, {y, th});
    uint32_t row = op(b, spv::Op::OpIMul, u, {ly, tw});
    uint32_t local = op(b, spv::Op::OpIAdd, u, {row, lx});
    if (z != 0) {
      uint32_t zMix = op(b, spv::Op::OpIMul, u, {z, constantU32(83492791u)});
      ty = op(b, spv::Op::OpBitwiseXor, u, {ty, zMix});
    }
    uint32_t h = hash(b, tx, ty);
    uint32_t pick = op(b, spv::Op::OpUMod, u, {h, constantU32(options_.mode.sampleRate)});
    return op(b, spv::Op::OpIEqual, tBool(), {local, pick});
  }

  uint32_t loadIntAsU32(Body& b, uint32_t var) {
    uint32_t type = types_.pointee(types_.typeOf(var));
    if (type == 0) type = tI32();  // created by us: i32
    const Instruction* t = defs_.def(type);
    bool isSigned = t == nullptr || t->word(3) == 1;
    uint32_t value = op(b, spv::Op::OpLoad, isSigned ? tI32() : tU32(), {var});
    return isSigned ? op(b, spv::Op::OpBitcast, tU32(), {value}) : value;
  }

  uint32_t sampledSelect(Body& b, Helper h, Stage stage) {
    uint32_t u = tU32();
    if (h == Helper::SampledFragment) {
      uint32_t v4 = tVec(tF32(), 4);
      uint32_t var = builtin(stage, spv::BuiltIn::FragCoord, v4);
      uint32_t coord = op(b, spv::Op::OpLoad, v4, {var});
      uint32_t fx = op(b, spv::Op::OpCompositeExtract, tF32(), {coord, 0});
      uint32_t fy = op(b, spv::Op::OpCompositeExtract, tF32(), {coord, 1});
      uint32_t x = op(b, spv::Op::OpConvertFToU, u, {fx});
      uint32_t y = op(b, spv::Op::OpConvertFToU, u, {fy});
      return tileSelect2D(b, x, y, 0);
    }
    if (h == Helper::SampledCompute) {
      uint32_t v3 = tVec(u, 3);
      uint32_t var = builtin(stage, spv::BuiltIn::GlobalInvocationId, v3);
      uint32_t id = op(b, spv::Op::OpLoad, v3, {var});
      uint32_t x = op(b, spv::Op::OpCompositeExtract, u, {id, 0});
      uint32_t y = op(b, spv::Op::OpCompositeExtract, u, {id, 1});
      uint32_t z = op(b, spv::Op::OpCompositeExtract, u, {id, 2});
      return tileSelect2D(b, x, y, z);
    }
    // Vertex: tiles of N consecutive vertex indices, per instance.
    uint32_t vertex = loadIntAsU32(b, builtin(stage, spv::BuiltIn::VertexIndex, tI32(), true));
    uint32_t instance = loadIntAsU32(b, builtin(stage, spv::BuiltIn::InstanceIndex, tI32(), true));
    uint32_t n = constantU32(options_.mode.sampleRate);
    uint32_t tile = op(b, spv::Op::OpUDiv, u, {vertex, n});
    uint32_t local = op(b, spv::Op::OpUMod, u, {vertex, n});
    uint32_t pick = op(b, spv::Op::OpUMod, u, {hash(b, tile, instance), n});
    return op(b, spv::Op::OpIEqual, tBool(), {local, pick});
  }

  // Opens a block that only non-helper lanes enter; returns the merge label
  // the caller branches to (and opens) when the block ends.
  uint32_t skipHelperLanes(Body& b, Stage stage) {
    uint32_t var = builtin(stage, spv::BuiltIn::HelperInvocation, tBool());
    std::vector<uint32_t> load = {var};
    if (vulkanMemoryModel_ && demotes_) load.push_back(1);  // Volatile access
    uint32_t isHelper = op(b, spv::Op::OpLoad, tBool(), load);
    uint32_t body = m_.newId(), end = m_.newId();
    selection(b, isHelper, end, body, end);
    label(b, body);
    return end;
  }

  // Where code counted at entry goes: after the entry block's label and its
  // OpVariables (and debug lines).
  static size_t entryStart(const std::vector<Instruction>& insts) {
    size_t at = 0;
    while (at < insts.size() && insts[at].opcode() != spv::Op::OpLabel) ++at;
    ++at;
    while (at < insts.size() && (insts[at].opcode() == spv::Op::OpVariable || insts[at].opcode() == spv::Op::OpLine ||
                                 insts[at].opcode() == spv::Op::OpNoLine)) {
      ++at;
    }
    return at;
  }

  uint32_t helperFunction(Helper h, Stage stage) {
    // Sampled and subgroup-fragment helpers read stage builtins: one per stage.
    bool stageFree = h == Helper::Exact || h == Helper::Subgroup || h == Helper::SubgroupUniform;
    auto key = std::make_pair(h, stageFree ? Stage::Other : stage);
    if (auto it = helpers_.find(key); it != helpers_.end()) return it->second;

    uint32_t fnType = type(spv::Op::OpTypeFunction, {tVoid(), tU32()});
    Function fn;
    Body b{fn.insts};
    uint32_t id = m_.newId();
    b.insts.emplace_back(spv::Op::OpFunction, std::vector<uint32_t>{tVoid(), id, 0, fnType});
    uint32_t slot = m_.newId();
    b.insts.emplace_back(spv::Op::OpFunctionParameter, std::vector<uint32_t>{tU32(), slot});
    label(b, m_.newId());
    uint32_t one = constantU32(1);

    switch (h) {
      case Helper::Exact: emitAdd(b, slot, one); break;
      case Helper::SampledFragment:
      case Helper::SampledCompute:
      case Helper::SampledVertex: {
        uint32_t selected = sampledSelect(b, h, stage);
        uint32_t yes = m_.newId(), end = m_.newId();
        selection(b, selected, yes, end, end);
        label(b, yes);
        emitAdd(b, slot, constantU32(options_.mode.sampleRate));
        branch(b, end);
        label(b, end);
        break;
      }
      case Helper::Subgroup:
      case Helper::SubgroupFragment:
      case Helper::SubgroupUniform:
      case Helper::SubgroupUniformFragment: {
        // Helper lanes take part in subgroup operations but must not be
        // counted, and an atomic from one has no effect: keep them out.
        uint32_t end = 0;
        if (h == Helper::SubgroupFragment || h == Helper::SubgroupUniformFragment) end = skipHelperLanes(b, stage);
        uint32_t scope = constantU32(kScopeSubgroup);
        if (h == Helper::SubgroupUniform || h == Helper::SubgroupUniformFragment) {
          uint32_t count = op(b, spv::Op::OpGroupNonUniformIAdd, tU32(), {scope, kGroupReduce, one});
          uint32_t elected = op(b, spv::Op::OpGroupNonUniformElect, tBool(), {scope});
          uint32_t add = m_.newId(), done = m_.newId();
          selection(b, elected, add, done, done);
          label(b, add);
          emitAdd(b, slot, count);
          branch(b, done);
          label(b, done);
          if (end != 0) {
            branch(b, end);
            label(b, end);
          }
          break;
        }
        // Waterfall: each pass takes the lanes whose slot equals the first
        // active lane's, adds their count in one atomic, and lets them leave.
        uint32_t header = m_.newId(), loop = m_.newId(), cont = m_.newId(), exit = m_.newId();
        uint32_t take = m_.newId(), took = m_.newId(), add = m_.newId(), skip = m_.newId();
        branch(b, header);
        label(b, header);
        opNoResult(b, spv::Op::OpLoopMerge, {exit, cont, 0});
        branch(b, loop);
        label(b, loop);
        uint32_t first = op(b, spv::Op::OpGroupNonUniformBroadcastFirst, tU32(), {scope, slot});
        uint32_t mine = op(b, spv::Op::OpIEqual, tBool(), {slot, first});
        selection(b, mine, take, skip, skip);
        label(b, take);
        uint32_t count = op(b, spv::Op::OpGroupNonUniformIAdd, tU32(), {scope, kGroupReduce, one});
        uint32_t elected = op(b, spv::Op::OpGroupNonUniformElect, tBool(), {scope});
        selection(b, elected, add, took, took);
        label(b, add);
        emitAdd(b, first, count);
        branch(b, took);
        label(b, took);
        branch(b, skip);
        label(b, skip);
        branch(b, cont);
        label(b, cont);
        opNoResult(b, spv::Op::OpBranchConditional, {mine, exit, header});
        label(b, exit);
        if (end != 0) {
          branch(b, end);
          label(b, end);
        }
        break;
      }
    }
    opNoResult(b, spv::Op::OpReturn, {});
    b.insts.emplace_back(spv::Op::OpFunctionEnd, std::vector<uint32_t>{});
    std::string fnName = helperName(h);
    if (key.second != Stage::Other) fnName += "_" + std::string(toString(stage));
    name(id, fnName);
    newFunctions_.push_back(std::move(fn));
    helpers_.emplace(key, id);
    return id;
  }

  // ---- accumulate: a register per slot, one flush per invocation --------
  //
  // Each site adds 1 to a Private (per-invocation) u32 accumulator of its
  // slot; the invocation flushes every accumulator of its stage once, where
  // it ends: before each OpReturn of the entry function, and before OpKill,
  // OpTerminateInvocation, OpDemoteToHelperInvocation (then zeroed: the
  // helper it becomes is not counted) and OpEmitMeshTasksEXT wherever they
  // are. The flush reduces across the subgroup (lo and hi 16 bits apart, so
  // that the sum is exact for any per-invocation count below 2^32) and one
  // elected lane adds a non-zero total; without subgroup arithmetic in the
  // stage each lane adds its own non-zero accumulator.

  static bool accumulates(Stage stage) { return stage != Stage::Other; }
  // Auto: per lane in options_.autoLaneStages, else reduced (docs/measurement.md,
  // "Which flush", with the figures that chose it).
  bool subgroupFlush(Stage stage) const {
    if ((options_.subgroupStages & stageBit(stage)) == 0) return false;
    switch (options_.mode.flush) {
      case Flush::Subgroup: return true;
      case Flush::Lane: return false;
      case Flush::Auto: return (options_.autoLaneStages & stageBit(stage)) == 0;
    }
    return false;
  }

  // A Private u32 (or u32[n]) variable initialised to zero.
  uint32_t privateVariable(uint32_t valueType, uint32_t zero, const std::string& varName) {
    uint32_t id = m_.newId();
    newGlobals_.emplace_back(spv::Op::OpVariable,
                             std::vector<uint32_t>{tPtr(spv::StorageClass::Private, valueType), id,
                                                   static_cast<uint32_t>(spv::StorageClass::Private), zero});
    name(id, varName);
    accumulators_.push_back(id);
    return id;
  }

  uint32_t scalarAccumulator(uint32_t slot) {
    if (auto it = scalarAcc_.find(slot); it != scalarAcc_.end()) return it->second;
    uint32_t id = privateVariable(tU32(), constantU32(0), "tally_acc_" + std::to_string(slot));
    scalarAcc_.emplace(slot, id);
    return id;
  }

  struct ArrayAccumulator {
    uint32_t variable, length;
  };
  uint32_t arrayAccumulator(uint32_t base, uint32_t length) {
    for (const auto& [key, acc] : arrayAcc_) {
      if (key == base && acc.length == length) return acc.variable;
    }
    uint32_t arrayType = m_.newId();
    newGlobals_.emplace_back(spv::Op::OpTypeArray, std::vector<uint32_t>{arrayType, tU32(), constantU32(length)});
    uint32_t null = m_.newId();
    newGlobals_.emplace_back(spv::Op::OpConstantNull, std::vector<uint32_t>{arrayType, null});
    uint32_t id = privateVariable(arrayType, null, "tally_acc_" + std::to_string(base) + "_x" + std::to_string(length));
    arrayAcc_.emplace_back(base, ArrayAccumulator{id, length});
    return id;
  }

  // acc += 1 through a Private pointer.
  void increment(Body& b, uint32_t pointer) {
    uint32_t v = op(b, spv::Op::OpLoad, tU32(), {pointer});
    uint32_t w = op(b, spv::Op::OpIAdd, tU32(), {v, constantU32(1)});
    opNoResult(b, spv::Op::OpStore, {pointer, w});
  }

  // min(index, length - 1) of a run-time descriptor index, as a u32.
  uint32_t clampedIndex(Body& b, const FoundSite& s, uint32_t length) {
    uint32_t u = tU32();
    uint32_t index = s.dynamicIndex;
    const Instruction* t = defs_.def(types_.typeOf(index));
    if (t != nullptr && t->opcode() == spv::Op::OpTypeInt) {
      if (t->word(2) != 32) {
        index = op(b, spv::Op::OpUConvert, u, {index});
      } else if (t->word(3) == 1) {
        index = op(b, spv::Op::OpBitcast, u, {index});
      }
    }
    uint32_t inRange = op(b, spv::Op::OpULessThan, tBool(), {index, constantU32(length)});
    return op(b, spv::Op::OpSelect, u, {inRange, index, constantU32(length - 1)});
  }

  // Whether the site runs at most once per invocation of its entry point:
  // counted at entry or at the return, or outside every loop of a function
  // that runs once.
  bool runsOnce(const FoundSite& s, const EntryPoint& ep) {
    if (s.placement != Placement::AfterInstruction) return true;
    auto [once, fresh] = runsOnce_.try_emplace(s.entryIndex);
    if (fresh) once->second = functionsRunOnce(m_, defs_, ep.functionIndex);
    if (s.function < 0 || size_t(s.function) >= once->second.size() || !once->second[s.function]) return false;
    auto [cycles, first] = cycles_.try_emplace(s.function);
    if (first) cycles->second = instructionsInCycles(m_.functions[s.function], defs_);
    return s.instruction < cycles->second.size() && !cycles->second[s.instruction];
  }

  // Emits the site's increment; false when the site is counted per access instead.
  bool accumulateSite(const FoundSite& s, const EntryPoint& ep, uint32_t slot,
                      std::vector<std::map<size_t, std::vector<Instruction>>>& after,
                      std::vector<std::map<size_t, std::vector<Instruction>>>& before) {
    if (!accumulates(ep.stage)) {
      noteOnce("accumulate mode: " + std::string(toString(ep.stage)) + " stage is counted per access");
      return false;
    }
    uint32_t length = s.dynamicIndex == 0 ? 1 : (s.arrayLength != 0 ? s.arrayLength : kRuntimeArraySlots);
    if (s.dynamicIndex != 0 && length > kAccumulateArrayMax) {
      noteOnce("accumulate mode: descriptor arrays of more than " + std::to_string(kAccumulateArrayMax) +
               " elements indexed at run time are counted per access");
      return false;
    }
    // A site that runs at most once per invocation saves nothing by
    // accumulating where the flush is an atomic per lane (one add either
    // way, plus the register's load, store and test), nor where its flush
    // would reduce every element of an array for one access.
    if (runsOnce(s, ep) && (!subgroupFlush(ep.stage) || length > 1)) {
      ++perAccessOnce_[ep.stage];
      return false;
    }
    const auto& insts = m_.functions[s.function].insts;
    auto emitInto = [&](std::vector<Instruction>& list) {
      Body b{list};
      uint32_t pointer;
      if (s.dynamicIndex == 0) {
        pointer = scalarAccumulator(slot);
      } else {
        uint32_t array = arrayAccumulator(slot, length);
        pointer = op(b, spv::Op::OpAccessChain, tPtr(spv::StorageClass::Private, tU32()),
                     {array, clampedIndex(b, s, length)});
      }
      increment(b, pointer);
    };
    switch (s.placement) {
      case Placement::AfterInstruction: emitInto(after[s.function][s.instruction]); break;
      case Placement::EntryStart: emitInto(before[s.function][entryStart(insts)]); break;
      case Placement::BeforeReturns:
        for (size_t at = 0; at < insts.size(); ++at) {
          if (insts[at].opcode() == spv::Op::OpReturn) emitInto(before[s.function][at]);
        }
        break;
    }
    // The stage's flush covers this slot (or these slots).
    auto& flush = flushSlots_[ep.stage];
    if (s.dynamicIndex == 0) {
      flush.scalars.insert(slot);
    } else {
      flush.arrays.insert({slot, length});
    }
    return true;
  }

  // counters[slot] += hi * 65536 + lo, both u32 below 2^32 / 65536 * subgroup size.
  void emitAddWide(Body& b, uint32_t slot, uint32_t lo, uint32_t hi) {
    uint32_t zero = constantU32(0), semantics = constantU32(kSemanticsRelaxed);
    if (options_.width == CounterWidth::Int64) {
      uint32_t wideHi = op(b, spv::Op::OpUConvert, tU64(), {hi});
      uint32_t shifted = op(b, spv::Op::OpShiftLeftLogical, tU64(), {wideHi, constantU32(16)});
      uint32_t wideLo = op(b, spv::Op::OpUConvert, tU64(), {lo});
      uint32_t amount = op(b, spv::Op::OpIAdd, tU64(), {shifted, wideLo});
      uint32_t ptr = op(b, spv::Op::OpAccessChain, elementPtr_, {counters_, zero, slot});
      op(b, spv::Op::OpAtomicIAdd, tU64(), {ptr, atomicScope(), semantics, amount});
      return;
    }
    // The amount as two words, then the low word's carry into the high one.
    uint32_t u = tU32();
    uint32_t hiLow = op(b, spv::Op::OpShiftLeftLogical, u, {hi, constantU32(16)});
    uint32_t low = op(b, spv::Op::OpIAdd, u, {hiLow, lo});
    uint32_t carryIn = op(b, spv::Op::OpULessThan, tBool(), {low, lo});
    uint32_t hiHigh = op(b, spv::Op::OpShiftRightLogical, u, {hi, constantU32(16)});
    uint32_t high = op(b, spv::Op::OpIAdd, u, {hiHigh, op(b, spv::Op::OpSelect, u, {carryIn, constantU32(1), zero})});
    uint32_t lowIndex = op(b, spv::Op::OpIMul, u, {slot, constantU32(2)});
    uint32_t lowPtr = op(b, spv::Op::OpAccessChain, elementPtr_, {counters_, zero, lowIndex});
    uint32_t old = op(b, spv::Op::OpAtomicIAdd, u, {lowPtr, atomicScope(), semantics, low});
    uint32_t sum = op(b, spv::Op::OpIAdd, u, {old, low});
    uint32_t wrapped = op(b, spv::Op::OpULessThan, tBool(), {sum, old});
    uint32_t total = op(b, spv::Op::OpIAdd, u, {high, op(b, spv::Op::OpSelect, u, {wrapped, constantU32(1), zero})});
    uint32_t any = op(b, spv::Op::OpINotEqual, tBool(), {total, zero});
    uint32_t carry = m_.newId(), merge = m_.newId();
    selection(b, any, carry, merge, merge);
    label(b, carry);
    uint32_t highIndex = op(b, spv::Op::OpIAdd, u, {lowIndex, constantU32(1)});
    uint32_t highPtr = op(b, spv::Op::OpAccessChain, elementPtr_, {counters_, zero, highIndex});
    op(b, spv::Op::OpAtomicIAdd, u, {highPtr, atomicScope(), semantics, total});
    branch(b, merge);
    label(b, merge);
  }

  // Flushes one accumulator (a Private u32 pointer) into counter `slot` (of
  // this invocation's copy), then zeroes it.
  void flushOne(Body& b, Stage stage, uint32_t pointer, uint32_t slot, uint32_t copyOffset) {
    uint32_t slotId = copyOffset == 0 ? constantU32(slot) : op(b, spv::Op::OpIAdd, tU32(), {constantU32(slot), copyOffset});
    uint32_t u = tU32(), zero = constantU32(0);
    uint32_t v = op(b, spv::Op::OpLoad, u, {pointer});
    opNoResult(b, spv::Op::OpStore, {pointer, zero});
    uint32_t add = m_.newId(), done = m_.newId();
    if (subgroupFlush(stage)) {
      uint32_t scope = constantU32(kScopeSubgroup);
      uint32_t lo = op(b, spv::Op::OpBitwiseAnd, u, {v, constantU32(0xffffu)});
      uint32_t hi = op(b, spv::Op::OpShiftRightLogical, u, {v, constantU32(16)});
      uint32_t sumLo = op(b, spv::Op::OpGroupNonUniformIAdd, u, {scope, kGroupReduce, lo});
      uint32_t sumHi = op(b, spv::Op::OpGroupNonUniformIAdd, u, {scope, kGroupReduce, hi});
      uint32_t either = op(b, spv::Op::OpBitwiseOr, u, {sumLo, sumHi});
      uint32_t nonZero = op(b, spv::Op::OpINotEqual, tBool(), {either, zero});
      uint32_t elected = op(b, spv::Op::OpGroupNonUniformElect, tBool(), {scope});
      uint32_t go = op(b, spv::Op::OpLogicalAnd, tBool(), {elected, nonZero});
      selection(b, go, add, done, done);
      label(b, add);
      emitAddWide(b, slotId, sumLo, sumHi);
    } else {
      // Per lane. A helper lane's atomic has no effect (Vulkan), as in exact mode.
      uint32_t nonZero = op(b, spv::Op::OpINotEqual, tBool(), {v, zero});
      selection(b, nonZero, add, done, done);
      label(b, add);
      emitAdd(b, slotId, v);
    }
    branch(b, done);
    label(b, done);
  }

  // Compute flushes stripe each slot over result_.copies copies: every
  // workgroup (and subgroup) of a dispatch flushing into one address
  // serialises on it, and a compute pass has no fixed-function work to hide
  // that behind. The reader sums the copies (foldCopies).
  bool stripes(Stage stage) const { return stage == Stage::Compute && result_.copies > 1; }

  // copy * copyStride, the copy chosen by workgroup and by subgroup (or by
  // lane, where the flush is per lane). Workgroups resident together are
  // consecutive in x, so x + 3y + 5z spreads them over the copies.
  uint32_t copyOffsetOf(Body& b, Stage stage) {
    uint32_t u = tU32(), v3 = tVec(u, 3);
    uint32_t id = op(b, spv::Op::OpLoad, v3, {builtin(stage, spv::BuiltIn::WorkgroupId, v3)});
    uint32_t x = op(b, spv::Op::OpCompositeExtract, u, {id, 0});
    uint32_t y = op(b, spv::Op::OpCompositeExtract, u, {id, 1});
    uint32_t z = op(b, spv::Op::OpCompositeExtract, u, {id, 2});
    uint32_t mix = op(b, spv::Op::OpIAdd, u, {x, op(b, spv::Op::OpIMul, u, {y, constantU32(3)})});
    mix = op(b, spv::Op::OpIAdd, u, {mix, op(b, spv::Op::OpIMul, u, {z, constantU32(5)})});
    uint32_t within = subgroupFlush(stage) ? builtin(stage, spv::BuiltIn::SubgroupId, u)
                                           : builtin(stage, spv::BuiltIn::LocalInvocationIndex, u);
    mix = op(b, spv::Op::OpIAdd, u, {mix, op(b, spv::Op::OpLoad, u, {within})});
    uint32_t copy = op(b, spv::Op::OpBitwiseAnd, u, {mix, constantU32(result_.copies - 1)});
    return op(b, spv::Op::OpIMul, u, {copy, constantU32(result_.copyStride)});
  }

  // The stage's flush function: every accumulator its sites use.
  uint32_t flushFunction(Stage stage) {
    if (auto it = flushFunctions_.find(stage); it != flushFunctions_.end()) return it->second;
    uint32_t fnType = type(spv::Op::OpTypeFunction, {tVoid()});
    Function fn;
    Body b{fn.insts};
    uint32_t id = m_.newId();
    b.insts.emplace_back(spv::Op::OpFunction, std::vector<uint32_t>{tVoid(), id, 0, fnType});
    label(b, m_.newId());
    // Helper lanes stay out of the flush altogether: were one the elected
    // lane, its atomic would have no effect and the subgroup's count would
    // be lost (NVIDIA elects them: found by the analytic suite on an H100).
    uint32_t end = 0;
    if (stage == Stage::Fragment && subgroupFlush(stage)) end = skipHelperLanes(b, stage);
    uint32_t copyOffset = stripes(stage) ? copyOffsetOf(b, stage) : 0;
    const FlushSlots& slots = flushSlots_[stage];
    for (uint32_t slot : slots.scalars) flushOne(b, stage, scalarAccumulator(slot), slot, copyOffset);
    for (const auto& [base, length] : slots.arrays) {
      uint32_t array = arrayAccumulator(base, length);
      for (uint32_t i = 0; i < length; ++i) {
        uint32_t element = op(b, spv::Op::OpAccessChain, tPtr(spv::StorageClass::Private, tU32()), {array, constantU32(i)});
        flushOne(b, stage, element, base + i, copyOffset);
      }
    }
    if (end != 0) {
      branch(b, end);
      label(b, end);
    }
    opNoResult(b, spv::Op::OpReturn, {});
    b.insts.emplace_back(spv::Op::OpFunctionEnd, std::vector<uint32_t>{});
    name(id, "tally_flush_" + std::string(toString(stage)));
    newFunctions_.push_back(std::move(fn));
    flushFunctions_.emplace(stage, id);
    return id;
  }

  // Executed arithmetic: at the top of every block of every function an
  // accumulating entry point reaches, the block's operations (arith.hpp)
  // added to one register, flushed by each stage into the arithmetic slot.
  void countExecutedArithmetic(const SiteScan& scan, std::vector<std::map<size_t, std::vector<Instruction>>>& before) {
    const uint32_t slot = static_cast<uint32_t>(result_.arithmeticSlot);
    const auto weights = arithmeticPerInstruction(m_);
    std::map<uint32_t, int> byId;
    for (size_t f = 0; f < m_.functions.size(); ++f) byId[m_.functions[f].id()] = static_cast<int>(f);
    std::set<int> reached;
    for (const auto& ep : scan.entryPoints) {
      if (!accumulates(ep.stage)) continue;
      flushSlots_[ep.stage].scalars.insert(slot);
      std::vector<int> work = {ep.functionIndex};
      while (!work.empty()) {
        int f = work.back();
        work.pop_back();
        if (f < 0 || !reached.insert(f).second) continue;
        for (const auto& inst : m_.functions[f].insts) {
          if (inst.opcode() == spv::Op::OpFunctionCall) {
            if (auto it = byId.find(inst.word(3)); it != byId.end()) work.push_back(it->second);
          }
        }
      }
    }
    const uint32_t acc = scalarAccumulator(slot);
    for (int f : reached) {
      const auto& insts = m_.functions[f].insts;
      for (size_t at = 0; at < insts.size(); ++at) {
        if (insts[at].opcode() != spv::Op::OpLabel) continue;
        uint64_t ops = 0;
        size_t end = at + 1;
        for (; end < insts.size() && insts[end].opcode() != spv::Op::OpLabel; ++end) ops += weights[f][end];
        if (ops == 0) continue;
        size_t into = at + 1;
        while (into < end && (insts[into].opcode() == spv::Op::OpPhi || insts[into].opcode() == spv::Op::OpVariable ||
                              insts[into].opcode() == spv::Op::OpLine || insts[into].opcode() == spv::Op::OpNoLine)) {
          ++into;
        }
        Body b{before[f][into]};
        uint32_t v = op(b, spv::Op::OpLoad, tU32(), {acc});
        uint32_t w = op(b, spv::Op::OpIAdd, tU32(), {v, constantU32(static_cast<uint32_t>(std::min<uint64_t>(ops, 0xffffffffu)))});
        opNoResult(b, spv::Op::OpStore, {acc, w});
      }
    }
  }

  // Calls each stage's flush where its invocations end.
  void insertFlushes(const SiteScan& scan, std::vector<std::map<size_t, std::vector<Instruction>>>& before) {
    // Functions by id, and the stage of the entry points that reach each.
    std::map<uint32_t, int> byId;
    for (size_t f = 0; f < m_.functions.size(); ++f) byId[m_.functions[f].id()] = static_cast<int>(f);
    std::map<int, Stage> stageOf;
    for (const auto& ep : scan.entryPoints) {
      if (!accumulates(ep.stage) || !flushSlots_.count(ep.stage)) continue;
      std::vector<int> work = {ep.functionIndex};
      while (!work.empty()) {
        int f = work.back();
        work.pop_back();
        if (f < 0 || !stageOf.emplace(f, ep.stage).second) continue;
        for (const auto& inst : m_.functions[f].insts) {
          if (inst.opcode() == spv::Op::OpFunctionCall) {
            if (auto it = byId.find(inst.word(3)); it != byId.end()) work.push_back(it->second);
          }
        }
      }
    }
    std::set<int> entryFunctions;
    for (const auto& ep : scan.entryPoints) entryFunctions.insert(ep.functionIndex);
    for (const auto& [f, stage] : stageOf) {
      const auto& insts = m_.functions[f].insts;
      for (size_t at = 0; at < insts.size(); ++at) {
        spv::Op o = insts[at].opcode();
        bool ends = (o == spv::Op::OpReturn && entryFunctions.count(f)) || o == spv::Op::OpKill ||
                    o == spv::Op::OpTerminateInvocation || o == spv::Op::OpDemoteToHelperInvocation ||
                    o == spv::Op::OpEmitMeshTasksEXT;
        if (ends) before[f][at].push_back(Instruction(spv::Op::OpFunctionCall, {tVoid(), m_.newId(), flushFunction(stage)}));
      }
    }
  }

  // ---- footprint: mark the blocks each access covers --------------------
  //
  // Straight-line code at the site computes what the access touches (a
  // buffer's byte offset, an image's coordinates and level of detail) and
  // calls one of the tally_fp_* functions, which read the slot's table entry
  // (spirv/footprint.hpp) and set the blocks' bits: a load first, and the
  // atomic OR only where the bit is still clear, so a block touched again
  // costs a read of a cached word. Branches live in those functions only:
  // the code at a site never splits the site's block.

  bool footprintOn() const { return options_.footprintBlockBytes != 0; }

  uint32_t tF32v(uint32_t n) { return tVec(tF32(), n); }
  uint32_t constantI32(int32_t v) { return constant(tI32(), {static_cast<uint32_t>(v)}); }
  uint32_t constantF32(float v) { return constant(tF32(), {std::bit_cast<uint32_t>(v)}); }

  uint32_t glslImport() {
    if (glsl_ != 0) return glsl_;
    for (const auto& inst : m_.imports) {
      if (inst.opcode() == spv::Op::OpExtInstImport && inst.literalString(2) == "GLSL.std.450") glsl_ = inst.resultId();
    }
    if (glsl_ == 0) {
      glsl_ = m_.newId();
      std::vector<uint32_t> operands = {glsl_};
      auto w = stringWords("GLSL.std.450");
      operands.insert(operands.end(), w.begin(), w.end());
      m_.imports.emplace_back(spv::Op::OpExtInstImport, std::move(operands));
    }
    return glsl_;
  }
  // GLSL.std.450 instruction numbers.
  enum Glsl : uint32_t { RoundEven = 2, Floor = 8, Ceil = 9, Log2 = 30, UMin = 38, FMax = 40, UMax = 41,
                         FClamp = 43, SClamp = 45, Length = 66 };
  uint32_t ext(Body& b, uint32_t resultType, Glsl inst, std::vector<uint32_t> args) {
    args.insert(args.begin(), {glslImport(), static_cast<uint32_t>(inst)});
    return op(b, spv::Op::OpExtInst, resultType, std::move(args));
  }

  // Two u32 runtime-array buffers: the table and the bitmaps.
  void declareFootprint() {
    bool storageBuffer = m_.version >= kVersion13;
    uint32_t array = m_.newId();
    newGlobals_.emplace_back(spv::Op::OpTypeRuntimeArray, std::vector<uint32_t>{array, tU32()});
    decorate(array, spv::Decoration::ArrayStride, {4});
    uint32_t block = m_.newId();
    newGlobals_.emplace_back(spv::Op::OpTypeStruct, std::vector<uint32_t>{block, array});
    decorate(block, storageBuffer ? spv::Decoration::Block : spv::Decoration::BufferBlock);
    newAnnotations_.emplace_back(spv::Op::OpMemberDecorate,
                                 std::vector<uint32_t>{block, 0, static_cast<uint32_t>(spv::Decoration::Offset), 0});
    name(block, "TallyFootprintWords");
    uint32_t blockPtr = tPtr(storageClass_, block);
    auto variable = [&](uint32_t binding, const char* varName) {
      uint32_t id = m_.newId();
      newGlobals_.emplace_back(spv::Op::OpVariable,
                               std::vector<uint32_t>{blockPtr, id, static_cast<uint32_t>(storageClass_)});
      decorate(id, spv::Decoration::DescriptorSet, {options_.set});
      decorate(id, spv::Decoration::Binding, {binding});
      name(id, varName);
      return id;
    };
    fpTable_ = variable(options_.footprintTableBinding, "tally_footprint_table");
    fpBitmap_ = variable(options_.footprintBitmapBinding, "tally_footprint_bitmap");
    fpWordPtr_ = tPtr(storageClass_, tU32());
  }

  uint32_t tableWord(Body& b, uint32_t entry, uint32_t word) {
    uint32_t index = word == 0 ? entry : op(b, spv::Op::OpIAdd, tU32(), {entry, constantU32(word)});
    uint32_t ptr = op(b, spv::Op::OpAccessChain, fpWordPtr_, {fpTable_, constantU32(0), index});
    return op(b, spv::Op::OpLoad, tU32(), {ptr});
  }
  uint32_t tableWordAt(Body& b, uint32_t entry, uint32_t word, uint32_t dynamicOffset) {
    uint32_t index = op(b, spv::Op::OpIAdd, tU32(), {entry, constantU32(word)});
    index = op(b, spv::Op::OpIAdd, tU32(), {index, dynamicOffset});
    uint32_t ptr = op(b, spv::Op::OpAccessChain, fpWordPtr_, {fpTable_, constantU32(0), index});
    return op(b, spv::Op::OpLoad, tU32(), {ptr});
  }

  struct FnBuild {
    Function fn;
    uint32_t id = 0;
    std::vector<uint32_t> params;
  };
  // A void function of the given parameter types, its first block open.
  std::unique_ptr<FnBuild> beginFunction(const std::vector<uint32_t>& paramTypes) {
    auto f = std::make_unique<FnBuild>();
    std::vector<uint32_t> typeOperands = {tVoid()};
    typeOperands.insert(typeOperands.end(), paramTypes.begin(), paramTypes.end());
    uint32_t fnType = type(spv::Op::OpTypeFunction, typeOperands);
    f->id = m_.newId();
    f->fn.insts.emplace_back(spv::Op::OpFunction, std::vector<uint32_t>{tVoid(), f->id, 0, fnType});
    for (uint32_t t : paramTypes) {
      uint32_t p = m_.newId();
      f->fn.insts.emplace_back(spv::Op::OpFunctionParameter, std::vector<uint32_t>{t, p});
      f->params.push_back(p);
    }
    Body b{f->fn.insts};
    label(b, m_.newId());
    return f;
  }
  uint32_t endFunction(std::unique_ptr<FnBuild> f, const std::string& fnName) {
    Body b{f->fn.insts};
    opNoResult(b, spv::Op::OpReturn, {});
    b.insts.emplace_back(spv::Op::OpFunctionEnd, std::vector<uint32_t>{});
    name(f->id, fnName);
    uint32_t id = f->id;
    newFunctions_.push_back(std::move(f->fn));
    return id;
  }
  // if (cond) return; the rest of the function continues in a new block.
  void returnIf(Body& b, uint32_t cond) {
    uint32_t out = m_.newId(), rest = m_.newId();
    selection(b, cond, out, rest, rest);
    label(b, out);
    opNoResult(b, spv::Op::OpReturn, {});
    label(b, rest);
  }
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
  uint32_t fnCall(Body& b, uint32_t fn, std::vector<uint32_t> args) {
    args.insert(args.begin(), fn);
    return op(b, spv::Op::OpFunctionCall, tVoid(), std::move(args));
  }

  // tally_fp_mark(base, capacity, block): sets the bit, block clamped into
  // the scratch bit past the bitmap.
  uint32_t fpMarkFn() {
    if (fpMark_ != 0) return fpMark_;
    uint32_t u = tU32();
    auto f = beginFunction({u, u, u});
    Body b{f->fn.insts};
    uint32_t base = f->params[0], cap = f->params[1], block = f->params[2];
    uint32_t inside = op(b, spv::Op::OpULessThan, tBool(), {block, cap});
    block = op(b, spv::Op::OpSelect, u, {inside, block, cap});
    uint32_t word = op(b, spv::Op::OpIAdd, u, {base, op(b, spv::Op::OpShiftRightLogical, u, {block, constantU32(5)})});
    uint32_t bit = op(b, spv::Op::OpShiftLeftLogical, u,
                      {constantU32(1), op(b, spv::Op::OpBitwiseAnd, u, {block, constantU32(31)})});
    uint32_t ptr = op(b, spv::Op::OpAccessChain, fpWordPtr_, {fpBitmap_, constantU32(0), word});
    uint32_t old = op(b, spv::Op::OpLoad, u, {ptr});
    uint32_t clear = op(b, spv::Op::OpIEqual, tBool(), {op(b, spv::Op::OpBitwiseAnd, u, {old, bit}), constantU32(0)});
    when(b, clear, [&](Body& bb) {
      op(bb, spv::Op::OpAtomicOr, u, {ptr, atomicScope(), constantU32(kSemanticsRelaxed), bit});
    });
    fpMark_ = endFunction(std::move(f), "tally_fp_mark");
    return fpMark_;
  }

  // tally_fp_bytes(entry, offset, bytes): the blocks of bytes [offset, offset + bytes)
  // of a Buffer entry, or of vertex `offset` (the vertex index) of a VertexInput entry.
  uint32_t fpBytesFn(bool shortRange) {
    uint32_t& cached = shortRange ? fpBytesShort_ : fpBytes_;
    if (cached != 0) return cached;
    uint32_t u = tU32();
    auto f = beginFunction({u, u, u});
    Body b{f->fn.insts};
    uint32_t entry = f->params[0], offset = f->params[1], bytes = f->params[2];
    // The loop counter: a Function variable, declared first.
    uint32_t counter = 0;
    if (!shortRange) {
      counter = m_.newId();
      b.insts.emplace_back(spv::Op::OpVariable, std::vector<uint32_t>{tPtr(spv::StorageClass::Function, u), counter,
                                                                       static_cast<uint32_t>(spv::StorageClass::Function)});
    }
    uint32_t kind = tableWord(b, entry, footprint::kKind);
    uint32_t isBuffer = op(b, spv::Op::OpIEqual, tBool(), {kind, constantU32(uint32_t(footprint::EntryKind::Buffer))});
    uint32_t isVertex =
        op(b, spv::Op::OpIEqual, tBool(), {kind, constantU32(uint32_t(footprint::EntryKind::VertexInput))});
    returnIf(b, op(b, spv::Op::OpLogicalNot, tBool(), {op(b, spv::Op::OpLogicalOr, tBool(), {isBuffer, isVertex})}));
    uint32_t stride = tableWord(b, entry, footprint::kTexelBytes), attr = tableWord(b, entry, footprint::kWidth);
    uint32_t vertexOffset = op(b, spv::Op::OpIAdd, u, {op(b, spv::Op::OpIMul, u, {offset, stride}), attr});
    uint32_t start = op(b, spv::Op::OpSelect, u, {isVertex, vertexOffset, offset});
    uint32_t shift = constantU32(static_cast<uint32_t>(std::countr_zero(options_.footprintBlockBytes)));
    uint32_t first = op(b, spv::Op::OpShiftRightLogical, u, {start, shift});
    uint32_t endByte = op(b, spv::Op::OpIAdd, u, {start, op(b, spv::Op::OpISub, u, {bytes, constantU32(1)})});
    uint32_t last = op(b, spv::Op::OpShiftRightLogical, u, {endByte, shift});
    uint32_t base = tableWord(b, entry, footprint::kBase), cap = tableWord(b, entry, footprint::kCapacity);
    if (shortRange) {
      // At most three blocks (bytes <= 2 x block + 1): first, the next, last;
      // no loop, which compilers (lavapipe's LLVM) analyse far faster inside
      // the shader's own loops.
      uint32_t second = ext(b, u, UMin, {op(b, spv::Op::OpIAdd, u, {first, constantU32(1)}), last});
      fnCall(b, fpMarkFn(), {base, cap, first});
      fnCall(b, fpMarkFn(), {base, cap, second});
      fnCall(b, fpMarkFn(), {base, cap, last});
      cached = endFunction(std::move(f), "tally_fp_bytes_short");
      return cached;
    }
    opNoResult(b, spv::Op::OpStore, {counter, first});
    uint32_t header = m_.newId(), test = m_.newId(), body = m_.newId(), cont = m_.newId(), exit = m_.newId();
    branch(b, header);
    label(b, header);
    opNoResult(b, spv::Op::OpLoopMerge, {exit, cont, 0});
    branch(b, test);
    label(b, test);
    uint32_t i = op(b, spv::Op::OpLoad, u, {counter});
    opNoResult(b, spv::Op::OpBranchConditional, {op(b, spv::Op::OpULessThanEqual, tBool(), {i, last}), body, exit});
    label(b, body);
    fnCall(b, fpMarkFn(), {base, cap, i});
    branch(b, cont);
    label(b, cont);
    opNoResult(b, spv::Op::OpStore, {counter, op(b, spv::Op::OpIAdd, u, {i, constantU32(1)})});
    branch(b, header);
    label(b, exit);
    cached = endFunction(std::move(f), "tally_fp_bytes");
    return cached;
  }

  // tally_fp_texel_level(entry, x, y, layer, imageLevel): one texel of an
  // Image entry; coordinates outside the level mark nothing.
  uint32_t fpTexelLevelFn() {
    if (fpTexelLevel_ != 0) return fpTexelLevel_;
    uint32_t u = tU32(), i = tI32(), bo = tBool();
    auto f = beginFunction({u, i, i, i, u});
    Body b{f->fn.insts};
    uint32_t entry = f->params[0], x = f->params[1], y = f->params[2], layer = f->params[3];
    uint32_t level = ext(b, u, UMin, {f->params[4], constantU32(footprint::kMaxLevels - 1)});
    uint32_t wl = ext(b, u, UMax, {op(b, spv::Op::OpShiftRightLogical, u, {tableWord(b, entry, footprint::kWidth), level}),
                                   constantU32(1)});
    uint32_t hl = ext(b, u, UMax, {op(b, spv::Op::OpShiftRightLogical, u, {tableWord(b, entry, footprint::kHeight), level}),
                                   constantU32(1)});
    uint32_t ux = op(b, spv::Op::OpBitcast, u, {x}), uy = op(b, spv::Op::OpBitcast, u, {y});
    uint32_t inside = op(b, spv::Op::OpLogicalAnd, bo,
                         {op(b, spv::Op::OpULessThan, bo, {ux, wl}), op(b, spv::Op::OpULessThan, bo, {uy, hl})});
    uint32_t tw = tableWord(b, entry, footprint::kTileWidth), th = tableWord(b, entry, footprint::kTileHeight);
    uint32_t tilesX = op(b, spv::Op::OpUDiv, u, {op(b, spv::Op::OpIAdd, u, {wl, op(b, spv::Op::OpISub, u, {tw, constantU32(1)})}), tw});
    uint32_t layers = tableWord(b, entry, footprint::kLayers);
    uint32_t lastLayer = op(b, spv::Op::OpBitcast, i, {op(b, spv::Op::OpISub, u, {layers, constantU32(1)})});
    uint32_t ul = op(b, spv::Op::OpBitcast, u, {ext(b, i, SClamp, {layer, constantI32(0), lastLayer})});
    uint32_t block = op(b, spv::Op::OpIMul, u, {ul, tableWord(b, entry, footprint::kLayerBlocks)});
    block = op(b, spv::Op::OpIAdd, u, {block, tableWordAt(b, entry, footprint::kLevelStart, level)});
    uint32_t row = op(b, spv::Op::OpIMul, u, {op(b, spv::Op::OpUDiv, u, {uy, th}), tilesX});
    block = op(b, spv::Op::OpIAdd, u, {block, op(b, spv::Op::OpIAdd, u, {row, op(b, spv::Op::OpUDiv, u, {ux, tw})})});
    uint32_t cap = tableWord(b, entry, footprint::kCapacity);
    block = op(b, spv::Op::OpSelect, u, {inside, block, cap});
    fnCall(b, fpMarkFn(), {tableWord(b, entry, footprint::kBase), cap, block});
    fpTexelLevel_ = endFunction(std::move(f), "tally_fp_texel_level");
    return fpTexelLevel_;
  }

  // tally_fp_texel(entry, x, y, layer, lod): a texel at level `lod` of the
  // bound view (fetches, storage images, attachments).
  uint32_t fpTexelFn() {
    if (fpTexel_ != 0) return fpTexel_;
    uint32_t u = tU32(), i = tI32();
    auto f = beginFunction({u, i, i, i, u});
    Body b{f->fn.insts};
    uint32_t entry = f->params[0];
    uint32_t kind = tableWord(b, entry, footprint::kKind);
    returnIf(b, op(b, spv::Op::OpINotEqual, tBool(), {kind, constantU32(uint32_t(footprint::EntryKind::Image))}));
    uint32_t lastLevel = op(b, spv::Op::OpISub, u, {tableWord(b, entry, footprint::kLevels), constantU32(1)});
    uint32_t level = op(b, spv::Op::OpIAdd, u,
                        {tableWord(b, entry, footprint::kBaseLevel), ext(b, u, UMin, {f->params[4], lastLevel})});
    fnCall(b, fpTexelLevelFn(), {entry, f->params[1], f->params[2], f->params[3], level});
    fpTexel_ = endFunction(std::move(f), "tally_fp_texel");
    return fpTexel_;
  }

  // The texel coordinate after the sampler's address mode; -1 (nothing)
  // outside a clamp-to-border image.
  uint32_t wrap(Body& b, uint32_t c, uint32_t size, uint32_t mode) {
    uint32_t i = tI32(), bo = tBool();
    uint32_t n = op(b, spv::Op::OpBitcast, i, {size});
    uint32_t last = op(b, spv::Op::OpISub, i, {n, constantI32(1)});
    uint32_t repeat = op(b, spv::Op::OpSMod, i, {c, n});
    uint32_t twice = op(b, spv::Op::OpIMul, i, {n, constantI32(2)});
    uint32_t t = op(b, spv::Op::OpSMod, i, {c, twice});
    uint32_t mirrored = op(b, spv::Op::OpSelect, i,
                           {op(b, spv::Op::OpSLessThan, bo, {t, n}), t,
                            op(b, spv::Op::OpISub, i, {op(b, spv::Op::OpISub, i, {twice, constantI32(1)}), t})});
    uint32_t clamped = ext(b, i, SClamp, {c, constantI32(0), last});
    uint32_t inside = op(b, spv::Op::OpLogicalAnd, bo,
                         {op(b, spv::Op::OpSGreaterThanEqual, bo, {c, constantI32(0)}), op(b, spv::Op::OpSLessThan, bo, {c, n})});
    uint32_t border = op(b, spv::Op::OpSelect, i, {inside, c, constantI32(-1)});
    uint32_t negative = op(b, spv::Op::OpSLessThan, bo, {c, constantI32(0)});
    uint32_t folded = op(b, spv::Op::OpSelect, i, {negative, op(b, spv::Op::OpISub, i, {constantI32(-1), c}), c});
    uint32_t mirrorClamp = ext(b, i, SClamp, {folded, constantI32(0), last});
    auto is = [&](uint32_t m) { return op(b, spv::Op::OpIEqual, bo, {mode, constantU32(m)}); };
    uint32_t r = clamped;
    r = op(b, spv::Op::OpSelect, i, {is(footprint::kRepeat), repeat, r});
    r = op(b, spv::Op::OpSelect, i, {is(footprint::kMirroredRepeat), mirrored, r});
    r = op(b, spv::Op::OpSelect, i, {is(footprint::kClampToBorder), border, r});
    r = op(b, spv::Op::OpSelect, i, {is(footprint::kMirrorClampToEdge), mirrorClamp, r});
    return r;
  }

  // tally_fp_sample_level(entry, imageLevel, u, v, layer, linear, offsetX, offsetY):
  // the texels a nearest (1) or bilinear (2 x 2) filter reads at one level.
  uint32_t fpSampleLevelFn() {
    if (fpSampleLevel_ != 0) return fpSampleLevel_;
    uint32_t u = tU32(), i = tI32(), fl = tF32(), bo = tBool();
    auto f = beginFunction({u, u, fl, fl, i, bo, i, i});
    Body b{f->fn.insts};
    uint32_t entry = f->params[0], level = ext(b, u, UMin, {f->params[1], constantU32(footprint::kMaxLevels - 1)});
    uint32_t linear = f->params[5];
    uint32_t sampler = tableWord(b, entry, footprint::kSampler);
    auto axis = [&](uint32_t coord, uint32_t sizeWord, uint32_t shift, uint32_t offset) {
      uint32_t size = ext(b, u, UMax, {op(b, spv::Op::OpShiftRightLogical, u, {tableWord(b, entry, sizeWord), level}),
                                       constantU32(1)});
      uint32_t scaled = op(b, spv::Op::OpFMul, fl, {coord, op(b, spv::Op::OpConvertUToF, fl, {size})});
      scaled = op(b, spv::Op::OpFSub, fl, {scaled, op(b, spv::Op::OpSelect, fl, {linear, constantF32(0.5f), constantF32(0.0f)})});
      uint32_t c0 = op(b, spv::Op::OpIAdd, i, {op(b, spv::Op::OpConvertFToS, i, {ext(b, fl, Floor, {scaled})}), offset});
      uint32_t c1 = op(b, spv::Op::OpIAdd, i, {c0, op(b, spv::Op::OpSelect, i, {linear, constantI32(1), constantI32(0)})});
      uint32_t mode = op(b, spv::Op::OpBitwiseAnd, u,
                         {op(b, spv::Op::OpShiftRightLogical, u, {sampler, constantU32(shift)}), constantU32(7)});
      return std::make_pair(wrap(b, c0, size, mode), wrap(b, c1, size, mode));
    };
    // Not structured bindings: clang before 16 cannot capture them in the lambda below.
    std::pair<uint32_t, uint32_t> xs = axis(f->params[2], footprint::kWidth, footprint::kAddressUShift, f->params[6]);
    std::pair<uint32_t, uint32_t> ys = axis(f->params[3], footprint::kHeight, footprint::kAddressVShift, f->params[7]);
    uint32_t x0 = xs.first, x1 = xs.second, y0 = ys.first, y1 = ys.second;
    uint32_t texel = fpTexelLevelFn(), layer = f->params[4];
    fnCall(b, texel, {entry, x0, y0, layer, level});
    when(b, linear, [&](Body& bb) {
      fnCall(bb, texel, {entry, x1, y0, layer, level});
      fnCall(bb, texel, {entry, x0, y1, layer, level});
      fnCall(bb, texel, {entry, x1, y1, layer, level});
    });
    fpSampleLevel_ = endFunction(std::move(f), "tally_fp_sample_level");
    return fpSampleLevel_;
  }

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
  uint32_t fpSampleFn() {
    if (fpSample_ != 0) return fpSample_;
    uint32_t u = tU32(), i = tI32(), fl = tF32(), bo = tBool();
    auto f = beginFunction({u, fl, fl, fl, u, fl, fl, i, i});
    Body b{f->fn.insts};
    uint32_t entry = f->params[0], lodKind = f->params[4], a = f->params[5], lam = f->params[6];
    returnIf(b, op(b, spv::Op::OpINotEqual, bo,
                   {tableWord(b, entry, footprint::kKind), constantU32(uint32_t(footprint::EntryKind::Image))}));
    uint32_t sampler = tableWord(b, entry, footprint::kSampler);
    auto bit = [&](uint32_t mask) {
      return op(b, spv::Op::OpINotEqual, bo, {op(b, spv::Op::OpBitwiseAnd, u, {sampler, constantU32(mask)}), constantU32(0)});
    };
    uint32_t levels = tableWord(b, entry, footprint::kLevels);
    uint32_t lastLevel = op(b, spv::Op::OpConvertUToF, fl, {op(b, spv::Op::OpISub, u, {levels, constantU32(1)})});
    uint32_t queried = op(b, spv::Op::OpIEqual, bo, {lodKind, constantU32(uint32_t(Lod::Queried))});
    uint32_t gather = op(b, spv::Op::OpIEqual, bo, {lodKind, constantU32(uint32_t(Lod::Gather))});
    uint32_t lambda = op(b, spv::Op::OpSelect, fl, {queried, lam, a});
    uint32_t d = op(b, spv::Op::OpSelect, fl, {queried, a, ext(b, fl, FClamp, {a, constantF32(0.0f), lastLevel})});
    uint32_t mag = op(b, spv::Op::OpLogicalOr, bo, {gather, op(b, spv::Op::OpFOrdLessThanEqual, bo, {lambda, constantF32(0.0f)})});
    uint32_t linear = op(b, spv::Op::OpLogicalOr, bo, {gather, op(b, spv::Op::OpSelect, bo, {mag, bit(footprint::kMagLinear),
                                                                                            bit(footprint::kMinLinear)})});
    uint32_t mipLinear = bit(footprint::kMipLinear);
    uint32_t dFloor = ext(b, fl, Floor, {d});
    uint32_t nearest = op(b, spv::Op::OpFSub, fl, {ext(b, fl, Ceil, {op(b, spv::Op::OpFAdd, fl, {d, constantF32(0.5f)})}),
                                                  constantF32(1.0f)});
    uint32_t l0f = op(b, spv::Op::OpSelect, fl, {mipLinear, dFloor, nearest});
    l0f = op(b, spv::Op::OpSelect, fl, {mag, constantF32(0.0f), l0f});
    l0f = ext(b, fl, FClamp, {l0f, constantF32(0.0f), lastLevel});
    uint32_t fraction = op(b, spv::Op::OpFOrdGreaterThan, bo, {op(b, spv::Op::OpFSub, fl, {d, dFloor}), constantF32(0.0f)});
    uint32_t below = op(b, spv::Op::OpFOrdLessThanEqual, bo, {op(b, spv::Op::OpFAdd, fl, {l0f, constantF32(1.0f)}), lastLevel});
    uint32_t second = op(b, spv::Op::OpLogicalAnd, bo, {op(b, spv::Op::OpLogicalNot, bo, {mag}), mipLinear});
    second = op(b, spv::Op::OpLogicalAnd, bo, {second, op(b, spv::Op::OpLogicalAnd, bo, {fraction, below})});
    uint32_t base = tableWord(b, entry, footprint::kBaseLevel);
    uint32_t level0 = op(b, spv::Op::OpIAdd, u, {base, op(b, spv::Op::OpConvertFToU, u, {l0f})});
    uint32_t lastLayer = op(b, spv::Op::OpBitcast, i, {op(b, spv::Op::OpISub, u, {tableWord(b, entry, footprint::kLayers),
                                                                               constantU32(1)})});
    uint32_t layer = ext(b, i, SClamp, {op(b, spv::Op::OpConvertFToS, i, {ext(b, fl, RoundEven, {f->params[3]})}),
                                        constantI32(0), lastLayer});
    uint32_t levelFn = fpSampleLevelFn();
    fnCall(b, levelFn, {entry, level0, f->params[1], f->params[2], layer, linear, f->params[7], f->params[8]});
    when(b, second, [&](Body& bb) {
      uint32_t level1 = op(bb, spv::Op::OpIAdd, u, {level0, constantU32(1)});
      fnCall(bb, levelFn, {entry, level1, f->params[1], f->params[2], layer, linear, f->params[7], f->params[8]});
    });
    fpSample_ = endFunction(std::move(f), "tally_fp_sample");
    return fpSample_;
  }

  // A u32 (or i32 with `asSigned`) from an integer value of any width and signedness.
  uint32_t intAs(Body& b, uint32_t value, bool asSigned) {
    uint32_t want = asSigned ? tI32() : tU32();
    const Instruction* t = defs_.def(types_.typeOf(value));
    if (t == nullptr) {  // created here: a u32 or i32
      return value;
    }
    if (t->opcode() != spv::Op::OpTypeInt) return value;
    if (t->word(2) != 32) {
      value = op(b, t->word(3) == 1 ? spv::Op::OpSConvert : spv::Op::OpUConvert, t->word(3) == 1 ? tI32() : tU32(), {value});
      return (t->word(3) == 1) == asSigned ? value : op(b, spv::Op::OpBitcast, want, {value});
    }
    return (t->word(3) == 1) == asSigned ? value : op(b, spv::Op::OpBitcast, want, {value});
  }

  // Component k of a scalar or vector value (the scalar itself for k = 0).
  uint32_t component(Body& b, uint32_t value, uint32_t k, uint32_t scalarType) {
    const Instruction* t = defs_.def(types_.typeOf(value));
    if (t != nullptr && t->opcode() == spv::Op::OpTypeVector) {
      return op(b, spv::Op::OpCompositeExtract, t->word(2), {value, k});
    }
    (void)scalarType;
    return value;
  }
  uint32_t componentCount(uint32_t value) {
    const Instruction* t = defs_.def(types_.typeOf(value));
    return t != nullptr && t->opcode() == spv::Op::OpTypeVector ? t->word(3) : 1;
  }

  // The byte offset of a buffer pointer from the start of its descriptor's
  // buffer (the element of a descriptor array), as straight-line code; 0
  // with `why` set where the chain cannot be followed.
  uint32_t byteOffset(Body& b, uint32_t pointer, int function, std::string& why) {
    std::vector<const Instruction*> chain;
    uint32_t variable = 0;
    for (int depth = 0; depth < 64 && variable == 0; ++depth) {
      const Instruction* d = defs_.def(pointer);
      if (d == nullptr) break;
      switch (d->opcode()) {
        case spv::Op::OpVariable: variable = pointer; break;
        case spv::Op::OpAccessChain:
        case spv::Op::OpInBoundsAccessChain:
          if (defs_.functionOf(pointer) != function) {
            why = "buffer accesses through pointers made in another function";
            return 0;
          }
          chain.push_back(d);
          pointer = d->word(3);
          break;
        case spv::Op::OpCopyObject: pointer = d->word(3); break;
        default:
          why = std::string("buffer accesses through ") +
                (d->opcode() == spv::Op::OpFunctionParameter ? "function parameters" : "pointer arithmetic");
          return 0;
      }
    }
    if (variable == 0) {
      why = "buffer accesses whose pointer has no variable";
      return 0;
    }
    std::reverse(chain.begin(), chain.end());
    uint32_t u = tU32();
    uint32_t type = types_.pointee(defs_.def(variable)->resultType());
    bool descriptorArray = false;
    if (const Instruction* t = defs_.def(type); t && (t->opcode() == spv::Op::OpTypeArray || t->opcode() == spv::Op::OpTypeRuntimeArray)) {
      descriptorArray = !defs_.decorationValue(type, spv::Decoration::ArrayStride).has_value();
    }
    uint64_t constantPart = 0;
    uint32_t dynamicPart = 0;
    std::optional<uint32_t> matrixStride;
    bool rowMajor = false;
    auto addDynamic = [&](uint32_t index, uint32_t stride) {
      uint32_t term = op(b, spv::Op::OpIMul, u, {intAs(b, index, false), constantU32(stride)});
      dynamicPart = dynamicPart == 0 ? term : op(b, spv::Op::OpIAdd, u, {dynamicPart, term});
    };
    bool first = true;
    for (const Instruction* ac : chain) {
      for (size_t w = 4; w < ac->size(); ++w) {
        uint32_t index = ac->word(w);
        const Instruction* t = defs_.def(type);
        if (t == nullptr) {
          why = "buffer accesses into an unknown type";
          return 0;
        }
        auto constIndex = types_.constantValue(index);
        if (first && descriptorArray) {  // the descriptor, not a byte offset
          type = t->word(2);
          first = false;
          continue;
        }
        first = false;
        switch (t->opcode()) {
          case spv::Op::OpTypeStruct: {
            if (!constIndex) {
              why = "buffer accesses with a run-time struct member";
              return 0;
            }
            uint32_t m = static_cast<uint32_t>(*constIndex);
            constantPart += defs_.memberDecorationValue(type, m, spv::Decoration::Offset).value_or(0);
            matrixStride = defs_.memberDecorationValue(type, m, spv::Decoration::MatrixStride);
            rowMajor = false;
            for (const auto& dec : defs_.memberDecorations(type, m)) {
              if (dec.kind == spv::Decoration::RowMajor) rowMajor = true;
            }
            type = t->word(2 + m);
            break;
          }
          case spv::Op::OpTypeArray:
          case spv::Op::OpTypeRuntimeArray: {
            auto stride = defs_.decorationValue(type, spv::Decoration::ArrayStride);
            if (!stride) {
              why = "buffer accesses into arrays without an ArrayStride";
              return 0;
            }
            if (constIndex) constantPart += *constIndex * *stride; else addDynamic(index, *stride);
            type = t->word(2);
            break;
          }
          case spv::Op::OpTypeMatrix: {
            if (!matrixStride || rowMajor) {
              why = "buffer accesses to columns of row-major matrices";
              return 0;
            }
            if (constIndex) constantPart += *constIndex * *matrixStride; else addDynamic(index, *matrixStride);
            type = t->word(2);
            break;
          }
          case spv::Op::OpTypeVector: {
            uint32_t bytes = types_.byteSize(t->word(2));
            if (constIndex) constantPart += *constIndex * bytes; else addDynamic(index, bytes);
            type = t->word(2);
            break;
          }
          default:
            why = "buffer accesses into an unknown type";
            return 0;
        }
      }
    }
    uint32_t offset = constantU32(static_cast<uint32_t>(constantPart));
    return dynamicPart == 0 ? offset : op(b, spv::Op::OpIAdd, u, {dynamicPart, offset});
  }

  // The pixel of a fragment invocation: floor(FragCoord.xy) as i32.
  std::pair<uint32_t, uint32_t> fragmentPixel(Body& b, Stage stage) {
    uint32_t v4 = tVec(tF32(), 4), i = tI32();
    uint32_t coord = op(b, spv::Op::OpLoad, v4, {builtin(stage, spv::BuiltIn::FragCoord, v4)});
    uint32_t x = op(b, spv::Op::OpConvertFToS, i, {ext(b, tF32(), Floor, {op(b, spv::Op::OpCompositeExtract, tF32(), {coord, 0})})});
    uint32_t y = op(b, spv::Op::OpConvertFToS, i, {ext(b, tF32(), Floor, {op(b, spv::Op::OpCompositeExtract, tF32(), {coord, 1})})});
    return {x, y};
  }

  // The image operands of an image instruction from word `at`: operand ids by mask bit.
  static std::map<uint32_t, std::vector<uint32_t>> imageOperands(const Instruction& inst, size_t at) {
    std::map<uint32_t, std::vector<uint32_t>> out;
    if (inst.size() <= at) return out;
    uint32_t mask = inst.word(at);
    size_t w = at + 1;
    for (uint32_t bit = 0; bit < 32; ++bit) {
      uint32_t m = 1u << bit;
      if ((mask & m) == 0) continue;
      uint32_t n = 0;
      switch (m) {
        case 0x1: case 0x2: case 0x8: case 0x10: case 0x20: case 0x40: case 0x80: case 0x100: case 0x200:
        case 0x10000: n = 1; break;
        case 0x4: n = 2; break;
        default: n = 0; break;
      }
      std::vector<uint32_t> ids;
      for (uint32_t k = 0; k < n; ++k) ids.push_back(inst.word(w++));
      out.emplace(m, std::move(ids));
    }
    return out;
  }

  // Integer texel coordinates (x, y, layer) of a 1D or 2D image access.
  struct TexelCoords {
    uint32_t x, y, layer;
  };
  TexelCoords texelCoords(Body& b, uint32_t coord, uint32_t dim, bool arrayed) {
    uint32_t i = tI32();
    auto c = [&](uint32_t k) { return intAs(b, component(b, coord, k, i), true); };
    bool twoD = dim != uint32_t(spv::Dim::Dim1D);
    uint32_t x = c(0);
    uint32_t y = twoD ? c(1) : constantI32(0);
    uint32_t layer = arrayed ? c(twoD ? 2 : 1) : constantI32(0);
    return {x, y, layer};
  }

  // Emits the marking of one site; false (with `why`) where the model does
  // not cover the access.
  bool emitFootprint(Body& b, const FoundSite& s, uint32_t entry, Stage stage, std::string& why) {
    const Site& site = s.site;
    uint32_t u = tU32(), i = tI32(), fl = tF32();
    if (site.kind == SiteKind::OutputWrite) {
      auto [x, y] = fragmentPixel(b, stage);
      fnCall(b, fpTexelFn(), {entry, x, y, constantI32(0), constantU32(0)});
      return true;
    }
    if ((site.kind == SiteKind::BufferRead || site.kind == SiteKind::BufferWrite) && site.location) {
      if (stage != Stage::Vertex || site.elementBytes == 0) {
        why = "vertex inputs of unknown size";
        return false;
      }
      uint32_t vertex = loadIntAsU32(b, builtin(stage, spv::BuiltIn::VertexIndex, tI32(), true));
      fnCall(b, fpBytesFn(site.elementBytes <= 2 * options_.footprintBlockBytes + 1), {entry, vertex, constantU32(site.elementBytes)});
      return true;
    }
    const Instruction& inst = m_.functions[s.function].insts[s.instruction];
    spv::Op o = inst.opcode();
    if (site.kind == SiteKind::BufferRead || site.kind == SiteKind::BufferWrite) {
      if (site.elementBytes == 0) {
        why = "buffer accesses of unknown size";
        return false;
      }
      uint32_t pointer = 0;
      if (o == spv::Op::OpLoad) pointer = inst.word(3);
      else if (o == spv::Op::OpStore || o == spv::Op::OpAtomicStore) pointer = inst.word(1);
      else if (o == spv::Op::OpCopyMemory || o == spv::Op::OpCopyMemorySized)
        pointer = site.kind == SiteKind::BufferRead ? inst.word(2) : inst.word(1);
      else pointer = inst.word(3);  // the other atomics
      uint32_t offset = byteOffset(b, pointer, s.function, why);
      if (offset == 0) return false;
      fnCall(b, fpBytesFn(site.elementBytes <= 2 * options_.footprintBlockBytes + 1), {entry, offset, constantU32(site.elementBytes)});
      return true;
    }
    // Images: the OpTypeImage behind the accessed image.
    uint32_t imageValue = 0, coord = 0;
    size_t operandsAt = 0;
    if (site.kind == SiteKind::ImageAtomic) {
      const Instruction* tp = defs_.def(inst.word(3));
      while (tp != nullptr && tp->opcode() == spv::Op::OpCopyObject) tp = defs_.def(tp->word(3));
      if (tp == nullptr || tp->opcode() != spv::Op::OpImageTexelPointer) {
        why = "image atomics through an unknown pointer";
        return false;
      }
      const Instruction* imageType = defs_.def(types_.imageType(types_.pointee(types_.typeOf(tp->word(3)))));
      if (!texelImage(imageType, why)) return false;
      TexelCoords c = texelCoords(b, tp->word(4), imageType->word(3), imageType->word(5) != 0);
      fnCall(b, fpTexelFn(), {entry, c.x, c.y, c.layer, constantU32(0)});
      return true;
    }
    if (site.kind == SiteKind::AttachmentRead) {
      auto [x, y] = fragmentPixel(b, stage);
      uint32_t ox = intAs(b, component(b, inst.word(4), 0, i), true);
      uint32_t oy = intAs(b, component(b, inst.word(4), 1, i), true);
      fnCall(b, fpTexelFn(), {entry, op(b, spv::Op::OpIAdd, i, {x, ox}), op(b, spv::Op::OpIAdd, i, {y, oy}),
                              constantI32(0), constantU32(0)});
      return true;
    }
    imageValue = o == spv::Op::OpImageWrite ? inst.word(1) : inst.word(3);
    coord = o == spv::Op::OpImageWrite ? inst.word(2) : inst.word(4);
    const Instruction* imageType = defs_.def(types_.imageType(types_.typeOf(imageValue)));
    if (!texelImage(imageType, why)) return false;
    const uint32_t dim = imageType->word(3);
    const bool arrayed = imageType->word(5) != 0;
    const bool fetch = o == spv::Op::OpImageFetch || o == spv::Op::OpImageSparseFetch;
    if (o == spv::Op::OpImageWrite || o == spv::Op::OpImageRead || o == spv::Op::OpImageSparseRead || fetch) {
      TexelCoords c = texelCoords(b, coord, dim, arrayed);
      uint32_t lod = constantU32(0);
      if (fetch) {
        auto ops = imageOperands(inst, 5);
        if (auto l = ops.find(0x2); l != ops.end()) lod = intAs(b, l->second[0], false);
        for (uint32_t bit : {0x8u, 0x10u}) {
          if (auto off = ops.find(bit); off != ops.end()) {
            c.x = op(b, spv::Op::OpIAdd, i, {c.x, intAs(b, component(b, off->second[0], 0, i), true)});
            if (dim != uint32_t(spv::Dim::Dim1D)) {
              c.y = op(b, spv::Op::OpIAdd, i, {c.y, intAs(b, component(b, off->second[0], 1, i), true)});
            }
          }
        }
      }
      fnCall(b, fpTexelFn(), {entry, c.x, c.y, c.layer, lod});
      return true;
    }
    // Filtered reads.
    const std::string& name = site.opcode;
    const bool dref = name.find("Dref") != std::string::npos;
    const bool proj = name.find("Proj") != std::string::npos;
    const bool gather = name.find("Gather") != std::string::npos;
    const bool implicit = name.find("ImplicitLod") != std::string::npos;
    operandsAt = (dref || gather) ? 6 : 5;
    auto ops = imageOperands(inst, operandsAt);
    if (ops.count(0x20) || ops.count(0x10000)) {
      why = "gathers with per-texel offsets";
      return false;
    }
    const bool twoD = dim != uint32_t(spv::Dim::Dim1D);
    uint32_t uc = component(b, coord, 0, fl);
    uint32_t vc = twoD ? component(b, coord, 1, fl) : constantF32(0.5f);
    uint32_t layer = arrayed ? component(b, coord, twoD ? 2 : 1, fl) : constantF32(0.0f);
    if (proj) {
      uint32_t q = component(b, coord, componentCount(coord) - 1, fl);
      uc = op(b, spv::Op::OpFDiv, fl, {uc, q});
      if (twoD) vc = op(b, spv::Op::OpFDiv, fl, {vc, q});
    }
    uint32_t lodKind = uint32_t(Lod::Explicit), a = constantF32(0.0f), lambda = constantF32(0.0f);
    if (gather) {
      lodKind = uint32_t(Lod::Gather);
    } else if (auto l = ops.find(0x2); l != ops.end()) {
      a = l->second[0];
    } else if (auto g = ops.find(0x4); g != ops.end()) {
      // lambda = log2(max(|dPdx * size|, |dPdy * size|)) at the view's first level.
      uint32_t base = tableWord(b, entry, footprint::kBaseLevel);
      auto size = [&](uint32_t word) {
        uint32_t n = ext(b, u, UMax, {op(b, spv::Op::OpShiftRightLogical, u, {tableWord(b, entry, word), base}), constantU32(1)});
        return op(b, spv::Op::OpConvertUToF, fl, {n});
      };
      uint32_t w = size(footprint::kWidth), h = size(footprint::kHeight);
      auto rho = [&](uint32_t d) {
        uint32_t dx = op(b, spv::Op::OpFMul, fl, {component(b, d, 0, fl), w});
        if (!twoD) return ext(b, fl, Length, {dx});
        uint32_t dy = op(b, spv::Op::OpFMul, fl, {component(b, d, 1, fl), h});
        return ext(b, fl, Length, {op(b, spv::Op::OpCompositeConstruct, tF32v(2), {dx, dy})});
      };
      a = ext(b, fl, Log2, {ext(b, fl, FMax, {rho(g->second[0]), rho(g->second[1])})});
    } else if (implicit && stage == Stage::Fragment) {
      addCapability(spv::Capability::ImageQuery);
      uint32_t queryCoord = twoD ? op(b, spv::Op::OpCompositeConstruct, tF32v(2), {uc, vc}) : uc;
      uint32_t q = op(b, spv::Op::OpImageQueryLod, tF32v(2), {inst.word(3), queryCoord});
      a = op(b, spv::Op::OpCompositeExtract, fl, {q, 0});
      lambda = op(b, spv::Op::OpCompositeExtract, fl, {q, 1});
      lodKind = uint32_t(Lod::Queried);
      if (auto bias = ops.find(0x1); bias != ops.end()) {
        // The shader's bias moves lambda; the level follows it, clamped by the sampler helper.
        a = op(b, spv::Op::OpFAdd, fl, {lambda, bias->second[0]});
        lodKind = uint32_t(Lod::Explicit);
      }
    }
    uint32_t ox = constantI32(0), oy = constantI32(0);
    for (uint32_t bit : {0x8u, 0x10u}) {
      if (auto off = ops.find(bit); off != ops.end()) {
        ox = intAs(b, component(b, off->second[0], 0, i), true);
        if (twoD) oy = intAs(b, component(b, off->second[0], 1, i), true);
      }
    }
    fnCall(b, fpSampleFn(), {entry, uc, vc, layer, constantU32(lodKind), a, lambda, ox, oy});
    return true;
  }

  // 1D and 2D images (arrayed or not, any sample count); others are not modelled.
  bool texelImage(const Instruction* imageType, std::string& why) {
    if (imageType == nullptr) {
      why = "accesses to images of unknown type";
      return false;
    }
    auto dim = static_cast<spv::Dim>(imageType->word(3));
    if (dim == spv::Dim::Dim1D || dim == spv::Dim::Dim2D) return true;
    static const std::map<spv::Dim, const char*> names = {{spv::Dim::Dim3D, "3D"}, {spv::Dim::Cube, "cube"},
                                                          {spv::Dim::Rect, "rect"}, {spv::Dim::Buffer, "texel buffer"},
                                                          {spv::Dim::SubpassData, "subpass"}};
    auto it = names.find(dim);
    why = std::string("accesses to ") + (it != names.end() ? it->second : "other") + " images";
    return false;
  }

  // Emits the site's marking where its count goes; result_.sites[index].footprint says whether it did.
  void footprintSite(size_t index, const FoundSite& s, const EntryPoint& ep, uint32_t slotBase,
                     std::vector<std::map<size_t, std::vector<Instruction>>>& after,
                     std::vector<std::map<size_t, std::vector<Instruction>>>& before) {
    if (s.site.kind == SiteKind::Invocation) return;
    if (s.site.set < 0 && !s.site.location && s.site.kind != SiteKind::OutputWrite) {
      noteOnce("footprint: " + std::string(toString(s.site.kind)) + " of " + s.site.resource + " not measured");
      return;
    }
    const auto& insts = m_.functions[s.function].insts;
    std::string why;
    auto emitInto = [&](std::vector<Instruction>& list) {
      std::vector<Instruction> code;
      Body b{code};
      uint32_t slot = slotValue(s, slotBase, code);
      uint32_t entry = op(b, spv::Op::OpIMul, tU32(), {slot, constantU32(footprint::kEntryWords)});
      if (!emitFootprint(b, s, entry, ep.stage, why)) return false;
      list.insert(list.end(), code.begin(), code.end());
      return true;
    };
    bool done = false;
    switch (s.placement) {
      case Placement::AfterInstruction: done = emitInto(after[s.function][s.instruction]); break;
      case Placement::EntryStart: done = emitInto(before[s.function][entryStart(insts)]); break;
      case Placement::BeforeReturns:
        done = true;
        for (size_t at = 0; at < insts.size() && done; ++at) {
          if (insts[at].opcode() == spv::Op::OpReturn) done = emitInto(before[s.function][at]);
        }
        break;
    }
    if (done) {
      result_.sites[index].footprint = true;
    } else {
      noteOnce("footprint: " + why + " not measured");
    }
  }

  Instruction call(uint32_t helper, uint32_t slot) {
    return Instruction(spv::Op::OpFunctionCall, {tVoid(), m_.newId(), helper, slot});
  }

  // The slot argument: a constant, or base + min(index, length - 1) for a
  // run-time descriptor index (emitted into `list`, before the call).
  uint32_t slotValue(const FoundSite& s, uint32_t base, std::vector<Instruction>& list) {
    if (s.dynamicIndex == 0) return constantU32(base);
    Body b{list};
    uint32_t length = s.arrayLength != 0 ? s.arrayLength : kRuntimeArraySlots;
    return op(b, spv::Op::OpIAdd, tU32(), {constantU32(base), clampedIndex(b, s, length)});
  }

  Module& m_;
  const DefIndex& defs_;
  const Types& types_;
  const InstrumentOptions& options_;
  Instrumented& result_;
  std::vector<std::string>& notes_;
  bool vulkanMemoryModel_ = false;
  bool demotes_ = false;  // the module uses OpDemoteToHelperInvocation
  spv::StorageClass storageClass_ = spv::StorageClass::StorageBuffer;
  uint32_t counters_ = 0;
  uint32_t elementPtr_ = 0;
  std::map<std::vector<uint32_t>, uint32_t> types_by_key_;
  std::map<std::vector<uint32_t>, uint32_t> constants_;
  std::vector<uint32_t> variables_;
  std::vector<std::pair<uint32_t, uint32_t>> createdBuiltins_;
  std::map<Stage, std::set<uint32_t>> stageBuiltins_;
  std::map<std::pair<Helper, Stage>, uint32_t> helpers_;
  // accumulate mode
  struct FlushSlots {
    std::set<uint32_t> scalars;
    std::set<std::pair<uint32_t, uint32_t>> arrays;  // (first slot, length)
  };
  std::map<Stage, FlushSlots> flushSlots_;
  std::map<uint32_t, uint32_t> scalarAcc_;  // slot -> Private u32
  std::vector<std::pair<uint32_t, ArrayAccumulator>> arrayAcc_;
  std::vector<uint32_t> accumulators_;      // every Private variable added
  std::map<Stage, uint32_t> flushFunctions_;
  std::map<uint32_t, std::vector<bool>> runsOnce_;  // entry index -> functions that run once
  std::map<int, std::vector<bool>> cycles_;         // function -> instructions on a cycle
  std::map<Stage, uint32_t> perAccessOnce_;         // sites counted per access because they run once
  std::vector<Instruction> newGlobals_, newAnnotations_, newNames_;
  std::vector<Function> newFunctions_;
  // footprint
  uint32_t glsl_ = 0;  // the GLSL.std.450 import
  uint32_t fpTable_ = 0, fpBitmap_ = 0, fpWordPtr_ = 0;
  uint32_t fpMark_ = 0, fpBytes_ = 0, fpBytesShort_ = 0, fpTexelLevel_ = 0, fpTexel_ = 0, fpSampleLevel_ = 0, fpSample_ = 0;
};

}  // namespace

std::string injectCounters(Module& module, const DefIndex& defs, const Types& types, const SiteScan& scan,
                           const std::vector<uint32_t>& slots, const InstrumentOptions& options,
                           Instrumented& result) {
  return Injector(module, defs, types, options, result).run(scan, slots);
}

}  // namespace tally::spirv
