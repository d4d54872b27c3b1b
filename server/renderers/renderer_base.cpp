// RendererBase: setting a renderer up on a scene (targets, shared passes,
// counters), recording and timing frames, reading results back, tearing down.
// Passes, pipelines, descriptor sets and scene draws are in base_*.cpp.
#include "renderers/renderer_base.hpp"

#include <chrono>

#include <algorithm>
#include <cstring>


#include "gpu/shaders.hpp"
#include "gpu/vk_check.hpp"
#include "renderers/projection.hpp"
#include "renderers/techniques/tile_memory.hpp"
#include "shared.h"

namespace tally::renderers {

namespace {

gpu::DescriptorWrite bufferWrite(uint32_t binding, VkDescriptorType type, const gpu::Buffer& b) {
  gpu::DescriptorWrite w;
  w.binding = binding;
  w.type = type;
  w.buffer = {b.buffer, 0, VK_WHOLE_SIZE};
  return w;
}

}  // namespace

// The descriptor pool and the set layouts every renderer shares.
void RendererBase::createSetLayouts(const GpuScene& scene, const RendererOptions& options) {
  const uint32_t materials = scene.materialCount();
  VkDescriptorPoolSize sizes[] = {
      {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 6 * (materials + 4) + 32 + shaders::kMaxMaterialMaps},
      {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 8},
      {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 48},
      {VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 16},
      {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER_DYNAMIC, 2}};
  pool_ = gpu::createDescriptorPool(*ctx_, materials + 32, sizes);
  using T = VkDescriptorType;
  const T ubo = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, ssbo = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
          image = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  frameLayout_ = options.shadows.filter == ShadowFilter::Off
                     ? setLayout({ubo, ubo, ssbo})
                     : setLayout({ubo, ubo, ssbo, ubo, image});  // + shadow_shared.h's kBindingShadow(Map)
  // draws, materials, vertices, indices; vertex_attributes, material_extras (glTF features)
  geometryLayout_ = setLayout({ssbo, ssbo, ssbo, ssbo, ssbo, ssbo});
  emptyLayout_ = setLayout({});
  // The counters; with footprint, the table (a bank per binding of the set) and the bitmaps.
  // Uninstrumented: no counter set at all. With draws, the counters are a
  // dynamic buffer: each draw binds its own region (base_draw_counts.cpp).
  const T counters = options.instrumented && options.draws ? VK_DESCRIPTOR_TYPE_STORAGE_BUFFER_DYNAMIC : ssbo;
  counterLayout_ = !options.instrumented                 ? VK_NULL_HANDLE
                   : options.footprintBlockBytes != 0 ? setLayout({counters, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER_DYNAMIC, ssbo})
                                                       : setLayout({counters});
  // The five maps; the emissive map at kBindingEmissiveMap where a material has one.
  const bool emissiveMaps = scene.features().emissiveMaps;
  materialLayout_ = emissiveMaps ? setLayout({image, image, image, image, image, image})
                                 : setLayout({image, image, image, image, image});
  mapArrayLayout_ = emissiveMaps ? setLayout({image, image, image, image, image, image})
                                 : setLayout({image, image, image, image, image});
}

// The camera and lighting buffers, and the level-of-detail chains and packed
// vertices where the options ask for them.
Result<bool> RendererBase::createFrameData(gpu::Context& ctx, const GpuScene& scene) {
  cameraBuffer_ = gpu::createBuffer(ctx, sizeof(shaders::Camera), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                                    gpu::MemoryUse::Upload);
  lightingBuffer_ = gpu::createBuffer(ctx, sizeof(shaders::Lighting), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                                      gpu::MemoryUse::Upload);
  shaders::Lighting lighting = {};
  lighting.lightCount = options_.lights;
  lighting.ambient = 0.15f;
  lighting.exposure = 1.0f;
  gpu::uploadBuffer(ctx, lightingBuffer_, {reinterpret_cast<const uint8_t*>(&lighting), sizeof lighting});

  if (options_.lodThresholdPx > 0) {  // levels of detail (renderers/techniques/lod.hpp): chains built on first use
    lod_ = std::make_unique<LodSelection>();
    if (auto ok = lod_->setup(ctx, scene, options_.lodThresholdPx); !ok) {
      lod_.reset();
      return makeError(ok.error());
    }
  }
  if (options_.tangentFrame == TangentFrameEncoding::Quaternion) {  // renderers/techniques/tbn.hpp
    auto packed = buildPackedVertices(ctx, scene);
    if (!packed) return makeError(packed.error());
    packedVertices_ = std::make_unique<PackedVertexBuffer>(std::move(*packed));
  }
  return true;
}

// The frame, geometry, material and map-array sets, written.
void RendererBase::writeSceneSets(gpu::Context& ctx, const GpuScene& scene) {
  using T = VkDescriptorType;
  const T ubo = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, ssbo = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  const uint32_t materials = scene.materialCount();
  const bool emissiveMaps = scene.features().emissiveMaps;
  frameSet_ = allocateSet(frameLayout_);
  geometrySet_ = allocateSet(geometryLayout_);
  gpu::DescriptorWrite frameWrites[] = {bufferWrite(0, ubo, cameraBuffer_),
                                        bufferWrite(1, ubo, lightingBuffer_),
                                        bufferWrite(2, ssbo, scene.lightBuffer())};
  gpu::updateDescriptorSet(ctx, frameSet_, frameWrites);
  gpu::DescriptorWrite geometryWrites[] = {
      bufferWrite(0, ssbo, drawsBuffer()), bufferWrite(1, ssbo, scene.materialBuffer()),
      bufferWrite(2, ssbo, vertexBuffer()), bufferWrite(3, ssbo, indexBuffer()),
      bufferWrite(shaders::kBindingVertexAttributes, ssbo, scene.attributeBuffer()),
      bufferWrite(shaders::kBindingMaterialExtras, ssbo, scene.materialExtraBuffer())};
  gpu::updateDescriptorSet(ctx, geometrySet_, geometryWrites);
  const VkImageLayout readOnly = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
  for (uint32_t m = 0; m < materials; ++m) {  // each map with its texture's own sampler
    VkDescriptorSet set = allocateSet(materialLayout_);
    for (uint32_t k = 0; k < scenes::kMapSlotCount; ++k) {
      writeImage(set, k, scene.materialMap(m, k), scene.materialSampler(m, k), readOnly);
    }
    if (emissiveMaps) writeImage(set, shaders::kBindingEmissiveMap, scene.emissiveMap(m), scene.emissiveSampler(m), readOnly);
    materialSets_.push_back(set);
  }
  // Map arrays: one repeating trilinear sampler per kind; a texture that
  // wraps otherwise is wrapped in the shader (TALLY_WRAP_EMULATION).
  mapArraySet_ = allocateSet(mapArrayLayout_);
  for (uint32_t k = 0; k < scenes::kMapSlotCount; ++k) {
    writeImage(mapArraySet_, k, scene.mapArray(k), scene.sampler(), readOnly);
  }
  if (emissiveMaps) writeImage(mapArraySet_, shaders::kBindingEmissiveMap, scene.emissiveArray(), scene.sampler(), readOnly);
  targetSampler_ = gpu::createSampler(ctx, VK_FILTER_NEAREST, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE);
}

// The scene's buffers under the names their lines carry, the camera and
// lighting buffers, and the targets every renderer has.
void RendererBase::addSharedResources(const GpuScene& scene) {
  for (auto& r : scene.bufferResources()) {
    // With LOD on, "indices" is the buffer the renderer binds: the original
    // indices and every coarser level.
    if (lod_ && r.name == "indices") r.allocationBytes = lod_->indexAllocationBytes();
    if (packedVertices_ && r.name == "vertices") r = packedVertices_->info;  // the buffer bound instead
    // The buffers bound under these names (LOD's index and draws buffers where it is on).
    if (r.name == "indices") r.objects = {gpu::objectOf(indexBuffer().buffer)};
    if (r.name == "draws") r.objects = {gpu::objectOf(drawsBuffer().buffer)};
    resources_.push_back(r);
  }
  ResourceInfo camera;
  camera.name = "camera";
  camera.kind = ResourceKind::Buffer;
  camera.elementBytes = sizeof(shaders::Camera);
  camera.allocationBytes = cameraBuffer_.size;
  camera.usage = "uniform";
  camera.objects = {gpu::objectOf(cameraBuffer_.buffer)};
  resources_.push_back(camera);
  camera.name = "lighting";
  camera.elementBytes = sizeof(shaders::Lighting);
  camera.allocationBytes = lightingBuffer_.size;
  camera.objects = {gpu::objectOf(lightingBuffer_.buffer)};
  resources_.push_back(camera);
  resources_.push_back(scene.skyResource());
  hdr_ = createTarget("hdr", kHdrFormat,
                      VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT | hdrExtraUsage(),
                      ResourceKind::Attachment);
  final_ = createTarget("final", kFinalFormat,
                        VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                        ResourceKind::Attachment);
  depth_ = createTarget("depth", kDepthFormat,
                        VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT |
                            VK_IMAGE_USAGE_TRANSFER_SRC_BIT,  // depthImage() reads it back
                        ResourceKind::Depth);
}

// The counter buffer and its set, the queries, and every object's debug name.
void RendererBase::createCountersAndQueries(gpu::Context& ctx) {
  const VkDescriptorType ssbo = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  if (options_.instrumented) {
    sizeCounterRegions();
    counters_ = gpu::createBuffer(ctx, VkDeviceSize(regionSlots_) * regionCount_ * sizeof(uint64_t),
                                  VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                                      VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                  gpu::MemoryUse::DeviceLocal);
    counterDescriptorSet_ = allocateSet(counterLayout_);
    gpu::DescriptorWrite counterWrite = bufferWrite(0, ssbo, counters_);
    if (countsDraws()) {  // one region, at the offset each bind gives
      counterWrite.type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER_DYNAMIC;
      counterWrite.buffer.range = VkDeviceSize(regionSlots_) * sizeof(uint64_t);
    }
    gpu::updateDescriptorSet(ctx, counterDescriptorSet_, {&counterWrite, 1});
  }
  if (ctx.timestamps) timestamps_ = gpu::createTimestampQueries(ctx, uint32_t(passes_.size()));
  if (ctx.pipelineStatistics) {
    statistics_ = gpu::createStatisticsQueries(ctx, uint32_t(passes_.size()),
                                               VK_QUERY_PIPELINE_STATISTIC_FRAGMENT_SHADER_INVOCATIONS_BIT |
                                                   VK_QUERY_PIPELINE_STATISTIC_COMPUTE_SHADER_INVOCATIONS_BIT);
  }
  // Every image and buffer under the name its lines carry, for tools
  // that intercept the application (VK_EXT_debug_utils; a no-op without it).
  for (const auto& r : resources_) {
    for (const auto& object : r.objects) gpu::nameObject(ctx, object, r.name);
  }
}

Result<bool> RendererBase::setup(gpu::Context& ctx, const GpuScene& scene, const RendererOptions& options) {
  destroy();
  setupTimes_ = {};
  ctx_ = &ctx;
  scene_ = &scene;
  options_ = options;
  options_.lights = std::min(options.lights, shaders::kMaxLights);
  extent_ = options.extent;
  if (extent_.width == 0 || extent_.height == 0) return makeError("extent: must be at least 1x1");
  if (options.bloom.blur != BloomBlur::Off && (options.bloom.taps % 2 == 0 || options.bloom.taps > 63)) {
    return makeError("bloom_taps: must be an odd kernel width up to 63, got " + std::to_string(options.bloom.taps));
  }
  counterSet_ = gpu::instrumentOptionsFor(ctx, options.counting).set;
  if (options.instrumented && counterSet_ <= shaders::kSetPassInput)
    return makeError("device: too few descriptor sets for the counters");
  counterDescriptorSet_ = VK_NULL_HANDLE;  // plain renderers have none (makePipelineLayout)
  maxLayoutSets_ = 0;
  try {
    createSetLayouts(scene, options);
    dynamicCull_ = scene.features().singleSided;
    if (dynamicCull_ && std::min(ctx.apiVersion, ctx.properties.apiVersion) < VK_API_VERSION_1_3) {
      destroy();
      return makeError(std::string(name()) +
                       ": the scene has single-sided materials; culling their back faces per draw needs "
                       "Vulkan 1.3 (dynamic cull mode)");
    }

    if (auto ok = createFrameData(ctx, scene); !ok) return makeError(ok.error());
    writeSceneSets(ctx, scene);

    addSharedResources(scene);
    if (auto ok = setupShadows(); !ok) {  // the "shadow" pass first (shadows.cpp)
      std::string why = ok.error();
      destroy();
      return makeError(why);
    }
    if (std::string why = featureRefusal(); !why.empty()) {
      destroy();
      return makeError(why);
    }
    if (auto ok = setupPasses(); !ok) {
      std::string why = ok.error();
      destroy();
      return makeError(why);
    }
    setupBloom();
    setupTonemapAndSkybox();

    createCountersAndQueries(ctx);
  } catch (const std::exception& e) {
    destroy();
    return makeError(std::string(name()) + ": " + e.what());
  }
  ready_ = true;
  return true;
}

nlohmann::json RendererBase::frameExtras() {
  nlohmann::json extras = nlohmann::json::object();
  if (!bloomExtras_.is_null()) extras["bloom"] = bloomExtras_;
  if (!shadow_.extras.is_null()) extras["shadows"] = shadow_.extras;
  if (lod_) extras["lod"] = lod_->extras();
  if (!tileMemoryExtras_.is_null()) extras["tile_memory"] = tileMemoryExtras_;
  if (packedVertices_) extras["tangent_frame"] = packedVertices_->stats;  // renderers/techniques/tbn.hpp
  return extras;
}

void RendererBase::recordAll(VkCommandBuffer cmd) {
  labelOpen_ = false;
  subpassLabelled_.clear();
  counterRegion_ = 0;
  if (counters_.buffer != VK_NULL_HANDLE) {  // instrumented
    vkCmdFillBuffer(cmd, counters_.buffer, 0, VK_WHOLE_SIZE, 0);  // counters are per frame
    VkMemoryBarrier barrier = {VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    barrier.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    barrier.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, 0, 1,
                         &barrier, 0, nullptr, 0, nullptr);
  }
  if (footprint_.created()) footprint_.recordClear(cmd);
  if (timestamps_.pool != VK_NULL_HANDLE) gpu::resetTimestamps(cmd, timestamps_);
  if (statistics_.pool != VK_NULL_HANDLE) gpu::resetStatistics(cmd, statistics_);
  for (uint32_t i = 0; i < passes_.size(); ++i) {
    passes_[i].indicesDrawn = 0;
    passes_[i].indexRanges.clear();
    passes_[i].drawsRecorded.clear();
    recordingPass_ = i;
    boundSets_ = {};
    if (timestamps_.pool != VK_NULL_HANDLE) gpu::writePassBegin(cmd, timestamps_, i);
    // The pass's debug label covers what its timestamps bracket. A pass an
    // earlier one recorded as its subpass was labelled there (nextSubpass):
    // its own record is empty and gets no second label.
    const bool ownLabel = subpassLabelled_.count(i) == 0;
    if (ownLabel) beginPassLabel(cmd, i);
    passes_[i].record(cmd);
    if (ownLabel) endPassLabel(cmd);  // or the label of the subpass it moved to
    if (timestamps_.pool != VK_NULL_HANDLE) gpu::writePassEnd(cmd, timestamps_, i);
  }
  subpassLabelled_.clear();
}

FrameResult RendererBase::renderFrame(const scenes::Camera& camera) {
  FrameResult frame;
  if (!ready_) return frame;
  // Near/far from the scene bounds unless the options fix them (sweeps).
  DepthRange range = options_.depthRange.zFar > options_.depthRange.zNear && options_.depthRange.zNear > 0
                         ? options_.depthRange
                         : depthRangeFor(scene_->bounds(), camera);
  shaders::Camera c = cameraUniform(camera, extent_, range);
  frameCamera_ = c;
  gpu::uploadBuffer(*ctx_, cameraBuffer_, {reinterpret_cast<const uint8_t*>(&c), sizeof c});
  if (lod_) lod_->select(camera, extent_);

  if (footprintOn() && !footprintReady_) discoverFootprint();

  using Clock = std::chrono::steady_clock;
  auto submitted = Clock::now();
  gpu::submitAndWait(*ctx_, [&](VkCommandBuffer cmd) { recordAll(cmd); });
  auto waited = Clock::now();
  frame.submitSeconds = std::chrono::duration<double>(waited - submitted).count();

  std::vector<double> times;
  if (timestamps_.pool != VK_NULL_HANDLE) times = gpu::readPassTimesMs(*ctx_, timestamps_);
  std::vector<gpu::PipelineStatistics> stats;
  if (statistics_.pool != VK_NULL_HANDLE) stats = gpu::readStatistics(*ctx_, statistics_);
  std::vector<uint64_t> counters;
  std::vector<std::vector<uint64_t>> regions;  // per draw region, with options_.draws
  if (options_.instrumented && slotCount_ > 0) counters = readCounters(regions);
  std::vector<uint32_t> bitmap;
  if (footprintReady_) bitmap = footprint_.read();
  frame.readbackSeconds = std::chrono::duration<double>(Clock::now() - waited).count();
  const uint32_t depthBytes = gpu::formatBytes(kDepthFormat);
  for (uint32_t i = 0; i < passes_.size(); ++i) {
    const Pass& p = passes_[i];
    PassResult r;
    r.name = p.name;
    if (i < times.size()) r.gpuMs = times[i];
    if (i < stats.size()) {
      r.fragmentInvocationsStatistic = int64_t(stats[i].fragmentShaderInvocations);
      r.computeInvocationsStatistic = int64_t(stats[i].computeShaderInvocations);
    }
    if (options_.instrumented) {
      PassCounts counts =
          attributeCounters(p.sites, counters, p.bindings, resources_, options_.sites);
      r.fragmentInvocations = counts.fragmentInvocations;
      r.computeInvocations = counts.computeInvocations;
      r.accesses = std::move(counts.accesses);
      r.maxSlotCount = counts.maxSlotCount;
      r.maxSlotResource = std::move(counts.maxSlotResource);
      r.sites = std::move(counts.sites);
      attributeDraws(i, r, regions);
      splitMaterialMaps(i, r, counts);
      if (footprintReady_) attributeFootprint(i, r.accesses, bitmap);
      if (!p.arithmetic.empty()) {
        r.arithmeticOps = 0;
        r.arithmeticCounted = p.arithmeticCounted;
        for (const auto& [slot, perInvocation] : p.arithmetic) {
          r.arithmeticOps += int64_t(perInvocation * (slot < counters.size() ? counters[slot] : 0));
        }
      }
      if (p.indexFetches && p.indicesDrawn > 0) {
        addAccess(r.accesses, "indices", false, p.indicesDrawn, sizeof(uint32_t), "derived");
        if (footprintReady_) indexFootprint(p, r.accesses);
      }
      if (!p.depthWrite.empty()) {
        // The written target's texel ("depth": D32_S8; "shadow_map": D32_SFLOAT).
        uint32_t writeBytes = depthBytes;
        for (const auto& info : resources_) {
          if (info.name == p.depthWrite && info.elementBytes > 0) writeBytes = info.elementBytes;
        }
        addAccess(r.accesses, p.depthWrite, true, r.fragmentInvocations, writeBytes, "derived");
      }
      if (p.name == "transparent") {
        // Blending reads the destination texel of every write (docs/measurement.md).
        std::vector<Access> blendReads;
        for (const auto& a : r.accesses)
          if (a.write && a.source == "counter" && a.resource == "final") blendReads.push_back(a);
        for (const auto& a : blendReads)
          addAccess(r.accesses, a.resource, false, a.count, a.count ? a.bytes / a.count : 0, "derived");
      }
    }
    frame.passes.push_back(std::move(r));
  }
  frame = finishFrame(std::move(frame));
  // The tile-memory model: lines of the resources a pass keeps on chip.
  for (uint32_t i = 0; i < passes_.size() && i < frame.passes.size(); ++i) {
    for (auto& a : frame.passes[i].accesses) a.onChip = passes_[i].onChip.count(a.resource) > 0;
  }
  // Extras only where a pass keeps something on chip (a technique's
  // measurement, as bloom's); elsewhere both models agree line by line.
  const bool anyOnChip = std::any_of(passes_.begin(), passes_.end(), [](const Pass& p) { return !p.onChip.empty(); });
  if (options_.instrumented && anyOnChip) tileMemoryExtras_ = tileMemorySummary(frame);
  return frame;
}

std::vector<uint8_t> RendererBase::finalImage() {
  if (!ready_) return {};
  return gpu::readImage(*ctx_, *final_, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
}

std::vector<float> RendererBase::depthImage() {
  if (!ready_) return {};
  // After the skybox pass the depth target is read-only depth/stencil.
  std::vector<uint8_t> bytes =
      gpu::readImage(*ctx_, *depth_, VK_IMAGE_LAYOUT_DEPTH_STENCIL_READ_ONLY_OPTIMAL);
  std::vector<float> out(bytes.size() / sizeof(float));
  std::memcpy(out.data(), bytes.data(), out.size() * sizeof(float));
  return out;
}

std::vector<uint8_t> RendererBase::targetBytes(std::string_view resourceName) {
  if (!ready_) return {};
  for (size_t i = 0; i < targets_.size(); ++i) {
    if (targetNames_[i].name != resourceName) continue;
    if ((targetNames_[i].usage & VK_IMAGE_USAGE_TRANSFER_SRC_BIT) == 0) return {};
    // Where the last frame leaves each target: "final" after the skybox pass,
    // "depth" read-only, every other target sampled by a later pass
    // (AttachmentSpec::final).
    VkImageLayout layout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
    if (&targets_[i] == final_) layout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    if (&targets_[i] == depth_) layout = VK_IMAGE_LAYOUT_DEPTH_STENCIL_READ_ONLY_OPTIMAL;
    return gpu::readImage(*ctx_, targets_[i], layout);
  }
  return {};
}

void RendererBase::destroy() {
  if (ctx_ == nullptr) return;
  const gpu::Context& ctx = *ctx_;
  vkDeviceWaitIdle(ctx.device);
  destroyPasses();
  footprint_.destroy();
  footprintReady_ = false;
  banks_.clear();
  footprintRegions_.clear();
  unmeasuredLines_.clear();
  vertexInputs_.clear();
  lod_.reset();
  if (packedVertices_) gpu::destroyBuffer(ctx, packedVertices_->buffer);
  packedVertices_.reset();
  for (auto p : pipelines_) vkDestroyPipeline(ctx.device, p, nullptr);
  for (auto l : pipelineLayouts_) vkDestroyPipelineLayout(ctx.device, l, nullptr);
  for (auto& m : modules_) gpu::destroyShaderModule(ctx, m);
  for (auto f : framebuffers_) vkDestroyFramebuffer(ctx.device, f, nullptr);
  for (auto r : renderPasses_) vkDestroyRenderPass(ctx.device, r, nullptr);
  if (pool_ != VK_NULL_HANDLE) vkDestroyDescriptorPool(ctx.device, pool_, nullptr);
  for (auto l : ownedSetLayouts_) vkDestroyDescriptorSetLayout(ctx.device, l, nullptr);
  if (targetSampler_ != VK_NULL_HANDLE) vkDestroySampler(ctx.device, targetSampler_, nullptr);
  if (depthOnlyView_ != VK_NULL_HANDLE) vkDestroyImageView(ctx.device, depthOnlyView_, nullptr);
  if (bloomSampler_ != VK_NULL_HANDLE) vkDestroySampler(ctx.device, bloomSampler_, nullptr);
  for (auto& t : targets_) gpu::destroyImage(ctx, t);
  for (auto* b : {&counters_, &cameraBuffer_, &lightingBuffer_}) gpu::destroyBuffer(ctx, *b);
  gpu::destroyTimestampQueries(ctx, timestamps_);
  gpu::destroyStatisticsQueries(ctx, statistics_);
  pipelines_.clear();
  passPipelines_.clear();
  modulePass_.clear();
  pipelineLayouts_.clear();
  modules_.clear();
  framebuffers_.clear();
  renderPasses_.clear();
  ownedSetLayouts_.clear();
  targets_.clear();
  targetNames_.clear();
  passes_.clear();
  resources_.clear();
  materialSets_.clear();
  pool_ = VK_NULL_HANDLE;
  targetSampler_ = VK_NULL_HANDLE;
  depthOnlyView_ = VK_NULL_HANDLE;
  bloomSampler_ = VK_NULL_HANDLE;
  bloomExtras_ = nullptr;
  tileMemoryExtras_ = nullptr;
  hdr_ = final_ = depth_ = bloom_ = nullptr;
  counterLayout_ = VK_NULL_HANDLE;
  counterDescriptorSet_ = VK_NULL_HANDLE;
  maxLayoutSets_ = 0;
  destroyShadows();
  slotCount_ = 0;
  copyLayouts_.clear();
  ready_ = false;
  ctx_ = nullptr;
}

}  // namespace tally::renderers
