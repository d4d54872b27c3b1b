// Executed arithmetic, counted beside accumulate's registers.

#include "spirv/injector.hpp"

#include <algorithm>

#include "spirv/arith.hpp"
#include "spirv/cfg.hpp"

namespace tally::spirv {

// Executed arithmetic: at the top of every block of every function an
// accumulating entry point reaches, the block's operations (arith.hpp)
// added to one register, flushed by each stage into the arithmetic slot.
// Blocks that run exactly once in every invocation (as sites are derived:
// accumulate.cpp) add nothing in the shader: where the module has one
// accumulating entry point with an invocation counter, their operations are
// derived from it (Instrumented::derived, times = their sum). Blocks of a
// loop whose class of blocks has a trip counter (accumulate_loops.cpp) are
// derived from that counter the same way; only the other blocks of branches
// and loops keep a register add.
void Injector::countExecutedArithmetic(const SiteScan& scan, std::vector<std::map<size_t, std::vector<Instruction>>>& before) {
  const uint32_t slot = static_cast<uint32_t>(result_.arithmeticSlot);
  const auto weights = arithmeticPerInstruction(m_);
  std::map<uint32_t, int> byId;
  for (size_t f = 0; f < m_.functions.size(); ++f) byId[m_.functions[f].id()] = static_cast<int>(f);
  std::set<int> reached;
  std::vector<uint32_t> accumulating;  // entry indices
  for (uint32_t e = 0; e < scan.entryPoints.size(); ++e) {
    if (accumulates(scan.entryPoints[e].stage)) accumulating.push_back(e);
  }
  const bool derive = accumulating.size() == 1 && invocationSlot_.count(accumulating.front()) != 0;
  uint64_t derivedOps = 0;
  for (const auto& ep : scan.entryPoints) {
    if (!accumulates(ep.stage)) continue;
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
  // The register, and each stage's flush of it, only where a block adds to it.
  uint32_t acc = 0;
  auto accumulator = [&] {
    if (acc != 0) return acc;
    for (uint32_t e : accumulating) flushSlots_[scan.entryPoints[e].stage].scalars.insert(slot);
    acc = scalarAccumulator(slot);
    return acc;
  };
  // The trip counter a block's class has, where one entry point accumulates.
  std::map<uint32_t, uint64_t> fromTrips;  // trip slot -> operations derived from it
  size_t tripBlocks = 0;
  auto tripOf = [&](int f, size_t label) -> std::optional<uint32_t> {
    if (accumulating.size() != 1) return std::nullopt;
    const FunctionLoops& fl = loopsOf(f);
    const int block = fl.blockAt[label];
    for (size_t l = 0; l < fl.loops.size() && block >= 0; ++l) {
      const int cls = fl.loops[l].classOf[block];
      if (cls < 0) continue;
      auto trip = tripSlots_.find({accumulating.front(), f, l, cls});
      if (trip != tripSlots_.end()) return trip->second;
    }
    return std::nullopt;
  };
  for (int f : reached) {
    const auto& insts = m_.functions[f].insts;
    for (size_t at = 0; at < insts.size(); ++at) {
      if (insts[at].opcode() != spv::Op::OpLabel) continue;
      uint64_t ops = 0;
      size_t end = at + 1;
      for (; end < insts.size() && insts[end].opcode() != spv::Op::OpLabel; ++end) ops += weights[f][end];
      if (ops == 0) continue;
      if (derive) {
        FoundSite block;  // a probe at the block's label: where a site there would run
        block.function = f;
        block.instruction = at;
        block.entryIndex = accumulating.front();
        if (runsExactlyOnce(block, scan.entryPoints[block.entryIndex])) {
          derivedOps += ops;
          continue;
        }
      }
      if (auto trip = tripOf(f, at)) {
        fromTrips[*trip] += ops;
        ++tripBlocks;
        continue;
      }
      size_t into = at + 1;
      while (into < end && (insts[into].opcode() == spv::Op::OpPhi || insts[into].opcode() == spv::Op::OpVariable ||
                            insts[into].opcode() == spv::Op::OpLine || insts[into].opcode() == spv::Op::OpNoLine)) {
        ++into;
      }
      Body b{addsInto(before[f][into])};
      uint32_t v = op(b, spv::Op::OpLoad, tU32(), {accumulator()});
      uint32_t w = op(b, spv::Op::OpIAdd, tU32(), {v, constantU32(static_cast<uint32_t>(std::min<uint64_t>(ops, 0xffffffffu)))});
      opNoResult(b, spv::Op::OpStore, {acc, w});
    }
  }
  for (auto [trip, ops] : fromTrips) {
    result_.derived.push_back({trip, slot, static_cast<uint32_t>(std::min<uint64_t>(ops, 0xffffffffu))});
  }
  if (tripBlocks > 0) {
    notes_.push_back("accumulate mode: executed arithmetic of " + std::to_string(tripBlocks) + " block" +
                     (tripBlocks == 1 ? "" : "s") + " in loops derived from their trip counters");
  }
  if (derivedOps > 0) {
    result_.derived.push_back({invocationSlot_.at(accumulating.front()), slot,
                               static_cast<uint32_t>(std::min<uint64_t>(derivedOps, 0xffffffffu))});
  }
}

}  // namespace tally::spirv
