// Shader objects' bookkeeping that needs no device: stages, slot bands, what
// cannot be instrumented, the twin's set layouts and the combination bound
// at a draw (shader_objects.hpp).
#include <algorithm>

#include "names.hpp"
#include "shader_objects.hpp"

namespace tally::layer {

int shaderStageIndex(VkShaderStageFlagBits stage) {
  switch (stage) {
    case VK_SHADER_STAGE_VERTEX_BIT: return 0;
    case VK_SHADER_STAGE_TESSELLATION_CONTROL_BIT: return 1;
    case VK_SHADER_STAGE_TESSELLATION_EVALUATION_BIT: return 2;
    case VK_SHADER_STAGE_GEOMETRY_BIT: return 3;
    case VK_SHADER_STAGE_FRAGMENT_BIT: return 4;
    case VK_SHADER_STAGE_TASK_BIT_EXT: return 5;
    case VK_SHADER_STAGE_MESH_BIT_EXT: return 6;
    case VK_SHADER_STAGE_COMPUTE_BIT: return int(kComputeShaderIndex);
    default: return -1;
  }
}

spirv::Stage shaderStage(VkShaderStageFlagBits stage) {
  using spirv::Stage;
  constexpr Stage kStages[] = {Stage::Vertex,   Stage::TessControl, Stage::TessEval, Stage::Geometry,
                               Stage::Fragment, Stage::Task,        Stage::Mesh,     Stage::Compute};
  const int index = shaderStageIndex(stage);
  return index < 0 ? Stage::Other : kStages[index];
}

SlotBand slotBand(VkShaderStageFlagBits stage, uint32_t maxSlots) {
  // Lowest first: the stages drawn least often, so that a vertex and a
  // fragment shader's region starts at the vertex band.
  auto band = [](uint32_t n) { return SlotBand{n * kShaderBandSlots, (n + 1) * kShaderBandSlots}; };
  switch (stage) {
    case VK_SHADER_STAGE_GEOMETRY_BIT: return band(0);
    case VK_SHADER_STAGE_TESSELLATION_EVALUATION_BIT: return band(1);
    case VK_SHADER_STAGE_TESSELLATION_CONTROL_BIT:
    case VK_SHADER_STAGE_TASK_BIT_EXT: return band(2);
    case VK_SHADER_STAGE_VERTEX_BIT:
    case VK_SHADER_STAGE_MESH_BIT_EXT: return band(3);
    case VK_SHADER_STAGE_FRAGMENT_BIT: return {4 * kShaderBandSlots, maxSlots};
    default: return {0, maxSlots};  // compute: alone at its bind point
  }
}

std::string shaderRefusal(const VkShaderCreateInfoEXT& info, uint32_t counterSet, bool fragmentStores,
                          bool vertexStores) {
  if (info.codeType != VK_SHADER_CODE_TYPE_SPIRV_EXT) {
    return "a binary shader object (VK_SHADER_CODE_TYPE_BINARY_EXT) holds no SPIR-V the layer could instrument: "
           "its draws run uncounted";
  }
  if (info.codeSize < 20 || info.codeSize % 4 != 0 || info.pCode == nullptr) {
    return "codeSize " + std::to_string(info.codeSize) + " is not a SPIR-V module's (a multiple of 4, at least 20)";
  }
  if (info.stage == VK_SHADER_STAGE_FRAGMENT_BIT && !fragmentStores) {
    return "the device has no fragmentStoresAndAtomics";
  }
  const VkShaderStageFlags vertexStages = VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_TESSELLATION_CONTROL_BIT |
                                          VK_SHADER_STAGE_TESSELLATION_EVALUATION_BIT | VK_SHADER_STAGE_GEOMETRY_BIT;
  if ((info.stage & vertexStages) != 0 && !vertexStores) return "the device has no vertexPipelineStoresAndAtomics";
  if (shaderStageIndex(info.stage) < 0) return "stage " + std::to_string(uint32_t(info.stage)) + " is not counted";
  if (info.setLayoutCount > counterSet) {
    return "the shader object uses " + std::to_string(info.setLayoutCount) +
           " descriptor sets and the layer needs set " + std::to_string(counterSet) + ": it runs unchanged, uncounted";
  }
  return "";
}

std::vector<VkDescriptorSetLayout> twinSetLayouts(const VkShaderCreateInfoEXT& info, uint32_t counterSet,
                                                  VkDescriptorSetLayout empty, VkDescriptorSetLayout counter) {
  std::vector<VkDescriptorSetLayout> sets(info.pSetLayouts, info.pSetLayouts + info.setLayoutCount);
  sets.resize(counterSet, empty);
  sets.push_back(counter);
  return sets;
}

std::string instrumentShaderObject(const std::vector<uint32_t>& words, spirv::InstrumentOptions options,
                                   uint32_t maxSlots, const std::string& name, ShaderObject& object,
                                   std::vector<uint32_t>& out, std::vector<std::string>& notes,
                                   std::vector<uint32_t>* early) {
  const SlotBand band = slotBand(object.stage, maxSlots);
  options.firstSlot = band.first;
  // Alpha to coverage is dynamic state for shader objects: the twin keeps
  // late tests, right whatever it is set to; `early` gets the copy with early
  // tests, bound while it is off (as pipelines' early-tests twins).
  options.earlyFragmentTests = false;
  auto result = spirv::instrument(words, options);
  if (!result) return result.error();
  const uint32_t reserved = result->layout().reserved();
  if (band.first + reserved > band.limit) {
    return "needs " + std::to_string(reserved) + " counter slots; a shader object of its stage holds " +
           std::to_string(band.limit - band.first);
  }
  object.firstSlot = band.first;
  object.counted.slots = band.first + reserved;
  object.counted.counted = true;
  object.counted.hasFragment = object.stage == VK_SHADER_STAGE_FRAGMENT_BIT;
  if (result->layout().needsSettling()) object.counted.foldLayouts.push_back(result->layout());
  for (auto& site : result->sites) {
    site.shader = name;
    object.counted.sites.push_back(std::move(site));
  }
  notes = std::move(result->notes);
  if (early != nullptr && object.stage == VK_SHADER_STAGE_FRAGMENT_BIT) {
    options.earlyFragmentTests = true;
    auto withEarly = spirv::instrument(words, options);
    // Bound in the twin's place, it must count into the same slots.
    if (withEarly && withEarly->earlyTestsAdded && withEarly->sites.size() == result->sites.size() &&
        withEarly->layout().reserved() == reserved && withEarly->derived == result->derived) {
      *early = std::move(withEarly->words);
      notes = std::move(withEarly->notes);
    }
  }
  out = std::move(result->words);
  return "";
}

std::shared_ptr<PipelineInfo> combineShaders(const std::vector<const ShaderObject*>& bound) {
  uint32_t shift = UINT32_MAX, end = 0;
  const ShaderObject* first = nullptr;
  for (const ShaderObject* s : bound) {
    if (s == nullptr || s->twin == VK_NULL_HANDLE || !s->counted.counted) continue;
    shift = std::min(shift, s->firstSlot);
    end = std::max(end, s->counted.slots);
    if (first == nullptr) first = s;
  }
  if (first == nullptr) return nullptr;
  auto info = std::make_shared<PipelineInfo>();
  info->handle = reinterpret_cast<uint64_t>(info.get());  // one identity per combination (regions' key)
  info->layout = first->counted.layout;
  info->slots = end - shift;
  info->regionShift = VkDeviceSize(shift) * 8;
  info->counted = true;
  // Named in per-draw lines by its shaders, as `shaders` names them.
  info->name = "shader objects";
  for (const ShaderObject* s : bound) {
    if (s != nullptr && s->twin != VK_NULL_HANDLE && s->counted.counted) info->name += " " + hexHandle(s->handle);
  }
  // Shader objects leave all this state to the command buffer.
  FixedFunction& fixed = info->fixed;
  fixed.dynamicWriteMask = fixed.dynamicWriteEnable = fixed.dynamicDiscard = fixed.dynamicVertexInput = true;
  for (const ShaderObject* s : bound) {
    if (s == nullptr || s->twin == VK_NULL_HANDLE || !s->counted.counted) continue;
    info->hasFragment = info->hasFragment || s->stage == VK_SHADER_STAGE_FRAGMENT_BIT;
    for (spirv::Site site : s->counted.sites) {
      site.slot -= shift;
      info->sites.push_back(std::move(site));
    }
    for (spirv::CopyLayout layout : s->counted.foldLayouts) {
      layout.firstSlot -= shift;
      for (auto& d : layout.derived) {
        d.from -= shift;
        d.to -= shift;
      }
      info->foldLayouts.push_back(std::move(layout));
    }
  }
  return info;
}

void unbindShaderObjects(CommandBufferState& cb, bool compute) {
  if (compute) {
    cb.shaders[kComputeShaderIndex] = 0;
  } else {
    std::fill(cb.shaders.begin(), cb.shaders.begin() + kComputeShaderIndex, 0);
  }
}

}  // namespace tally::layer
