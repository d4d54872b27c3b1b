// What a reader is shown of each site when it counts per site
// (InstrumentOptions::perSite): the function, the instruction's position in
// the module and its disassembly.
#pragma once

#include <vector>

#include "spirv/find_sites.hpp"
#include "spirv/module.hpp"

namespace tally::spirv {

// Fills Site::function, Site::instruction and Site::disassembly of `sites`
// (one per `found`, in order) from the module the sites were found in.
void describeSites(const Module& module, const DefIndex& defs, const std::vector<FoundSite>& found,
                   std::vector<Site>& sites);

}  // namespace tally::spirv
