// The layer's intercepts for shader objects (VK_EXT_shader_object): each
// SPIR-V stage instrumented into a twin at vkCreateShadersEXT, the twins
// bound in counting command buffers at vkCmdBindShadersEXT, and the bound
// combination counted at each draw as a pipeline is (shader_objects.hpp).
//
// vkGetShaderBinaryDataEXT passes through untouched: the application's
// handle is its own uninstrumented shader, so the binary it gets back is
// that shader's. A shader created from such a binary is not instrumented
// (there is no SPIR-V), and is noted.
#include <algorithm>
#include <mutex>
#include <utility>

#include "intercepts.hpp"
#include "names.hpp"
#include "shader_objects.hpp"
#include "state.hpp"

namespace tally::layer {
namespace {

ShaderObjects& objectsOf(DeviceState& dev) {
  if (!dev.shaderObjects) {
    auto objects = std::make_shared<ShaderObjects>();
    auto next = [&](const char* name) { return dev.d.GetDeviceProcAddr(dev.device, name); };
    objects->create = reinterpret_cast<PFN_vkCreateShadersEXT>(next("vkCreateShadersEXT"));
    objects->destroy = reinterpret_cast<PFN_vkDestroyShaderEXT>(next("vkDestroyShaderEXT"));
    objects->bind = reinterpret_cast<PFN_vkCmdBindShadersEXT>(next("vkCmdBindShadersEXT"));
    dev.shaderObjects = std::move(objects);
  }
  return *dev.shaderObjects;
}

// One vkCreateShadersEXT call as the layer instruments it: the twins'
// create infos and what they point to, and each shader's bookkeeping.
struct Batch {
  std::vector<VkShaderCreateInfoEXT> infos;
  std::vector<std::vector<uint32_t>> code, earlyCode;
  std::vector<std::vector<VkDescriptorSetLayout>> sets;
  std::vector<std::shared_ptr<ShaderObject>> objects;
  std::vector<bool> instrumented;
};

// Instruments `words` into `object` with the device's options; the reason
// it cannot be counted, or "".
std::string instrumentStage(DeviceState& dev, const std::vector<uint32_t>& words, ShaderObject& object,
                            const std::string& name, std::vector<uint32_t>& out, std::vector<uint32_t>* early) {
  spirv::InstrumentOptions options = dev.instrumentOptions;
  options.perSite = dev.config.sites;
  // Lavapipe cannot compile the subgroup flush in modules that demote (as pipelines.cpp).
  if (dev.llvmpipe && spirv::usesDemote(words)) options.subgroupStages &= ~spirv::stageBit(spirv::Stage::Fragment);
  std::vector<std::string> notes;
  std::string why =
      instrumentShaderObject(words, options, uint32_t(dev.regionRange / 8), name, object, out, notes, early);
  for (const auto& note : notes) dev.notes.insert(note);
  return why;
}

// Under dev.mutex: each shader's twin create info, instrumented where it can be.
Batch planBatch(DeviceState& dev, uint32_t count, const VkShaderCreateInfoEXT* infos, const VkShaderEXT* shaders) {
  Batch batch;
  batch.infos.assign(infos, infos + count);
  batch.code.resize(count);
  batch.earlyCode.resize(count);
  batch.sets.resize(count);
  batch.instrumented.assign(count, false);
  ShaderObjects& objects = objectsOf(dev);
  const uint64_t group = objects.nextLinkGroup++;
  for (uint32_t i = 0; i < count; ++i) {
    auto object = std::make_shared<ShaderObject>();
    object->handle = u64(shaders[i]);
    object->stage = infos[i].stage;
    object->linkGroup = (infos[i].flags & VK_SHADER_CREATE_LINK_STAGE_BIT_EXT) ? group : 0;
    batch.objects.push_back(object);
    if (shaders[i] == VK_NULL_HANDLE || !dev.counting || !windowAhead(dev)) continue;
    const std::string name = "shader object " + hexHandle(object->handle);
    std::string why = shaderRefusal(infos[i], dev.counterSet, dev.fragmentStores, dev.vertexStores);
    if (why.empty()) {
      const auto* words = static_cast<const uint32_t*>(infos[i].pCode);
      // Linked shaders are bound together: a fragment one has no early-tests twin to swap in.
      const bool linked = object->linkGroup != 0;
      why = instrumentStage(dev, std::vector<uint32_t>(words, words + infos[i].codeSize / 4), *object, name,
                            batch.code[i], linked ? nullptr : &batch.earlyCode[i]);
    }
    if (why.empty()) {
      batch.infos[i].pCode = batch.code[i].data();
      batch.infos[i].codeSize = batch.code[i].size() * 4;
      batch.instrumented[i] = true;
    } else if (infos[i].codeType != VK_SHADER_CODE_TYPE_SPIRV_EXT) {
      dev.notes.insert(why);
    }
    if (infos[i].setLayoutCount <= dev.counterSet) {
      batch.sets[i] = twinSetLayouts(infos[i], dev.counterSet, dev.emptySetLayout, dev.counterSetLayout);
      batch.infos[i].setLayoutCount = uint32_t(batch.sets[i].size());
      batch.infos[i].pSetLayouts = batch.sets[i].data();
    }
    dev.shaderReports.push_back({{"name", name},
                                 {"stage", std::string(spirv::toString(shaderStage(infos[i].stage)))},
                                 {"instrumented", why.empty()},
                                 {"sites", object->counted.sites.size()},
                                 {"reason", why}});
  }
  return batch;
}

// The layout the counter set is bound through: the twin's set layouts and
// the application's push constant ranges, so the sets below it stay bound.
VkPipelineLayout counterLayout(DeviceState& dev, const VkShaderCreateInfoEXT& twin) {
  VkPipelineLayoutCreateInfo info = {VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  info.setLayoutCount = twin.setLayoutCount;
  info.pSetLayouts = twin.pSetLayouts;
  info.pushConstantRangeCount = twin.pushConstantRangeCount;
  info.pPushConstantRanges = twin.pPushConstantRanges;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  if (dev.d.CreatePipelineLayout(dev.device, &info, nullptr, &layout) != VK_SUCCESS) return VK_NULL_HANDLE;
  return layout;
}

// Creates the twins: linked shaders in one call, all of them (linked shaders
// are bound together, so either all are twins or none), only where one of
// them is instrumented; each unlinked instrumented shader alone.
void createTwins(DeviceState& dev, ShaderObjects& objects, Batch& batch) {
  std::vector<uint32_t> linked;
  bool linkedCounted = false, linkedComplete = true;
  for (uint32_t i = 0; i < batch.infos.size(); ++i) {
    if (batch.objects[i]->linkGroup != 0) {
      linked.push_back(i);
      linkedCounted = linkedCounted || batch.instrumented[i];
      linkedComplete = linkedComplete && batch.objects[i]->handle != 0 && !batch.sets[i].empty() &&
                       batch.infos[i].codeType == VK_SHADER_CODE_TYPE_SPIRV_EXT;
    } else if (batch.instrumented[i]) {
      VkShaderEXT twin = VK_NULL_HANDLE;
      if (objects.create(dev.device, 1, &batch.infos[i], nullptr, &twin) == VK_SUCCESS) batch.objects[i]->twin = twin;
      if (twin != VK_NULL_HANDLE && !batch.earlyCode[i].empty()) {
        VkShaderCreateInfoEXT early = batch.infos[i];
        early.pCode = batch.earlyCode[i].data();
        early.codeSize = batch.earlyCode[i].size() * 4;
        if (objects.create(dev.device, 1, &early, nullptr, &twin) == VK_SUCCESS) batch.objects[i]->earlyTwin = twin;
      }
    }
  }
  if (!linked.empty() && linkedCounted && linkedComplete) {
    std::vector<VkShaderCreateInfoEXT> infos;
    for (uint32_t i : linked) infos.push_back(batch.infos[i]);
    std::vector<VkShaderEXT> twins(infos.size(), VK_NULL_HANDLE);
    if (objects.create(dev.device, uint32_t(infos.size()), infos.data(), nullptr, twins.data()) == VK_SUCCESS) {
      for (size_t k = 0; k < linked.size(); ++k) batch.objects[linked[k]]->twin = twins[k];
    } else {
      for (VkShaderEXT t : twins) {
        if (t != VK_NULL_HANDLE) objects.destroy(dev.device, t, nullptr);
      }
    }
  }
  for (uint32_t i = 0; i < batch.infos.size(); ++i) {
    ShaderObject& object = *batch.objects[i];
    if (object.twin == VK_NULL_HANDLE) continue;
    object.counted.layout = counterLayout(dev, batch.infos[i]);
    if (object.counted.layout != VK_NULL_HANDLE) continue;
    objects.destroy(dev.device, object.twin, nullptr);
    object.twin = VK_NULL_HANDLE;
  }
}

VKAPI_ATTR VkResult VKAPI_CALL CreateShadersEXT(VkDevice device, uint32_t count, const VkShaderCreateInfoEXT* infos,
                                                const VkAllocationCallbacks* alloc, VkShaderEXT* shaders) {
  DeviceState* dev = deviceOf(device);
  ShaderObjects* objects = nullptr;
  {
    std::lock_guard lock(dev->mutex);
    objects = &objectsOf(*dev);
  }
  // The application's shaders first, exactly as it asked.
  const VkResult result = objects->create(device, count, infos, alloc, shaders);
  if (result != VK_SUCCESS && result != VK_INCOMPATIBLE_SHADER_BINARY_EXT) return result;
  Batch batch;
  {
    std::lock_guard lock(dev->mutex);
    batch = planBatch(*dev, count, infos, shaders);
  }
  createTwins(*dev, *objects, batch);
  std::lock_guard lock(dev->mutex);
  uint32_t refused = 0;
  for (uint32_t i = 0; i < count; ++i) {
    if (shaders[i] == VK_NULL_HANDLE) continue;
    ShaderObject& object = *batch.objects[i];
    object.counted.counted = object.counted.counted && object.twin != VK_NULL_HANDLE;
    refused += batch.instrumented[i] && object.twin == VK_NULL_HANDLE ? 1 : 0;
    ++objects->created;
    objects->counted += object.counted.counted ? 1 : 0;
    objects->shaders[object.handle] = batch.objects[i];
    if (object.earlyTwin != VK_NULL_HANDLE) {
      dev->notes.insert("a fragment shader object runs with early tests while alpha to coverage is off, with late "
                        "tests while it is on (rejected fragments counted then)");
    }
  }
  if (refused > 0) {
    dev->notes.insert("the driver refused an instrumented shader object: the application's own runs there, uncounted");
  }
  return result;
}

// Combinations naming a shader are forgotten with it; regions recorded with
// them keep their own reference.
void forgetCombinations(ShaderObjects& objects, uint64_t handle) {
  for (auto it = objects.combinations.begin(); it != objects.combinations.end();) {
    if (std::find(it->first.begin(), it->first.end(), handle) != it->first.end()) {
      it = objects.combinations.erase(it);
    } else {
      ++it;
    }
  }
}

VKAPI_ATTR void VKAPI_CALL DestroyShaderEXT(VkDevice device, VkShaderEXT shader, const VkAllocationCallbacks* alloc) {
  DeviceState* dev = deviceOf(device);
  std::shared_ptr<ShaderObject> object;
  ShaderObjects* objects = nullptr;
  {
    std::lock_guard lock(dev->mutex);
    objects = &objectsOf(*dev);
    if (auto it = objects->shaders.find(u64(shader)); it != objects->shaders.end()) {
      object = std::move(it->second);
      objects->shaders.erase(it);
    }
    forgetCombinations(*objects, u64(shader));
  }
  if (object && object->twin != VK_NULL_HANDLE) objects->destroy(device, object->twin, nullptr);
  if (object && object->earlyTwin != VK_NULL_HANDLE) objects->destroy(device, object->earlyTwin, nullptr);
  if (object && object->counted.layout != VK_NULL_HANDLE) {
    dev->d.DestroyPipelineLayout(device, object->counted.layout, nullptr);
  }
  objects->destroy(device, shader, alloc);
}

// The combination bound at a bind point of a counting command buffer.
std::shared_ptr<PipelineInfo> boundCombination(ShaderObjects& objects, const CommandBufferState& cb, bool compute) {
  std::array<uint64_t, kComputeShaderIndex + 1> key{};
  for (size_t s = 0; s < key.size(); ++s) {
    if ((s == kComputeShaderIndex) == compute) key[s] = cb.shaders[s];
  }
  if (auto it = objects.combinations.find(key); it != objects.combinations.end()) return it->second;
  std::vector<const ShaderObject*> bound;
  for (uint64_t handle : key) {
    auto it = objects.shaders.find(handle);
    if (handle != 0 && it != objects.shaders.end()) bound.push_back(it->second.get());
  }
  auto combined = combineShaders(bound);
  objects.combinations[key] = combined;
  return combined;
}

VKAPI_ATTR void VKAPI_CALL CmdBindShadersEXT(VkCommandBuffer cmd, uint32_t count, const VkShaderStageFlagBits* stages,
                                             const VkShaderEXT* shaders) {
  DeviceState* dev = deviceOf(cmd);
  std::lock_guard lock(dev->mutex);
  ShaderObjects& objects = objectsOf(*dev);
  CommandBufferState* cb = cbState(*dev, cmd);
  const bool counting = cb != nullptr && cb->counted && dev->counting && dev->config.counts;
  if (!counting || shaders == nullptr) {
    objects.bind(cmd, count, stages, shaders);
  } else {
    // The twins where the command buffer counts (twins.cpp explains why).
    std::vector<VkShaderEXT> bound(shaders, shaders + count);
    for (auto& shader : bound) {
      auto it = objects.shaders.find(u64(shader));
      if (it != objects.shaders.end() && it->second->twin != VK_NULL_HANDLE) shader = it->second->twin;
    }
    objects.bind(cmd, count, stages, bound.data());
  }
  if (cb == nullptr || !cb->counted) return;
  bool graphics = false, compute = false;
  for (uint32_t i = 0; i < count; ++i) {
    const int index = shaderStageIndex(stages[i]);
    if (index < 0) continue;
    cb->shaders[size_t(index)] = shaders == nullptr ? 0 : u64(shaders[i]);
    if (size_t(index) == kFragmentShaderIndex) cb->coverage.twinBound = false;  // the late-tests twin, as bound
    (size_t(index) == kComputeShaderIndex ? compute : graphics) = true;
  }
  for (const bool isCompute : {false, true}) {
    if (!(isCompute ? compute : graphics)) continue;
    // Binding shader objects replaces the pipeline at that bind point.
    auto& bp = cb->bind[isCompute ? 1 : 0];
    bp.pipeline = counting ? boundCombination(objects, *cb, isCompute) : nullptr;
    bp.dirty = true;
    if (!isCompute) cb->coverage.pipeline = VK_NULL_HANDLE;
    if (!bp.pipeline) continue;
    // As for pipelines (draws.cpp): the counter set bound at the sink until a
    // draw the layer sees binds the draw's region.
    const uint32_t sink = 0;
    dev->d.CmdBindDescriptorSets(cmd, isCompute ? VK_PIPELINE_BIND_POINT_COMPUTE : VK_PIPELINE_BIND_POINT_GRAPHICS,
                                 bp.pipeline->layout, dev->counterSet, 1, &dev->counterDescriptorSet, 1, &sink);
    bp.boundOffset = 0;
  }
}

}  // namespace

void bindShadersForCoverage(DeviceState& dev, CommandBufferState& cb) {
  if (!cb.counted || !dev.counting || !dev.config.counts || !dev.shaderObjects) return;
  ShaderObjects& objects = *dev.shaderObjects;
  auto it = objects.shaders.find(cb.shaders[kFragmentShaderIndex]);
  if (it == objects.shaders.end() || it->second->earlyTwin == VK_NULL_HANDLE) return;
  const bool early = cb.coverage.known && !cb.coverage.alphaToCoverage;
  if (early == cb.coverage.twinBound) return;
  const VkShaderStageFlagBits stage = VK_SHADER_STAGE_FRAGMENT_BIT;
  objects.bind(cb.handle, 1, &stage, early ? &it->second->earlyTwin : &it->second->twin);
  cb.coverage.twinBound = early;
}

void destroyShaderObjects(DeviceState& dev) {
  if (!dev.shaderObjects) return;
  ShaderObjects& objects = *dev.shaderObjects;
  for (const auto& [handle, object] : objects.shaders) {
    if (object->twin != VK_NULL_HANDLE) objects.destroy(dev.device, object->twin, nullptr);
    if (object->earlyTwin != VK_NULL_HANDLE) objects.destroy(dev.device, object->earlyTwin, nullptr);
    if (object->counted.layout != VK_NULL_HANDLE) dev.d.DestroyPipelineLayout(dev.device, object->counted.layout, nullptr);
  }
  objects.shaders.clear();
  objects.combinations.clear();
}

PFN_vkVoidFunction interceptedShaderObjects(std::string_view name) {
  TALLY_INTERCEPT(CreateShadersEXT)
  TALLY_INTERCEPT(DestroyShaderEXT)
  TALLY_INTERCEPT(CmdBindShadersEXT)
  return nullptr;
}

}  // namespace tally::layer
