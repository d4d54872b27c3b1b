#include "renderers/workloads/workloads.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <glm/gtc/packing.hpp>

#include "gpu/vk_check.hpp"
#include "renderers/renderers.hpp"
#include "renderers/techniques/tile_memory.hpp"

namespace tally::renderers {

using nlohmann::json;

std::string_view toString(FogOctaves mode) {
  switch (mode) {
    case FogOctaves::Fixed: return "fixed";
    case FogOctaves::Dynamic: return "dynamic";
    case FogOctaves::Constant: return "constant";
  }
  return "fixed";
}

std::optional<FogOctaves> parseFogOctaves(std::string_view name) {
  for (auto m : {FogOctaves::Fixed, FogOctaves::Dynamic, FogOctaves::Constant}) {
    if (name == toString(m)) return m;
  }
  return std::nullopt;
}

void addWorkloadOptions(std::vector<OptionDef>& defs) {
  defs.push_back({"octaves",
                  {"volume-fog"},
                  {"fixed", "dynamic", "constant"},
                  {},
                  nullptr,
                  "Octaves of the fog density per ray-march sample: fixed (a loop to fog_max_octaves read from a "
                  "uniform: the reference), dynamic (clamp(max - floor(log2(t / t0)), 1, max) from the sample's "
                  "distance: a runtime loop bound) or constant (the maximum as a compile-time #define the "
                  "compiler may unroll)",
                  "fixed",
                  [](RendererOptions& o, const json& v) { o.workload.fogOctaves = *parseFogOctaves(v.get<std::string>()); }});
  defs.push_back({"fog_steps",
                  {"volume-fog"},
                  {64, 8, 16, 32, 128, 256},
                  {},
                  nullptr,
                  "Samples per ray between the fog box's entry and exit (fewer where the opacity reaches 0.99 first)",
                  nullptr,
                  [](RendererOptions& o, const json& v) { o.workload.fogSteps = v.get<uint32_t>(); }});
  defs.back().parameter = true;
  defs.push_back({"fog_max_octaves",
                  {"volume-fog"},
                  {6, 1, 2, 3, 4, 5, 7, 8},
                  {},
                  nullptr,
                  "The most octaves (3D texture reads) per sample, at doubling frequency and halving amplitude",
                  nullptr,
                  [](RendererOptions& o, const json& v) { o.workload.fogMaxOctaves = v.get<uint32_t>(); }});
  defs.back().parameter = true;
  defs.push_back({"fog_density",
                  {"volume-fog"},
                  {},
                  {0.0, 64.0},
                  1.0,
                  "Extinction scale: optical depth along the scene's diagonal at mean density is about 2 x this",
                  nullptr,
                  [](RendererOptions& o, const json& v) { o.workload.fogDensity = v.get<float>(); }});
  defs.back().parameter = true;
  defs.push_back({"spheres",
                  {"raytrace"},
                  {32, 8, 16, 64, 128, 256},
                  {},
                  nullptr,
                  "Spheres in the ray tracer's storage buffer; every ray tests every sphere",
                  nullptr,
                  [](RendererOptions& o, const json& v) { o.workload.spheres = v.get<uint32_t>(); }});
  defs.back().parameter = true;
  defs.push_back({"bounces",
                  {"raytrace"},
                  {1, 0, 2, 3},
                  {},
                  nullptr,
                  "Specular reflection rays after the primary hit (each hit also casts one shadow ray)",
                  nullptr,
                  [](RendererOptions& o, const json& v) { o.workload.bounces = v.get<uint32_t>(); }});
  defs.back().parameter = true;
}

namespace {

uint32_t hash(uint32_t x) {  // lowbias32
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return x;
}

float hashUnit(uint32_t x) { return float(hash(x) >> 8) / float(1u << 24); }

}  // namespace

std::vector<uint8_t> fogDensityTexels() {
  const uint32_t n = kFogTextureSize;
  std::vector<float> noise(size_t(n) * n * n);
  for (uint32_t i = 0; i < noise.size(); ++i) noise[i] = hashUnit(i * 2654435761u + 12345u);
  // Two periodic 3x3x3 box blurs: smooth, still tiling.
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<float> out(noise.size());
    for (uint32_t z = 0; z < n; ++z) {
      for (uint32_t y = 0; y < n; ++y) {
        for (uint32_t x = 0; x < n; ++x) {
          float sum = 0;
          for (int dz = -1; dz <= 1; ++dz) {
            for (int dy = -1; dy <= 1; ++dy) {
              for (int dx = -1; dx <= 1; ++dx) {
                uint32_t xx = (x + n + dx) % n, yy = (y + n + dy) % n, zz = (z + n + dz) % n;
                sum += noise[(size_t(zz) * n + yy) * n + xx];
              }
            }
          }
          out[(size_t(z) * n + y) * n + x] = sum / 27.0f;
        }
      }
    }
    noise = std::move(out);
  }
  // Stretch the blurred values (around 0.5, narrow) back over [0, 1].
  std::vector<uint8_t> texels(noise.size());
  for (size_t i = 0; i < noise.size(); ++i) {
    float v = std::clamp(0.5f + (noise[i] - 0.5f) * 5.0f, 0.0f, 1.0f);
    texels[i] = uint8_t(std::lround(v * 255.0f));
  }
  return texels;
}

