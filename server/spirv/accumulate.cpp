// Accumulate: a register per slot, one flush per invocation.
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
//
// A site that runs exactly once in every invocation of its entry point
// (on every path to a return, outside loops) costs the shader nothing: where
// the entry point can end only by returning, the reader derives its count
// from the entry point's invocation counter (Instrumented::derived). A
// full-screen pass's texture reads and output writes then share one count.

#include "spirv/injector.hpp"

#include "spirv/cfg.hpp"

namespace tally::spirv {

// Auto: per lane in options_.autoLaneStages, else reduced (docs/measurement.md,
// "Which flush", with the figures that chose it).
bool Injector::subgroupFlush(Stage stage) const {
  if ((options_.subgroupStages & stageBit(stage)) == 0) return false;
  switch (options_.mode.flush) {
    case Flush::Subgroup: return true;
    case Flush::Lane: return false;
    case Flush::Auto: return (options_.autoLaneStages & stageBit(stage)) == 0;
  }
  return false;
}

// A Private u32 (or u32[n]) variable initialised to zero.
uint32_t Injector::privateVariable(uint32_t valueType, uint32_t zero, const std::string& varName) {
  uint32_t id = m_.newId();
  newGlobals_.emplace_back(spv::Op::OpVariable,
                           std::vector<uint32_t>{tPtr(spv::StorageClass::Private, valueType), id,
                                                 static_cast<uint32_t>(spv::StorageClass::Private), zero});
  name(id, varName);
  accumulators_.push_back(id);
  return id;
}

uint32_t Injector::scalarAccumulator(uint32_t slot) {
  if (auto it = scalarAcc_.find(slot); it != scalarAcc_.end()) return it->second;
  uint32_t id = privateVariable(tU32(), constantU32(0), "tally_acc_" + std::to_string(slot));
  scalarAcc_.emplace(slot, id);
  return id;
}

uint32_t Injector::arrayAccumulator(uint32_t base, uint32_t length) {
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
void Injector::increment(Body& b, uint32_t pointer) {
  uint32_t v = op(b, spv::Op::OpLoad, tU32(), {pointer});
  uint32_t w = op(b, spv::Op::OpIAdd, tU32(), {v, constantU32(1)});
  opNoResult(b, spv::Op::OpStore, {pointer, w});
}

// Whether the site runs at most once per invocation of its entry point:
// counted at entry or at the return, or outside every loop of a function
// that runs once.
bool Injector::runsOnce(const FoundSite& s, const EntryPoint& ep) {
  if (s.placement != Placement::AfterInstruction) return true;
  auto [once, fresh] = runsOnce_.try_emplace(s.entryIndex);
  if (fresh) once->second = functionsRunOnce(m_, defs_, ep.functionIndex);
  if (s.function < 0 || size_t(s.function) >= once->second.size() || !once->second[s.function]) return false;
  auto [cycles, first] = cycles_.try_emplace(s.function);
  if (first) cycles->second = instructionsInCycles(m_.functions[s.function], defs_);
  return s.instruction < cycles->second.size() && !cycles->second[s.instruction];
}

bool Injector::runsExactlyOnce(const FoundSite& s, const EntryPoint& ep) {
  if (s.placement != Placement::AfterInstruction) return s.function == ep.functionIndex;
  if (!runsOnce(s, ep)) return false;
  auto [exactly, fresh] = runsExactly_.try_emplace(s.entryIndex);
  if (fresh) exactly->second = functionsRunExactlyOnce(m_, defs_, ep.functionIndex);
  if (s.function < 0 || size_t(s.function) >= exactly->second.size() || !exactly->second[s.function]) return false;
  auto [paths, first] = everyPath_.try_emplace(s.function);
  if (first) paths->second = instructionsOnEveryReturnPath(m_.functions[s.function], defs_);
  return s.instruction < paths->second.size() && paths->second[s.instruction];
}

void Injector::findInvocationSlots(const SiteScan& scan, const std::vector<uint32_t>& slots) {
  if (!options_.deriveOnceSites) return;
  std::map<int, int> entriesOf;  // function -> entry points that start there
  for (const auto& ep : scan.entryPoints) ++entriesOf[ep.functionIndex];
  for (size_t i = 0; i < scan.sites.size(); ++i) {
    const FoundSite& s = scan.sites[i];
    if (s.site.kind != SiteKind::Invocation) continue;
    const EntryPoint& ep = scan.entryPoints[s.entryIndex];
    if (!accumulates(ep.stage) || entriesOf[ep.functionIndex] != 1) continue;
    // An invocation that ends early (a discard, a demote) may have run a
    // site without returning, or returned without running one after it.
    if (endsOtherThanByReturn(m_, ep.functionIndex)) continue;
    invocationSlot_.emplace(s.entryIndex, slots[i]);
  }
}

bool Injector::deriveSite(const FoundSite& s, const EntryPoint& ep, uint32_t slot) {
  if (s.site.kind == SiteKind::Invocation || dynamicSlot(s)) return false;
  auto invocations = invocationSlot_.find(s.entryIndex);
  if (invocations == invocationSlot_.end() || !runsExactlyOnce(s, ep)) return false;
  ++derivedSites_[ep.stage];
  for (DerivedCount& d : result_.derived) {
    if (d.from == invocations->second && d.to == slot) {
      ++d.times;
      return true;
    }
  }
  result_.derived.push_back({invocations->second, slot, 1});
  return true;
}

// Emits the site's increment; false when the site is counted per access instead.
bool Injector::accumulateSite(const FoundSite& s, const EntryPoint& ep, uint32_t slot,
                    std::vector<std::map<size_t, std::vector<Instruction>>>& after,
                    std::vector<std::map<size_t, std::vector<Instruction>>>& before) {
  if (!accumulates(ep.stage)) {
    noteOnce("accumulate mode: " + std::string(toString(ep.stage)) + " stage is counted per access");
    return false;
  }
  if (addressed(s)) {
    noteOnce("accumulate mode: buffer device address accesses (a slot per buffer) are counted per access");
    return false;
  }
  uint32_t length = s.dynamicIndex == 0 ? 1 : (s.arrayLength != 0 ? s.arrayLength : kRuntimeArraySlots);
  if (s.dynamicIndex != 0 && length > kAccumulateArrayMax) {
    if (accumulateCachedArray(s, ep, slot, length, after)) return true;
    noteOnce("accumulate mode: descriptor arrays of more than " + std::to_string(kAccumulateArrayMax) +
             " elements indexed at run time are counted per access in stages without subgroup arithmetic");
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
    Body b{addsInto(list)};
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
void Injector::emitAddWide(Body& b, uint32_t slot, uint32_t lo, uint32_t hi) {
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
void Injector::flushOne(Body& b, Stage stage, uint32_t pointer, uint32_t slot, uint32_t copyOffset) {
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

// copy * copyStride, the copy chosen by workgroup and by subgroup (or by
// lane, where the flush is per lane). Workgroups resident together are
// consecutive in x, so x + 3y + 5z spreads them over the copies.
uint32_t Injector::copyOffsetOf(Body& b, Stage stage) {
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
uint32_t Injector::flushFunction(Stage stage) {
  if (auto it = flushFunctions_.find(stage); it != flushFunctions_.end()) return it->second;
  uint32_t fnType = type(spv::Op::OpTypeFunction, {tVoid()});
  Function fn;
  Body b{fn.insts};
  uint32_t id = m_.newId();
  uint32_t control = (options_.study & kStudyInlineFlush) != 0 ? uint32_t(spv::FunctionControlMask::Inline) : 0;
  b.insts.emplace_back(spv::Op::OpFunction, std::vector<uint32_t>{tVoid(), id, control, fnType});
  label(b, m_.newId());
  // Registers are flushed together (accumulate_rounds.cpp) wherever they
  // reduce across the subgroup; one at a time only for the study of what
  // that flush cost before.
  const uint32_t before = kStudyElectedAdds | kStudySplitReductions;
  const bool together = subgroupFlush(stage) && (options_.study & before) != before;
  const FlushSlots& slots = flushSlots_[stage];
  // Caches share one waterfall where the registers reduce too (on NVIDIA
  // compute; its fragment stage flushes registers per lane and keeps a
  // waterfall per cache, as measured there).
  const bool cachesTogether =
      !slots.cached.empty() && subgroupFlush(stage) && (options_.study & kStudyWaterfallEach) == 0;
  uint32_t counter = 0;
  if ((together && (options_.study & kStudyElectedAdds) == 0) || cachesTogether) {
    counter = functionVariable(b, tU32());
  }
  // Helper lanes stay out of the flush altogether: were one the elected
  // lane, its atomic would have no effect and the subgroup's count would
  // be lost (NVIDIA elects them: found by the analytic suite on an H100).
  uint32_t end = 0;
  if (stage == Stage::Fragment && subgroupFlush(stage)) end = skipHelperLanes(b, stage);
  uint32_t copyOffset = stripes(stage) ? copyOffsetOf(b, stage) : 0;
  std::vector<std::pair<uint32_t, uint32_t>> registers;  // (Private pointer, slot), when flushed together
  auto flush = [&](uint32_t pointer, uint32_t slot) {
    if (together) {
      registers.emplace_back(pointer, slot);
    } else {
      flushOne(b, stage, pointer, slot, copyOffset);
    }
  };
  for (uint32_t slot : slots.scalars) flush(scalarAccumulator(slot), slot);
  for (const auto& [base, length] : slots.arrays) {
    uint32_t array = arrayAccumulator(base, length);
    for (uint32_t i = 0; i < length; ++i) {
      flush(op(b, spv::Op::OpAccessChain, tPtr(spv::StorageClass::Private, tU32()), {array, constantU32(i)}), base + i);
    }
  }
  if (together) flushInRounds(b, registers, copyOffset, counter);
  if (cachesTogether) {
    std::vector<CachedArray> caches;
    for (size_t cache : slots.cached) caches.push_back(cachedArrays_[cache]);
    flushCachesTogether(b, stage, caches, copyOffset, counter);  // helper lanes are out already (above)
  } else if (!slots.cached.empty()) {
    std::vector<CachedArray> caches;
    for (size_t cache : slots.cached) caches.push_back(cachedArrays_[cache]);
    flushCachedArrays(b, stage, caches, copyOffset);
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
void Injector::insertFlushes(const SiteScan& scan, std::vector<std::map<size_t, std::vector<Instruction>>>& before) {
  if ((options_.study & kStudyNoFlush) != 0) return;
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

}  // namespace tally::spirv
