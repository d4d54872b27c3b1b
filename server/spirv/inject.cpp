#include "spirv/inject.hpp"

#include "spirv/cfg.hpp"

#include <algorithm>
#include <map>
#include <set>

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

    // Per-function insertions, keyed by instruction index.
    std::vector<std::map<size_t, std::vector<Instruction>>> after(m_.functions.size());
    std::vector<std::map<size_t, std::vector<Instruction>>> before(m_.functions.size());
    for (size_t i = 0; i < scan.sites.size(); ++i) {
      const FoundSite& s = scan.sites[i];
      const EntryPoint& ep = scan.entryPoints[s.entryIndex];
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
};

}  // namespace

std::string injectCounters(Module& module, const DefIndex& defs, const Types& types, const SiteScan& scan,
                           const std::vector<uint32_t>& slots, const InstrumentOptions& options,
                           Instrumented& result) {
  return Injector(module, defs, types, options, result).run(scan, slots);
}

}  // namespace tally::spirv
