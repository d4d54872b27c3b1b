// GLSL -> SPIR-V at run time with glslang. No Vulkan dependency.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "common/result.hpp"
#include "spirv/sites.hpp"

namespace tally::glsl {

// Vulkan 1.0 -> SPIR-V 1.0, 1.1 -> 1.3, 1.2 -> 1.5, 1.3 -> 1.6.
enum class Target { Vulkan10, Vulkan11, Vulkan12, Vulkan13 };

struct CompileOptions {
  Target target = Target::Vulkan13;
  bool debugInfo = false;          // emit OpLine/OpSource (file:line in site tables)
  std::string fileName = "shader";  // used in messages and OpLine
  std::vector<std::string> includeDirs;  // for #include "..."
};

// Compiles one stage. The error names the file and glslang's message.
Result<std::vector<uint32_t>> compile(std::string_view source, spirv::Stage stage,
                                      const CompileOptions& options = {});

// The stage for a file named <pass>.<stage>.glsl or *.vert/*.frag/*.comp...
Result<spirv::Stage> stageFromFileName(std::string_view fileName);

}  // namespace tally::glsl