FogVolume fogVolumeFor(const scenes::Bounds& bounds, float densityOption) {
  FogVolume v;
  v.min = bounds.min;
  v.max = bounds.max;
  const float diagonal = std::max(glm::length(bounds.max - bounds.min), 1e-3f);
  v.tileSize = diagonal / 4.0f;
  v.t0 = diagonal / 32.0f;
  v.sigmaScale = densityOption * 4.0f / diagonal;
  return v;
}

uint32_t fogDynamicOctaves(float t, float t0, uint32_t maxOctaves) {
  int n = int(maxOctaves) - int(std::floor(std::log2(t / t0)));
  return uint32_t(std::clamp(n, 1, int(maxOctaves)));
}

glm::vec3 workloadRayDirection(const glm::mat4& view, const glm::mat4& proj, glm::vec2 viewport, uint32_t x,
                               uint32_t y) {
  glm::vec2 ndc = (glm::vec2(float(x), float(y)) + 0.5f) * (1.0f / viewport) * 2.0f - 1.0f;
  glm::vec3 v(ndc.x / proj[0][0], ndc.y / proj[1][1], -1.0f);
  return glm::normalize(glm::transpose(glm::mat3(view)) * v);
}

std::vector<glm::vec4> raytraceSpheres(const scenes::Bounds& bounds, uint32_t count) {
  std::vector<glm::vec4> out;
  const glm::vec3 size = bounds.max - bounds.min;
  const float diagonal = std::max(glm::length(size), 1e-3f);
  for (uint32_t i = 0; i < count; ++i) {
    float r = diagonal * (0.015f + 0.025f * hashUnit(4 * i + 1));
    float x = bounds.min.x + size.x * (0.1f + 0.8f * hashUnit(4 * i + 2));
    float z = bounds.min.z + size.z * (0.1f + 0.8f * hashUnit(4 * i + 3));
    // Most rest on the ground; every fourth floats at up to half the height.
    float lift = (i % 4 == 3) ? size.y * 0.5f * hashUnit(4 * i + 4) : 0.0f;
    out.emplace_back(x, bounds.min.y + r + lift, z, r);
  }
  return out;
}

glm::vec3 raytraceLight(const scenes::Bounds& bounds) {
  glm::vec3 c = (bounds.min + bounds.max) * 0.5f;
  return {c.x + 0.2f * (bounds.max.x - bounds.min.x), bounds.max.y, c.z + 0.1f * (bounds.max.z - bounds.min.z)};
}

float raytraceEpsilon(const scenes::Bounds& bounds) {
  return std::max(glm::length(bounds.max - bounds.min), 1e-3f) * 1e-4f;
}

namespace {

struct FogParams {     // std140; volume_fog.comp.glsl's FogBlock
  glm::vec4 boxMin;    // w: tile size
  glm::vec4 boxMax;    // w: t0
  glm::vec4 params;    // x: sigma scale, y: termination opacity
  glm::uvec4 counts;   // x: steps, y: max octaves
};

struct RayParams {     // std140; raytrace.comp.glsl's RayBlock
  glm::vec4 light;     // xyz: position; w: ground plane y
  glm::vec4 params;    // x: epsilon
  glm::uvec4 counts;   // x: spheres, y: bounces
};

// What both workloads share: "hdr" written by one compute pass, read back
// for the per-pixel figures the pass leaves in its alpha channel.
class WorkloadBase : public RendererBase {
 public:
  std::vector<float> depthImage() override { return {}; }  // no depth is written

