// Shader modules: from SPIR-V words, or from GLSL compiled at run time and
// instrumented at pipeline creation (STYLE 6).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

#include "common/result.hpp"
#include "gpu/context.hpp"
#include "gpu/glsl.hpp"
#include "spirv/instrument.hpp"

namespace tally::gpu {

VkShaderModule createShaderModule(const Context& ctx, std::span<const uint32_t> words);
void destroyShaderModule(const Context& ctx, VkShaderModule& module);

// The newest GLSL target (and so SPIR-V version) the device accepts.
glsl::Target glslTarget(const Context& ctx);

// Instrumentation options that this device can run: Int64 counters where
// shaderBufferInt64Atomics is present (Uint32Pair otherwise), and subgroup
// counting only in the stages whose subgroup operations the device supports.
// Given the module, also: on ctx.volatileHelperInvocationCrashes devices,
// fragment subgroup counting of a module that demotes (and so needs a
// volatile HelperInvocation read) falls back to exact, with a note.
spirv::InstrumentOptions instrumentOptionsFor(const Context& ctx, spirv::Mode mode, uint32_t firstSlot = 0,
                                              std::span<const uint32_t> module = {});

// Why an instrumented module cannot run on this device ("" when it can):
// 64-bit counters without int64 atomics, counters in a stage without stores
// and atomics (fragmentStoresAndAtomics, vertexPipelineStoresAndAtomics).
std::string unsupportedReason(const Context& ctx, spirv::Stage stage,
                              const spirv::InstrumentOptions& options);

Result<std::string> readTextFile(const std::string& path);

struct ShaderStageSource {
  std::string source;  // GLSL text
  spirv::Stage stage = spirv::Stage::Other;
  glsl::CompileOptions compile;
};

// A stage's GLSL, compiled and (unless `instrument` is false) instrumented.
struct CompiledShader {
  spirv::Stage stage = spirv::Stage::Other;
  std::vector<uint32_t> words;  // what the module is created from
  bool instrumented = false;
  spirv::Instrumented result;  // sites and slots when instrumented
};

Result<CompiledShader> compileShader(const ShaderStageSource& source);
// `options` as from instrumentOptionsFor(ctx, ...); the module-dependent
// quirks are applied here, once the module's version is known.
Result<CompiledShader> compileAndInstrument(const Context& ctx, const ShaderStageSource& source,
                                            spirv::InstrumentOptions options);

// Reads <dir>/<name>, takes the stage from the file name (<pass>.<stage>.glsl)
// and compiles it for the context's Vulkan version, with `dir` as include folder.
Result<ShaderStageSource> loadShaderSource(const Context& ctx, const std::string& dir,
                                           const std::string& name);

}  // namespace tally::gpu
