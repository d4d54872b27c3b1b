// A scenes::Scene on the GPU, uploaded once per context and shared by every
// renderer: one vertex buffer (all meshes), one index buffer (32-bit), the
// per-draw and per-material SSBOs, the material maps with full mip chains
// (one image per texture plus a 1x1 dummy per map kind, for the per-draw
// passes; and one layered image per map kind, for the per-pixel shading passes
// on devices without descriptor indexing), deterministic point lights and a
// procedural sky cube map. Records every allocation for ResourceInfo.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

#include "common/result.hpp"
#include "gpu/context.hpp"
#include "gpu/resources.hpp"
#include "renderers/renderer.hpp"
#include "scenes/scene.hpp"

namespace tally::renderers {

// Point lights uploaded; a renderer uses the first RendererOptions::lights of
// them. The positions follow a Halton sequence, so every prefix is spread
// over the scene's bounds.
constexpr uint32_t kSceneLights = 400;
constexpr uint32_t kSkyFaceSize = 64;  // texels per cube face side: a smooth gradient needs few

// An image with a full mip chain (or layers), and its view.
struct MipImage {
  VkImage image = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkImageView view = VK_NULL_HANDLE;
  VkFormat format = VK_FORMAT_UNDEFINED;
  uint32_t width = 0, height = 0, levels = 1, layers = 1;
  uint64_t allocationBytes = 0;
};

class SceneLod;  // renderers/lod.hpp

struct GpuDraw {
  uint32_t material = 0;
  uint32_t firstIndex = 0;
  int32_t vertexOffset = 0;
  uint32_t indexCount = 0;
};

class GpuScene {
 public:
  GpuScene() = default;
  ~GpuScene();
  GpuScene(const GpuScene&) = delete;
  GpuScene& operator=(const GpuScene&) = delete;

  // Uploads `scene`. Fails (with the reason) on a scene no renderer can
  // draw: no triangles.
  Result<bool> upload(gpu::Context& ctx, const scenes::Scene& scene);
  void destroy();

  const gpu::Context& context() const { return *ctx_; }
  const scenes::Bounds& bounds() const { return bounds_; }
  const std::vector<GpuDraw>& draws() const { return draws_; }
  uint32_t materialCount() const { return uint32_t(materialMapViews_.size()); }

  // The material's map of kind k (the kind's dummy where it has none), for
  // the per-draw passes (forward, gbuffer).
  VkImageView materialMap(uint32_t material, uint32_t kind) const {
    return materialMapViews_[material][kind];
  }
  // One sampler2DArray per kind; Material::maps[k] (materials buffer) is the layer.
  VkImageView mapArray(uint32_t kind) const { return mapArrays_[kind].view; }
  // Descriptor-indexing path (shading passes' materialMaps[kMaxMaterialMaps]):
  // element e's view and the resource it belongs to; the dummies first, then
  // every scene texture; unused elements repeat dummy 0. Empty when the
  // scene has more maps than the array holds.
  const std::vector<VkImageView>& indexedMapViews() const { return indexedViews_; }
  const std::vector<std::string>& indexedMapNames() const { return indexedNames_; }
  // Materials whose maps[k] index indexedMapViews() (the materials buffer's index layers).
  const gpu::Buffer& indexedMaterialBuffer() const { return indexedMaterialBuffer_; }
  VkImageView skyView() const { return sky_.view; }
  VkSampler sampler() const { return sampler_; }        // trilinear, repeat
  VkSampler skySampler() const { return skySampler_; }  // linear, clamp

  // CPU copies of the uploaded geometry (all meshes, as in vertices() and
  // indices(); draws() gives each draw's range; models are the identity):
  // CPU passes over what the GPU draws (forward output=density).
  const std::vector<glm::vec3>& cpuPositions() const { return cpuPositions_; }
  const std::vector<uint32_t>& cpuIndices() const { return cpuIndices_; }

  const gpu::Buffer& vertices() const { return vertices_; }
  const gpu::Buffer& indices() const { return indices_; }
  const gpu::Buffer& drawBuffer() const { return drawBuffer_; }
  const gpu::Buffer& materialBuffer() const { return materialBuffer_; }
  const gpu::Buffer& lightBuffer() const { return lightBuffer_; }
  // Levels of detail of every draw (renderers/lod.hpp), built on the first
  // call (by a renderer with LOD on) and kept with the scene.
  Result<const SceneLod*> lod() const;

  // "vertices", "indices", "draws", "materials", "lights", "sky".
  std::vector<ResourceInfo> bufferResources() const;
  ResourceInfo skyResource() const;
  // "material_maps.<kind>": the per-texture images (and dummy) of each kind.
  std::vector<ResourceInfo> materialMapResources() const;
  // "material_maps.<kind>": the layered image of each kind.
  std::vector<ResourceInfo> mapArrayResources() const;

 private:
  gpu::Context* ctx_ = nullptr;
  scenes::Bounds bounds_;
  gpu::Buffer vertices_, indices_, drawBuffer_, materialBuffer_, lightBuffer_, indexedMaterialBuffer_;
  std::vector<VkImageView> indexedViews_;
  std::vector<std::string> indexedNames_;
  std::vector<GpuDraw> draws_;
  std::vector<glm::vec3> cpuPositions_;
  std::vector<uint32_t> cpuIndices_;
  std::vector<MipImage> textures_;                         // per scene texture
  std::array<MipImage, scenes::kMapSlotCount> dummies_;    // 1x1 per kind
  std::array<MipImage, scenes::kMapSlotCount> mapArrays_;  // layered per kind
  std::vector<std::array<VkImageView, scenes::kMapSlotCount>> materialMapViews_;
  std::array<uint64_t, scenes::kMapSlotCount> mapBytesPerKind_{};  // textures + dummy
  mutable std::shared_ptr<const SceneLod> lod_;  // lod(): built on first use
  MipImage sky_;
  VkSampler sampler_ = VK_NULL_HANDLE, skySampler_ = VK_NULL_HANDLE;
};

// Names of the map kinds, in binding order: "diffuse", "ambient", ...
const char* mapKindName(uint32_t kind);

}  // namespace tally::renderers
