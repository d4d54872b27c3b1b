// Helpers shared by the SPIR-V unit tests: GLSL or assembly in, words out,
// disassembly for line-by-line expectations (SPIRV-Tools pass-fixture style).
#pragma once

#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <spirv-tools/libspirv.hpp>

#include "gpu/glsl.hpp"
#include "spirv/instrument.hpp"

namespace tally::test {

inline std::vector<uint32_t> compileGlsl(const std::string& source, spirv::Stage stage,
                                         glsl::Target target = glsl::Target::Vulkan13) {
  glsl::CompileOptions options;
  options.target = target;
  auto words = glsl::compile(source, stage, options);
  EXPECT_TRUE(words.ok()) << (words.ok() ? "" : words.error());
  return words.ok() ? *words : std::vector<uint32_t>{};
}

inline std::vector<uint32_t> assemble(const std::string& text, spv_target_env env = SPV_ENV_VULKAN_1_3) {
  spvtools::SpirvTools tools(env);
  std::string error;
  tools.SetMessageConsumer([&error](spv_message_level_t, const char*, const spv_position_t& p, const char* m) {
    error += "line " + std::to_string(p.line) + ": " + m + "\n";
  });
  std::vector<uint32_t> words;
  EXPECT_TRUE(tools.Assemble(text, &words)) << error;
  return words;
}

inline std::string disassemble(const std::vector<uint32_t>& words) {
  spvtools::SpirvTools tools(SPV_ENV_VULKAN_1_3);
  std::string text;
  tools.Disassemble(words, &text, SPV_BINARY_TO_TEXT_OPTION_FRIENDLY_NAMES | SPV_BINARY_TO_TEXT_OPTION_NO_HEADER);
  return text;
}

inline spirv::Instrumented instrumentOk(const std::vector<uint32_t>& words, const spirv::InstrumentOptions& options = {}) {
  auto result = spirv::instrument(words, options);
  EXPECT_TRUE(result.ok()) << (result.ok() ? "" : result.error());
  return result.ok() ? *result : spirv::Instrumented{};
}

inline std::vector<const spirv::Site*> sitesOf(const spirv::Instrumented& r, spirv::SiteKind kind) {
  std::vector<const spirv::Site*> out;
  for (const auto& s : r.sites) {
    if (s.kind == kind) out.push_back(&s);
  }
  return out;
}

}  // namespace tally::test
