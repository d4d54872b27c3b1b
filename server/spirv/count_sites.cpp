// Per-site counting: the counter buffer and the tally_count_* helper each
// site calls with its slot, in exact, subgroup and sampled modes.

#include "spirv/injector.hpp"

namespace tally::spirv {

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

Helper Injector::helperFor(Stage stage) {
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

// The counter buffer: struct { uint64_t c[]; } (or uint32 pairs), 8 bytes a slot.
void Injector::declareCounters() {
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

// counters[slot] += amount (a u32 value). Leaves the current block open.
void Injector::emitAdd(Body& b, uint32_t slot, uint32_t amount) {
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
uint32_t Injector::hash(Body& b, uint32_t x, uint32_t y) {
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
uint32_t Injector::tileSelect2D(Body& b, uint32_t x, uint32_t y, uint32_t z) {
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

uint32_t Injector::sampledSelect(Body& b, Helper h, Stage stage) {
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
uint32_t Injector::skipHelperLanes(Body& b, Stage stage) {
  uint32_t var = builtin(stage, spv::BuiltIn::HelperInvocation, tBool());
  std::vector<uint32_t> load = {var};
  if (vulkanMemoryModel_ && demotes_) load.push_back(1);  // Volatile access
  uint32_t isHelper = op(b, spv::Op::OpLoad, tBool(), load);
  uint32_t body = m_.newId(), end = m_.newId();
  selection(b, isHelper, end, body, end);
  label(b, body);
  return end;
}

uint32_t Injector::helperFunction(Helper h, Stage stage) {
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
      waterfall(
          b, slot, [&](Body& bb) { return op(bb, spv::Op::OpGroupNonUniformIAdd, tU32(), {scope, kGroupReduce, one}); },
          [&](Body& bb, uint32_t first, uint32_t count) { emitAdd(bb, first, count); });
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

// min(index, length - 1) of a run-time descriptor index, as a u32.
uint32_t Injector::clampedIndex(Body& b, const FoundSite& s, uint32_t length) {
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

// The slot argument: a constant, or base + min(index, length - 1) for a
// run-time descriptor index (emitted into `list`, before the call).
uint32_t Injector::slotValue(const FoundSite& s, uint32_t base, std::vector<Instruction>& list) {
  if (!dynamicSlot(s)) return constantU32(base);
  Body b{list};
  return op(b, spv::Op::OpIAdd, tU32(), {constantU32(base), slotIndex(b, s, dynamicSlots(s))});
}

}  // namespace tally::spirv
