#include "renderers/visbuffer_base.hpp"

#include "shared.h"

namespace tally::renderers {

std::string visibilityIdOverflow(const std::vector<GpuDraw>& draws) {
  if (draws.size() > shaders::kMaxDraws) {
    return "the scene has " + std::to_string(draws.size()) + " draws; the visibility id holds at most " +
           std::to_string(shaders::kMaxDraws) + " (" + std::to_string(shaders::kDrawIdBits) + " bits of draw id)";
  }
  for (size_t i = 0; i < draws.size(); ++i) {
    const uint64_t triangles = draws[i].indexCount / 3;
    if (triangles > shaders::kTriangleIdMask) {
      return "draw " + std::to_string(i) + " has " + std::to_string(triangles) +
             " triangles; the visibility id holds at most " + std::to_string(shaders::kTriangleIdMask) +
             " per draw (" + std::to_string(shaders::kTriangleIdBits) +
             " bits of triangle id, the all-ones id being the clear value)";
    }
  }
  return "";
}

Result<bool> VisbufferBase::checkIdCapacity() const {
  if (std::string why = visibilityIdOverflow(scene_->draws()); !why.empty()) {
    return makeError(std::string(name()) + ": " + why);
  }
  return true;
}

bool VisbufferBase::indexedMaps() const {
  return ctx_ != nullptr && ctx_->descriptorIndexing && scene_ != nullptr &&
         !scene_->indexedMapViews().empty();
}

void VisbufferBase::addMapResources() {
  if (indexedMaps()) {
    for (auto& r : scene_->materialMapResources()) resources_.push_back(r);
    return;
  }
  // Map arrays: the shading pass reads the layered image of each kind, while
  // the alpha-tested twins and the transparent pass bind the per-texture
  // images of the same kind; both count under "material_maps.<kind>", so
  // both carry that name (the bytes are the layered image's).
  const std::vector<ResourceInfo> perTexture = scene_->materialMapResources();
  for (auto& r : scene_->mapArrayResources()) {
    for (const auto& t : perTexture) {
      if (t.name == r.name) r.objects.insert(r.objects.end(), t.objects.begin(), t.objects.end());
    }
    resources_.push_back(r);
  }
}

std::string materialSelectionUnsupported(const gpu::Context& ctx, MaterialSelection selection) {
  const std::string name = "material selection '" + std::string(toString(selection)) + "'";
  if (selection == MaterialSelection::Uniform && !ctx.descriptorIndexing) {
    return name + " needs descriptor indexing (shaderSampledImageArrayNonUniformIndexing), which this device lacks";
  }
  if (selection == MaterialSelection::FirstLane) {
    // The context keeps only what subgroup counting needs; ask again.
    VkPhysicalDeviceSubgroupProperties subgroup = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
    VkPhysicalDeviceProperties2 props = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
    props.pNext = &subgroup;
    vkGetPhysicalDeviceProperties2(ctx.physicalDevice, &props);
    const bool fragment = (subgroup.supportedStages & VK_SHADER_STAGE_FRAGMENT_BIT) != 0;
    const bool ballot = (subgroup.supportedOperations & VK_SUBGROUP_FEATURE_BALLOT_BIT) != 0;
    if (!fragment || !ballot) {
      return name + " needs subgroup ballot in fragment shaders (subgroupBroadcastFirst), which this device " +
             "lacks (VkPhysicalDeviceSubgroupProperties: " +
             (fragment ? "" : "supportedStages without FRAGMENT") + (!fragment && !ballot ? ", " : "") +
             (ballot ? "" : "supportedOperations without BALLOT") + ")";
    }
  }
  return "";
}

Result<bool> VisbufferBase::checkMsaa(const std::vector<MsaaTarget>& targets) const {
  if (std::string why = msaaUnsupported(*ctx_, options_.msaa, targets, false); !why.empty()) {
    return makeError(std::string(name()) + ": " + why);
  }
  return true;
}

FrameResult VisbufferBase::finishFrame(FrameResult frame) {
  for (auto& p : frame.passes) {
    if (p.name == "visibility") scaleSampleWrites(p, resources_, options_.msaa);
  }
  return frame;
}

nlohmann::json VisbufferBase::frameExtras() {
  nlohmann::json extras = RendererBase::frameExtras();
  if (options_.msaa > 1) extras["msaa"] = msaaExtras(resources_, options_.msaa);
  return extras;
}

nlohmann::json VisbufferBase::notes() const {
  nlohmann::json notes = {{"material_maps", indexedMaps() ? "descriptor_indexing" : "texture_arrays"},
                          {"material_selection", toString(options_.materialSelection)}};
  computeShadingNotes(notes);
  return notes;
}

Result<bool> VisbufferBase::addVisibilityPass(const std::string& vertex, const std::string& fragment,
                                              const std::vector<Target>& targets,
                                              const std::vector<std::string>& defines) {
  const VkImageLayout depthAttachment = VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
  const VkImageLayout depthReadOnly = VK_IMAGE_LAYOUT_DEPTH_STENCIL_READ_ONLY_OPTIMAL;
  uint32_t p = addPass("visibility");
  const uint32_t n = options_.msaa;
  const auto samples = VkSampleCountFlagBits(n);
  std::vector<AttachmentSpec> colors;
  std::vector<VkImageView> views;
  for (uint32_t i = 0; i < targets.size(); ++i) {
    colors.push_back({targets[i].image->format});
    colors.back().samples = samples;
    views.push_back(targets[i].image->view);
    pass(p).bindings.outputs[i] = targets[i].name;  // kOutVisibility = 0, kOutUvDerivatives = 1
  }
  // msaa: an N-sample depth/stencil for this pass only (the shading pass reads no depth).
  const gpu::Image* depth =
      n > 1 ? createTarget(kMsaaDepthName, kDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                           ResourceKind::Depth, n)
            : depth_;
  views.push_back(depth->view);
  AttachmentSpec depthSpec{kDepthFormat, true, VK_IMAGE_LAYOUT_UNDEFINED, depthAttachment, depthReadOnly};
  depthSpec.samples = samples;
  VkRenderPass rp = ownRenderPass(createPassRenderPass(*ctx_, colors, depthSpec));
  VkFramebuffer fb = framebuffer(rp, views);
  auto shaders =
      shaderPipeline(p, vertex, fragment, pipelineLayout(VK_NULL_HANDLE, VK_NULL_HANDLE), rp, defines);
  if (!shaders) return makeError(shaders.error());
  gpu::GraphicsPipelineDesc desc = *shaders;
  desc.colorAttachmentCount = uint32_t(colors.size());
  desc.samples = samples;
  meshVertexInput(desc);
  geometryState(desc, true);
  VkPipeline pipe = pipeline(desc);
  VkPipelineLayout layout = desc.layout;
  pass(p).depthWrite = n > 1 ? kMsaaDepthName : "depth";
  pass(p).indexFetches = true;
  const size_t colorCount = colors.size();
  auto masked = maskedDraws(p, desc, vertex, fragment, defines);  // alphaMode MASK: ids only where the test passes
  if (!masked) return makeError(masked.error());
  pass(p).record = [=, this, masked = *masked](VkCommandBuffer cmd) {
    std::vector<VkClearValue> clears(colorCount + 1);
    for (size_t i = 0; i < colorCount; ++i) {
      for (auto& v : clears[i].color.uint32) v = shaders::kVisibilityClear;
    }
    clears[colorCount] = depthClear();
    beginRenderPass(cmd, p, rp, fb, clears);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipe);
    bindSets(cmd, layout, VK_NULL_HANDLE, VK_NULL_HANDLE);
    drawScene(cmd, p, layout, false);
    if (masked) masked(cmd);
    endRenderPass(cmd, p);
  };
  return true;
}

