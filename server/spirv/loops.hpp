// Structured loops, for the accumulate mode: which blocks run exactly as
// often as one another within a loop's iterations, and where a loop's trip
// count is known at its entry (docs/measurement.md, "The accumulate mode",
// "Sites in loops").
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "spirv/module.hpp"

namespace tally::spirv {

constexpr size_t kNever = ~size_t(0);

// A canonical counted loop: an induction variable that starts at a value
// known before the loop, steps by a constant each iteration, and is
// compared in the loop's only exit test against a bound that does not
// change inside the loop. The loop runs while `induction compare bound`.
struct CountedLoop {
  spv::Op compare = spv::Op::OpNop;  // a 32-bit integer comparison (never OpIEqual)
  int32_t step = 0;
  uint32_t phi = 0;       // the induction variable: an OpPhi of the header, or
  uint32_t variable = 0;  // a Function variable, read at the loop's entry
  uint32_t bound = 0;     // the bound: an id available at the loop's entry, or
  size_t boundLoad = kNever;  // the instruction index of a load to repeat there
  size_t stepStore = kNever;  // the variable's one store in the loop (variable = load + step)
};

struct Loop {
  int header = -1;  // its header's block
  // Per block of the function: the first block of its class, or -1. A class
  // is a set of blocks that run exactly as often as one another in every
  // iteration (each dominates or post-dominates the others within one
  // iteration, none on a nested cycle); the first dominates the rest.
  std::vector<int> classOf;
  // Per block: the first instruction where the invocation may end or
  // stop being counted (OpDemoteToHelperInvocation, a call to a function
  // that can), kNever where none. A site after it runs less often than its class.
  std::vector<size_t> mayEndAt;
  // The class that runs once in every iteration that passes the exit test,
  // when the loop is counted (-1 otherwise).
  int everyIteration = -1;
  std::optional<CountedLoop> counted;
  std::vector<bool> in;        // per block: on the loop's cycle (nested loops' blocks too)
  std::vector<int> iterIdom;   // per block: its immediate dominator within one iteration
  // Each entry into the loop from outside: the instruction index of the
  // OpBranch to the header, and the OpPhi's value for it (counted.phi).
  std::vector<std::pair<size_t, uint32_t>> entries;
};

namespace detail {
struct FunctionGraph;  // the function's blocks, dominators and definitions (loops.cpp)
}

struct FunctionLoops {
  std::vector<int> blockAt;     // per instruction, its block (-1 before the first label)
  std::vector<size_t> labelAt;  // per block, its OpLabel's index
  std::vector<Loop> loops;
  std::shared_ptr<const detail::FunctionGraph> graph;
};

// The structured loops (OpLoopMerge) of function `function` of `m`.
FunctionLoops findLoops(const Module& m, const DefIndex& defs, int function);

// Whether `id` holds the same value in every iteration of `loop` and can be
// had at its entry: a constant, a parameter, a value defined before the
// loop, or (returned as `load`, the instruction index of a load to repeat
// there) a load inside the loop from memory the loop cannot change: a
// Function variable it never stores, a push constant, a uniform block.
bool invariantIn(const FunctionLoops& fl, const Loop& loop, uint32_t id, size_t& load);

// Whether block `a` dominates block `b` in the dominator tree `idom`.
bool dominates(const std::vector<int>& idom, int a, int b);

// Where code that runs at the start of block `block` goes: after its label and OpPhis.
size_t blockStart(const Function& f, size_t labelIndex);

}  // namespace tally::spirv