 protected:
  VkImageUsageFlags hdrExtraUsage() const override {
    // transfer_src: frameExtras reads the alpha channel's per-pixel figures.
    return VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  }
  bool drawsSky() const override { return false; }
  void destroyPasses() override {
    if (ctx_ == nullptr) return;
    for (auto* b : {&params_, &data_}) gpu::destroyBuffer(*ctx_, *b);
    if (sampler_ != VK_NULL_HANDLE) vkDestroySampler(ctx_->device, sampler_, nullptr);
    sampler_ = VK_NULL_HANDLE;
    if (volumeView_ != VK_NULL_HANDLE) vkDestroyImageView(ctx_->device, volumeView_, nullptr);
    if (volume_ != VK_NULL_HANDLE) vkDestroyImage(ctx_->device, volume_, nullptr);
    if (volumeMemory_ != VK_NULL_HANDLE) vkFreeMemory(ctx_->device, volumeMemory_, nullptr);
    volumeView_ = VK_NULL_HANDLE;
    volume_ = VK_NULL_HANDLE;
    volumeMemory_ = VK_NULL_HANDLE;
  }

  // A host-visible uniform or storage buffer with `bytes`, recorded as a resource.
  gpu::Buffer& buffer(gpu::Buffer& b, const std::string& name, const void* data, size_t size, uint32_t element,
                      bool storage) {
    b = gpu::createBuffer(*ctx_, size,
                          storage ? VK_BUFFER_USAGE_STORAGE_BUFFER_BIT : VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                          gpu::MemoryUse::Upload);
    gpu::uploadBuffer(*ctx_, b, {static_cast<const uint8_t*>(data), size});
    ResourceInfo info;
    info.name = name;
    info.kind = ResourceKind::Buffer;
    info.elementBytes = element;
    info.allocationBytes = b.size;
    info.usage = storage ? "storage" : "uniform";
    resources_.push_back(info);
    return b;
  }

  void writeBuffer(VkDescriptorSet set, uint32_t binding, VkDescriptorType type, const gpu::Buffer& b) {
    gpu::DescriptorWrite w;
    w.binding = binding;
    w.type = type;
    w.buffer = {b.buffer, 0, VK_WHOLE_SIZE};
    gpu::updateDescriptorSet(*ctx_, set, {&w, 1});
  }

