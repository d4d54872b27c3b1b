// Finds every access site in the functions reachable from each entry point.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/result.hpp"
#include "spirv/module.hpp"
#include "spirv/sites.hpp"
#include "spirv/types.hpp"

namespace tally::spirv {

// Where the counting call goes.
enum class Placement {
  AfterInstruction,  // right after the access
  BeforeReturns,     // before every OpReturn of the entry function (fragment outputs)
  EntryStart,        // at the top of the entry function (invocations)
};

struct FoundSite {
  Site site;                 // all fields but slot/slotCount
  int function = -1;         // index into Module::functions
  size_t instruction = 0;    // index into that function's instructions
  Placement placement = Placement::AfterInstruction;
  uint32_t entryIndex = 0;   // index into EntryPoints
  uint32_t dynamicIndex = 0; // id of the run-time descriptor index, 0 if none
  uint32_t arrayLength = 0;  // descriptor array length for dynamic indices (0: runtime-sized)
  uint32_t address = 0;      // a PhysicalStorageBuffer access: the pointer whose address picks the slot
  // The instruction a reader is shown (Site::instruction): the access, or
  // for an output write the first store to the output; function -1: none.
  int shownFunction = -1;
  size_t shownInstruction = 0;
};

struct EntryPoint {
  spv::ExecutionModel model;
  Stage stage;
  uint32_t function;   // function id
  int functionIndex;   // index into Module::functions
  std::string name;
  size_t instIndex;    // index into Module::entryPoints
  std::vector<uint32_t> interface;
};

struct SiteScan {
  std::vector<EntryPoint> entryPoints;
  std::vector<FoundSite> sites;
  // Non-empty when some site can only be resolved after inlining.
  std::string needsInline;
  std::vector<std::string> notes;
};

Stage stageOf(spv::ExecutionModel model);

Result<SiteScan> findSites(const Module& module, const DefIndex& defs, const Types& types);

}  // namespace tally::spirv
