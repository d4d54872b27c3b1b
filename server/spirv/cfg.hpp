// Control flow facts the accumulate mode needs: which instructions can run
// more than once per invocation, and which run exactly once in every
// invocation that returns.
#pragma once

#include <vector>

#include "spirv/module.hpp"

namespace tally::spirv {

// A function's blocks, numbered in order, with their successors.
struct BlockGraph {
  std::vector<int> blockAt;             // per instruction, its block (-1 before the first label)
  std::vector<std::vector<int>> next;   // per block, its successors
  std::vector<bool> returns;            // per block, whether it ends in OpReturn or OpReturnValue
};

BlockGraph blockGraph(const Function& f, const DefIndex& defs);

// Immediate dominators of a graph from `entry` (Cooper, Harvey and
// Kennedy's iterative algorithm over reverse postorder); the entry is its
// own, -1 where unreachable.
std::vector<int> immediateDominators(const std::vector<std::vector<int>>& next, int entry);

// For each instruction of `f`, whether its block lies on a cycle of the
// function's control-flow graph (a loop, structured or not).
std::vector<bool> instructionsInCycles(const Function& f, const DefIndex& defs);

// For each function of `m`, whether it runs at most once per invocation of
// the entry point `entryFunction` (an index into m.functions): the entry
// point itself, and every function called exactly once in the module, from
// outside any loop, by a function that runs at most once. Functions the entry
// point does not reach are false.
std::vector<bool> functionsRunOnce(const Module& m, const DefIndex& defs, int entryFunction);

// For each instruction of `f`, whether every path from the function's first
// block to one of its returns (OpReturn, OpReturnValue) passes through the
// instruction's block: its block dominates every return. All false where no
// return is reachable.
std::vector<bool> instructionsOnEveryReturnPath(const Function& f, const DefIndex& defs);

// For each function of `m`, whether it runs exactly once in every invocation
// of the entry point `entryFunction` that returns: the entry point, and every
// function that runs at most once (functionsRunOnce) and is called from a
// block that every return of its caller passes through, its caller being
// such a function too.
std::vector<bool> functionsRunExactlyOnce(const Module& m, const DefIndex& defs, int entryFunction);

// Whether an invocation of the entry point can end other than by returning:
// OpKill, OpTerminateInvocation, OpDemoteToHelperInvocation (a helper is not
// counted), OpEmitMeshTasksEXT, or the ray-tracing terminators, in any
// function the entry point reaches.
bool endsOtherThanByReturn(const Module& m, int entryFunction);

}  // namespace tally::spirv
