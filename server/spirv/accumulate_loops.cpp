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
// iteration adds the trip count once, before the loop, and nothing inside.
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

// The loop's trip count, computed where it is entered: u32, 0 where the test fails at once.
uint32_t Injector::tripCount(Body& b, const Function& f, const CountedLoop& c, uint32_t phiValue) {
  uint32_t u = tU32();
  uint32_t start = phiValue;
  if (c.variable != 0) {
    const Instruction* pointerType = defs_.def(defs_.def(c.variable)->resultType());
    start = op(b, spv::Op::OpLoad, pointerType->word(3), {c.variable});
  }
  uint32_t bound = c.bound;
  if (c.boundLoad != kNever) {
    const Instruction& load = f.insts[c.boundLoad];
    uint32_t pointer = load.word(3);
    const Instruction* chain = defs_.def(pointer);
    if (chain != nullptr && defs_.functionOf(pointer) >= 0 &&
        (chain->opcode() == spv::Op::OpAccessChain || chain->opcode() == spv::Op::OpInBoundsAccessChain)) {
      std::vector<uint32_t> operands(chain->words.begin() + 3, chain->words.end());
      pointer = op(b, chain->opcode(), chain->resultType(), operands);
    }
    bound = op(b, spv::Op::OpLoad, load.resultType(), {pointer});
  }
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

void Injector::countLoops(const SiteScan& scan, std::vector<std::map<size_t, std::vector<Instruction>>>& before,
                          const std::vector<uint32_t>& slots) {
  if (!options_.deriveOnceSites) return;
  // (entry point, function, loop, class) -> the sites there that can be derived.
  std::map<std::tuple<uint32_t, int, size_t, int>, std::vector<size_t>> groups;
  std::map<int, FunctionLoops> loopsOf;
  for (size_t i = 0; i < scan.sites.size(); ++i) {
    const FoundSite& s = scan.sites[i];
    const EntryPoint& ep = scan.entryPoints[s.entryIndex];
    if (!accumulates(ep.stage) || dynamicSlot(s) || s.placement != Placement::AfterInstruction ||
        s.site.kind == SiteKind::Invocation || s.function < 0) {
      continue;
    }
    auto [at, fresh] = loopsOf.try_emplace(s.function);
    if (fresh) at->second = findLoops(m_, defs_, s.function);
    const FunctionLoops& fl = at->second;
    const int block = s.instruction < fl.blockAt.size() ? fl.blockAt[s.instruction] : -1;
    if (block < 0) continue;
    for (size_t l = 0; l < fl.loops.size(); ++l) {
      const Loop& loop = fl.loops[l];
      if (loop.classOf[block] < 0 || s.instruction >= loop.mayEndAt[block]) continue;
      groups[{s.entryIndex, s.function, l, loop.classOf[block]}].push_back(i);
    }
  }
  for (const auto& [key, sites] : groups) {
    const auto& [entry, function, l, cls] = key;
    const Loop& loop = loopsOf[function].loops[l];
    const bool counted = loop.counted && cls == loop.everyIteration;
    // One site gains nothing from a counter of its own unless it is counted at the entry.
    if (!counted && sites.size() < 2) continue;
    const Stage stage = scan.entryPoints[entry].stage;
    const uint32_t trip = result_.firstSlot + result_.slotCount++;
    for (size_t i : sites) {
      loopDerived_.insert(i);
      auto same = std::find_if(result_.derived.begin(), result_.derived.end(),
                               [&](const DerivedCount& d) { return d.from == trip && d.to == slots[i]; });
      if (same != result_.derived.end()) {
        ++same->times;
      } else {
        result_.derived.push_back({trip, slots[i], 1});
      }
    }
    flushSlots_[stage].scalars.insert(trip);
    LoopNote& note = loopNotes_[stage];
    note.sites += uint32_t(sites.size());
    ++note.counters;
    const Function& f = m_.functions[function];
    if (!counted) {
      Body b{before[function][blockStart(f, loopsOf[function].labelAt[cls])]};
      increment(b, scalarAccumulator(trip));
      continue;
    }
    ++note.counted;
    for (const auto& [branch, phiValue] : loop.entries) {
      Body b{before[function][branch]};
      uint32_t trips = tripCount(b, f, *loop.counted, phiValue);
      uint32_t pointer = scalarAccumulator(trip);
      uint32_t v = op(b, spv::Op::OpLoad, tU32(), {pointer});
      opNoResult(b, spv::Op::OpStore, {pointer, op(b, spv::Op::OpIAdd, tU32(), {v, trips})});
    }
  }
  for (const auto& [stage, note] : loopNotes_) {
    notes_.push_back("accumulate mode: " + std::to_string(note.sites) + " " + std::string(toString(stage)) +
                     " site" + (note.sites == 1 ? "" : "s") + " in loops derived from " +
                     std::to_string(note.counters) + " trip counter" + (note.counters == 1 ? "" : "s") + " (" +
                     std::to_string(note.counted) + " added once where the loop is entered)");
  }
}

}  // namespace tally::spirv
