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

BlockGraph blockGraph(const Function& f, const DefIndex& defs) {
  const auto& insts = f.insts;
  std::map<uint32_t, int> blockOf;
  int blocks = 0;
  for (size_t i = 0; i < insts.size(); ++i) {
    if (insts[i].opcode() == spv::Op::OpLabel) blockOf[insts[i].resultId()] = blocks++;
  }
  BlockGraph g;
  g.blockAt.assign(insts.size(), -1);
  g.next.resize(blocks);
  g.returns.assign(blocks, false);
  int current = -1;
  std::vector<uint32_t> labels;
  for (size_t i = 0; i < insts.size(); ++i) {
    if (insts[i].opcode() == spv::Op::OpLabel) current = blockOf[insts[i].resultId()];
    g.blockAt[i] = current;
    if (current < 0) continue;
    if (insts[i].opcode() == spv::Op::OpReturn || insts[i].opcode() == spv::Op::OpReturnValue) g.returns[current] = true;
    labels.clear();
    successors(insts[i], defs, labels);
    for (uint32_t l : labels) {
      if (auto it = blockOf.find(l); it != blockOf.end()) g.next[current].push_back(it->second);
    }
  }
  return g;
}


std::vector<int> immediateDominators(const std::vector<std::vector<int>>& next, int entry) {
  const int n = static_cast<int>(next.size());
  std::vector<int> postorder, order(n, -1);
  std::vector<std::pair<int, size_t>> work = {{entry, 0}};
  std::vector<bool> seen(n, false);
  seen[entry] = true;
  while (!work.empty()) {
    auto& [v, edge] = work.back();
    if (edge < next[v].size()) {
      int w = next[v][edge++];
      if (!seen[w]) {
        seen[w] = true;
        work.push_back({w, 0});
      }
      continue;
    }
    order[v] = static_cast<int>(postorder.size());
    postorder.push_back(v);
    work.pop_back();
  }
  std::vector<std::vector<int>> preds(n);
  for (int b = 0; b < n; ++b) {
    if (!seen[b]) continue;
    for (int w : next[b]) preds[w].push_back(b);
  }
  std::vector<int> idom(n, -1);
  idom[entry] = entry;
  auto intersect = [&](int a, int b) {
    while (a != b) {
      while (order[a] < order[b]) a = idom[a];
      while (order[b] < order[a]) b = idom[b];
    }
    return a;
  };
  for (bool changed = true; changed;) {
    changed = false;
    for (auto it = postorder.rbegin(); it != postorder.rend(); ++it) {
      int v = *it, dom = -1;
      if (v == entry) continue;
      for (int p : preds[v]) {
        if (idom[p] >= 0) dom = dom < 0 ? p : intersect(p, dom);
      }
      if (dom != idom[v]) {
        idom[v] = dom;
        changed = true;
      }
    }
  }
  return idom;
}

std::vector<bool> instructionsInCycles(const Function& f, const DefIndex& defs) {
  const auto& insts = f.insts;
  BlockGraph g = blockGraph(f, defs);
  const int blocks = static_cast<int>(g.next.size());
  const auto& next = g.next;
  const auto& blockAt = g.blockAt;

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

std::vector<bool> instructionsOnEveryReturnPath(const Function& f, const DefIndex& defs) {
  BlockGraph g = blockGraph(f, defs);
  const int blocks = static_cast<int>(g.next.size());
  std::vector<bool> out(f.insts.size(), false);
  if (blocks == 0) return out;
  // Dominators of a virtual exit that every return branches to (Cooper,
  // Harvey and Kennedy's iterative algorithm over reverse postorder): the
  // blocks on its dominator chain are the ones every return path crosses.
  const int exit = blocks;
  std::vector<std::vector<int>> next = g.next;
  next.emplace_back();
  for (int b = 0; b < blocks; ++b) {
    if (g.returns[b]) next[b].push_back(exit);
  }
  std::vector<int> idom = immediateDominators(next, 0);
  if (idom[exit] < 0) return out;
  std::vector<bool> onChain(blocks, false);
  for (int v = idom[exit];; v = idom[v]) {
    onChain[v] = true;
    if (v == 0) break;
  }
  for (size_t i = 0; i < out.size(); ++i) out[i] = g.blockAt[i] >= 0 && onChain[g.blockAt[i]];
  return out;
}

std::vector<bool> functionsRunExactlyOnce(const Module& m, const DefIndex& defs, int entryFunction) {
  std::vector<bool> exactly = functionsRunOnce(m, defs, entryFunction);
  const size_t n = m.functions.size();
  if (entryFunction < 0 || size_t(entryFunction) >= n) return exactly;
  std::map<uint32_t, size_t> byId;
  for (size_t f = 0; f < n; ++f) byId[m.functions[f].id()] = f;
  // Outward from the entry point, as functionsRunOnce: a callee keeps its
  // mark only where its one call lies on every return path of a caller
  // that kept its own.
  std::vector<bool> settled(n, false);
  settled[entryFunction] = true;
  std::vector<size_t> work = {size_t(entryFunction)};
  while (!work.empty()) {
    size_t f = work.back();
    work.pop_back();
    const auto& insts = m.functions[f].insts;
    std::vector<bool> everyPath;
    for (size_t i = 0; i < insts.size(); ++i) {
      if (insts[i].opcode() != spv::Op::OpFunctionCall) continue;
      auto it = byId.find(insts[i].word(3));
      if (it == byId.end() || !exactly[it->second] || settled[it->second]) continue;
      if (everyPath.empty()) everyPath = instructionsOnEveryReturnPath(m.functions[f], defs);
      settled[it->second] = true;
      if (!exactly[f] || !everyPath[i]) {
        exactly[it->second] = false;
      }
      work.push_back(it->second);
    }
  }
  for (size_t f = 0; f < n; ++f) {
    if (!settled[f]) exactly[f] = false;
  }
  return exactly;
}

bool endsOtherThanByReturn(const Module& m, int entryFunction) {
  const size_t n = m.functions.size();
  if (entryFunction < 0 || size_t(entryFunction) >= n) return true;
  std::map<uint32_t, size_t> byId;
  for (size_t f = 0; f < n; ++f) byId[m.functions[f].id()] = f;
  std::vector<bool> reached(n, false);
  std::vector<size_t> work = {size_t(entryFunction)};
  reached[entryFunction] = true;
  while (!work.empty()) {
    size_t f = work.back();
    work.pop_back();
    for (const auto& inst : m.functions[f].insts) {
      switch (inst.opcode()) {
        case spv::Op::OpKill:
        case spv::Op::OpTerminateInvocation:
        case spv::Op::OpDemoteToHelperInvocation:
        case spv::Op::OpEmitMeshTasksEXT:
        case spv::Op::OpTerminateRayKHR:
        case spv::Op::OpIgnoreIntersectionKHR:
        case spv::Op::OpTerminateRayNV:
        case spv::Op::OpIgnoreIntersectionNV: return true;
        case spv::Op::OpFunctionCall:
          if (auto it = byId.find(inst.word(3)); it != byId.end() && !reached[it->second]) {
            reached[it->second] = true;
            work.push_back(it->second);
          }
          break;
        default: break;
      }
    }
  }
  return false;
}

}  // namespace tally::spirv