Result<bool> VisbufferBase::addShadingPass(const std::string& fragment, const std::vector<Target>& inputs,
                                           const std::vector<std::string>& encodingDefines) {
  uint32_t p = addPass("shading");
  if (options_.computeShading && options_.msaa > 1) {
    return makeError(std::string(name()) + ": shading=compute with msaa " + std::to_string(options_.msaa) +
                     " is not supported");
  }
  std::vector<VkDescriptorType> types(inputs.size(), VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER);
  // shading=compute: the same inputs and "hdr" as a storage image (compute_shading.cpp).
  VkDescriptorSetLayout inputLayout =
      options_.computeShading ? computeShadingInputLayout(uint32_t(inputs.size())) : setLayout(types);
  VkDescriptorSet input = allocateSet(inputLayout);
  auto& b = pass(p).bindings;
  for (uint32_t i = 0; i < inputs.size(); ++i) {
    writeImage(input, i, inputs[i].image->view, targetSampler_, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    b.bind(shaders::kSetPassInput, i, inputs[i].name);
  }
  const bool indexed = indexedMaps();
  std::vector<std::string> defines = encodingDefines;
  if (!indexed) defines.push_back("TALLY_MAP_ARRAYS");
  const MaterialSelection selection = options_.materialSelection;
  if (std::string why = materialSelectionUnsupported(*ctx_, selection); !why.empty()) {
    return makeError(std::string(name()) + ": " + why);
  }
  if (selection == MaterialSelection::Uniform) {
    // Map arrays select by layer: there is no descriptor index to leave non-uniform.
    if (!indexed) {
      return makeError(std::string(name()) + ": material selection 'uniform' needs the descriptor-indexing " +
                       "path, and the scene's maps do not fit materialMaps[" +
                       std::to_string(shaders::kMaxMaterialMaps) + "]");
    }
    defines.push_back("TALLY_SELECT_UNIFORM");
  }
  if (selection == MaterialSelection::FirstLane) defines.push_back("TALLY_SELECT_FIRST_LANE");
  VkDescriptorSetLayout mapsLayout = mapArrayLayout_;
  VkDescriptorSet maps = mapArraySet_;
  VkDescriptorSet geometry = VK_NULL_HANDLE;
  if (indexed) {
    // materialMaps[kMaxMaterialMaps] at binding 0; element e counts under the
    // resource of the texture bound there.
    mapsLayout = setLayout({VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER}, {shaders::kMaxMaterialMaps});
    maps = allocateSet(mapsLayout);
    const auto& views = scene_->indexedMapViews();
    std::vector<gpu::DescriptorWrite> writes(views.size());
    for (uint32_t e = 0; e < views.size(); ++e) {
      writes[e].binding = shaders::kBindingMaterialMaps;
      writes[e].arrayElement = e;
      writes[e].type = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
      writes[e].image = {scene_->indexedMapSamplers()[e], views[e], VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
    }
    gpu::updateDescriptorSet(*ctx_, maps, writes);
    b.bindings[{shaders::kSetMaterial, shaders::kBindingMaterialMaps}] = scene_->indexedMapNames();
    geometry = geometrySetWith(scene_->indexedMaterialBuffer(), scene_->indexedMaterialExtraBuffer());
  } else {
    for (uint32_t k = 0; k < scenes::kMapSlotCount; ++k) {
      b.bind(shaders::kSetMaterial, k, std::string("material_maps.") + mapKindName(k));
    }
    if (scene_->features().emissiveMaps) {
      b.bind(shaders::kSetMaterial, shaders::kBindingEmissiveMap, std::string("material_maps.") + mapKindName(shaders::kMapEmissive));
    }
  }
  if (options_.computeShading) {
    // shading.frag.glsl -> shading.comp.glsl: the same shadeTriangle (visbuffer_shade.h).
    const std::string compute = fragment.substr(0, fragment.find(".frag")) + ".comp.glsl";
    return addComputeShading(p, compute, mapsLayout, maps, inputLayout, input, geometry, defines);
  }
  return addFullScreenShading(p, fragment, mapsLayout, maps, inputLayout, input, geometry, defines);
}

}  // namespace tally::renderers
