// SPIRV-Tools glue: validation and the optimizer passes Tally borrows.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "common/result.hpp"

namespace tally::spirv {

// Validates under the Vulkan environment that matches the module's SPIR-V
// version (1.0 -> Vulkan 1.0, 1.3 -> 1.1, 1.4 -> 1.1+SPIR-V 1.4, 1.5 -> 1.2,
// 1.6 -> 1.3). Returns the first error, or nullopt when valid.
std::optional<std::string> validate(std::span<const uint32_t> words);

// Inlines every function call (SPIRV-Tools' exhaustive inliner), so that each
// access is in its entry point's function and its resource is visible.
Result<std::vector<uint32_t>> inlineAll(std::span<const uint32_t> words);

}  // namespace tally::spirv
