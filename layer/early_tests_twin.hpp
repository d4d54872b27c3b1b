// Early fragment tests where alpha to coverage is dynamic state (zink sets
// it at every draw). The application's pipeline keeps its fragment shader's
// late tests, which are right whatever alpha to coverage is; the layer also
// creates a twin whose fragment shader was given early tests (same sites,
// same slots) and binds it in the application's place at each draw while
// alpha to coverage is off, so the application keeps its early depth test.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "shader_options.hpp"
#include "state.hpp"

namespace tally::layer {

// How a graphics pipeline's fragment shader is instrumented.
struct EarlyTestsPlan {
  std::string lateWhy;  // what in the pipeline's state forbids early tests ("": nothing)
  bool twin = false;    // alpha to coverage is dynamic: late tests here, early tests in a twin
  VkShaderModule earlyFragment = VK_NULL_HANDLE;  // out: the twin's fragment module, where it has one
  // Whether the application's own pipeline may be given early tests.
  bool early() const { return lateWhy.empty() && !twin; }
};
EarlyTestsPlan earlyTestsPlan(const VkGraphicsPipelineCreateInfo& info);

// The twin's fragment module: `words` instrumented as `late` was but with
// early tests. VK_NULL_HANDLE where that adds nothing (the shader declares
// them, or cannot have them) or fails; `notes` become the early module's.
VkShaderModule earlyTestsFragment(DeviceState& dev, const std::vector<uint32_t>& words,
                                  spirv::InstrumentOptions options, const spirv::Instrumented& late,
                                  std::vector<std::string>& notes);

// Creates the twin of each pipeline that `earlyFragments` gives a module
// for, and destroys those modules. A twin that fails is left out, and the
// pipeline keeps its late tests.
void createEarlyTestsTwins(DeviceState& dev, VkPipelineCache cache, const std::vector<VkGraphicsPipelineCreateInfo>& infos,
                           const std::vector<VkShaderModule>& earlyFragments, const VkPipeline* pipelines,
                           const std::vector<std::shared_ptr<PipelineInfo>>& states);

// Before a draw: the twin while alpha to coverage is off, the application's
// pipeline otherwise. Under the device's mutex.
void bindForCoverage(DeviceState& dev, CommandBufferState& cb);

}  // namespace tally::layer
