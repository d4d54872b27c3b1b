#include "gpu/shaders.hpp"

#include <algorithm>
#include <fstream>
#include <sstream>

#include "gpu/vk_check.hpp"

namespace tally::gpu {

VkShaderModule createShaderModule(const Context& ctx, std::span<const uint32_t> words) {
  VkShaderModuleCreateInfo info = {VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  info.codeSize = words.size() * sizeof(uint32_t);
  info.pCode = words.data();
  VkShaderModule module = VK_NULL_HANDLE;
  VK_CHECK(vkCreateShaderModule(ctx.device, &info, nullptr, &module));
  return module;
}

void destroyShaderModule(const Context& ctx, VkShaderModule& module) {
  if (module != VK_NULL_HANDLE) vkDestroyShaderModule(ctx.device, module, nullptr);
  module = VK_NULL_HANDLE;
}

glsl::Target glslTarget(const Context& ctx) {
  if (ctx.apiVersion >= VK_API_VERSION_1_3) return glsl::Target::Vulkan13;
  if (ctx.apiVersion >= VK_API_VERSION_1_2) return glsl::Target::Vulkan12;
  if (ctx.apiVersion >= VK_API_VERSION_1_1) return glsl::Target::Vulkan11;
  return glsl::Target::Vulkan10;
}

spirv::InstrumentOptions instrumentOptionsFor(const Context& ctx, spirv::Mode mode, uint32_t firstSlot,
                                              std::span<const uint32_t> module) {
  spirv::InstrumentOptions options;
  options.mode = mode;
  options.firstSlot = firstSlot;
  options.width = ctx.int64Atomics ? spirv::CounterWidth::Int64 : spirv::CounterWidth::Uint32Pair;
  options.subgroupStages = ctx.subgroupStages;
  options.partitionedStages = ctx.subgroupPartitionedStages;
  // NVIDIA combines a warp's same-address atomics in the graphics stages,
  // where an explicit reduction costs more (H200: tonemap x2.2 reduced, x1.5
  // per lane); lavapipe does not (tonemap x2.0 reduced, x6.4 per lane), nor
  // does any device in compute (H200 ray tracer: x2.9 reduced, x18.8 per lane).
  constexpr uint32_t kNvidiaVendorId = 0x10DE;
  using spirv::Stage;
  options.autoLaneStages = ctx.properties.vendorID == kNvidiaVendorId
                               ? spirv::stageBit(Stage::Vertex) | spirv::stageBit(Stage::TessControl) |
                                     spirv::stageBit(Stage::TessEval) | spirv::stageBit(Stage::Geometry) |
                                     spirv::stageBit(Stage::Fragment)
                               : 0u;
  // Keep the counter buffer in the last set the device can bind (lavapipe: 8 sets, so set 7).
  options.set = std::min<uint32_t>(options.set, ctx.limits.maxBoundDescriptorSets - 1);
  // Subgroup mode reads HelperInvocation volatile in modules that demote,
  // which Mesa 22.3's lavapipe cannot compile: count those exactly there.
  if (ctx.volatileHelperInvocationCrashes && spirv::usesDemote(module)) {
    options.subgroupStages &= ~spirv::stageBit(spirv::Stage::Fragment);
  }
  return options;
}

std::string unsupportedReason(const Context& ctx, spirv::Stage stage,
                              const spirv::InstrumentOptions& options) {
  using spirv::Stage;
  if (options.width == spirv::CounterWidth::Int64 && !ctx.int64Atomics) {
    return "64-bit counters need shaderInt64 and shaderBufferInt64Atomics; use uint32_pair";
  }
  if (stage == Stage::Fragment && !ctx.fragmentStoresAndAtomics) {
    return "the device has no fragmentStoresAndAtomics";
  }
  bool preRaster = stage == Stage::Vertex || stage == Stage::TessControl || stage == Stage::TessEval ||
                   stage == Stage::Geometry;
  if (preRaster && !ctx.vertexPipelineStoresAndAtomics)
    return "the device has no vertexPipelineStoresAndAtomics";
  if (options.set >= ctx.limits.maxBoundDescriptorSets) {
    return "counter set " + std::to_string(options.set) + " is past maxBoundDescriptorSets (" +
           std::to_string(ctx.limits.maxBoundDescriptorSets) + ")";
  }
  return "";
}

Result<std::string> readTextFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return makeError(path + ": cannot open");
  std::stringstream text;
  text << in.rdbuf();
  if (in.bad()) return makeError(path + ": read error");
  return text.str();
}

Result<CompiledShader> compileShader(const ShaderStageSource& source) {
  auto words = glsl::compile(source.source, source.stage, source.compile);
  if (!words) return makeError(words.error());
  CompiledShader shader;
  shader.stage = source.stage;
  shader.words = std::move(*words);
  return shader;
}

Result<CompiledShader> compileAndInstrument(const Context& ctx, const ShaderStageSource& source,
                                            spirv::InstrumentOptions options) {
  auto words = glsl::compile(source.source, source.stage, source.compile);
  if (!words) return makeError(words.error());
  options.subgroupStages &= instrumentOptionsFor(ctx, options.mode, options.firstSlot, *words).subgroupStages;
  auto result = spirv::instrument(*words, options);
  if (!result) return makeError(source.compile.fileName + ": " + result.error());
  CompiledShader shader;
  shader.stage = source.stage;
  shader.words = result->words;
  shader.instrumented = true;
  shader.result = std::move(*result);
  return shader;
}

Result<ShaderStageSource> loadShaderSource(const Context& ctx, const std::string& dir,
                                           const std::string& name) {
  auto stage = glsl::stageFromFileName(name);
  if (!stage) return makeError(stage.error());
  auto text = readTextFile(dir + "/" + name);
  if (!text) return makeError(text.error());
  ShaderStageSource source;
  source.source = std::move(*text);
  source.stage = *stage;
  source.compile.target = glslTarget(ctx);
  source.compile.fileName = name;
  source.compile.includeDirs = {dir};
  return source;
}

}  // namespace tally::gpu
