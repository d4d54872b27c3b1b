#include "spirv/validate.hpp"

#include <algorithm>
#include <utility>

#include <spirv-tools/libspirv.hpp>
#include <spirv-tools/optimizer.hpp>

namespace tally::spirv {
namespace {

// The environments in the order each allows more than the last.
constexpr spv_target_env kEnvironments[] = {SPV_ENV_VULKAN_1_0, SPV_ENV_VULKAN_1_1, SPV_ENV_VULKAN_1_1_SPIRV_1_4,
                                            SPV_ENV_VULKAN_1_2, SPV_ENV_VULKAN_1_3};

// The rank in kEnvironments of the environment a module's SPIR-V version needs.
int moduleRank(std::span<const uint32_t> words) {
  uint32_t version = words.size() > 1 ? words[1] : 0;
  switch ((version >> 8) & 0xffff) {
    case 0x0100: return 0;
    case 0x0101:
    case 0x0102:
    case 0x0103: return 1;
    case 0x0104: return 2;
    case 0x0105: return 3;
    default: return 4;
  }
}

// The rank of the environment of a Vulkan version (0: none known). A 1.1
// device may also take SPIR-V 1.4 through VK_KHR_spirv_1_4; the module's
// version asks for that environment itself.
int vulkanRank(uint32_t apiVersion) {
  const uint32_t major = apiVersion >> 22, minor = (apiVersion >> 12) & 0x3ff;
  if (major == 0 || (major == 1 && minor == 0)) return 0;
  if (major == 1 && minor == 1) return 1;
  if (major == 1 && minor == 2) return 3;
  return 4;
}

spv_target_env envFor(std::span<const uint32_t> words) { return kEnvironments[moduleRank(words)]; }

spv_target_env envFor(std::span<const uint32_t> words, const ValidationTarget& target) {
  return kEnvironments[std::max(moduleRank(words), vulkanRank(target.vulkanVersion))];
}

}  // namespace

std::optional<std::string> validate(std::span<const uint32_t> words, const ValidationTarget& target) {
  if (words.size() < 5) return "truncated SPIR-V: shorter than the 5-word header";
  spvtools::SpirvTools tools(envFor(words, target));
  std::string first;
  tools.SetMessageConsumer([&first](spv_message_level_t level, const char*, const spv_position_t& position,
                                    const char* message) {
    if (level > SPV_MSG_ERROR || !first.empty()) return;
    first = std::string(message) + " (at word " + std::to_string(position.index) + ")";
  });
  spvtools::ValidatorOptions options;
  // Each only widens what is valid: the environment of Vulkan 1.1 and later
  // already relaxes block layout and 1.3's allows LocalSizeId.
  options.SetRelaxBlockLayout(target.relaxedBlockLayout);
  options.SetUniformBufferStandardLayout(target.uniformBufferStandardLayout);
  options.SetScalarBlockLayout(target.scalarBlockLayout);
  options.SetWorkgroupScalarBlockLayout(target.workgroupScalarBlockLayout);
  options.SetAllowLocalSizeId(target.localSizeId);
  if (tools.Validate(words.data(), words.size(), options)) return std::nullopt;
  if (first.empty()) first = "validation failed";
  // Keep it to one line: the validator appends disassembly on new lines.
  for (auto& c : first) {
    if (c == '\n') c = ' ';
  }
  return first;
}

std::string describe(const ValidationTarget& target) {
  std::string text = target.vulkanVersion == 0 ? std::string("the module's own Vulkan version")
                                               : "Vulkan " + std::to_string(target.vulkanVersion >> 22) + "." +
                                                     std::to_string((target.vulkanVersion >> 12) & 0x3ff);
  const std::pair<bool, const char*> relaxations[] = {
      {target.relaxedBlockLayout, "relaxed block layout"},
      {target.uniformBufferStandardLayout, "uniform buffer standard layout"},
      {target.scalarBlockLayout, "scalar block layout"},
      {target.workgroupScalarBlockLayout, "workgroup scalar block layout"},
      {target.localSizeId, "LocalSizeId"},
  };
  for (const auto& [on, name] : relaxations) {
    if (on) text += std::string(", ") + name;
  }
  return text;
}

Result<std::vector<uint32_t>> inlineAll(std::span<const uint32_t> words) {
  spvtools::Optimizer optimizer(envFor(words));
  std::string first;
  optimizer.SetMessageConsumer([&first](spv_message_level_t level, const char*, const spv_position_t&,
                                        const char* message) {
    if (level <= SPV_MSG_ERROR && first.empty()) first = message;
  });
  optimizer.RegisterPass(spvtools::CreateInlineExhaustivePass());
  optimizer.RegisterPass(spvtools::CreateEliminateDeadFunctionsPass());
  spvtools::OptimizerOptions options;
  options.set_run_validator(false);  // the input was validated already
  std::vector<uint32_t> out;
  if (!optimizer.Run(words.data(), words.size(), &out, options)) {
    return makeError("inlining failed: " + (first.empty() ? std::string("unknown optimizer error") : first));
  }
  return out;
}

}  // namespace tally::spirv
