// Accumulate: sites that run once per loop iteration share a trip counter.
//
// Within a structured loop, the sites of one class of blocks (loops.hpp:
// blocks that run exactly as often as one another in every iteration,
// outside nested loops, before any point where the invocation may end)
// get no code: the loop's trip counter for that class, a Private register
// of a slot of its own flushed with the others, adds 1 at the class's first
// block, and the reader derives each site's count from it
// (Instrumented::derived: counters[site] += times * counters[trip]).
// Where the loop is counted (CountedLoop) the class that runs in every
// iteration adds the trip count once, before the loop, and nothing inside;
// a constant trip count at an entry that runs as often as the enclosing
// loop's class or the invocation is itself derived from that count.
// A trip slot is no site: readers, which go through sites, never show it.

#include "spirv/injector.hpp"
#include "spirv/loops.hpp"

namespace tally::spirv {

namespace {

bool inclusive(spv::Op o) {
  return o == spv::Op::OpULessThanEqual || o == spv::Op::OpSLessThanEqual || o == spv::Op::OpUGreaterThanEqual ||
         o == spv::Op::OpSGreaterThanEqual;
}

}  // namespace

// The load at instruction `at` of `f` (from memory the loop cannot change:
// invariantIn), made again where the loop is entered, its access chain too.
uint32_t Injector::repeatLoad(Body& b, const Function& f, size_t at) {
  const Instruction& load = f.insts[at];
  uint32_t pointer = load.word(3);
  const Instruction* chain = defs_.def(pointer);
  if (chain != nullptr && defs_.functionOf(pointer) >= 0 &&
      (chain->opcode() == spv::Op::OpAccessChain || chain->opcode() == spv::Op::OpInBoundsAccessChain)) {
    std::vector<uint32_t> operands(chain->words.begin() + 3, chain->words.end());
    pointer = op(b, chain->opcode(), chain->resultType(), operands);
  }
  return op(b, spv::Op::OpLoad, load.resultType(), {pointer});
}

const FunctionLoops& Injector::loopsOf(int function) {
  auto [at, fresh] = loops_.try_emplace(function);
  if (fresh) at->second = findLoops(m_, defs_, function);
  return at->second;
}

uint32_t Injector::inductionStart(Body& b, const CountedLoop& c, uint32_t phiValue) {
  if (c.variable == 0) return phiValue;
  const Instruction* pointerType = defs_.def(defs_.def(c.variable)->resultType());
  return op(b, spv::Op::OpLoad, pointerType->word(3), {c.variable});
}

// The loop's trip count, computed where it is entered: u32, 0 where the test fails at once.
uint32_t Injector::tripCount(Body& b, const Function& f, const CountedLoop& c, uint32_t phiValue) {
  uint32_t u = tU32();
  uint32_t start = inductionStart(b, c, phiValue);
  uint32_t bound = c.boundLoad != kNever ? repeatLoad(b, f, c.boundLoad) : c.bound;
  const bool up = c.step > 0;
  const uint32_t magnitude = up ? uint32_t(c.step) : uint32_t(-int64_t(c.step));
  uint32_t diff = up ? op(b, spv::Op::OpISub, u, {bound, start}) : op(b, spv::Op::OpISub, u, {start, bound});
  if (c.compare == spv::Op::OpINotEqual) return diff;  // step 1 or -1: wraps as the variable does
  uint32_t trips = diff;
  if (magnitude > 1) {
    trips = op(b, spv::Op::OpUDiv, u, {diff, constantU32(magnitude)});
    if (!inclusive(c.compare)) {
      uint32_t rest = op(b, spv::Op::OpUMod, u, {diff, constantU32(magnitude)});
      uint32_t partial = op(b, spv::Op::OpINotEqual, tBool(), {rest, constantU32(0)});
      trips = op(b, spv::Op::OpIAdd, u, {trips, op(b, spv::Op::OpSelect, u, {partial, constantU32(1), constantU32(0)})});
    }
  }
  if (inclusive(c.compare)) trips = op(b, spv::Op::OpIAdd, u, {trips, constantU32(1)});
  uint32_t runs = op(b, c.compare, tBool(), {start, bound});
  return op(b, spv::Op::OpSelect, u, {runs, trips, constantU32(0)});
}

// The trip count of a counted loop entered from the block ending at
// `branch`, where its start and bound are constants there.
std::optional<uint32_t> Injector::constantTrips(const Function& f, const CountedLoop& c, size_t branch,
                                                uint32_t phiValue) const {
  auto constant = [&](uint32_t id) -> std::optional<uint32_t> {
    const Instruction* d = defs_.def(id);
    if (d == nullptr || d->opcode() != spv::Op::OpConstant || d->size() != 4) return std::nullopt;
    return d->word(3);
  };
  if (c.boundLoad != kNever) return std::nullopt;
  auto bound = constant(c.bound);
  std::optional<uint32_t> start = c.phi != 0 ? constant(phiValue) : std::nullopt;
  // A variable: its last store in the entering block (it is only ever stored whole).
  for (size_t at = branch; c.variable != 0 && at-- > 0 && f.insts[at].opcode() != spv::Op::OpLabel;) {
    if (f.insts[at].opcode() == spv::Op::OpStore && f.insts[at].word(1) == c.variable) {
      start = constant(f.insts[at].word(2));
      break;
    }
  }
  if (!start || !bound) return std::nullopt;
  const uint32_t s = *start, b = *bound;
  const bool up = c.step > 0;
  const uint32_t magnitude = up ? uint32_t(c.step) : uint32_t(-int64_t(c.step));
  const uint32_t diff = up ? b - s : s - b;
  if (c.compare == spv::Op::OpINotEqual) return diff;
  bool runs = false;
  switch (c.compare) {
    case spv::Op::OpULessThan: runs = s < b; break;
    case spv::Op::OpULessThanEqual: runs = s <= b; break;
    case spv::Op::OpUGreaterThan: runs = s > b; break;
    case spv::Op::OpUGreaterThanEqual: runs = s >= b; break;
    case spv::Op::OpSLessThan: runs = int32_t(s) < int32_t(b); break;
    case spv::Op::OpSLessThanEqual: runs = int32_t(s) <= int32_t(b); break;
    case spv::Op::OpSGreaterThan: runs = int32_t(s) > int32_t(b); break;
    case spv::Op::OpSGreaterThanEqual: runs = int32_t(s) >= int32_t(b); break;
    default: return std::nullopt;
  }
  if (!runs) return 0u;
  if (inclusive(c.compare)) return diff / magnitude + 1;
  return diff / magnitude + (diff % magnitude != 0 ? 1 : 0);
}

// The slot a counted loop's constant trips, added where it is entered from
// the block ending at `branch`, can be derived from: the trip counter of the
// enclosing loop's class that block is in, or the invocation counter where
// the block runs exactly once in every invocation; nullopt where neither.
std::optional<uint32_t> Injector::entryParent(const FunctionLoops& fl, size_t self, uint32_t entry, int function,
                                              size_t branch, const EntryPoint& ep) {
  const int block = fl.blockAt[branch];
  for (size_t l = 0; l < fl.loops.size(); ++l) {
    const Loop& outer = fl.loops[l];
    if (l == self || outer.classOf[block] < 0 || branch >= outer.mayEndAt[block]) continue;
    auto it = tripSlots_.find({entry, function, l, outer.classOf[block]});
    if (it != tripSlots_.end()) return it->second;
  }
  auto invocations = invocationSlot_.find(entry);
  FoundSite at;
  at.function = function;
  at.instruction = branch;
  at.entryIndex = entry;
  if (invocations != invocationSlot_.end() && runsExactlyOnce(at, ep)) return invocations->second;
  return std::nullopt;
}

void Injector::countLoops(const SiteScan& scan, std::vector<std::map<size_t, std::vector<Instruction>>>& before,
                          const std::vector<uint32_t>& slots) {
  if (!options_.deriveOnceSites) return;
  // (entry point, function, loop, class) -> the sites there that can be derived.
  std::map<TripKey, std::vector<size_t>> groups;
  for (size_t i = 0; i < scan.sites.size(); ++i) {
    const FoundSite& s = scan.sites[i];
    const EntryPoint& ep = scan.entryPoints[s.entryIndex];
    if (!accumulates(ep.stage) || dynamicSlot(s) || s.placement != Placement::AfterInstruction ||
        s.site.kind == SiteKind::Invocation || s.function < 0) {
      continue;
    }
    const FunctionLoops& fl = loopsOf(s.function);
    const int block = s.instruction < fl.blockAt.size() ? fl.blockAt[s.instruction] : -1;
    if (block < 0) continue;
    for (size_t l = 0; l < fl.loops.size(); ++l) {
      const Loop& loop = fl.loops[l];
      if (loop.classOf[block] < 0 || s.instruction >= loop.mayEndAt[block]) continue;
      groups[{s.entryIndex, s.function, l, loop.classOf[block]}].push_back(i);
    }
  }
  // A slot for each class with a counter, and what the reader derives from it.
  std::vector<DerivedCount> derived;
  auto derive = [&](uint32_t from, uint32_t to, uint32_t times) {
    auto same = std::find_if(derived.begin(), derived.end(), [&](const DerivedCount& d) { return d.from == from && d.to == to; });
    if (same != derived.end()) {
      same->times += times;
    } else {
      derived.push_back({from, to, times});
    }
  };
  for (const auto& [key, sites] : groups) {
    const auto& [entry, function, l, cls] = key;
    const Loop& loop = loopsOf(function).loops[l];
    // One site gains nothing from a counter of its own unless it is counted at the entry.
    if (!(loop.counted && cls == loop.everyIteration) && sites.size() < 2) continue;
    const uint32_t trip = result_.firstSlot + result_.slotCount++;
    tripSlots_.emplace(key, trip);
    for (size_t i : sites) {
      loopDerived_.insert(i);
      derive(trip, slots[i], 1);
    }
    LoopNote& note = loopNotes_[scan.entryPoints[entry].stage];
    note.sites += uint32_t(sites.size());
    ++note.counters;
  }
  // The counters' code: an add per iteration, or the trip count at each
  // entry, itself derived where it is a constant at an entry that runs as
  // often as a count the reader has.
  std::map<uint32_t, uint32_t> parentOf;
  for (const auto& [key, trip] : tripSlots_) {
    const auto& [entry, function, l, cls] = key;
    const FunctionLoops& fl = loopsOf(function);
    const Loop& loop = fl.loops[l];
    const EntryPoint& ep = scan.entryPoints[entry];
    const Function& f = m_.functions[function];
    LoopNote& note = loopNotes_[ep.stage];
    bool code = false;
    if (!(loop.counted && cls == loop.everyIteration)) {
      Body b{addsInto(before[function][blockStart(f, fl.labelAt[cls])])};
      increment(b, scalarAccumulator(trip));
      code = true;
    } else {
      ++note.counted;
      for (const auto& [branch, phiValue] : loop.entries) {
        auto trips = constantTrips(f, *loop.counted, branch, phiValue);
        auto parent = trips ? entryParent(fl, l, entry, function, branch, ep) : std::nullopt;
        if (parent) {
          derive(*parent, trip, *trips);
          parentOf[trip] = *parent;
          ++note.fromEnclosing;
          continue;
        }
        Body b{addsInto(before[function][branch])};
        uint32_t amount = trips ? constantU32(*trips) : tripCount(b, f, *loop.counted, phiValue);
        uint32_t pointer = scalarAccumulator(trip);
        uint32_t v = op(b, spv::Op::OpLoad, tU32(), {pointer});
        opNoResult(b, spv::Op::OpStore, {pointer, op(b, spv::Op::OpIAdd, tU32(), {v, amount})});
        code = true;
      }
    }
    if (code) flushSlots_[ep.stage].scalars.insert(trip);
  }
  // A count is derived before what is derived from it.
  auto depth = [&](uint32_t slot) {
    int d = 0;
    for (auto it = parentOf.find(slot); it != parentOf.end(); it = parentOf.find(it->second)) ++d;
    return d;
  };
  std::stable_sort(derived.begin(), derived.end(),
                   [&](const DerivedCount& a, const DerivedCount& b) { return depth(a.from) < depth(b.from); });
  result_.derived.insert(result_.derived.end(), derived.begin(), derived.end());
  for (const auto& [stage, note] : loopNotes_) {
    notes_.push_back("accumulate mode: " + std::to_string(note.sites) + " " + std::string(toString(stage)) +
                     " site" + (note.sites == 1 ? "" : "s") + " in loops derived from " +
                     std::to_string(note.counters) + " trip counter" + (note.counters == 1 ? "" : "s") + " (" +
                     std::to_string(note.counted) + " added once where the loop is entered" +
                     (note.fromEnclosing == 0 ? std::string()
                                              : ", " + std::to_string(note.fromEnclosing) +
                                                    " of those adds derived from an enclosing count") +
                     ")");
  }
}

}  // namespace tally::spirv
