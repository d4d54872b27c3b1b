// Early fragment tests. The counters are stores, and a fragment shader with
// stores runs before the depth and stencil tests unless it declares
// EarlyFragmentTests: instrumenting a shader that has none would move its
// tests after it, so fragments the tests reject would run, be counted and
// cost. Where the mode changes nothing the shader does, the instrumented
// module declares it; elsewhere a note says why not. docs/measurement.md.
#pragma once

#include <string>
#include <vector>

#include "spirv/find_sites.hpp"
#include "spirv/module.hpp"

namespace tally::spirv {

// Why the fragment entry point `function` cannot run its tests early without
// changing what it does ("it discards (OpKill)", "it writes FragDepth", ...):
// a discard or demote, a depth, stencil or sample-mask output, a store to
// memory others see, an atomic or a debug print, in it or in any function it
// calls. "" when it can.
std::string earlyTestsBlocker(const Module& module, const DefIndex& defs, const Types& types, uint32_t function);

// For each fragment entry point without EarlyFragmentTests: with `add`, gives
// it the mode where earlyTestsBlocker allows; appends a note for each that
// keeps its late tests, saying why. Returns whether it added the mode.
bool preserveEarlyTests(Module& module, const DefIndex& defs, const Types& types,
                        const std::vector<EntryPoint>& entryPoints, bool add, std::vector<std::string>& notes);

}  // namespace tally::spirv
