// Control flow facts the accumulate mode needs: which instructions can run
// more than once per invocation.
#pragma once

#include <vector>

#include "spirv/module.hpp"

namespace tally::spirv {

// For each instruction of `f`, whether its block lies on a cycle of the
// function's control-flow graph (a loop, structured or not).
std::vector<bool> instructionsInCycles(const Function& f, const DefIndex& defs);

// For each function of `m`, whether it runs at most once per invocation of
// the entry point `entryFunction` (an index into m.functions): the entry
// point itself, and every function called exactly once in the module, from
// outside any loop, by a function that runs at most once. Functions the entry
// point does not reach are false.
std::vector<bool> functionsRunOnce(const Module& m, const DefIndex& defs, int entryFunction);

}  // namespace tally::spirv
