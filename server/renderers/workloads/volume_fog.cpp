// volume-fog: rays marched through the scene bounds' tiled density texture
// (workloads.hpp has the model; the counts the tests derive are from its helpers).
#include <algorithm>
#include <cmath>
#include <cstring>

#include "renderers/renderers.hpp"
#include "renderers/techniques/tile_memory.hpp"
#include "renderers/workloads/workload_base.hpp"

namespace tally::renderers {

using nlohmann::json;

namespace {

struct FogParams {     // std140; volume_fog.comp.glsl's FogBlock
  glm::vec4 boxMin;    // w: tile size
  glm::vec4 boxMax;    // w: t0
  glm::vec4 params;    // x: sigma scale, y: termination opacity
  glm::uvec4 counts;   // x: steps, y: max octaves
};

class VolumeFog final : public WorkloadBase {
 public:
  std::string_view name() const override { return "volume-fog"; }

  nlohmann::json frameExtras() override {
    json extras = RendererBase::frameExtras();
    extras.erase("tangent_frame");  // no vertices
    const WorkloadOptions& o = options_.workload;
    json fog = {{"mode", std::string(toString(o.fogOctaves))},
                {"steps", o.fogSteps},
                {"max_octaves", o.fogMaxOctaves},
                {"density", o.fogDensity},
                {"texture_size", kFogTextureSize},
                {"termination_opacity", kFogTerminationOpacity}};
    // Per pixel the pass leaves the samples it marched in alpha.
    const std::vector<float> steps = hdrAlpha();
    uint64_t rays = 0, early = 0, samples = 0;
    for (float s : steps) {
      if (s <= 0.0f) continue;  // the ray missed the box
      ++rays;
      samples += uint64_t(s);
      if (uint32_t(s) < o.fogSteps) ++early;
    }
    fog["rays"] = rays;
    fog["samples"] = samples;
    fog["samples_per_ray_mean"] = rays ? double(samples) / double(rays) : 0.0;
    fog["terminated_early_fraction"] = rays ? double(early) / double(rays) : 0.0;
    if (options_.instrumented && densityReads_ >= 0) {
      fog["reads"] = densityReads_;
      fog["reads_per_ray_mean"] = rays ? double(densityReads_) / double(rays) : 0.0;
      fog["reads_per_sample_mean"] = samples ? double(densityReads_) / double(samples) : 0.0;
    }
    extras["fog"] = fog;
    return extras;
  }

 protected:
  std::vector<std::string> ownPassNames() const override { return {"fog"}; }

  FrameResult finishFrame(FrameResult frame) override {
    densityReads_ = -1;
    for (const auto& p : frame.passes) {
      if (p.name != "fog") continue;
      densityReads_ = 0;
      for (const auto& a : p.accesses) {
        if (a.resource == "fog_density" && !a.write) densityReads_ += int64_t(a.count);
      }
    }
    return frame;
  }

