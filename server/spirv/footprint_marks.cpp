// Footprint: tally_fp_mark, where every block an access covers is set in
// its bitmap, and what it skips before the atomic OR (InstrumentOptions::
// footprintDedup). Every mark is a word index and a bit; a bit once set
// stays set for the pass, so skipping a mark whose bit is known to be set,
// or letting one lane set the bits of others, leaves the bitmap, and every
// count read from it, as it was.
//
// - The cache: each invocation keeps the last two words it marked and the
//   bits it set in them (Private registers). A loop over a texture, or a
//   bilinear filter's four texels, mostly lands in blocks marked already;
//   those then cost two compares instead of a load from the bitmap.
// - The subgroup: lanes usually touch the same block. The lanes marking the
//   first active lane's word OR their bits, and one of them loads and, where
//   a bit is new, sets them all; lanes marking other words set their own.

#include "spirv/injector.hpp"

#include <algorithm>

namespace tally::spirv {

// The subgroup form needs one stage (helper lanes are a fragment builtin)
// with subgroup arithmetic and ballots (options_.subgroupStages, as for
// accumulate's reduced flush).
bool Injector::footprintSubgroup(const SiteScan& scan) {
  if (!footprintOn()) return false;
  FootprintDedup dedup = options_.footprintDedup.value_or(FootprintDedup{});
  result_.footprintDedup = dedup;
  if ((!dedup.subgroup && !dedup.lanes) || scan.entryPoints.empty()) return false;
  Stage stage = scan.entryPoints.front().stage;
  bool oneStage = std::all_of(scan.entryPoints.begin(), scan.entryPoints.end(),
                              [&](const EntryPoint& ep) { return ep.stage == stage; });
  if (!oneStage || stage == Stage::Other || (options_.subgroupStages & stageBit(stage)) == 0) {
    result_.footprintDedup->subgroup = false;
    result_.footprintDedup->lanes = false;
    if (dedup.subgroup) {
      noteOnce(std::string("footprint: marks not combined across the subgroup: ") +
               (oneStage ? "no subgroup arithmetic in the " + std::string(toString(stage)) + " stage"
                         : "entry points of several stages"));
    }
    return false;
  }
  fpStage_ = stage;
  fpCombines_ = dedup.lanes;
  if (fpCombines_ && (options_.study & kStudyFpQuad) != 0) addCapability(spv::Capability::GroupNonUniformShuffle);
  return true;
}

// Where the lanes' marks combine: texel marks and fragment outputs, by a
// partition by block where the device has one (NVIDIA), else with the
// subgroup's first marking lane (ballots only); filtered reads and buffers
// not (on the H200 that cost more than it saved: docs/measurement.md, "What
// a mark costs"), but for the study.
Injector::FpCombine Injector::fpCombine(FpMarkKind kind) const {
  if (!fpCombines_) return FpCombine::None;
  const bool match = (options_.partitionedStages & options_.subgroupStages & stageBit(fpStage_)) != 0;
  switch (kind) {
    case FpMarkKind::Texel: break;
    case FpMarkKind::Output:
      if ((options_.study & kStudyFpOwnOutputs) != 0) return FpCombine::None;
      break;
    case FpMarkKind::Sample: return match && (options_.study & kStudyFpMatchSamples) != 0 ? FpCombine::Match : FpCombine::None;
    case FpMarkKind::Bytes: return match && (options_.study & kStudyFpMatchBytes) != 0 ? FpCombine::Match : FpCombine::None;
  }
  if ((options_.study & kStudyFpQuad) != 0) return FpCombine::Quad;
  if ((options_.study & kStudyFpFirst) != 0 || !match) return FpCombine::First;
  return FpCombine::Match;
}

// if the bit is among the bits this invocation marked in the word: return;
// else remember it. Registers: (word0, bits0) the last word marked, (word1,
// bits1) the one before.
void Injector::fpSkipCached(Body& b, uint32_t word, uint32_t bit) {
  uint32_t u = tU32(), bo = tBool();
  if (fpCache_[0] == 0) {
    const char* names[] = {"tally_fp_word0", "tally_fp_bits0", "tally_fp_word1", "tally_fp_bits1"};
    for (int k = 0; k < 4; ++k) fpCache_[k] = privateVariable(u, constantU32(0), names[k]);
  }
  uint32_t word0 = op(b, spv::Op::OpLoad, u, {fpCache_[0]}), bits0 = op(b, spv::Op::OpLoad, u, {fpCache_[1]});
  uint32_t word1 = op(b, spv::Op::OpLoad, u, {fpCache_[2]}), bits1 = op(b, spv::Op::OpLoad, u, {fpCache_[3]});
  uint32_t hit0 = op(b, spv::Op::OpIEqual, bo, {word0, word});
  uint32_t hit1 = op(b, spv::Op::OpIEqual, bo, {word1, word});
  // Registers start at word 0 with no bits: a hit on them knows no block.
  uint32_t known = op(b, spv::Op::OpSelect, u, {hit0, bits0, op(b, spv::Op::OpSelect, u, {hit1, bits1, constantU32(0)})});
  // The word marked now goes first; the other entry keeps the older word.
  opNoResult(b, spv::Op::OpStore, {fpCache_[0], word});
  opNoResult(b, spv::Op::OpStore, {fpCache_[1], op(b, spv::Op::OpBitwiseOr, u, {known, bit})});
  opNoResult(b, spv::Op::OpStore, {fpCache_[2], op(b, spv::Op::OpSelect, u, {hit0, word1, word0})});
  opNoResult(b, spv::Op::OpStore, {fpCache_[3], op(b, spv::Op::OpSelect, u, {hit0, bits1, bits0})});
  returnIf(b, op(b, spv::Op::OpINotEqual, bo, {op(b, spv::Op::OpBitwiseAnd, u, {known, bit}), constantU32(0)}));
}

// bitmap[word] |= bits, with a load first: the atomic only where a bit is new
// (`oneBit`: where the one bit is clear).
void Injector::fpSetBits(Body& b, uint32_t word, uint32_t bits, bool oneBit, bool red) {
  uint32_t u = tU32(), bo = tBool();
  uint32_t ptr = op(b, spv::Op::OpAccessChain, fpWordPtr_, {fpBitmap_, constantU32(0), word});
  if (red) {
    op(b, spv::Op::OpAtomicOr, u, {ptr, atomicScope(), constantU32(kSemanticsRelaxed), bits});
    return;
  }
  if ((options_.study & kStudyFpNoBitmap) != 0) {
    // The work before it kept alive behind a test no word passes.
    uint32_t never = op(b, spv::Op::OpIEqual, bo, {word, constantU32(~0u)});
    when(b, never, [&](Body& bb) {
      op(bb, spv::Op::OpAtomicOr, u, {ptr, atomicScope(), constantU32(kSemanticsRelaxed), bits});
    });
    return;
  }
  uint32_t old = op(b, spv::Op::OpLoad, u, {ptr});
  uint32_t present = op(b, spv::Op::OpBitwiseAnd, u, {old, bits});
  uint32_t fresh = oneBit ? op(b, spv::Op::OpIEqual, bo, {present, constantU32(0)})
                          : op(b, spv::Op::OpINotEqual, bo, {present, bits});
  when(b, fresh, [&](Body& bb) {
    op(bb, spv::Op::OpAtomicOr, u, {ptr, atomicScope(), constantU32(kSemanticsRelaxed), bits});
  });
}

// One round of a waterfall: the lanes marking the first active lane's word
// OR their bits, and that lane (the one elected) sets them all; lanes
// marking other words set their own bit as without the subgroup. Where the
// lanes share a word (a full-screen pass: neighbouring pixels in one block)
// the word gets one atomic instead of one per lane, for a fixed cost; the
// full waterfall, a loop over every distinct word, cost more than it saved
// (docs/measurement.md, "What a mark skips").
void Injector::fpSetBitsOfSubgroup(Body& b, uint32_t word, uint32_t bit) {
  uint32_t u = tU32(), bo = tBool(), scope = constantU32(kScopeSubgroup);
  // Helper lanes take part in subgroup operations, but an atomic from one
  // has no effect: one elected would lose the others' bits.
  uint32_t end = fpStage_ == Stage::Fragment ? skipHelperLanes(b, fpStage_) : 0;
  uint32_t first = op(b, spv::Op::OpGroupNonUniformBroadcastFirst, u, {scope, word});
  uint32_t same = op(b, spv::Op::OpIEqual, bo, {word, first});
  uint32_t mine = op(b, spv::Op::OpSelect, u, {same, bit, constantU32(0)});
  uint32_t bits = op(b, spv::Op::OpGroupNonUniformBitwiseOr, u, {scope, kGroupReduce, mine});
  // Elect and BroadcastFirst both pick the active lane of lowest id.
  uint32_t elected = op(b, spv::Op::OpGroupNonUniformElect, bo, {scope});
  when(b, elected, [&](Body& bb) { fpSetBits(bb, first, bits, false); });
  when(b, op(b, spv::Op::OpLogicalNot, bo, {same}), [&](Body& bb) { fpSetBits(bb, word, bit, true); });
  if (end != 0) {
    branch(b, end);
    label(b, end);
  }
}

// tally_fp_mark(base, capacity, block): sets the bit, block clamped into
// the scratch bit past the bitmap.
uint32_t Injector::fpMarkFn(FpCombine combine, bool red) {
  uint32_t& cached = fpMarks_[static_cast<int>(combine) + (red ? 4 : 0)];
  if (cached != 0) return cached;
  static const char* const names[] = {"tally_fp_mark", "tally_fp_mark_quad", "tally_fp_mark_first", "tally_fp_mark_match"};
  uint32_t u = tU32(), bo = tBool();
  auto f = beginFunction({u, u, u});
  Body b{f->fn.insts};
  if ((options_.study & kStudyFpNoMarks) != 0) {
    cached = endFunction(std::move(f), names[static_cast<int>(combine)]);
    return cached;
  }
  uint32_t base = f->params[0], cap = f->params[1], block = f->params[2];
  uint32_t inside = op(b, spv::Op::OpULessThan, bo, {block, cap});
  block = op(b, spv::Op::OpSelect, u, {inside, block, cap});
  uint32_t word = op(b, spv::Op::OpIAdd, u, {base, op(b, spv::Op::OpShiftRightLogical, u, {block, constantU32(5)})});
  uint32_t bit = op(b, spv::Op::OpShiftLeftLogical, u,
                    {constantU32(1), op(b, spv::Op::OpBitwiseAnd, u, {block, constantU32(31)})});
  const FootprintDedup& dedup = *result_.footprintDedup;
  if (combine != FpCombine::None) {
    // Helper lanes stay out: an atomic from one has no effect. Exact
    // whatever lanes combine: a lane compares blocks, not pixels.
    uint32_t scope = constantU32(kScopeSubgroup);
    uint32_t end = fpStage_ == Stage::Fragment ? skipHelperLanes(b, fpStage_) : 0;
    uint32_t id = op(b, spv::Op::OpLoad, u, {builtin(fpStage_, spv::BuiltIn::SubgroupLocalInvocationId, u)});
    uint32_t leader = 0;
    if (combine == FpCombine::Match) {
      addCapability(spv::Capability::GroupNonUniformPartitionedNV);
      addExtension("SPV_NV_shader_subgroup_partitioned");
      uint32_t part = op(b, spv::Op::OpGroupNonUniformPartitionNV, tVec(u, 4), {block});
      leader = op(b, spv::Op::OpGroupNonUniformBallotFindLSB, u, {scope, part});
    } else if (combine == FpCombine::First) {
      uint32_t first = op(b, spv::Op::OpGroupNonUniformBroadcastFirst, u, {scope, block});
      uint32_t firstLane = op(b, spv::Op::OpGroupNonUniformBroadcastFirst, u, {scope, id});
      leader = op(b, spv::Op::OpSelect, u, {op(b, spv::Op::OpIEqual, bo, {first, block}), firstLane, id});
    } else {
      uint32_t always = op(b, spv::Op::OpIEqual, bo, {id, id});
      uint32_t ballot = op(b, spv::Op::OpGroupNonUniformBallot, tVec(u, 4), {scope, always});
      uint32_t w = op(b, spv::Op::OpVectorExtractDynamic, u, {ballot, op(b, spv::Op::OpShiftRightLogical, u, {id, constantU32(5)})});
      uint32_t lanes = op(b, spv::Op::OpBitwiseAnd, u,
                          {op(b, spv::Op::OpShiftRightLogical, u, {w, op(b, spv::Op::OpBitwiseAnd, u, {id, constantU32(28)})}),
                           constantU32(15)});
      uint32_t first = op(b, spv::Op::OpIAdd, u,
                          {op(b, spv::Op::OpBitwiseAnd, u, {id, constantU32(~3u)}), ext(b, u, FindILsb, {lanes})});
      uint32_t theirs = op(b, spv::Op::OpGroupNonUniformShuffle, u, {scope, block, first});
      leader = op(b, spv::Op::OpSelect, u, {op(b, spv::Op::OpIEqual, bo, {theirs, block}), first, id});
    }
    when(b, op(b, spv::Op::OpIEqual, bo, {leader, id}), [&](Body& bb) { fpSetBits(bb, word, bit, true, red); });
    if (end != 0) {
      branch(b, end);
      label(b, end);
    }
  } else {
    if (dedup.cache) fpSkipCached(b, word, bit);
    if (dedup.subgroup) {
      fpSetBitsOfSubgroup(b, word, bit);
    } else {
      fpSetBits(b, word, bit, true, red);
    }
  }
  cached = endFunction(std::move(f), names[static_cast<int>(combine)]);
  return cached;
}

}  // namespace tally::spirv
