// A scenes::Scene on the GPU, uploaded once per context and shared by every
// renderer: one vertex buffer (all meshes), one index buffer (32-bit), the
// per-draw and per-material SSBOs, the material maps with full mip chains
// (one image per texture plus a 1x1 dummy per map kind, for the per-draw
// passes; and one layered image per map kind, for the per-pixel shading passes
// on devices without descriptor indexing), deterministic point lights and a
// procedural sky cube map. Records every allocation for ResourceInfo.
#pragma once

#include <array>
#include <map>
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

class SceneLod;  // renderers/techniques/lod.hpp

struct GpuDraw {
  uint32_t material = 0;
  uint32_t firstIndex = 0;
  int32_t vertexOffset = 0;
  uint32_t indexCount = 0;
  scenes::AlphaMode alpha = scenes::AlphaMode::Opaque;  // its material's
  bool doubleSided = true;                              // its material's; false: back faces culled
  glm::vec3 center{0.0f};                               // of its bounds: the transparent pass sorts by it
};

// Which draws a geometry pass records (RendererBase::drawScene).
enum class DrawSubset {
  Opaque,  // alphaMode OPAQUE: the founding study's draws
  Masked,  // alphaMode MASK: a pipeline that alpha-tests (no early fragment tests)
  Blend,   // alphaMode BLEND: the transparent pass, back to front
};
bool inSubset(const GpuDraw& draw, DrawSubset subset);

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
  // What the scene asks beyond the founding study (scenes::Scene::features).
  const scenes::Scene::Features& features() const { return features_; }
  // The shader defines those features turn on, for every shader of every
  // renderer (shaders/common.h): none for the procedural scenes, so their
  // shaders and counts are the founding study's.
  std::vector<std::string> featureDefines() const;
  // The emissive map of a material (TALLY_EMISSIVE_MAPS): its texture, or a
  // white dummy (the factor alone), with the sampler to bind it with.
  VkImageView emissiveMap(uint32_t material) const { return emissiveViews_[material]; }
  VkSampler emissiveSampler(uint32_t material) const { return emissiveSamplers_[material]; }
  // The sampler of a material's map of kind k: the texture's own (glTF
  // samplers), or the default (repeat, trilinear) for a dummy.
  VkSampler materialSampler(uint32_t material, uint32_t kind) const { return materialSamplers_[material][kind]; }
  // Descriptor-indexing path: element e's sampler (its texture's own).
  const std::vector<VkSampler>& indexedMapSamplers() const { return indexedSamplers_; }
  // Map arrays: the emissive maps' layered image (TALLY_EMISSIVE_MAPS).
  VkImageView emissiveArray() const { return emissiveArray_.view; }
  // True when a map-array shader must wrap uvs itself (a texture that does
  // not repeat; the arrays' one sampler repeats): TALLY_WRAP_EMULATION.
  bool wrapEmulation() const { return wrapEmulation_; }
  // True when a feature define reads MaterialExtra (the alpha modes, uv
  // sets and transforms, emissive, wrap emulation).
  bool usesMaterialExtras() const {
    return features_.alphaMask || features_.alphaBlend || features_.uv1 || features_.uvTransform ||
           features_.emissive || wrapEmulation_;
  }

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
  // What counts per draw and per material are reported under
  // (gpu_scene_names.cpp): draw d's mesh name (its index where unnamed),
  // material m's name, and per element of indexedMapViews() the materials
  // that sample it (a dummy: every material without that map).
  const std::string& meshName(uint32_t draw) const { return meshNames_[draw]; }
  const std::string& materialName(uint32_t material) const { return materialNames_[material]; }
  const std::vector<std::vector<uint32_t>>& indexedMapMaterials() const { return indexedMapMaterials_; }
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
  // shaders::VertexAttributes per vertex (a 16-byte stand-in when no mesh
  // has colours or a second uv set); MaterialExtra per material, for the
  // per-draw and map-array paths and for the descriptor-indexing path.
  const gpu::Buffer& attributeBuffer() const { return attributes_; }
  const gpu::Buffer& materialExtraBuffer() const { return materialExtras_; }
  const gpu::Buffer& indexedMaterialExtraBuffer() const { return indexedMaterialExtras_; }
  // Levels of detail of every draw (renderers/techniques/lod.hpp), built on the first
  // call (by a renderer with LOD on) and kept with the scene.
  Result<const SceneLod*> lod() const;

  // "vertices", "indices", "draws", "materials", "lights", "sky".
  std::vector<ResourceInfo> bufferResources() const;
  ResourceInfo skyResource() const;
  // "material_maps.<kind>": the per-texture images (and dummy) of each kind
  // ("material_maps.emissive" too where a material has an emissive map). A
  // texture that serves several kinds is listed (and counted) under the
  // first kind a material uses it for.
  std::vector<ResourceInfo> materialMapResources() const;
  // "material_maps.<kind>": the layered image of each kind.
  std::vector<ResourceInfo> mapArrayResources() const;

 private:
  // upload's steps, in this order.
  struct MaterialTables;
  void uploadGeometry(gpu::Context& ctx, const scenes::Scene& scene);
  void uploadTextures(gpu::Context& ctx, const scenes::Scene& scene);
  void uploadMaterials(gpu::Context& ctx, const scenes::Scene& scene, MaterialTables& tables);
  void buildIndexedMaps(gpu::Context& ctx, const scenes::Scene& scene, const MaterialTables& tables);
  void uploadMapArrays(gpu::Context& ctx, const scenes::Scene& scene, const MaterialTables& tables);
  void uploadLightsAndSky(gpu::Context& ctx, const scenes::Scene& scene, const VkSamplerCreateInfo& defaults);
  void recordNames(const scenes::Scene& scene);  // after buildIndexedMaps
  std::vector<std::string> meshNames_, materialNames_;
  std::vector<std::vector<uint32_t>> indexedMapMaterials_;

  gpu::Context* ctx_ = nullptr;
  scenes::Bounds bounds_;
  gpu::Buffer vertices_, indices_, drawBuffer_, materialBuffer_, lightBuffer_, indexedMaterialBuffer_;
  gpu::Buffer attributes_, materialExtras_, indexedMaterialExtras_;
  scenes::Scene::Features features_;
  bool wrapEmulation_ = false;
  std::map<scenes::Sampler, VkSampler> samplers_;  // one per distinct glTF sampler
  std::vector<std::array<VkSampler, scenes::kMapSlotCount>> materialSamplers_;
  std::vector<VkSampler> indexedSamplers_;
  std::vector<VkImageView> emissiveViews_;
  std::vector<VkSampler> emissiveSamplers_;
  MipImage emissiveDummy_, emissiveArray_;
  uint64_t emissiveBytes_ = 0;
  VkSampler samplerFor(const scenes::Sampler& s);
  std::vector<VkImageView> indexedViews_;
  std::vector<std::string> indexedNames_;
  std::vector<GpuDraw> draws_;
  std::vector<glm::vec3> cpuPositions_;
  std::vector<uint32_t> cpuIndices_;
  std::vector<MipImage> textures_;                         // per scene texture
  std::vector<int32_t> textureKinds_;  // per texture: the map kind its bytes count under (-1: no material's)
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