  Result<bool> setupPasses() override {
    const WorkloadOptions& o = options_.workload;
    if (o.fogMaxOctaves < 1 || o.fogMaxOctaves > kFogMaxOctavesLimit) {
      return makeError("fog_max_octaves: must be 1 to " + std::to_string(kFogMaxOctavesLimit) + ", got " +
                       std::to_string(o.fogMaxOctaves));
    }
    if (o.fogSteps < 1) return makeError("fog_steps: must be at least 1");
    createVolume();
    const FogVolume v = fogVolumeFor(scene_->bounds(), o.fogDensity);
    FogParams params = {glm::vec4(v.min, v.tileSize), glm::vec4(v.max, v.t0),
                        glm::vec4(v.sigmaScale, kFogTerminationOpacity, 0, 0),
                        glm::uvec4(o.fogSteps, o.fogMaxOctaves, 0, 0)};
    buffer(params_, "fog_params", &params, sizeof params, sizeof params, false);
    VkDescriptorSetLayout layout = setLayout({VK_DESCRIPTOR_TYPE_STORAGE_IMAGE,
                                              VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER,
                                              VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER});
    VkDescriptorSet set = allocateSet(layout);
    writeImage(set, 1, volumeView_, sampler_, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    writeBuffer(set, 2, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, params_);
    inputs_ = {{1, "fog_density"}, {2, "fog_params"}};
    std::vector<std::string> defines;
    switch (o.fogOctaves) {
      case FogOctaves::Fixed: break;
      case FogOctaves::Dynamic: defines.push_back("FOG_DYNAMIC"); break;
      case FogOctaves::Constant:
        defines.push_back("FOG_CONSTANT");
        defines.push_back("FOG_MAX_OCTAVES " + std::to_string(o.fogMaxOctaves) + "u");
        break;
    }
    return addComputePass("fog", "volume_fog.comp.glsl", defines, layout, set);
  }

 private:
  // "fog_density": a 3D R8_UNORM texture, uploaded once, linear REPEAT sampler.
  void createVolume() {
    const uint32_t n = kFogTextureSize;
    VkImageCreateInfo info = {VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
    info.imageType = VK_IMAGE_TYPE_3D;
    info.format = VK_FORMAT_R8_UNORM;
    info.extent = {n, n, n};
    info.mipLevels = 1;
    info.arrayLayers = 1;
    info.samples = VK_SAMPLE_COUNT_1_BIT;
    info.tiling = VK_IMAGE_TILING_OPTIMAL;
    info.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    VK_CHECK(vkCreateImage(ctx_->device, &info, nullptr, &volume_));
    VkMemoryRequirements r;
    vkGetImageMemoryRequirements(ctx_->device, volume_, &r);
    VkMemoryAllocateInfo alloc = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
    alloc.allocationSize = r.size;
    alloc.memoryTypeIndex =
        gpu::selectMemoryType(ctx_->memoryProperties, r.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    VK_CHECK(vkAllocateMemory(ctx_->device, &alloc, nullptr, &volumeMemory_));
    VK_CHECK(vkBindImageMemory(ctx_->device, volume_, volumeMemory_, 0));
    VkImageViewCreateInfo view = {VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    view.image = volume_;
    view.viewType = VK_IMAGE_VIEW_TYPE_3D;
    view.format = VK_FORMAT_R8_UNORM;
    view.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    VK_CHECK(vkCreateImageView(ctx_->device, &view, nullptr, &volumeView_));
    sampler_ = gpu::createSampler(*ctx_, VK_FILTER_LINEAR, VK_SAMPLER_ADDRESS_MODE_REPEAT);

    const std::vector<uint8_t> texels = fogDensityTexels();
    gpu::Image wrapper;  // for transitionImage
    wrapper.image = volume_;
    gpu::submitFromStaging(*ctx_, texels, [&](VkCommandBuffer cmd, VkBuffer staging) {
      gpu::transitionImage(cmd, wrapper, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
      VkBufferImageCopy region = {};
      region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
      region.imageExtent = {n, n, n};
      vkCmdCopyBufferToImage(cmd, staging, volume_, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
      gpu::transitionImage(cmd, wrapper, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                           VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    });

    ResourceInfo res;
    res.name = "fog_density";
    res.kind = ResourceKind::Texture;
    res.format = VK_FORMAT_R8_UNORM;
    res.formatName = "R8_UNORM";
    res.elementBytes = 1;
    res.width = n;
    res.height = n;  // and n deep (ResourceInfo has no depth field)
    res.allocationBytes = r.size;
    res.usage = "sampled|transfer_dst|3d";
    res.memory = imageMemoryKind(*ctx_, r);
    res.objects = {gpu::objectOf(volume_)};
    resources_.push_back(res);
  }

  int64_t densityReads_ = -1;
};

}  // namespace

std::unique_ptr<Renderer> makeVolumeFog() { return std::make_unique<VolumeFog>(); }

}  // namespace tally::renderers
