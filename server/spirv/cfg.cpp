#include "spirv/cfg.hpp"

#include <algorithm>
#include <map>

namespace tally::spirv {

namespace {

// Successor labels of a block terminator.
void successors(const Instruction& inst, const DefIndex& defs, std::vector<uint32_t>& out) {
  switch (inst.opcode()) {
    case spv::Op::OpBranch: out.push_back(inst.word(1)); break;
    case spv::Op::OpBranchConditional:
      out.push_back(inst.word(2));
      out.push_back(inst.word(3));
      break;
    case spv::Op::OpSwitch: {
      out.push_back(inst.word(2));
      // Case literals are one word for selectors up to 32 bits, two for 64.
      size_t literalWords = 1;
      if (const Instruction* selector = defs.def(inst.word(1))) {
        const Instruction* type = defs.def(selector->resultType());
        if (type != nullptr && type->opcode() == spv::Op::OpTypeInt && type->word(2) == 64) literalWords = 2;
      }
      for (size_t i = 3 + literalWords; i < inst.size(); i += literalWords + 1) out.push_back(inst.word(i));
      break;
    }
    default: break;
  }
}

}  // namespace

std::vector<bool> instructionsInCycles(const Function& f, const DefIndex& defs) {
  const auto& insts = f.insts;
  std::map<uint32_t, int> blockOf;
  std::vector<int> blockAt(insts.size(), -1);
  int blocks = 0;
  for (size_t i = 0; i < insts.size(); ++i) {
    if (insts[i].opcode() == spv::Op::OpLabel) blockOf[insts[i].resultId()] = blocks++;
  }
  std::vector<std::vector<int>> next(blocks);
  int current = -1;
  std::vector<uint32_t> labels;
  for (size_t i = 0; i < insts.size(); ++i) {
    if (insts[i].opcode() == spv::Op::OpLabel) current = blockOf[insts[i].resultId()];
    blockAt[i] = current;
    if (current < 0) continue;
    labels.clear();
    successors(insts[i], defs, labels);
    for (uint32_t l : labels) {
      if (auto it = blockOf.find(l); it != blockOf.end()) next[current].push_back(it->second);
    }
  }

  // Tarjan's strongly connected components, iteratively: a block is on a
  // cycle when its component has more than one block or it branches to itself.
  std::vector<int> index(blocks, -1), low(blocks, 0), component(blocks, -1);
  std::vector<bool> onStack(blocks, false);
  std::vector<int> stack;
  std::vector<std::pair<int, size_t>> work;  // (block, next successor to visit)
  int counter = 0, components = 0;
  for (int root = 0; root < blocks; ++root) {
    if (index[root] >= 0) continue;
    work.push_back({root, 0});
    while (!work.empty()) {
      auto& [v, edge] = work.back();
      if (edge == 0 && index[v] < 0) {
        index[v] = low[v] = counter++;
        stack.push_back(v);
        onStack[v] = true;
      }
      if (edge < next[v].size()) {
        int w = next[v][edge++];
        if (index[w] < 0) {
          work.push_back({w, 0});
        } else if (onStack[w]) {
          low[v] = std::min(low[v], index[w]);
        }
        continue;
      }
      if (low[v] == index[v]) {
        int w;
        do {
          w = stack.back();
          stack.pop_back();
          onStack[w] = false;
          component[w] = components;
        } while (w != v);
        ++components;
      }
      int done = v;
      work.pop_back();
      if (!work.empty()) low[work.back().first] = std::min(low[work.back().first], low[done]);
    }
  }
  std::vector<int> size(components, 0);
  for (int b = 0; b < blocks; ++b) ++size[component[b]];
  std::vector<bool> cyclic(blocks, false);
  for (int b = 0; b < blocks; ++b) {
    cyclic[b] = size[component[b]] > 1 || std::find(next[b].begin(), next[b].end(), b) != next[b].end();
  }
  std::vector<bool> out(insts.size(), false);
  for (size_t i = 0; i < insts.size(); ++i) out[i] = blockAt[i] >= 0 && cyclic[blockAt[i]];
  return out;
}

std::vector<bool> functionsRunOnce(const Module& m, const DefIndex& defs, int entryFunction) {
  const size_t n = m.functions.size();
  std::map<uint32_t, size_t> byId;
  for (size_t f = 0; f < n; ++f) byId[m.functions[f].id()] = f;
  // Every call site in the module: (caller, instruction) per callee.
  std::vector<std::vector<std::pair<size_t, size_t>>> callers(n);
  for (size_t f = 0; f < n; ++f) {
    const auto& insts = m.functions[f].insts;
    for (size_t i = 0; i < insts.size(); ++i) {
      if (insts[i].opcode() != spv::Op::OpFunctionCall) continue;
      if (auto it = byId.find(insts[i].word(3)); it != byId.end()) callers[it->second].push_back({f, i});
    }
  }
  std::vector<bool> once(n, false);
  if (entryFunction < 0 || size_t(entryFunction) >= n) return once;
  once[entryFunction] = true;
  // Outward from the entry point: no recursion in shaders, so each function
  // is settled once its only caller is.
  std::vector<size_t> work = {size_t(entryFunction)};
  std::map<size_t, std::vector<bool>> cycles;
  while (!work.empty()) {
    size_t f = work.back();
    work.pop_back();
    const auto& insts = m.functions[f].insts;
    for (size_t i = 0; i < insts.size(); ++i) {
      if (insts[i].opcode() != spv::Op::OpFunctionCall) continue;
      auto it = byId.find(insts[i].word(3));
      if (it == byId.end() || callers[it->second].size() != 1 || once[it->second]) continue;
      auto [c, fresh] = cycles.try_emplace(f);
      if (fresh) c->second = instructionsInCycles(m.functions[f], defs);
      if (c->second[i]) continue;
      once[it->second] = true;
      work.push_back(it->second);
    }
  }
  return once;
}

}  // namespace tally::spirv
