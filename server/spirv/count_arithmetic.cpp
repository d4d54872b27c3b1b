// Executed arithmetic, counted beside accumulate's registers.

#include "spirv/injector.hpp"

#include <algorithm>

#include "spirv/arith.hpp"
#include "spirv/cfg.hpp"

namespace tally::spirv {

// Executed arithmetic: at the top of every block of every function an
// accumulating entry point reaches, the block's operations (arith.hpp)
// added to one register, flushed by each stage into the arithmetic slot.
void Injector::countExecutedArithmetic(const SiteScan& scan, std::vector<std::map<size_t, std::vector<Instruction>>>& before) {
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

}  // namespace tally::spirv
