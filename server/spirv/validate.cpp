#include "spirv/validate.hpp"

#include <spirv-tools/libspirv.hpp>
#include <spirv-tools/optimizer.hpp>

namespace tally::spirv {
namespace {

spv_target_env envFor(std::span<const uint32_t> words) {
  uint32_t version = words.size() > 1 ? words[1] : 0;
  switch ((version >> 8) & 0xffff) {
    case 0x0100: return SPV_ENV_VULKAN_1_0;
    case 0x0101:
    case 0x0102:
    case 0x0103: return SPV_ENV_VULKAN_1_1;
    case 0x0104: return SPV_ENV_VULKAN_1_1_SPIRV_1_4;
    case 0x0105: return SPV_ENV_VULKAN_1_2;
    default: return SPV_ENV_VULKAN_1_3;
  }
}

}  // namespace

std::optional<std::string> validate(std::span<const uint32_t> words) {
  if (words.size() < 5) return "truncated SPIR-V: shorter than the 5-word header";
  spvtools::SpirvTools tools(envFor(words));
  std::string first;
  tools.SetMessageConsumer([&first](spv_message_level_t level, const char*, const spv_position_t& position,
                                    const char* message) {
    if (level > SPV_MSG_ERROR || !first.empty()) return;
    first = std::string(message) + " (at word " + std::to_string(position.index) + ")";
  });
  spvtools::ValidatorOptions options;
  if (tools.Validate(words.data(), words.size(), options)) return std::nullopt;
  if (first.empty()) first = "validation failed";
  // Keep it to one line: the validator appends disassembly on new lines.
  for (auto& c : first) {
    if (c == '\n') c = ' ';
  }
  return first;
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
