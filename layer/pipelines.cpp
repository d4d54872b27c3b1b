// The layer's intercepts for shader modules, pipeline layouts and pipelines:
// where the application's stages are instrumented (docs/layer.md).
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string_view>
#include <utility>

#include "descriptor_buffers_layer.hpp"
#include "early_tests_twin.hpp"
#include "intercepts.hpp"
#include "libraries.hpp"
#include "names.hpp"
#include "shader_options.hpp"
#include "state.hpp"
#include "uncounted.hpp"

namespace tally::layer {
namespace {

VKAPI_ATTR VkResult VKAPI_CALL CreateShaderModule(VkDevice device, const VkShaderModuleCreateInfo* info,
                                                  const VkAllocationCallbacks* alloc, VkShaderModule* module) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.CreateShaderModule(device, info, alloc, module);
  if (result != VK_SUCCESS) return result;
  std::lock_guard lock(dev->mutex);
  ShaderInfo shader;
  shader.words.assign(info->pCode, info->pCode + info->codeSize / 4);
  dev->shaders[u64(*module)] = std::move(shader);
  return result;
}

VKAPI_ATTR void VKAPI_CALL DestroyShaderModule(VkDevice device, VkShaderModule module,
                                               const VkAllocationCallbacks* alloc) {
  DeviceState* dev = deviceOf(device);
  {
    std::lock_guard lock(dev->mutex);
    dev->shaders.erase(u64(module));
  }
  dev->d.DestroyShaderModule(device, module, alloc);
}

VKAPI_ATTR VkResult VKAPI_CALL CreatePipelineLayout(VkDevice device, const VkPipelineLayoutCreateInfo* info,
                                                    const VkAllocationCallbacks* alloc, VkPipelineLayout* layout) {
  DeviceState* dev = deviceOf(device);
  std::vector<VkDescriptorSetLayout> sets;
  {
    std::lock_guard lock(dev->mutex);
    const std::string uncounted = layoutRefusal(*dev, *info);
    if (!uncounted.empty()) {
      if (dev->notes.insert(uncounted).second) log(uncounted);
      ++dev->layoutsRefused;
    } else if (dev->counting && info->setLayoutCount <= dev->counterSet) {
      // Descriptor buffers: every set of the layout is one, the layer's too.
      VkDescriptorSetLayout counter = dev->counterSetLayout, empty = dev->emptySetLayout;
      descriptorBufferLayouts(*dev, *info, counter, empty);
      sets.assign(info->pSetLayouts, info->pSetLayouts + info->setLayoutCount);
      sets.resize(dev->counterSet, empty);
      sets.push_back(counter);
    } else if (dev->counting) {
      const std::string refused = "a pipeline layout uses " + std::to_string(info->setLayoutCount) +
                                  " descriptor sets; the device allows " +
                                  std::to_string(dev->properties.limits.maxBoundDescriptorSets) +
                                  " and the layer needs set " + std::to_string(dev->counterSet) +
                                  ": its pipelines run unchanged, uncounted";
      dev->notes.insert(refused);
      ++dev->layoutsRefused;
      log(refused);
    }
  }
  if (sets.empty()) {
    VkResult result = dev->d.CreatePipelineLayout(device, info, alloc, layout);
    std::lock_guard lock(dev->mutex);
    if (result == VK_SUCCESS) notePipelineLayout(*dev, *layout, *info);
    return result;
  }
  VkPipelineLayoutCreateInfo extended = *info;
  extended.setLayoutCount = uint32_t(sets.size());
  extended.pSetLayouts = sets.data();
  // Independent sets (graphics pipeline libraries): the application's
  // handle leaves the sets between null, as a library's layout may lack a set
  // another library of the same pipeline defines; complete pipelines get a
  // twin with empty sets there, through which the counter set is bound
  // (lavapipe cannot bind past a null set layout).
  VkPipelineLayout twin = VK_NULL_HANDLE;
  if (info->flags & VK_PIPELINE_LAYOUT_CREATE_INDEPENDENT_SETS_BIT_EXT) {
    if (dev->d.CreatePipelineLayout(device, &extended, alloc, &twin) != VK_SUCCESS) twin = VK_NULL_HANDLE;
    for (size_t s = info->setLayoutCount; s < dev->counterSet; ++s) sets[s] = VK_NULL_HANDLE;
  }
  VkResult result = dev->d.CreatePipelineLayout(device, &extended, alloc, layout);
  if (result != VK_SUCCESS) {
    if (twin != VK_NULL_HANDLE) dev->d.DestroyPipelineLayout(device, twin, alloc);
    return result;
  }
  std::lock_guard lock(dev->mutex);
  dev->countedLayouts.insert(u64(*layout));
  notePipelineLayout(*dev, *layout, *info);
  if (twin != VK_NULL_HANDLE) {
    notePipelineLayout(*dev, twin, *info);
    dev->countedLayouts.insert(u64(twin));
    dev->completeLayouts[u64(*layout)] = twin;
  }
  return result;
}

VKAPI_ATTR void VKAPI_CALL DestroyPipelineLayout(VkDevice device, VkPipelineLayout layout,
                                                const VkAllocationCallbacks* alloc) {
  DeviceState* dev = deviceOf(device);
  VkPipelineLayout twin = VK_NULL_HANDLE;
  {
    std::lock_guard lock(dev->mutex);
    dev->countedLayouts.erase(u64(layout));  // a later layout may reuse the handle
    if (auto it = dev->completeLayouts.find(u64(layout)); it != dev->completeLayouts.end()) {
      twin = it->second;
      dev->countedLayouts.erase(u64(twin));
      dev->completeLayouts.erase(it);
    }
  }
  dev->d.DestroyPipelineLayout(device, layout, alloc);
  if (twin != VK_NULL_HANDLE) dev->d.DestroyPipelineLayout(device, twin, alloc);
}

spirv::Stage stageOf(VkShaderStageFlagBits stage) {
  switch (stage) {
    case VK_SHADER_STAGE_VERTEX_BIT: return spirv::Stage::Vertex;
    case VK_SHADER_STAGE_TESSELLATION_CONTROL_BIT: return spirv::Stage::TessControl;
    case VK_SHADER_STAGE_TESSELLATION_EVALUATION_BIT: return spirv::Stage::TessEval;
    case VK_SHADER_STAGE_GEOMETRY_BIT: return spirv::Stage::Geometry;
    case VK_SHADER_STAGE_FRAGMENT_BIT: return spirv::Stage::Fragment;
    case VK_SHADER_STAGE_COMPUTE_BIT: return spirv::Stage::Compute;
    case VK_SHADER_STAGE_TASK_BIT_EXT: return spirv::Stage::Task;
    case VK_SHADER_STAGE_MESH_BIT_EXT: return spirv::Stage::Mesh;
    default: return spirv::Stage::Other;
  }
}

// Instruments a pipeline's stages into `modules` (temporary modules to
// destroy after creation) and fills `info`. Stages that cannot be
// instrumented keep the application's module; each is reported. `split`:
// a pipeline made of libraries, whose fragment stages count from
// kPreRasterizationSlots (libraries.hpp). `plan`: whether the fragment shader
// may be given early tests (graphics pipelines).
void instrumentStages(DeviceState& dev, std::vector<VkPipelineShaderStageCreateInfo>& stages, PipelineInfo& info,
                      std::vector<VkShaderModule>& modules, bool split = false, EarlyTestsPlan* plan = nullptr) {
  uint32_t nextSlot = 0, fragmentSlot = kPreRasterizationSlots;
  const uint32_t maxSlots = uint32_t(dev.regionRange / 8);
  for (auto& stage : stages) {
    if (!stageInParts(stage.stage, info.libraryParts)) continue;  // a library ignores the parts it does not define
    const spirv::Stage s = stageOf(stage.stage);
    uint32_t& next = split && s == spirv::Stage::Fragment ? fragmentSlot : nextSlot;
    const uint32_t limit = split && s != spirv::Stage::Fragment ? kPreRasterizationSlots : maxSlots;
    if (s == spirv::Stage::Fragment) info.hasFragment = true;
    nlohmann::json report = {{"stage", std::string(spirv::toString(s))}, {"instrumented", false}, {"sites", 0}};
    auto shader = dev.shaders.find(u64(stage.module));
    std::string why;
    if (stage.module == VK_NULL_HANDLE || shader == dev.shaders.end()) {
      why = "the stage's SPIR-V is not in a shader module the layer saw (VkShaderModuleCreateInfo in the stage's pNext, or a module identifier)";
    } else if (s == spirv::Stage::Fragment && !dev.fragmentStores) {
      why = "the device has no fragmentStoresAndAtomics";
    } else if ((s == spirv::Stage::Vertex || s == spirv::Stage::TessControl || s == spirv::Stage::TessEval ||
                s == spirv::Stage::Geometry) &&
               !dev.vertexStores) {
      why = "the device has no vertexPipelineStoresAndAtomics";
    }
    report["name"] = shader != dev.shaders.end() && !shader->second.name.empty()
                         ? shader->second.name
                         : "shader " + hexHandle(u64(stage.module));
    if (why.empty()) {
      spirv::InstrumentOptions options = dev.instrumentOptions;
      options.firstSlot = next;
      options.perSite = dev.config.sites;
      // The descriptor-buffer counter set holds the counters only: addresses
      // are counted per access width there (docs/layer.md, "Limits").
      if (isDescriptorBufferLayout(dev, info.layout)) options.addressTable = false;
      if (s == spirv::Stage::Fragment && plan != nullptr && !plan->early()) options.earlyFragmentTests = false;
      // Lavapipe cannot compile the subgroup flush in modules that demote
      // (as gpu::instrumentOptionsFor): those flush per lane there.
      if (dev.llvmpipe && spirv::usesDemote(shader->second.words)) {
        options.subgroupStages &= ~spirv::stageBit(spirv::Stage::Fragment);
      }
      auto result = spirv::instrument(shader->second.words, options);
      if (!result) {
        why = result.error();
      } else if (next + result->layout().reserved() > limit) {
        why = "needs " + std::to_string(result->layout().reserved()) + " counter slots; the layer's region holds " +
              std::to_string(limit - next) + (limit < maxSlots ? " (a pre-rasterization library's share)" : "");
      } else {
        VkShaderModuleCreateInfo moduleInfo = {VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
        moduleInfo.codeSize = result->words.size() * 4;
        moduleInfo.pCode = result->words.data();
        VkShaderModule module = VK_NULL_HANDLE;
        if (dev.d.CreateShaderModule(dev.device, &moduleInfo, nullptr, &module) != VK_SUCCESS) {
          why = "the driver refused the instrumented module";
        } else {
          modules.push_back(module);
          stage.module = module;
          next += result->layout().reserved();
          if (result->layout().needsSettling()) info.foldLayouts.push_back(result->layout());
          for (auto& site : result->sites) {
            site.shader = report["name"].get<std::string>();
            info.sites.push_back(std::move(site));
          }
          report["instrumented"] = true;
          report["sites"] = result->sites.size();
          std::vector<std::string> notes = result->notes;
          if (s == spirv::Stage::Fragment && plan != nullptr && plan->twin) {
            plan->earlyFragment = earlyTestsFragment(dev, shader->second.words, options, *result, notes);
          }
          for (const auto& note : notes) {
            dev.notes.insert(note);
            if (plan != nullptr && !plan->lateWhy.empty() && note.find("early_fragment_tests") != std::string::npos) {
              dev.notes.insert("a pipeline keeps its fragment shader's late depth and stencil tests (" + plan->lateWhy +
                               "): early tests would write depth and stencil for samples it removes");
            }
          }
        }
      }
    }
    report["reason"] = why;
    dev.shaderReports.push_back(report);
  }
  info.slots = std::max({info.slots, nextSlot, fragmentSlot > kPreRasterizationSlots ? fragmentSlot : 0});
  info.counted = info.slots > 0;
}

bool layoutCounted(DeviceState& dev, VkPipelineLayout layout) {
  return dev.countedLayouts.count(u64(layout)) > 0;
}

void registerPipelines(DeviceState& dev, uint32_t count, const VkPipeline* pipelines,
                       const std::vector<std::shared_ptr<PipelineInfo>>& states) {
  std::lock_guard lock(dev.mutex);
  for (uint32_t i = 0; i < count; ++i) {
    if (pipelines[i] == VK_NULL_HANDLE) {  // a failed creation in a batch
      if (states[i]->instrumented != VK_NULL_HANDLE) dev.d.DestroyPipeline(dev.device, states[i]->instrumented, nullptr);
      continue;
    }
    states[i]->handle = u64(pipelines[i]);
    if (states[i]->library) {  // counted once linked, as part of the pipelines it makes
      dev.libraries[u64(pipelines[i])] = states[i];
      ++dev.librariesCreated;
      continue;
    }
    dev.pipelines[u64(pipelines[i])] = states[i];
    dev.pipelinesLinked += states[i]->linked ? 1 : 0;
    ++dev.pipelinesCreated;
    dev.pipelinesCounted += states[i]->counted ? 1 : 0;
  }
}

using Clock = std::chrono::steady_clock;
void addPipelineTimes(DeviceState& dev, Clock::time_point start, Clock::time_point twins) {
  const auto ms = [](auto d) { return std::chrono::duration<double, std::milli>(d).count(); };
  std::lock_guard lock(dev.mutex);
  dev.pipelineMsInstrumented += ms(twins - start);
  dev.pipelineMsApplication += ms(Clock::now() - twins);
}

VKAPI_ATTR VkResult VKAPI_CALL CreateGraphicsPipelines(VkDevice device, VkPipelineCache cache, uint32_t count,
                                                       const VkGraphicsPipelineCreateInfo* infos,
                                                       const VkAllocationCallbacks* alloc, VkPipeline* pipelines) {
  DeviceState* dev = deviceOf(device);
  std::vector<VkGraphicsPipelineCreateInfo> patched(infos, infos + count);
  std::vector<std::vector<VkPipelineShaderStageCreateInfo>> stages(count);
  std::vector<std::shared_ptr<PipelineInfo>> states(count);
  std::vector<VkShaderModule> modules, earlyFragments(count, VK_NULL_HANDLE);
  const auto start = Clock::now();
  {
    std::lock_guard lock(dev->mutex);
    for (uint32_t i = 0; i < count; ++i) {
      auto state = std::make_shared<PipelineInfo>();
      state->layout = infos[i].layout;
      // Graphics pipeline libraries: a library's stages are instrumented as
      // a pipeline's are; a pipeline linked from libraries counts their sites.
      const LibraryUse use = libraryUse(infos[i]);
      state->library = use.library;
      state->libraryParts = use.parts;
      // A library's create info holds the state of its own parts only: the
      // other pointers may be garbage.
      VkGraphicsPipelineCreateInfo held = infos[i];
      if (!(use.parts & VK_GRAPHICS_PIPELINE_LIBRARY_VERTEX_INPUT_INTERFACE_BIT_EXT)) held.pVertexInputState = nullptr;
      if (!(use.parts & VK_GRAPHICS_PIPELINE_LIBRARY_PRE_RASTERIZATION_SHADERS_BIT_EXT)) {
        held.pRasterizationState = nullptr;
      }
      if (!(use.parts & VK_GRAPHICS_PIPELINE_LIBRARY_FRAGMENT_OUTPUT_INTERFACE_BIT_EXT)) held.pColorBlendState = nullptr;
      state->fixed = fixedFunctionOf(*dev, held);
      state->libraryParts |= mergeLibraries(*dev, use.linked, *state);
      state->linked = !use.linked.empty();
      if (windowAhead(*dev) && layoutCounted(*dev, infos[i].layout) && infos[i].stageCount > 0 &&
          (use.parts & (VK_GRAPHICS_PIPELINE_LIBRARY_PRE_RASTERIZATION_SHADERS_BIT_EXT |
                        VK_GRAPHICS_PIPELINE_LIBRARY_FRAGMENT_SHADER_BIT_EXT))) {
        stages[i].assign(infos[i].pStages, infos[i].pStages + infos[i].stageCount);
        EarlyTestsPlan plan = earlyTestsPlan(infos[i]);
        instrumentStages(*dev, stages[i], *state, modules, use.split(), &plan);
        earlyFragments[i] = plan.earlyFragment;
        patched[i].pStages = stages[i].data();
      }
      // The counter set is bound through the pipeline's layout.
      if (auto twin = dev->completeLayouts.find(u64(state->layout)); !use.library && twin != dev->completeLayouts.end()) {
        state->layout = twin->second;
        if (patched[i].layout != VK_NULL_HANDLE) patched[i].layout = twin->second;
      }
      state->counted = state->counted && dev->counting && layoutCounted(*dev, state->layout);
      states[i] = state;
    }
  }
  // Graphics pipeline libraries, and pipelines linked from them, are created
  // instrumented in the application's place: a linked pipeline names its
  // libraries by the application's handles, so they can have no twins.
  std::vector<VkGraphicsPipelineCreateInfo> own(infos, infos + count);
  for (uint32_t i = 0; i < count; ++i) {
    if (states[i]->library || states[i]->linked) {
      own[i] = patched[i];
      states[i]->inPlace = true;
    }
  }
  createGraphicsTwins(*dev, patched, states);
  const auto twins = Clock::now();
  // Last, so that what the application's pNext receives (creation feedback) is its own pipeline's.
  VkResult result = dev->d.CreateGraphicsPipelines(device, cache, count, own.data(), alloc, pipelines);
  addPipelineTimes(*dev, start, twins);
  for (uint32_t i = 0; i < count; ++i) {
    if (states[i]->inPlace && states[i]->counted) states[i]->instrumented = pipelines[i];
  }
  createEarlyTestsTwins(*dev, cache, patched, earlyFragments, pipelines, states);
  for (VkShaderModule m : modules) dev->d.DestroyShaderModule(device, m, nullptr);
  registerPipelines(*dev, count, pipelines, states);
  return result;
}

VKAPI_ATTR VkResult VKAPI_CALL CreateComputePipelines(VkDevice device, VkPipelineCache cache, uint32_t count,
                                                      const VkComputePipelineCreateInfo* infos,
                                                      const VkAllocationCallbacks* alloc, VkPipeline* pipelines) {
  DeviceState* dev = deviceOf(device);
  std::vector<VkComputePipelineCreateInfo> patched(infos, infos + count);
  std::vector<std::shared_ptr<PipelineInfo>> states(count);
  std::vector<VkShaderModule> modules;
  const auto start = Clock::now();
  {
    std::lock_guard lock(dev->mutex);
    for (uint32_t i = 0; i < count; ++i) {
      auto state = std::make_shared<PipelineInfo>();
      state->layout = infos[i].layout;
      if (windowAhead(*dev) && layoutCounted(*dev, infos[i].layout)) {
        std::vector<VkPipelineShaderStageCreateInfo> stage = {infos[i].stage};
        instrumentStages(*dev, stage, *state, modules);
        patched[i].stage = stage[0];
      }
      states[i] = state;
    }
  }
  createComputeTwins(*dev, patched, states);
  for (VkShaderModule m : modules) dev->d.DestroyShaderModule(device, m, nullptr);
  const auto twins = Clock::now();
  VkResult result = dev->d.CreateComputePipelines(device, cache, count, infos, alloc, pipelines);
  addPipelineTimes(*dev, start, twins);
  registerPipelines(*dev, count, pipelines, states);
  return result;
}

VKAPI_ATTR void VKAPI_CALL DestroyPipeline(VkDevice device, VkPipeline pipeline, const VkAllocationCallbacks* alloc) {
  DeviceState* dev = deviceOf(device);
  VkPipeline twin = VK_NULL_HANDLE, early = VK_NULL_HANDLE;
  {
    std::lock_guard lock(dev->mutex);
    if (auto it = dev->pipelines.find(u64(pipeline)); it != dev->pipelines.end()) {
      if (!it->second->inPlace) twin = it->second->instrumented;
      early = std::exchange(it->second->earlyTestsTwin, VK_NULL_HANDLE);
    }
    dev->pipelines.erase(u64(pipeline));  // recorded regions keep their own reference
    dev->libraries.erase(u64(pipeline));  // pipelines linked from it keep its sites
  }
  if (twin != VK_NULL_HANDLE) dev->d.DestroyPipeline(device, twin, nullptr);
  if (early != VK_NULL_HANDLE) dev->d.DestroyPipeline(device, early, nullptr);
  dev->d.DestroyPipeline(device, pipeline, alloc);
}

}  // namespace

PFN_vkVoidFunction interceptedPipelines(std::string_view name) {
  TALLY_INTERCEPT(CreateShaderModule)
  TALLY_INTERCEPT(DestroyShaderModule)
  TALLY_INTERCEPT(CreatePipelineLayout)
  TALLY_INTERCEPT(DestroyPipelineLayout)
  TALLY_INTERCEPT(CreateGraphicsPipelines)
  TALLY_INTERCEPT(CreateComputePipelines)
  TALLY_INTERCEPT(DestroyPipeline)
  return nullptr;
}

}  // namespace tally::layer
