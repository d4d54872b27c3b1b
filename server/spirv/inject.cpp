#include "spirv/inject.hpp"

#include "spirv/injector.hpp"

namespace tally::spirv {

TileShape sampledTileShape(uint32_t n) {
  uint32_t height = 1;
  for (uint32_t d = 1; d * d <= n; ++d) {
    if (n % d == 0) height = d;
  }
  return {n / height, height};
}

Result<bool> Injector::run(const SiteScan& scan, const std::vector<uint32_t>& slots) {
  // Which helper each stage uses decides the capabilities and version.
  const bool accumulate = options_.mode.kind == CountMode::Accumulate;
  bool subgroup = footprintSubgroup(scan);
  for (const FoundSite& s : scan.sites) {  // a cached array's flush (accumulate_arrays.cpp) reduces whatever the policy
    Stage stage = scan.entryPoints[s.entryIndex].stage;
    if (accumulate && accumulates(stage) && s.dynamicIndex != 0 && (s.arrayLength == 0 || s.arrayLength > kAccumulateArrayMax) &&
        (options_.subgroupStages & stageBit(stage)) != 0) {
      subgroup = true;
    }
  }
  for (const auto& ep : scan.entryPoints) {
    if (accumulate) {
      if (accumulates(ep.stage) && subgroupFlush(ep.stage)) subgroup = true;
      continue;
    }
    Helper h = helperFor(ep.stage);
    if (h != Helper::Exact && options_.mode.kind == CountMode::Subgroup) subgroup = true;
  }
  if (subgroup && m_.version < kVersion13) {
    notes_.push_back("SPIR-V version raised from " + versionString(m_.version) +
                     " to 1.3 for subgroup operations (needs Vulkan 1.1)");
    m_.version = kVersion13;
  }
  if (options_.width == CounterWidth::Int64) {
    addCapability(spv::Capability::Int64);
    addCapability(spv::Capability::Int64Atomics);
  }
  if (subgroup) {
    addCapability(spv::Capability::GroupNonUniform);
    addCapability(spv::Capability::GroupNonUniformArithmetic);
    addCapability(spv::Capability::GroupNonUniformBallot);
    if (accumulate && (options_.study & kStudySplitReductions) == 0) addCapability(spv::Capability::GroupNonUniformVote);
  }
  declareCounters();
  if (footprintOn()) declareFootprint();
  if (std::any_of(scan.sites.begin(), scan.sites.end(), [&](const FoundSite& s) { return addressed(s); })) {
    declareAddressTable();
  }

  // Per-function insertions, keyed by instruction index.
  std::vector<std::map<size_t, std::vector<Instruction>>> after(m_.functions.size());
  std::vector<std::map<size_t, std::vector<Instruction>>> before(m_.functions.size());
  if (accumulate) findInvocationSlots(scan, slots);
  if (accumulate) countLoops(scan, before, slots);
  for (size_t i = 0; i < scan.sites.size(); ++i) {
    const FoundSite& s = scan.sites[i];
    const EntryPoint& ep = scan.entryPoints[s.entryIndex];
    if (footprintOn()) footprintSite(i, s, ep, slots[i], after, before);
    if (accumulate && deriveSite(s, ep, slots[i])) continue;
    if (accumulate && loopDerived_.count(i)) continue;
    if (accumulate && accumulateSite(s, ep, slots[i], after, before)) continue;
    Helper kind = helperFor(ep.stage);
    if (!dynamicSlot(s) && kind == Helper::Subgroup) kind = Helper::SubgroupUniform;
    if (!dynamicSlot(s) && kind == Helper::SubgroupFragment) kind = Helper::SubgroupUniformFragment;
    uint32_t helper = helperFunction(kind, ep.stage);
    const auto& insts = m_.functions[s.function].insts;
    switch (s.placement) {
      case Placement::AfterInstruction: {
        auto& list = after[s.function][s.instruction];
        uint32_t slot = slotValue(s, slots[i], list);
        list.push_back(call(helper, slot));
        break;
      }
      case Placement::EntryStart:
        before[s.function][entryStart(insts)].push_back(call(helper, constantU32(slots[i])));
        break;
      case Placement::BeforeReturns:
        for (size_t at = 0; at < insts.size(); ++at) {
          if (insts[at].opcode() == spv::Op::OpReturn) before[s.function][at].push_back(call(helper, constantU32(slots[i])));
        }
        break;
    }
  }

  for (const auto& [stage, sites] : fpLoopSites_) {
    notes_.push_back("footprint: " + std::to_string(sites) + " " + std::string(toString(stage)) + " buffer site" +
                     (sites == 1 ? "" : "s") + " in counted loops marked once where the loop is entered, " +
                     "as the range of blocks the iterations cover");
  }
  if (accumulate && result_.arithmeticSlot >= 0) countExecutedArithmetic(scan, before);
  if (accumulate && flushSlots_.count(Stage::Compute) && options_.computeCopies > 1) {
    result_.copies = options_.computeCopies;
    result_.copyStride = (result_.slotCount + kCopyAlignSlots - 1) / kCopyAlignSlots * kCopyAlignSlots;
  }
  if (accumulate) insertFlushes(scan, before);
  for (const auto& [stage, sites] : derivedSites_) {
    notes_.push_back("accumulate mode: " + std::to_string(sites) + " " + std::string(toString(stage)) + " site" +
                     (sites == 1 ? "" : "s") +
                     " that run exactly once in every invocation derived from the invocation count");
  }
  for (const auto& [stage, sites] : perAccessOnce_) {
    notes_.push_back("accumulate mode: " + std::to_string(sites) + " " + std::string(toString(stage)) + " site" +
                     (sites == 1 ? "" : "s") +
                     " that run at most once per invocation counted per access (their flush would cost as much)");
  }

  // Entry-point interfaces: builtins always, every global from SPIR-V 1.4 on.
  for (const auto& ep : scan.entryPoints) {
    std::set<uint32_t> add(stageBuiltins_[ep.stage].begin(), stageBuiltins_[ep.stage].end());
    if (m_.version >= kVersion14) {
      add.insert(counters_);
      if (footprintOn()) add.insert({fpTable_, fpBitmap_});
      if (addressTable_ != 0) add.insert(addressTable_);
      add.insert(accumulators_.begin(), accumulators_.end());
    }
    Instruction& inst = m_.entryPoints[ep.instIndex];
    for (uint32_t id : add) {
      if (std::find(ep.interface.begin(), ep.interface.end(), id) == ep.interface.end()) inst.words.push_back(id);
    }
    inst.words[0] = (static_cast<uint32_t>(inst.words.size()) << 16) | (inst.words[0] & 0xffffu);
  }

  // Apply, now that no more lookups into the old sections are needed.
  for (size_t f = 0; f < m_.functions.size(); ++f) {
    if (after[f].empty() && before[f].empty()) continue;
    auto& insts = m_.functions[f].insts;
    std::vector<Instruction> out;
    out.reserve(insts.size() + 4 * (after[f].size() + before[f].size()));
    for (size_t at = 0; at < insts.size(); ++at) {
      if (auto b = before[f].find(at); b != before[f].end()) out.insert(out.end(), b->second.begin(), b->second.end());
      out.push_back(std::move(insts[at]));
      if (auto a = after[f].find(at); a != after[f].end()) out.insert(out.end(), a->second.begin(), a->second.end());
    }
    insts = std::move(out);
  }
  m_.globals.insert(m_.globals.end(), newGlobals_.begin(), newGlobals_.end());
  m_.annotations.insert(m_.annotations.end(), newAnnotations_.begin(), newAnnotations_.end());
  auto processed = std::find_if(m_.debug.begin(), m_.debug.end(), [](const Instruction& d) {
    return d.opcode() == spv::Op::OpModuleProcessed;
  });
  m_.debug.insert(processed, newNames_.begin(), newNames_.end());
  for (auto& f : newFunctions_) m_.functions.push_back(std::move(f));
  return true;
}

Result<bool> injectCounters(Module& module, const DefIndex& defs, const Types& types, const SiteScan& scan,
                            const std::vector<uint32_t>& slots, const InstrumentOptions& options,
                            Instrumented& result) {
  return Injector(module, defs, types, options, result).run(scan, slots);
}

}  // namespace tally::spirv
