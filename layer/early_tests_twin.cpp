#include "early_tests_twin.hpp"

#include "shader_objects.hpp"

namespace tally::layer {

EarlyTestsPlan earlyTestsPlan(const VkGraphicsPipelineCreateInfo& info) {
  EarlyTestsPlan plan;
  switch (alphaToCoverage(info)) {
    case AlphaToCoverage::On: plan.lateWhy = "it enables alpha to coverage"; break;
    case AlphaToCoverage::Dynamic: plan.twin = true; break;
    case AlphaToCoverage::Off: break;
  }
  return plan;
}

VkShaderModule earlyTestsFragment(DeviceState& dev, const std::vector<uint32_t>& words,
                                  spirv::InstrumentOptions options, const spirv::Instrumented& late,
                                  std::vector<std::string>& notes) {
  options.earlyFragmentTests = true;
  auto early = spirv::instrument(words, options);
  // The twin shares the pipeline's sites and slots: anything else would count into the wrong slots.
  if (!early || !early->earlyTestsAdded || early->sites.size() != late.sites.size() ||
      early->layout().reserved() != late.layout().reserved() || early->derived != late.derived) {
    return VK_NULL_HANDLE;
  }
  VkShaderModuleCreateInfo moduleInfo = {VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  moduleInfo.codeSize = early->words.size() * 4;
  moduleInfo.pCode = early->words.data();
  VkShaderModule module = VK_NULL_HANDLE;
  if (dev.d.CreateShaderModule(dev.device, &moduleInfo, nullptr, &module) != VK_SUCCESS) return VK_NULL_HANDLE;
  notes = early->notes;
  return module;
}

void createEarlyTestsTwins(DeviceState& dev, VkPipelineCache cache, const std::vector<VkGraphicsPipelineCreateInfo>& infos,
                           const std::vector<VkShaderModule>& earlyFragments, const VkPipeline* pipelines,
                           const std::vector<std::shared_ptr<PipelineInfo>>& states) {
  for (size_t i = 0; i < infos.size(); ++i) {
    if (earlyFragments[i] == VK_NULL_HANDLE) continue;
    if (pipelines[i] != VK_NULL_HANDLE) {
      std::vector<VkPipelineShaderStageCreateInfo> stages(infos[i].pStages, infos[i].pStages + infos[i].stageCount);
      for (auto& stage : stages) {
        if (stage.stage == VK_SHADER_STAGE_FRAGMENT_BIT) stage.module = earlyFragments[i];
      }
      VkGraphicsPipelineCreateInfo twin = infos[i];
      twin.pStages = stages.data();
      // Created alone: a base given by its index in the application's batch has no meaning here.
      twin.flags &= ~VkPipelineCreateFlags(VK_PIPELINE_CREATE_DERIVATIVE_BIT);
      twin.basePipelineHandle = VK_NULL_HANDLE;
      twin.basePipelineIndex = -1;
      VkPipeline pipeline = VK_NULL_HANDLE;
      const bool created = dev.d.CreateGraphicsPipelines(dev.device, cache, 1, &twin, nullptr, &pipeline) == VK_SUCCESS;
      std::lock_guard lock(dev.mutex);
      if (created) {
        states[i]->earlyTestsTwin = pipeline;
        dev.notes.insert("a pipeline with dynamic alpha to coverage runs its fragment shader with early tests while "
                         "alpha to coverage is off, with late tests while it is on (rejected fragments counted then)");
      } else {
        dev.notes.insert("a pipeline with dynamic alpha to coverage keeps its fragment shader's late tests: the "
                         "driver refused the layer's copy with early tests");
      }
    }
    dev.d.DestroyShaderModule(dev.device, earlyFragments[i], nullptr);
  }
}

void bindForCoverage(DeviceState& dev, CommandBufferState& cb) {
  if (cb.shaders[kFragmentShaderIndex] != 0) return bindShadersForCoverage(dev, cb);  // a fragment shader object
  const auto& pipeline = cb.bind[0].pipeline;
  if (!pipeline || pipeline->earlyTestsTwin == VK_NULL_HANDLE) return;
  const bool twin = cb.coverage.known && !cb.coverage.alphaToCoverage;
  if (twin == cb.coverage.twinBound) return;
  // Both have the same layout and dynamic state: the sets, push constants and state set so far stay.
  dev.d.CmdBindPipeline(cb.handle, VK_PIPELINE_BIND_POINT_GRAPHICS,
                        twin ? pipeline->earlyTestsTwin : cb.coverage.pipeline);
  cb.coverage.twinBound = twin;
}

}  // namespace tally::layer
