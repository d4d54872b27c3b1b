// Accumulate: descriptor arrays too long for a register per element (more
// than kAccumulateArrayMax, or runtime-sized: the lean visibility buffer's
// material maps) are accumulated in a one-entry cache per site.
//
// Each such site keeps, per invocation, the last element it counted and how
// many times (two Private u32 registers); a site that runs at most once per
// invocation, in a stage whose flush reduces across the subgroup, only
// stores its element and a count of 1. An access to the same element adds
// 1; an access to another element first adds the count so far to that
// element's counter (one atomic, rare: a site reading one material's map
// per invocation never does) and starts again at 1. The stage's flush adds
// what is left, combined across the subgroup: a waterfall over the lanes'
// elements, one atomic per distinct element, where lanes shading one
// material share it. Counts are the per-access ones, element by element.

#include "spirv/injector.hpp"

namespace tally::spirv {

bool Injector::accumulateCachedArray(const FoundSite& s, const EntryPoint& ep, uint32_t slot, uint32_t length,
                                     std::vector<std::map<size_t, std::vector<Instruction>>>& after) {
  // The cache pays only through the waterfall at the flush, which needs
  // subgroup arithmetic in the stage; without it each lane would add per
  // element, what counting per access costs a site that runs once. It
  // combines lanes whichever flush the stage's scalars take (on NVIDIA,
  // per lane in fragment shaders: "Which flush").
  if (s.placement != Placement::AfterInstruction || (options_.subgroupStages & stageBit(ep.stage)) == 0) return false;
  uint32_t u = tU32(), bo = tBool();
  std::string prefix = "tally_cache_" + std::to_string(slot) + "_" + std::to_string(cachedArrays_.size());
  CachedArray cache{slot, length, privateVariable(u, constantU32(0), prefix + "_element"),
                    privateVariable(u, constantU32(0), prefix + "_count")};
  Body b{addsInto(after[s.function][s.instruction])};
  uint32_t element = clampedIndex(b, s, length);
  uint32_t next;
  if (runsOnce(s, ep) && subgroupFlush(ep.stage) && (options_.study & kStudyEvictAlways) == 0) {
    // At most once per invocation: the cache is empty whenever the site
    // runs, so it takes the element with a count of 1, and nothing is ever
    // evicted. No branch and no atomic beside the access: the lean compute
    // shading pass x1.134 -> x1.082 on the H200. Only where the flush
    // reduces across the subgroup: where it flushes per lane (NVIDIA's
    // fragment stage) the same took Sponza's lean fragment shading from
    // x1.030 to x1.050 (docs/accuracy.md, "Cached sites that run once").
    next = constantU32(1);
  } else {
    uint32_t count = op(b, spv::Op::OpLoad, u, {cache.count});
    uint32_t cached = op(b, spv::Op::OpLoad, u, {cache.element});
    uint32_t same = op(b, spv::Op::OpIEqual, bo, {cached, element});
    uint32_t held = op(b, spv::Op::OpINotEqual, bo, {count, constantU32(0)});
    when(b, op(b, spv::Op::OpLogicalAnd, bo, {held, op(b, spv::Op::OpLogicalNot, bo, {same})}), [&](Body& bb) {
      // The reader sums a striped slot's copies: the first copy takes it.
      emitAdd(bb, op(bb, spv::Op::OpIAdd, u, {constantU32(slot), cached}), count);
    });
    // An empty cache holds element 0 with no count: 1 either way.
    next = op(b, spv::Op::OpSelect, u, {same, op(b, spv::Op::OpIAdd, u, {count, constantU32(1)}), constantU32(1)});
  }
  opNoResult(b, spv::Op::OpStore, {cache.element, element});
  opNoResult(b, spv::Op::OpStore, {cache.count, next});
  flushSlots_[ep.stage].cached.push_back(cachedArrays_.size());
  cachedArrays_.push_back(cache);
  return true;
}

// In the stage's flush: lanes holding a count combine per element (every
// cache of the stage in one partition where the device partitions, else a
// waterfall each). Helper lanes stay out (one elected would add nothing):
// the flush keeps them out where its scalars reduce too, this where they
// do not.
void Injector::flushCachedArrays(Body& b, Stage stage, const std::vector<CachedArray>& caches, uint32_t copyOffset) {
  auto withoutHelpers = [&](auto&& flush) {
    uint32_t end = stage == Stage::Fragment && !subgroupFlush(stage) ? skipHelperLanes(b, stage) : 0;
    flush();
    if (end != 0) {
      branch(b, end);
      label(b, end);
    }
  };
  if (partitioned(stage)) {
    withoutHelpers([&] { flushCachesPartitioned(b, caches, copyOffset); });
    return;
  }
  for (const CachedArray& cache : caches) withoutHelpers([&] { flushCachedElements(b, cache, copyOffset); });
}

void Injector::flushCachedElements(Body& b, const CachedArray& cache, uint32_t copyOffset) {
  uint32_t u = tU32(), zero = constantU32(0);
  uint32_t count = op(b, spv::Op::OpLoad, u, {cache.count});
  uint32_t element = op(b, spv::Op::OpLoad, u, {cache.element});
  opNoResult(b, spv::Op::OpStore, {cache.count, zero});
  when(b, op(b, spv::Op::OpINotEqual, tBool(), {count, zero}), [&](Body& bb) {
    uint32_t sumHi = 0;
    waterfall(
        bb, element,
        [&](Body& r) {
          std::vector<uint32_t> lo, hi;
          reduceAll(r, {count}, lo, hi);
          sumHi = hi[0];
          return lo[0];
        },
        [&](Body& a, uint32_t first, uint32_t sumLo) {
          uint32_t slotId = op(a, spv::Op::OpIAdd, u, {constantU32(cache.base), first});
          if (copyOffset != 0) slotId = op(a, spv::Op::OpIAdd, u, {slotId, copyOffset});
          emitAddWide(a, slotId, sumLo, sumHi);
        });
  });
}

}  // namespace tally::spirv
