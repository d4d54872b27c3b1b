// Twin pipelines: the application's pipeline is created exactly as it asked,
// and the handle it holds is that one; each pipeline the layer instruments
// also gets a twin from the same create info with the instrumented stages,
// bound instead only in command buffers recorded for counting (docs/layer.md).
// Outside the counted window the application runs its own shaders.
#include "state.hpp"

namespace tally::layer {
namespace {

// A twin is created on its own, one pipeline per call: not a derivative of
// the application's batch, no early return, and compiled whatever the
// application allowed its cache to do.
template <class Info>
Info twinInfo(Info info) {
  info.flags &= ~VkPipelineCreateFlags(VK_PIPELINE_CREATE_DERIVATIVE_BIT |
                                       VK_PIPELINE_CREATE_FAIL_ON_PIPELINE_COMPILE_REQUIRED_BIT |
                                       VK_PIPELINE_CREATE_EARLY_RETURN_ON_FAILURE_BIT);
  info.basePipelineHandle = VK_NULL_HANDLE;
  info.basePipelineIndex = -1;
  return info;
}

template <class Info, class Create>
void createTwins(DeviceState& dev, const std::vector<Info>& patched,
                 const std::vector<std::shared_ptr<PipelineInfo>>& states, Create create) {
  uint32_t refused = 0;
  for (size_t i = 0; i < patched.size(); ++i) {
    PipelineInfo& state = *states[i];
    if (!state.counted || state.inPlace) continue;  // the application's pipeline is the instrumented one
    const Info info = twinInfo(patched[i]);
    // Without the application's pipeline cache: twins stay out of what it may save.
    if (create(info, &state.instrumented) != VK_SUCCESS) {
      state.instrumented = VK_NULL_HANDLE;
      state.counted = false;
      ++refused;
    }
  }
  if (refused == 0) return;
  std::lock_guard lock(dev.mutex);
  dev.notes.insert("the driver refused an instrumented pipeline: the application's own runs there, uncounted");
}

}  // namespace

void createGraphicsTwins(DeviceState& dev, const std::vector<VkGraphicsPipelineCreateInfo>& patched,
                         const std::vector<std::shared_ptr<PipelineInfo>>& states) {
  createTwins(dev, patched, states, [&](const VkGraphicsPipelineCreateInfo& info, VkPipeline* out) {
    return dev.d.CreateGraphicsPipelines(dev.device, VK_NULL_HANDLE, 1, &info, nullptr, out);
  });
}

void createComputeTwins(DeviceState& dev, const std::vector<VkComputePipelineCreateInfo>& patched,
                        const std::vector<std::shared_ptr<PipelineInfo>>& states) {
  createTwins(dev, patched, states, [&](const VkComputePipelineCreateInfo& info, VkPipeline* out) {
    return dev.d.CreateComputePipelines(dev.device, VK_NULL_HANDLE, 1, &info, nullptr, out);
  });
}

}  // namespace tally::layer
