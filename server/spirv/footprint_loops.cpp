// Footprint: a buffer access in a counted loop marks, once where the loop
// is entered, the blocks all its iterations cover, and nothing inside the
// loop (InstrumentOptions::footprintDedup.loops).
//
// The access must run once in every iteration (the loop's everyIteration
// class, before any point where the invocation may end), its descriptor
// must not depend on the iteration, and its byte offset must be
// first + k * step at iteration k: every run-time index of its access chain
// is either the loop's induction variable or a value made before the loop.
// Where |step| is at most a block the iterations' blocks are one contiguous
// range, from the lowest offset's block to the highest's end; the range is
// marked word by word, a load each and an atomic OR where a bit is new.
// tally_fp_range checks at run time that no offset wraps past 2^32, and
// where one would, it marks each iteration's access as the loop would have.
// Either way the bitmap is the one the per-iteration marks would have set.

#include "spirv/injector.hpp"

#include <bit>

#include "spirv/footprint.hpp"

namespace tally::spirv {

bool Injector::footprintLoopRange(const FoundSite& s, uint32_t slotBase,
                                  std::vector<std::map<size_t, std::vector<Instruction>>>& before) {
  if (!options_.footprintDedup.value_or(FootprintDedup{}).loops) return false;
  const Site& site = s.site;
  if ((site.kind != SiteKind::BufferRead && site.kind != SiteKind::BufferWrite) || site.location ||
      site.elementBytes == 0 || s.placement != Placement::AfterInstruction || s.function < 0 || dynamicSlot(s)) {
    return false;
  }
  const FunctionLoops& fl = loopsOf(s.function);
  const int block = s.instruction < fl.blockAt.size() ? fl.blockAt[s.instruction] : -1;
  if (block < 0) return false;
  const Loop* loop = nullptr;
  for (const Loop& l : fl.loops) {
    if (l.counted && l.everyIteration >= 0 && l.classOf[block] == l.everyIteration && s.instruction < l.mayEndAt[block]) {
      loop = &l;
      break;
    }
  }
  if (loop == nullptr) return false;
  std::string why;
  auto terms = offsetTerms(sitePointer(s), s.function, why);
  if (!terms) return false;
  const Function& f = m_.functions[s.function];
  const CountedLoop& c = *loop->counted;
  auto blockOf = [&](uint32_t id) -> std::pair<int, size_t> {
    const Instruction* d = defs_.def(id);
    if (d == nullptr || defs_.functionOf(id) != s.function) return {-1, kNever};
    size_t i = static_cast<size_t>(d - f.insts.data());
    return {i < fl.blockAt.size() ? fl.blockAt[i] : -1, i};
  };
  // The induction variable's value in this iteration: the header's phi, or
  // a load of the variable before the iteration's one store to it.
  auto induction = [&](uint32_t id) {
    if (c.phi != 0) return id == c.phi;
    const Instruction* d = defs_.def(id);
    if (d == nullptr || d->opcode() != spv::Op::OpLoad || d->word(3) != c.variable) return false;
    auto [loadBlock, loadAt] = blockOf(id);
    const int storeBlock = fl.blockAt[c.stepStore];
    if (loadBlock < 0 || !loop->in[loadBlock]) return false;
    return loadBlock == storeBlock ? loadAt < c.stepStore : dominates(loop->iterIdom, loadBlock, storeBlock);
  };
  int64_t stride = 0;
  std::vector<uint32_t> inductions;
  std::vector<std::pair<uint32_t, size_t>> reloads;  // an index loaded in the loop -> the load to repeat at the entry
  for (auto [id, bytes] : terms->dynamic) {
    if (induction(id)) {
      stride += bytes;
      inductions.push_back(id);
      continue;
    }
    size_t load = kNever;
    if (!invariantIn(fl, *loop, id, load)) return false;  // changes inside the loop
    if (load != kNever) reloads.push_back({id, load});
  }
  const int64_t step = stride * c.step;
  if (step > int64_t(options_.footprintBlockBytes) || -step > int64_t(options_.footprintBlockBytes)) return false;

  for (const auto& [branch, phiValue] : loop->entries) {
    Body b{before[s.function][branch]};
    uint32_t start = inductionStart(b, c, phiValue);
    auto constant = constantTrips(f, c, branch, phiValue);
    uint32_t trips = constant ? constantU32(*constant) : tripCount(b, f, c, phiValue);
    std::map<uint32_t, uint32_t> replace;  // the offset's indices as they are at the first trip
    for (uint32_t id : inductions) replace[id] = start;
    for (auto [id, load] : reloads) replace[id] = repeatLoad(b, f, load);
    uint32_t first = emitOffset(b, *terms, replace);
    uint32_t slot = slotValue(s, slotBase, b.insts);
    uint32_t entry = op(b, spv::Op::OpIMul, tU32(), {slot, constantU32(footprint::kEntryWords)});
    fnCall(b, fpRangeFn(shortBytes(site.elementBytes)),
           {entry, first, constantU32(static_cast<uint32_t>(step)), trips, constantU32(site.elementBytes)});
  }
  return true;
}

// tally_fp_range(entry, first, step, trips, bytes).
uint32_t Injector::fpRangeFn(bool shortRange) {
  uint32_t& cached = shortRange ? fpRangeShort_ : fpRange_;
  if (cached != 0) return cached;
  const uint32_t bytesFn = fpBytesFn(shortRange);
  const uint32_t u = tU32(), bo = tBool();
  auto f = beginFunction({u, u, u, u, u});
  Body b{f->fn.insts};
  const uint32_t entry = f->params[0], first = f->params[1], step = f->params[2], trips = f->params[3],
                 bytes = f->params[4];
  const uint32_t k = m_.newId(), w = m_.newId();
  declareVariable(b, k, u);
  declareVariable(b, w, u);
  const uint32_t all = constantU32(0xffffffffu);
  returnIf(b, op(b, spv::Op::OpIEqual, bo, {trips, constantU32(0)}));
  // What tally_fp_bytes marks nothing of.
  uint32_t kind = tableWord(b, entry, footprint::kKind);
  uint32_t isBuffer = op(b, spv::Op::OpIEqual, bo, {kind, constantU32(uint32_t(footprint::EntryKind::Buffer))});
  uint32_t isVertex = op(b, spv::Op::OpIEqual, bo, {kind, constantU32(uint32_t(footprint::EntryKind::VertexInput))});
  returnIf(b, op(b, spv::Op::OpLogicalNot, bo, {op(b, spv::Op::OpLogicalOr, bo, {isBuffer, isVertex})}));
  // The lowest offset, and the distance from it to the highest, without wrapping.
  uint32_t m = op(b, spv::Op::OpISub, u, {trips, constantU32(1)});
  uint32_t down = op(b, spv::Op::OpSLessThan, bo, {step, constantU32(0)});
  uint32_t size = op(b, spv::Op::OpSelect, u, {down, op(b, spv::Op::OpSNegate, u, {step}), step});
  uint32_t last = op(b, spv::Op::OpIAdd, u, {first, op(b, spv::Op::OpIMul, u, {m, step})});
  uint32_t low = op(b, spv::Op::OpSelect, u, {down, last, first});
  uint32_t limit = op(b, spv::Op::OpUDiv, u, {all, ext(b, u, UMax, {size, constantU32(1)})});
  uint32_t travel = op(b, spv::Op::OpIMul, u, {m, size});
  uint32_t tail = op(b, spv::Op::OpISub, u, {bytes, constantU32(1)});
  uint32_t reach = op(b, spv::Op::OpIAdd, u, {low, travel});
  auto fits = [&](uint32_t a, uint32_t add) {  // a + add < 2^32
    return op(b, spv::Op::OpULessThanEqual, bo, {a, op(b, spv::Op::OpISub, u, {all, add})});
  };
  uint32_t ok = op(b, spv::Op::OpULessThanEqual, bo, {m, limit});
  ok = op(b, spv::Op::OpLogicalAnd, bo, {ok, fits(low, travel)});
  ok = op(b, spv::Op::OpLogicalAnd, bo, {ok, fits(reach, tail)});
  ok = op(b, spv::Op::OpLogicalAnd, bo, {ok, isBuffer});
  // Otherwise each iteration's access, as the loop marks it.
  when(b, op(b, spv::Op::OpLogicalNot, bo, {ok}), [&](Body& bb) {
    opNoResult(bb, spv::Op::OpStore, {k, constantU32(0)});
    uint32_t i = 0;
    whileLoop(
        bb,
        [&](Body& t) {
          i = op(t, spv::Op::OpLoad, u, {k});
          return op(t, spv::Op::OpULessThan, bo, {i, trips});
        },
        [&](Body& t) {
          uint32_t offset = op(t, spv::Op::OpIAdd, u, {first, op(t, spv::Op::OpIMul, u, {i, step})});
          fnCall(t, bytesFn, {entry, offset, bytes});
        },
        [&](Body& t) { opNoResult(t, spv::Op::OpStore, {k, op(t, spv::Op::OpIAdd, u, {i, constantU32(1)})}); });
  });
  returnIf(b, op(b, spv::Op::OpLogicalNot, bo, {ok}));
  // Blocks [b0, b1]; those past the bitmap set its scratch bit, as a mark clamps them.
  uint32_t shift = constantU32(static_cast<uint32_t>(std::countr_zero(options_.footprintBlockBytes)));
  uint32_t b0 = op(b, spv::Op::OpShiftRightLogical, u, {low, shift});
  uint32_t b1 = op(b, spv::Op::OpShiftRightLogical, u, {op(b, spv::Op::OpIAdd, u, {reach, tail}), shift});
  uint32_t base = tableWord(b, entry, footprint::kBase), cap = tableWord(b, entry, footprint::kCapacity);
  when(b, op(b, spv::Op::OpUGreaterThanEqual, bo, {b1, cap}), [&](Body& bb) {
    uint32_t word = op(bb, spv::Op::OpIAdd, u, {base, op(bb, spv::Op::OpShiftRightLogical, u, {cap, constantU32(5)})});
    uint32_t bit = op(bb, spv::Op::OpShiftLeftLogical, u,
                      {constantU32(1), op(bb, spv::Op::OpBitwiseAnd, u, {cap, constantU32(31)})});
    fpSetBits(bb, word, bit, true);
  });
  returnIf(b, op(b, spv::Op::OpUGreaterThanEqual, bo, {b0, cap}));
  uint32_t top = ext(b, u, UMin, {b1, op(b, spv::Op::OpISub, u, {cap, constantU32(1)})});
  uint32_t w0 = op(b, spv::Op::OpShiftRightLogical, u, {b0, constantU32(5)});
  uint32_t w1 = op(b, spv::Op::OpShiftRightLogical, u, {top, constantU32(5)});
  opNoResult(b, spv::Op::OpStore, {w, w0});
  uint32_t word = 0;
  whileLoop(
      b,
      [&](Body& t) {
        word = op(t, spv::Op::OpLoad, u, {w});
        return op(t, spv::Op::OpULessThanEqual, bo, {word, w1});
      },
      [&](Body& t) {
        uint32_t lowBit = op(t, spv::Op::OpSelect, u,
                             {op(t, spv::Op::OpIEqual, bo, {word, w0}),
                              op(t, spv::Op::OpBitwiseAnd, u, {b0, constantU32(31)}), constantU32(0)});
        uint32_t highBit = op(t, spv::Op::OpSelect, u,
                              {op(t, spv::Op::OpIEqual, bo, {word, w1}),
                               op(t, spv::Op::OpBitwiseAnd, u, {top, constantU32(31)}), constantU32(31)});
        uint32_t mask = op(t, spv::Op::OpBitwiseAnd, u,
                           {op(t, spv::Op::OpShiftLeftLogical, u, {all, lowBit}),
                            op(t, spv::Op::OpShiftRightLogical, u, {all, op(t, spv::Op::OpISub, u, {constantU32(31), highBit})})});
        fpSetBits(t, op(t, spv::Op::OpIAdd, u, {base, word}), mask, false);
      },
      [&](Body& t) { opNoResult(t, spv::Op::OpStore, {w, op(t, spv::Op::OpIAdd, u, {word, constantU32(1)})}); });
  cached = endFunction(std::move(f), shortRange ? "tally_fp_range_short" : "tally_fp_range");
  return cached;
}

}  // namespace tally::spirv
