#include "spirv/loops.hpp"

#include <algorithm>
#include <climits>
#include <functional>
#include <map>
#include <memory>

#include "spirv/cfg.hpp"

namespace tally::spirv {

// What findLoops shares between its steps for one function.
namespace detail {

struct FunctionGraph {
  const Module& m;
  const DefIndex& defs;
  const Function& f;
  BlockGraph g;
  std::vector<size_t> labelAt;           // per block, its OpLabel's index
  std::map<uint32_t, int> blockOfLabel;
  std::vector<int> idom;                 // over the whole function
  std::vector<std::vector<int>> preds;
  std::map<uint32_t, size_t> indexOf;   // result id -> its instruction
};

}  // namespace detail

bool dominates(const std::vector<int>& idom, int a, int b) {
  if (b < 0 || idom[b] < 0) return false;
  for (;; b = idom[b]) {
    if (b == a) return true;
    if (idom[b] == b) return false;
  }
}

namespace {

using detail::FunctionGraph;

// Blocks on a cycle through `header`: reached backwards from the edges into it
// from blocks it dominates, without passing it.
std::vector<bool> naturalLoop(const FunctionGraph& fg, int header) {
  std::vector<bool> in(fg.g.next.size(), false);
  in[header] = true;
  std::vector<int> work;
  for (int p : fg.preds[header]) {
    if (dominates(fg.idom, header, p) && !in[p]) {
      in[p] = true;
      work.push_back(p);
    }
  }
  while (!work.empty()) {
    int b = work.back();
    work.pop_back();
    for (int p : fg.preds[b]) {
      if (!in[p] && dominates(fg.idom, header, p)) {
        in[p] = true;
        work.push_back(p);
      }
    }
  }
  return in;
}

bool isIntCompare(spv::Op o) {
  switch (o) {
    case spv::Op::OpULessThan: case spv::Op::OpSLessThan: case spv::Op::OpULessThanEqual:
    case spv::Op::OpSLessThanEqual: case spv::Op::OpUGreaterThan: case spv::Op::OpSGreaterThan:
    case spv::Op::OpUGreaterThanEqual: case spv::Op::OpSGreaterThanEqual: case spv::Op::OpINotEqual:
    case spv::Op::OpIEqual: return true;
    default: return false;
  }
}

// a OP b as b OP' a.
spv::Op swapped(spv::Op o) {
  switch (o) {
    case spv::Op::OpULessThan: return spv::Op::OpUGreaterThan;
    case spv::Op::OpSLessThan: return spv::Op::OpSGreaterThan;
    case spv::Op::OpULessThanEqual: return spv::Op::OpUGreaterThanEqual;
    case spv::Op::OpSLessThanEqual: return spv::Op::OpSGreaterThanEqual;
    case spv::Op::OpUGreaterThan: return spv::Op::OpULessThan;
    case spv::Op::OpSGreaterThan: return spv::Op::OpSLessThan;
    case spv::Op::OpUGreaterThanEqual: return spv::Op::OpULessThanEqual;
    case spv::Op::OpSGreaterThanEqual: return spv::Op::OpSLessThanEqual;
    default: return o;
  }
}

// !(a OP b) as a OP' b.
spv::Op negated(spv::Op o) {
  switch (o) {
    case spv::Op::OpULessThan: return spv::Op::OpUGreaterThanEqual;
    case spv::Op::OpSLessThan: return spv::Op::OpSGreaterThanEqual;
    case spv::Op::OpULessThanEqual: return spv::Op::OpUGreaterThan;
    case spv::Op::OpSLessThanEqual: return spv::Op::OpSGreaterThan;
    case spv::Op::OpUGreaterThan: return spv::Op::OpULessThanEqual;
    case spv::Op::OpSGreaterThan: return spv::Op::OpSLessThanEqual;
    case spv::Op::OpUGreaterThanEqual: return spv::Op::OpULessThan;
    case spv::Op::OpSGreaterThanEqual: return spv::Op::OpSLessThan;
    case spv::Op::OpINotEqual: return spv::Op::OpIEqual;
    case spv::Op::OpIEqual: return spv::Op::OpINotEqual;
    default: return o;
  }
}

bool is32BitInt(const DefIndex& defs, uint32_t typeId) {
  const Instruction* t = defs.def(typeId);
  return t != nullptr && t->opcode() == spv::Op::OpTypeInt && t->word(2) == 32;
}

// The value of a 32-bit integer OpConstant.
std::optional<int32_t> constantInt(const DefIndex& defs, uint32_t id) {
  const Instruction* c = defs.def(id);
  if (c == nullptr || c->opcode() != spv::Op::OpConstant || !is32BitInt(defs, c->resultType())) return std::nullopt;
  return static_cast<int32_t>(c->word(3));
}

// `value` = induction + step (or step + induction, or induction - step): the step.
std::optional<int32_t> stepOf(const DefIndex& defs, uint32_t value, const std::function<bool(uint32_t)>& isInduction) {
  const Instruction* d = defs.def(value);
  if (d == nullptr || !is32BitInt(defs, d->resultType())) return std::nullopt;
  if (d->opcode() == spv::Op::OpIAdd) {
    if (isInduction(d->word(3))) return constantInt(defs, d->word(4));
    if (isInduction(d->word(4))) return constantInt(defs, d->word(3));
  }
  if (d->opcode() == spv::Op::OpISub && isInduction(d->word(3))) {
    auto c = constantInt(defs, d->word(4));
    if (c && *c != INT32_MIN) return -*c;
  }
  return std::nullopt;
}


// Whether Function variable `v` of `f` is only loaded and stored whole: nothing else can change it.
bool plainVariable(const Function& f, const DefIndex& defs, uint32_t v) {
  const Instruction* d = defs.def(v);
  if (d == nullptr || d->opcode() != spv::Op::OpVariable ||
      static_cast<spv::StorageClass>(d->word(3)) != spv::StorageClass::Function) {
    return false;
  }
  for (const auto& inst : f.insts) {
    if (inst.opcode() == spv::Op::OpVariable && inst.resultId() == v) continue;
    for (size_t w = 1; w < inst.size(); ++w) {
      if (inst.word(w) != v) continue;
      if (inst.opcode() == spv::Op::OpLoad && w == 3) continue;
      if (inst.opcode() == spv::Op::OpStore && w == 1) continue;
      if (inst.opcode() == spv::Op::OpLine || inst.opcode() == spv::Op::OpName) continue;
      return false;
    }
  }
  return true;
}

// The stores to `v` in the loop's blocks: (block, instruction).
std::vector<std::pair<int, size_t>> storesIn(const FunctionGraph& fg, const std::vector<bool>& in, uint32_t v) {
  std::vector<std::pair<int, size_t>> out;
  for (size_t i = 0; i < fg.f.insts.size(); ++i) {
    const int b = fg.g.blockAt[i];
    if (b >= 0 && in[b] && fg.f.insts[i].opcode() == spv::Op::OpStore && fg.f.insts[i].word(1) == v) {
      out.push_back({b, i});
    }
  }
  return out;
}

// Whether pointer parameter `param` is only ever loaded, and every call
// passes it a Function variable of the caller that no other argument of the
// call names: then nothing the function does can change what it points to
// (glslang passes every parameter so, through a copy of its own).
bool unaliasedParameter(const FunctionGraph& fg, uint32_t param) {
  size_t position = 0;
  bool found = false;
  for (const auto& inst : fg.f.insts) {
    if (inst.opcode() == spv::Op::OpFunctionParameter) {
      if (inst.resultId() == param) found = true;
      if (!found) ++position;
      continue;
    }
    for (size_t w = 1; w < inst.size(); ++w) {
      if (inst.word(w) == param && !(inst.opcode() == spv::Op::OpLoad && w == 3) && inst.opcode() != spv::Op::OpLine) {
        return false;
      }
    }
  }
  for (const auto& caller : fg.m.functions) {
    for (const auto& call : caller.insts) {
      if (call.opcode() != spv::Op::OpFunctionCall || call.word(3) != fg.f.id()) continue;
      const uint32_t arg = call.word(4 + position);
      const Instruction* v = fg.defs.def(arg);
      if (v == nullptr || v->opcode() != spv::Op::OpVariable ||
          static_cast<spv::StorageClass>(v->word(3)) != spv::StorageClass::Function) {
        return false;
      }
      for (size_t w = 4; w < call.size(); ++w) {
        if (w != 4 + position && call.word(w) == arg) return false;
      }
    }
  }
  return found;
}

// Whether `id` holds the same value everywhere in the loop and can be had
// at its entry: a constant, a parameter, a value defined before the loop,
// or (returned as `load`) a load, inside the loop, from memory the loop
// cannot change: a plain Function variable it never stores, a push
// constant, a uniform block (through constant indices).
bool invariant(const FunctionGraph& fg, const std::vector<bool>& in, int header, uint32_t id, size_t& load) {
  load = kNever;
  const int fn = fg.defs.functionOf(id);
  const Instruction* d = fg.defs.def(id);
  if (d == nullptr) return false;
  if (fn < 0 || d->opcode() == spv::Op::OpFunctionParameter) return true;
  auto found = fg.indexOf.find(id);
  if (found == fg.indexOf.end()) return false;
  const size_t at = found->second;
  const int b = fg.g.blockAt[at];
  if (b >= 0 && !in[b]) return b != header && dominates(fg.idom, b, header);
  if (d->opcode() != spv::Op::OpLoad) return false;
  uint32_t pointer = d->word(3);
  const Instruction* p = fg.defs.def(pointer);
  if (p == nullptr) return false;
  if (p->opcode() == spv::Op::OpAccessChain || p->opcode() == spv::Op::OpInBoundsAccessChain) {
    for (size_t w = 4; w < p->size(); ++w) {
      if (!constantInt(fg.defs, p->word(w))) return false;
    }
    p = fg.defs.def(p->word(3));
    if (p == nullptr) return false;
  }
  if (p->opcode() == spv::Op::OpFunctionParameter && p->resultId() == pointer) {
    if (!unaliasedParameter(fg, pointer)) return false;
    load = at;
    return true;
  }
  if (p->opcode() != spv::Op::OpVariable) return false;
  const auto sc = static_cast<spv::StorageClass>(p->word(3));
  bool unchanging = sc == spv::StorageClass::PushConstant;
  if (sc == spv::StorageClass::Uniform) {
    // A uniform block's member (not a BufferBlock: that is a storage buffer).
    const Instruction* ptrType = fg.defs.def(p->resultType());
    const Instruction* block = ptrType != nullptr ? fg.defs.def(ptrType->word(3)) : nullptr;
    unchanging = block != nullptr && fg.defs.hasDecoration(block->resultId(), spv::Decoration::Block);
  }
  if (sc == spv::StorageClass::Function) {
    unchanging = p->resultId() == pointer && plainVariable(fg.f, fg.defs, pointer) && storesIn(fg, in, pointer).empty();
  }
  if (!unchanging) return false;
  load = at;
  return true;
}

// The counted loop's shape, where the loop has one: see CountedLoop.
std::optional<CountedLoop> countedLoop(const FunctionGraph& fg, const std::vector<bool>& in, const Loop& loop,
                                       int exitTest, int body) {
  size_t term = kNever;
  for (size_t i = fg.labelAt[exitTest]; i < fg.f.insts.size() && fg.g.blockAt[i] == exitTest; ++i) term = i;
  const Instruction& cond = fg.f.insts[term];
  const Instruction* cmp = fg.defs.def(cond.word(1));
  if (cmp == nullptr || !isIntCompare(cmp->opcode())) return std::nullopt;
  CountedLoop c;
  c.compare = cmp->opcode();
  auto taken = fg.blockOfLabel.find(cond.word(2));
  if (taken == fg.blockOfLabel.end()) return std::nullopt;
  if (taken->second != body) c.compare = negated(c.compare);
  // The induction variable: the header's OpPhi, or a plain variable loaded in the test.
  auto isPhi = [&](uint32_t id) {
    auto at = fg.indexOf.find(id);
    return at != fg.indexOf.end() && fg.f.insts[at->second].opcode() == spv::Op::OpPhi &&
           fg.g.blockAt[at->second] == loop.header;
  };
  auto loadedVariable = [&](uint32_t id) -> uint32_t {
    const Instruction* d = fg.defs.def(id);
    if (d == nullptr || d->opcode() != spv::Op::OpLoad) return 0;
    return plainVariable(fg.f, fg.defs, d->word(3)) ? d->word(3) : 0;
  };
  uint32_t induction = cmp->word(3), bound = cmp->word(4);
  auto inTest = [&](uint32_t id) {
    auto at = fg.indexOf.find(id);
    return at != fg.indexOf.end() && fg.g.blockAt[at->second] >= 0 && in[fg.g.blockAt[at->second]] &&
           dominates(fg.idom, fg.g.blockAt[at->second], exitTest);
  };
  for (int side = 0; side < 2; ++side) {
    if (isPhi(induction) || (loadedVariable(induction) != 0 && inTest(induction))) break;
    std::swap(induction, bound);
    c.compare = swapped(c.compare);
    if (side == 1) return std::nullopt;
  }
  if (c.compare == spv::Op::OpIEqual || !is32BitInt(fg.defs, fg.defs.def(induction)->resultType())) return std::nullopt;
  if (!invariant(fg, in, loop.header, bound, c.boundLoad)) return std::nullopt;
  c.bound = bound;
  if (isPhi(induction)) {
    c.phi = induction;
    const Instruction* phi = fg.defs.def(induction);
    for (size_t w = 3; w + 1 < phi->size(); w += 2) {
      auto it = fg.blockOfLabel.find(phi->word(w + 1));
      if (it == fg.blockOfLabel.end()) return std::nullopt;
      if (!in[it->second]) continue;
      auto step = stepOf(fg.defs, phi->word(w), [&](uint32_t x) { return x == induction; });
      if (!step || (c.step != 0 && *step != c.step)) return std::nullopt;
      c.step = *step;
    }
  } else {
    // One store in the loop, once in every iteration that passes the test:
    // v = load(v) + step, the load in the same block.
    c.variable = loadedVariable(induction);
    auto stores = storesIn(fg, in, c.variable);
    if (stores.size() != 1 || loop.classOf[stores[0].first] != loop.everyIteration) return std::nullopt;
    const uint32_t value = fg.f.insts[stores[0].second].word(2);
    auto step = stepOf(fg.defs, value, [&](uint32_t x) {
      const Instruction* d = fg.defs.def(x);
      if (d == nullptr || d->opcode() != spv::Op::OpLoad || d->word(3) != c.variable) return false;
      auto at = fg.indexOf.find(x);
      return at != fg.indexOf.end() && at->second < stores[0].second && at->second > fg.labelAt[stores[0].first];
    });
    if (!step) return std::nullopt;
    c.step = *step;
    c.stepStore = stores[0].second;
  }
  // Which shapes have a trip count by formula (docs/measurement.md).
  const spv::Op o = c.compare;
  const bool up = o == spv::Op::OpULessThan || o == spv::Op::OpSLessThan || o == spv::Op::OpULessThanEqual ||
                  o == spv::Op::OpSLessThanEqual;
  const bool down = o == spv::Op::OpUGreaterThan || o == spv::Op::OpSGreaterThan ||
                    o == spv::Op::OpUGreaterThanEqual || o == spv::Op::OpSGreaterThanEqual;
  if ((up && c.step <= 0) || (down && c.step >= 0)) return std::nullopt;
  if (o == spv::Op::OpINotEqual && c.step != 1 && c.step != -1) return std::nullopt;
  return c;
}

// Per block, the first instruction where the invocation may end or stop
// being counted without leaving the block by its terminator.
std::vector<size_t> mayEndPoints(const FunctionGraph& fg) {
  std::map<uint32_t, int> byId;
  for (size_t i = 0; i < fg.m.functions.size(); ++i) byId[fg.m.functions[i].id()] = int(i);
  std::map<int, bool> ends;
  std::vector<size_t> out(fg.g.next.size(), kNever);
  for (size_t i = 0; i < fg.f.insts.size(); ++i) {
    const int b = fg.g.blockAt[i];
    if (b < 0 || out[b] != kNever) continue;
    const Instruction& inst = fg.f.insts[i];
    bool end = inst.opcode() == spv::Op::OpDemoteToHelperInvocation;
    if (inst.opcode() == spv::Op::OpFunctionCall) {
      auto it = byId.find(inst.word(3));
      if (it == byId.end()) {
        end = true;
      } else {
        auto [e, fresh] = ends.try_emplace(it->second);
        if (fresh) e->second = endsOtherThanByReturn(fg.m, it->second);
        end = e->second;
      }
    }
    if (end) out[b] = i;
  }
  return out;
}

// The classes of the loop's blocks (Loop::classOf), over one iteration: a
// graph of the loop's blocks whose edges back to the header, out of the
// loop, and from where an invocation may end all go to one exit node.
void classify(const FunctionGraph& fg, const std::vector<bool>& in, const std::vector<bool>& nested, Loop& loop,
              std::vector<int>& iterIdom, std::vector<int>& iterPdom) {
  const int n = static_cast<int>(fg.g.next.size()), exit = n;
  std::vector<std::vector<int>> next(n + 1), back(n + 1);
  for (int b = 0; b < n; ++b) {
    if (!in[b]) continue;
    bool leaves = fg.g.next[b].empty() || loop.mayEndAt[b] != kNever;
    for (int s : fg.g.next[b]) {
      if (s == loop.header || !in[s]) {
        leaves = true;
      } else {
        next[b].push_back(s);
      }
    }
    if (leaves) next[b].push_back(exit);
  }
  for (int b = 0; b <= n; ++b) {
    for (int s : next[b]) back[s].push_back(b);
  }
  iterIdom = immediateDominators(next, loop.header);
  iterPdom = immediateDominators(back, exit);
  loop.classOf.assign(n, -1);
  for (int b = 0; b < n; ++b) {
    if (!in[b] || nested[b] || iterIdom[b] < 0 || iterPdom[b] < 0) continue;
    // Up the dominators: the highest block on the chain that b post-dominates
    // (blocks of nested loops on the way are passed over).
    int first = b;
    for (int a = b; a != loop.header;) {
      a = iterIdom[a];
      if (nested[a]) continue;
      if (!dominates(iterPdom, b, a)) break;
      first = a;
    }
    loop.classOf[b] = first;
  }
}

}  // namespace

FunctionLoops findLoops(const Module& m, const DefIndex& defs, int function) {
  const Function& f = m.functions[function];
  auto graph = std::make_shared<FunctionGraph>(FunctionGraph{m, defs, f, blockGraph(f, defs), {}, {}, {}, {}, {}});
  FunctionGraph& fg = *graph;
  const int n = static_cast<int>(fg.g.next.size());
  FunctionLoops out;
  out.blockAt = fg.g.blockAt;
  std::vector<Loop>& loops = out.loops;
  if (n == 0) return out;
  fg.labelAt.assign(n, 0);
  for (size_t i = 0; i < f.insts.size(); ++i) {
    if (f.insts[i].opcode() == spv::Op::OpLabel) {
      fg.labelAt[fg.g.blockAt[i]] = i;
      fg.blockOfLabel[f.insts[i].resultId()] = fg.g.blockAt[i];
    }
    if (f.insts[i].hasResult()) fg.indexOf[f.insts[i].resultId()] = i;
  }
  fg.idom = immediateDominators(fg.g.next, 0);
  fg.preds.resize(n);
  for (int b = 0; b < n; ++b) {
    for (int s : fg.g.next[b]) fg.preds[s].push_back(b);
  }
  const std::vector<size_t> mayEnd = mayEndPoints(fg);
  std::vector<int> headers;
  std::vector<uint32_t> merges;
  for (size_t i = 0; i < f.insts.size(); ++i) {
    if (f.insts[i].opcode() != spv::Op::OpLoopMerge || fg.g.blockAt[i] < 0 || fg.idom[fg.g.blockAt[i]] < 0) continue;
    headers.push_back(fg.g.blockAt[i]);
    merges.push_back(f.insts[i].word(1));
  }
  std::vector<std::vector<bool>> bodies;
  for (int h : headers) bodies.push_back(naturalLoop(fg, h));
  for (size_t l = 0; l < headers.size(); ++l) {
    Loop loop;
    loop.header = headers[l];
    loop.mayEndAt = mayEnd;
    const std::vector<bool>& in = bodies[l];
    std::vector<bool> nested(n, false);
    for (size_t k = 0; k < headers.size(); ++k) {
      if (k == l || !in[headers[k]]) continue;
      for (int b = 0; b < n; ++b) nested[b] = nested[b] || bodies[k][b];
    }
    std::vector<int> iterIdom, iterPdom;
    classify(fg, in, nested, loop, iterIdom, iterPdom);
    loop.in = in;
    loop.iterIdom = iterIdom;
    // The exit test: the end of the header's chain of unconditional branches;
    // the loop's only way out, to its merge block.
    int test = loop.header;
    for (int steps = 0; fg.g.next[test].size() == 1 && steps < n; ++steps) {
      int s = fg.g.next[test][0];
      if (s == loop.header || !in[s]) break;
      test = s;
    }
    auto merge = fg.blockOfLabel.find(merges[l]);
    if (merge == fg.blockOfLabel.end() || fg.g.next[test].size() != 2) {
      loops.push_back(std::move(loop));
      continue;
    }
    int body = -1, outs = 0;
    for (int s : fg.g.next[test]) {
      if (s == merge->second) ++outs;
      if (s != merge->second && in[s] && s != loop.header) body = s;
    }
    bool only = outs == 1 && body >= 0;
    for (int b = 0; b < n && only; ++b) {
      if (!in[b]) continue;
      only = loop.mayEndAt[b] == kNever && !fg.g.next[b].empty();
      for (int s : fg.g.next[b]) only = only && (in[s] || b == test);
    }
    if (only) {
      for (int b = 0; b < n; ++b) {
        if (loop.classOf[b] >= 0 && dominates(iterIdom, body, b) && dominates(iterPdom, b, body)) {
          loop.everyIteration = loop.classOf[b];
          break;
        }
      }
    }
    // Each entry from outside must be an unconditional branch: the trip count is added before it.
    bool entries = true;
    for (int p : fg.preds[loop.header]) {
      if (in[p]) continue;
      size_t term = fg.labelAt[p];
      while (term + 1 < f.insts.size() && fg.g.blockAt[term + 1] == p) ++term;
      entries = entries && f.insts[term].opcode() == spv::Op::OpBranch;
      // An outer loop's header branching straight in: its OpLoopMerge must stay last but one.
      if (term > 0 && f.insts[term - 1].opcode() == spv::Op::OpLoopMerge) --term;
      loop.entries.push_back({term, 0});
    }
    if (loop.everyIteration >= 0 && entries) loop.counted = countedLoop(fg, in, loop, test, body);
    if (loop.counted && loop.counted->phi != 0) {
      const Instruction& phi = f.insts[fg.indexOf.at(loop.counted->phi)];
      for (auto& [term, value] : loop.entries) {
        for (size_t w = 3; w + 1 < phi.size(); w += 2) {
          auto from = fg.blockOfLabel.find(phi.word(w + 1));
          if (from != fg.blockOfLabel.end() && from->second == fg.g.blockAt[term]) value = phi.word(w);
        }
        if (value == 0) loop.counted.reset();
      }
    }
    loops.push_back(std::move(loop));
  }
  out.labelAt = fg.labelAt;
  out.graph = graph;
  return out;
}

bool invariantIn(const FunctionLoops& fl, const Loop& loop, uint32_t id, size_t& load) {
  load = kNever;
  return fl.graph != nullptr && !loop.in.empty() && invariant(*fl.graph, loop.in, loop.header, id, load);
}

size_t blockStart(const Function& f, size_t labelIndex) {
  size_t at = labelIndex + 1;
  while (at < f.insts.size() && (f.insts[at].opcode() == spv::Op::OpPhi || f.insts[at].opcode() == spv::Op::OpLine ||
                                 f.insts[at].opcode() == spv::Op::OpNoLine)) {
    ++at;
  }
  return at;
}

}  // namespace tally::spirv
