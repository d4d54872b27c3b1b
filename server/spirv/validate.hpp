// SPIRV-Tools glue: validation and the optimizer passes Tally borrows.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "common/result.hpp"

namespace tally::spirv {

// What the device that will run a module allows beyond the defaults of its
// Vulkan version: a module valid there must not be refused for a rule the
// device relaxed. The default target is the strictest reading, the one the
// built-in renderers' own shaders are held to.
struct ValidationTarget {
  // The Vulkan version the module runs under (VK_MAKE_API_VERSION's
  // encoding: major << 22 | minor << 12); 0 when unknown, then the module's
  // SPIR-V version alone picks the environment.
  uint32_t vulkanVersion = 0;
  bool relaxedBlockLayout = false;           // VK_KHR_relaxed_block_layout (core, and on by itself, from 1.1)
  bool uniformBufferStandardLayout = false;  // uniform blocks may use storage-buffer (std430) layout
  bool scalarBlockLayout = false;            // every block may use scalar layout
  bool workgroupScalarBlockLayout = false;   // workgroupMemoryExplicitLayoutScalarBlockLayout
  bool localSizeId = false;                  // maintenance4 (core in 1.3): LocalSizeId execution modes

  bool operator==(const ValidationTarget&) const = default;
};

// Validates under the Vulkan environment that both the module and the target
// allow: the later of the one the module's SPIR-V version needs (1.0 ->
// Vulkan 1.0, 1.3 -> 1.1, 1.4 -> 1.1 + SPIR-V 1.4, 1.5 -> 1.2, 1.6 -> 1.3)
// and the target's Vulkan version, with the target's layout relaxations.
// Returns the first error, or nullopt when valid.
std::optional<std::string> validate(std::span<const uint32_t> words, const ValidationTarget& target = {});

// "Vulkan 1.2, scalar block layout, ...": how a target reads in a reason.
std::string describe(const ValidationTarget& target);

// Inlines every function call (SPIRV-Tools' exhaustive inliner), so that each
// access is in its entry point's function and its resource is visible.
Result<std::vector<uint32_t>> inlineAll(std::span<const uint32_t> words);

}  // namespace tally::spirv
