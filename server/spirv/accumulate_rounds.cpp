// The accumulate mode's flush where registers reduce across the subgroup
// (docs/measurement.md, "The accumulate mode's cost, part by part").
// flushOne reduced each register and let one elected lane add it: a branch
// and an atomic per register, one after the other, which cost compute
// passes up to x1.26 on the H200. Here every register is reduced first; then
// the active lanes share the adds in rounds, the lane of rank q among them
// adding the sums of registers q, q + A, q + 2A, ... (A lanes active), so
// that a subgroup with A >= n registers makes all its adds in one branch.
// A subgroup whose every register is below 2^24 sums each register whole,
// in one reduction (no sum of at most 128 lanes can then wrap); any larger,
// lo and hi 16 bits apart as flushOne. The study's kStudyElectedAdds and
// kStudySplitReductions take either half back.

#include "spirv/injector.hpp"

namespace tally::spirv {

constexpr uint32_t kGroupExclusiveScan = 2;
constexpr uint32_t kGroupPartitionedReduce = 6, kGroupPartitionedExclusiveScan = 8;  // SPV_NV_shader_subgroup_partitioned

// The subgroup's sums of each of `values`, as (lo[j], hi[j]) with the sum
// hi[j] * 65536 + lo[j]: whole in lo where every lane's every value is
// below 2^24, else 16 bits apart (kStudySplitReductions: always apart).
void Injector::reduceAll(Body& b, const std::vector<uint32_t>& values, std::vector<uint32_t>& lo,
                         std::vector<uint32_t>& hi, uint32_t partition) {
  const size_t n = values.size();
  uint32_t u = tU32(), bo = tBool(), zero = constantU32(0), scope = constantU32(kScopeSubgroup);
  lo.assign(n, 0);
  hi.assign(n, 0);
  auto sum = [&](Body& s, uint32_t value) {
    if (partition == 0) return op(s, spv::Op::OpGroupNonUniformIAdd, u, {scope, kGroupReduce, value});
    return op(s, spv::Op::OpGroupNonUniformIAdd, u, {scope, kGroupPartitionedReduce, value, partition});
  };
  auto split = [&](Body& s, std::vector<uint32_t>& los, std::vector<uint32_t>& his) {
    for (size_t j = 0; j < n; ++j) {
      los[j] = sum(s, op(s, spv::Op::OpBitwiseAnd, u, {values[j], constantU32(0xffffu)}));
      his[j] = sum(s, op(s, spv::Op::OpShiftRightLogical, u, {values[j], constantU32(16)}));
    }
  };
  if ((options_.study & kStudySplitReductions) != 0) {
    split(b, lo, hi);
    return;
  }
  uint32_t any = values[0];
  for (size_t j = 1; j < n; ++j) any = op(b, spv::Op::OpBitwiseOr, u, {any, values[j]});
  uint32_t small = op(b, spv::Op::OpGroupNonUniformAll, bo,
                      {scope, op(b, spv::Op::OpULessThan, bo, {any, constantU32(1u << 24)})});
  uint32_t whole = m_.newId(), parts = m_.newId(), merge = m_.newId();
  selection(b, small, whole, parts, merge);
  label(b, whole);
  std::vector<uint32_t> sums(n), partLo(n), partHi(n);
  for (size_t j = 0; j < n; ++j) sums[j] = sum(b, values[j]);
  branch(b, merge);
  label(b, parts);
  split(b, partLo, partHi);
  branch(b, merge);
  label(b, merge);
  for (size_t j = 0; j < n; ++j) {
    lo[j] = op(b, spv::Op::OpPhi, u, {sums[j], whole, partLo[j], parts});
    hi[j] = op(b, spv::Op::OpPhi, u, {zero, whole, partHi[j], parts});
  }
}

void Injector::flushInRounds(Body& b, const std::vector<std::pair<uint32_t, uint32_t>>& registers,
                             uint32_t copyOffset, uint32_t counter) {
  const size_t n = registers.size();
  if (n == 0) return;
  uint32_t u = tU32(), bo = tBool(), zero = constantU32(0), scope = constantU32(kScopeSubgroup);
  std::vector<uint32_t> values(n), lo, hi;
  for (size_t j = 0; j < n; ++j) {
    values[j] = op(b, spv::Op::OpLoad, u, {registers[j].first});
    opNoResult(b, spv::Op::OpStore, {registers[j].first, zero});
  }
  reduceAll(b, values, lo, hi);
  if ((options_.study & kStudyElectedAdds) != 0) {
    // One elected lane adds each register's sums, as flushOne does.
    uint32_t elected = op(b, spv::Op::OpGroupNonUniformElect, bo, {scope});
    when(b, elected, [&](Body& e) {
      for (size_t j = 0; j < n; ++j) {
        uint32_t slot = copyOffset == 0 ? constantU32(registers[j].second)
                                        : op(e, spv::Op::OpIAdd, u, {constantU32(registers[j].second), copyOffset});
        uint32_t nonZero = op(e, spv::Op::OpINotEqual, bo, {op(e, spv::Op::OpBitwiseOr, u, {lo[j], hi[j]}), zero});
        when(e, nonZero, [&](Body& a) { emitAddWide(a, slot, lo[j], hi[j]); });
      }
    });
    return;
  }
  std::vector<uint32_t> slots(n);
  for (size_t j = 0; j < n; ++j) {
    slots[j] = copyOffset == 0 ? constantU32(registers[j].second)
                               : op(b, spv::Op::OpIAdd, u, {constantU32(registers[j].second), copyOffset});
  }
  addInRounds(b, slots, lo, hi, counter);
}

// The active lanes share the adds of (slots[j], lo[j], hi[j]): the lane of
// rank q among the A active adds j = q, q + A, ...; a zero sum adds nothing.
void Injector::addInRounds(Body& b, const std::vector<uint32_t>& slots, const std::vector<uint32_t>& lo,
                           const std::vector<uint32_t>& hi, uint32_t counter) {
  const size_t n = slots.size();
  uint32_t u = tU32(), bo = tBool(), zero = constantU32(0), scope = constantU32(kScopeSubgroup);
  uint32_t always = op(b, spv::Op::OpIEqual, bo, {zero, zero});
  uint32_t all = op(b, spv::Op::OpGroupNonUniformBallot, tVec(u, 4), {scope, always});
  uint32_t active = op(b, spv::Op::OpGroupNonUniformBallotBitCount, u, {scope, kGroupReduce, all});
  uint32_t rank = op(b, spv::Op::OpGroupNonUniformBallotBitCount, u, {scope, kGroupExclusiveScan, all});
  opNoResult(b, spv::Op::OpStore, {counter, rank});
  uint32_t k = 0;
  whileLoop(
      b,
      [&](Body& c) {
        k = op(c, spv::Op::OpLoad, u, {counter});
        return op(c, spv::Op::OpULessThan, bo, {k, constantU32(static_cast<uint32_t>(n))});
      },
      [&](Body& d) {
        uint32_t slot = slots[0], sumLo = lo[0], sumHi = hi[0];
        for (size_t j = 1; j < n; ++j) {
          uint32_t is = op(d, spv::Op::OpIEqual, bo, {k, constantU32(static_cast<uint32_t>(j))});
          slot = op(d, spv::Op::OpSelect, u, {is, slots[j], slot});
          sumLo = op(d, spv::Op::OpSelect, u, {is, lo[j], sumLo});
          sumHi = op(d, spv::Op::OpSelect, u, {is, hi[j], sumHi});
        }
        uint32_t nonZero = op(d, spv::Op::OpINotEqual, bo, {op(d, spv::Op::OpBitwiseOr, u, {sumLo, sumHi}), zero});
        when(d, nonZero, [&](Body& a) { emitAddWide(a, slot, sumLo, sumHi); });
      },
      [&](Body& st) {
        uint32_t now = op(st, spv::Op::OpLoad, u, {counter});
        opNoResult(st, spv::Op::OpStore, {counter, op(st, spv::Op::OpIAdd, u, {now, active})});
      });
}

// Each cache's count and key (its element, or ~0 where it holds no count,
// which matches only other caches without one), zeroing the count; returns
// whether the lane holds any count.
uint32_t Injector::loadCacheKeys(Body& b, const std::vector<CachedArray>& caches, std::vector<uint32_t>& counts,
                                 std::vector<uint32_t>& keys) {
  const size_t n = caches.size();
  uint32_t u = tU32(), bo = tBool(), zero = constantU32(0);
  counts.assign(n, 0);
  keys.assign(n, 0);
  uint32_t held = 0;
  for (size_t j = 0; j < n; ++j) {
    counts[j] = op(b, spv::Op::OpLoad, u, {caches[j].count});
    uint32_t element = op(b, spv::Op::OpLoad, u, {caches[j].element});
    opNoResult(b, spv::Op::OpStore, {caches[j].count, zero});
    uint32_t has = op(b, spv::Op::OpINotEqual, bo, {counts[j], zero});
    keys[j] = op(b, spv::Op::OpSelect, u, {has, element, constantU32(0xffffffffu)});
    held = held == 0 ? has : op(b, spv::Op::OpLogicalOr, bo, {held, has});
  }
  return held;
}

// Every cached array of the stage in one waterfall (accumulate_arrays.cpp has
// one per cache): each pass takes the lanes whose elements, in every cache
// that holds a count, equal the first active lane's (one pass per distinct
// material, say, where each cache is one of its maps), reduces each cache's
// count across them and adds the sums in rounds.
void Injector::flushCachesTogether(Body& b, Stage stage, const std::vector<CachedArray>& caches, uint32_t copyOffset,
                                   uint32_t counter) {
  if (partitioned(stage)) {
    flushCachesPartitioned(b, caches, copyOffset);
    return;
  }
  const size_t n = caches.size();
  uint32_t u = tU32(), bo = tBool(), scope = constantU32(kScopeSubgroup);
  std::vector<uint32_t> counts, keys;
  uint32_t held = loadCacheKeys(b, caches, counts, keys);
  when(b, held, [&](Body& w) {
    uint32_t header = m_.newId(), loop = m_.newId(), cont = m_.newId(), exit = m_.newId();
    uint32_t take = m_.newId(), skip = m_.newId();
    branch(w, header);
    label(w, header);
    opNoResult(w, spv::Op::OpLoopMerge, {exit, cont, 0});
    branch(w, loop);
    label(w, loop);
    std::vector<uint32_t> firsts(n);
    uint32_t mine = 0;
    for (size_t j = 0; j < n; ++j) {
      firsts[j] = op(w, spv::Op::OpGroupNonUniformBroadcastFirst, u, {scope, keys[j]});
      uint32_t same = op(w, spv::Op::OpIEqual, bo, {keys[j], firsts[j]});
      mine = mine == 0 ? same : op(w, spv::Op::OpLogicalAnd, bo, {mine, same});
    }
    selection(w, mine, take, skip, skip);
    label(w, take);
    std::vector<uint32_t> lo, hi, slots(n);
    reduceAll(w, counts, lo, hi);
    for (size_t j = 0; j < n; ++j) {
      slots[j] = op(w, spv::Op::OpIAdd, u, {constantU32(caches[j].base), firsts[j]});
      if (copyOffset != 0) slots[j] = op(w, spv::Op::OpIAdd, u, {slots[j], copyOffset});
    }
    addInRounds(w, slots, lo, hi, counter);
    branch(w, skip);
    label(w, skip);
    branch(w, cont);
    label(w, cont);
    opNoResult(w, spv::Op::OpBranchConditional, {mine, exit, header});
    label(w, exit);
  });
}

bool Injector::partitioned(Stage stage) const {
  const uint32_t bit = stageBit(stage);
  return (options_.partitionedStages & options_.subgroupStages & bit) != 0 && (options_.study & kStudyPartitioned) != 0;
}

// Where the device partitions a subgroup by value: the lanes holding a count
// split into parts of equal elements in every cache (the partitions by each
// cache's key, intersected), each cache's count is reduced within each part,
// and the part's first lane adds the sums: every part at once, where the
// waterfall took one pass per distinct element.
void Injector::flushCachesPartitioned(Body& b, const std::vector<CachedArray>& caches, uint32_t copyOffset) {
  addCapability(spv::Capability::GroupNonUniformPartitionedNV);
  addExtension("SPV_NV_shader_subgroup_partitioned");
  const size_t n = caches.size();
  uint32_t u = tU32(), bo = tBool(), zero = constantU32(0), scope = constantU32(kScopeSubgroup);
  uint32_t ballot = tVec(u, 4);
  std::vector<uint32_t> counts, keys;
  uint32_t held = loadCacheKeys(b, caches, counts, keys);
  when(b, held, [&](Body& w) {
    uint32_t part = 0;
    for (size_t j = 0; j < n; ++j) {
      uint32_t p = op(w, spv::Op::OpGroupNonUniformPartitionNV, ballot, {keys[j]});
      part = part == 0 ? p : op(w, spv::Op::OpBitwiseAnd, ballot, {part, p});
    }
    std::vector<uint32_t> lo, hi;
    reduceAll(w, counts, lo, hi, part);
    uint32_t before = op(w, spv::Op::OpGroupNonUniformIAdd, u,
                         {scope, kGroupPartitionedExclusiveScan, constantU32(1), part});
    when(w, op(w, spv::Op::OpIEqual, bo, {before, zero}), [&](Body& first) {
      for (size_t j = 0; j < n; ++j) {
        uint32_t slot = op(first, spv::Op::OpIAdd, u, {constantU32(caches[j].base), keys[j]});
        if (copyOffset != 0) slot = op(first, spv::Op::OpIAdd, u, {slot, copyOffset});
        uint32_t nonZero = op(first, spv::Op::OpINotEqual, bo, {op(first, spv::Op::OpBitwiseOr, u, {lo[j], hi[j]}), zero});
        when(first, nonZero, [&](Body& a) { emitAddWide(a, slot, lo[j], hi[j]); });
      }
    });
  });
}

}  // namespace tally::spirv