  // The one compute pass: `file` with `defines`, set 3 = `layout`/`set`
  // (binding 0 the "hdr" storage image), one invocation per pixel in 8x8 groups.
  Result<bool> addComputePass(const std::string& name, const std::string& file,
                              const std::vector<std::string>& defines, VkDescriptorSetLayout layout,
                              VkDescriptorSet set) {
    uint32_t p = addPass(name);
    writeStorageImage(set, 0, hdr_->view);
    pass(p).bindings.bind(shaders::kSetPassInput, 0, "hdr");
    for (const auto& [binding, resource] : inputs_) pass(p).bindings.bind(shaders::kSetPassInput, binding, resource);
    VkPipelineLayout pipelineLayout = computePipelineLayout(VK_NULL_HANDLE, layout);
    auto pipe = computePipeline(p, file, pipelineLayout, defines);
    if (!pipe) return makeError(pipe.error());
    VkPipeline pipeline = *pipe;
    const uint32_t gx = (extent_.width + 7) / 8, gy = (extent_.height + 7) / 8;
    pass(p).record = [=, this](VkCommandBuffer cmd) {
      gpu::transitionImage(cmd, *hdr_, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL);
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
      bindComputeSets(cmd, pipelineLayout, VK_NULL_HANDLE, set);
      beginComputePass(cmd, p);
      vkCmdDispatch(cmd, gx, gy, 1);
      endComputePass(cmd, p);
      gpu::transitionImage(cmd, *hdr_, VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    };
    return true;
  }

  // The alpha channel of "hdr" after the last frame, one float per pixel.
  std::vector<float> hdrAlpha() {
    std::vector<uint8_t> bytes = targetBytes("hdr");
    std::vector<float> out(bytes.size() / 8);
    for (size_t i = 0; i < out.size(); ++i) {
      uint16_t half;
      std::memcpy(&half, bytes.data() + i * 8 + 6, 2);
      out[i] = glm::unpackHalf1x16(half);
    }
    return out;
  }

  std::vector<std::pair<uint32_t, std::string>> inputs_;  // set-3 bindings besides "hdr"
  gpu::Buffer params_, data_;
  VkImage volume_ = VK_NULL_HANDLE;
  VkDeviceMemory volumeMemory_ = VK_NULL_HANDLE;
  VkImageView volumeView_ = VK_NULL_HANDLE;
  VkSampler sampler_ = VK_NULL_HANDLE;
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
    gpu::Buffer staging = gpu::createBuffer(*ctx_, texels.size(), VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                            gpu::MemoryUse::Upload);
    gpu::uploadBuffer(*ctx_, staging, texels);
    gpu::Image wrapper;  // for transitionImage
    wrapper.image = volume_;
    gpu::submitAndWait(*ctx_, [&](VkCommandBuffer cmd) {
      gpu::transitionImage(cmd, wrapper, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
      VkBufferImageCopy region = {};
      region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
      region.imageExtent = {n, n, n};
      vkCmdCopyBufferToImage(cmd, staging.buffer, volume_, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
      gpu::transitionImage(cmd, wrapper, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                           VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    });
    gpu::destroyBuffer(*ctx_, staging);

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
    resources_.push_back(res);
  }

  int64_t densityReads_ = -1;
};

class Raytrace final : public WorkloadBase {
 public:
  std::string_view name() const override { return "raytrace"; }

  nlohmann::json frameExtras() override {
    json extras = RendererBase::frameExtras();
    extras.erase("tangent_frame");
    const WorkloadOptions& o = options_.workload;
    // Per pixel the pass leaves shadow rays x 8 + reflection rays in alpha.
    uint64_t primary = 0, shadow = 0, reflection = 0;
    for (float a : hdrAlpha()) {
      uint32_t code = uint32_t(std::lround(a));
      ++primary;
      shadow += code / 8;
      reflection += code % 8;
    }
    json rt = {{"spheres", o.spheres},
               {"bounces", o.bounces},
               {"rays", {{"primary", primary}, {"shadow", shadow}, {"reflection", reflection},
                         {"total", primary + shadow + reflection}}},
               {"sphere_tests_predicted", (primary + shadow + reflection) * o.spheres}};
    if (options_.instrumented && sphereReads_ >= 0) rt["sphere_reads"] = sphereReads_;
    extras["raytrace"] = rt;
    return extras;
  }

 protected:
  std::vector<std::string> ownPassNames() const override { return {"raytrace"}; }

  FrameResult finishFrame(FrameResult frame) override {
    sphereReads_ = -1;
    for (const auto& p : frame.passes) {
      if (p.name != "raytrace") continue;
      sphereReads_ = 0;
      for (const auto& a : p.accesses) {
        if (a.resource == "spheres" && !a.write) sphereReads_ += int64_t(a.count);
      }
    }
    return frame;
  }

  Result<bool> setupPasses() override {
    const WorkloadOptions& o = options_.workload;
    if (o.spheres < 1 || o.spheres > 4096) return makeError("spheres: must be 1 to 4096");
    if (o.bounces > 3) return makeError("bounces: must be 0 to 3, got " + std::to_string(o.bounces));
    const scenes::Bounds& bounds = scene_->bounds();
    const std::vector<glm::vec4> spheres = raytraceSpheres(bounds, o.spheres);
    buffer(data_, "spheres", spheres.data(), spheres.size() * sizeof(glm::vec4), sizeof(glm::vec4), true);
    RayParams params = {glm::vec4(raytraceLight(bounds), bounds.min.y),
                        glm::vec4(raytraceEpsilon(bounds), 0, 0, 0), glm::uvec4(o.spheres, o.bounces, 0, 0)};
    buffer(params_, "raytrace_params", &params, sizeof params, sizeof params, false);
    VkDescriptorSetLayout layout = setLayout({VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                                              VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER});
    VkDescriptorSet set = allocateSet(layout);
    writeBuffer(set, 1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, data_);
    writeBuffer(set, 2, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, params_);
    inputs_ = {{1, "spheres"}, {2, "raytrace_params"}};
    return addComputePass("raytrace", "raytrace.comp.glsl", {}, layout, set);
  }

 private:
  int64_t sphereReads_ = -1;
};

}  // namespace

std::unique_ptr<Renderer> makeVolumeFog() { return std::make_unique<VolumeFog>(); }
std::unique_ptr<Renderer> makeRaytrace() { return std::make_unique<Raytrace>(); }

}  // namespace tally::renderers
