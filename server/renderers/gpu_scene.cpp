#include "renderers/gpu_scene.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <span>

#include "gpu/vk_check.hpp"
#include "renderers/scene_images.hpp"
#include "renderers/techniques/lod.hpp"
#include "shared.h"

namespace tally::renderers {
namespace {

constexpr uint32_t kKinds = scenes::kMapSlotCount;

// The neutral texel of each map kind where a material lacks the map: white
// diffuse, full ambient, no specular, roughness 1 (G), flat normal.
constexpr std::array<std::array<uint8_t, 4>, kKinds> kDummyTexels = {{
    {255, 255, 255, 255},  // diffuse
    {255, 255, 255, 255},  // ambient (occlusion in R)
    {0, 0, 0, 255},        // specular
    {255, 255, 0, 255},    // roughness in G, metalness in B
    {128, 128, 255, 255},  // normal (0.5, 0.5, 1)
}};


VkFormat kindFormat(uint32_t kind) {
  return kind == uint32_t(scenes::MapSlot::Diffuse) ? VK_FORMAT_R8G8B8A8_SRGB : VK_FORMAT_R8G8B8A8_UNORM;
}

double halton(uint32_t index, uint32_t base) {
  double f = 1, r = 0;
  for (uint32_t i = index; i > 0; i /= base) {
    f /= base;
    r += f * (i % base);
  }
  return r;
}


template <class T>
gpu::Buffer storageBuffer(const gpu::Context& ctx, const std::vector<T>& data, VkBufferUsageFlags extra) {
  VkDeviceSize bytes = std::max<VkDeviceSize>(data.size() * sizeof(T), 16);
  gpu::Buffer b = gpu::createBuffer(
      ctx, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT | extra,
      gpu::MemoryUse::DeviceLocal);
  if (!data.empty()) {
    gpu::uploadBuffer(ctx, b, {reinterpret_cast<const uint8_t*>(data.data()), data.size() * sizeof(T)});
  }
  return b;
}

VkSamplerAddressMode addressMode(scenes::Wrap w) {
  switch (w) {
    case scenes::Wrap::Repeat: return VK_SAMPLER_ADDRESS_MODE_REPEAT;
    case scenes::Wrap::MirroredRepeat: return VK_SAMPLER_ADDRESS_MODE_MIRRORED_REPEAT;
    case scenes::Wrap::ClampToEdge: return VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  }
  return VK_SAMPLER_ADDRESS_MODE_REPEAT;
}

VkFilter filterOf(scenes::Filter f) { return f == scenes::Filter::Nearest ? VK_FILTER_NEAREST : VK_FILTER_LINEAR; }

// RGBA in [0, 1] -> two uints of RGBA16 unorm (shaders::VertexAttributes::color).
void packColor(const glm::vec4& c, uint32_t out[2]) {
  auto q = [](float v) { return uint32_t(std::lround(std::clamp(v, 0.0f, 1.0f) * 65535.0f)); };
  out[0] = q(c.r) | q(c.g) << 16;
  out[1] = q(c.b) | q(c.a) << 16;
}

// The two rows of a uv transform as MaterialExtra::uvTransform stores them.
void putTransform(shaders::MaterialExtra& e, uint32_t map, const scenes::UvTransform& t) {
  const glm::mat3x2 m = t.matrix();
  e.uvTransform[2 * map] = glm::vec4(m[0][0], m[1][0], m[2][0], 0.0f);
  e.uvTransform[2 * map + 1] = glm::vec4(m[0][1], m[1][1], m[2][1], 0.0f);
}

uint32_t wrapBits(const scenes::Sampler& s) { return uint32_t(s.wrapU) | uint32_t(s.wrapV) << 2; }

uint64_t allocationOf(const gpu::Context& ctx, const gpu::Buffer& b) {
  VkMemoryRequirements r;
  vkGetBufferMemoryRequirements(ctx.device, b.buffer, &r);
  return r.size;
}

}  // namespace

const char* mapKindName(uint32_t kind) {
  return kind == shaders::kMapEmissive ? "emissive" : scenes::toString(scenes::MapSlot(kind));
}

bool inSubset(const GpuDraw& draw, DrawSubset subset) {
  switch (subset) {
    case DrawSubset::Opaque: return draw.alpha == scenes::AlphaMode::Opaque;
    case DrawSubset::Masked: return draw.alpha == scenes::AlphaMode::Mask;
    case DrawSubset::Blend: return draw.alpha == scenes::AlphaMode::Blend;
  }
  return false;
}

std::vector<std::string> GpuScene::featureDefines() const {
  std::vector<std::string> d;
  if (features_.vertexColors) d.push_back("TALLY_VERTEX_COLORS");
  if (features_.uv1) d.push_back("TALLY_UV1");
  if (features_.uvTransform) d.push_back("TALLY_UV_TRANSFORM");
  if (features_.emissive) d.push_back("TALLY_EMISSIVE");
  if (features_.emissiveMaps) d.push_back("TALLY_EMISSIVE_MAPS");
  if (wrapEmulation_) d.push_back("TALLY_WRAP_EMULATION");
  return d;
}

VkSampler GpuScene::samplerFor(const scenes::Sampler& s) {
  auto it = samplers_.find(s);
  if (it != samplers_.end()) return it->second;
  VkSamplerCreateInfo info = {VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  info.magFilter = filterOf(s.mag);
  info.minFilter = filterOf(s.min);
  info.mipmapMode = s.mip == scenes::Filter::Nearest ? VK_SAMPLER_MIPMAP_MODE_NEAREST : VK_SAMPLER_MIPMAP_MODE_LINEAR;
  info.addressModeU = addressMode(s.wrapU);
  info.addressModeV = addressMode(s.wrapV);
  info.addressModeW = VK_SAMPLER_ADDRESS_MODE_REPEAT;
  // No mipmaps (glTF minFilter NEAREST or LINEAR): level 0 only. A maxLod of
  // 0.25 rather than 0 keeps the min filter for minification (Vulkan picks
  // the mag filter at lod <= 0 after clamping).
  info.maxLod = s.mipmaps ? VK_LOD_CLAMP_NONE : 0.25f;
  VkSampler sampler = VK_NULL_HANDLE;
  VK_CHECK(vkCreateSampler(ctx_->device, &info, nullptr, &sampler));
  ctx_->log->sampler(sampler, info);
  samplers_[s] = sampler;
  return sampler;
}

GpuScene::~GpuScene() { destroy(); }

// What the materials' step leaves for the later ones: the materials (one
// default where the scene has none), their shader records, the texture per
// layer of each kind's array and of the emissive array (-1: the dummy), and
// the default sampler's description (the sky's sampler starts from it).
struct GpuScene::MaterialTables {
  std::vector<scenes::Material> materials;
  std::vector<shaders::Material> materialData;
  std::vector<shaders::MaterialExtra> extras;
  std::array<std::vector<int32_t>, kKinds> layersOf;  // texture index per layer (-1: dummy)
  std::vector<int32_t> emissiveLayers = {-1};  // texture per layer of the emissive array (-1: the dummy)
  VkSamplerCreateInfo defaults = {VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
};

Result<bool> GpuScene::upload(gpu::Context& ctx, const scenes::Scene& scene) {
  if (scene.meshes.empty() || scene.triangleCount() == 0) return makeError("scene: no triangles");
  for (const auto& t : scene.textures) {
    if (std::string why = explicitMipsError(t); !why.empty()) return makeError(why);
  }
  // The visibility id's draw and triangle limits are the visibility buffers'
  // alone: they refuse such a scene at setup (visbuffer_base.hpp).
  destroy();
  ctx_ = &ctx;
  bounds_ = scene.bounds;
  features_ = scene.features();

  uploadGeometry(ctx, scene);
  uploadTextures(ctx, scene);
  MaterialTables tables;
  uploadMaterials(ctx, scene, tables);
  buildIndexedMaps(ctx, scene, tables);
  recordNames(scene);
  uploadMapArrays(ctx, scene, tables);
  uploadLightsAndSky(ctx, scene, tables.defaults);
  return true;
}

void GpuScene::uploadGeometry(gpu::Context& ctx, const scenes::Scene& scene) {
  // Geometry: all meshes in one vertex and one index buffer.
  std::vector<scenes::Vertex> vertices;
  std::vector<uint32_t> indices;
  std::vector<shaders::DrawData> drawData;
  for (const auto& m : scene.meshes) {
    GpuDraw d;
    d.material = std::min<uint32_t>(m.material, uint32_t(std::max<size_t>(scene.materials.size(), 1) - 1));
    d.firstIndex = uint32_t(indices.size());
    d.vertexOffset = int32_t(vertices.size());
    d.indexCount = uint32_t(m.indices.size());
    if (d.material < scene.materials.size()) {
      d.alpha = scene.materials[d.material].alphaMode;
      d.doubleSided = scene.materials[d.material].doubleSided;
    }
    d.center = m.bounds.empty() ? glm::vec3(0.0f) : m.bounds.center();
    draws_.push_back(d);
    vertices.insert(vertices.end(), m.vertices.begin(), m.vertices.end());
    indices.insert(indices.end(), m.indices.begin(), m.indices.end());
    shaders::DrawData dd = {};
    dd.model = glm::mat4(1.0f);
    dd.materialIndex = d.material;
    dd.firstIndex = d.firstIndex;
    dd.vertexOffset = d.vertexOffset;
    dd.indexCount = d.indexCount;
    drawData.push_back(dd);
  }
  cpuPositions_.clear();
  cpuPositions_.reserve(vertices.size());
  for (const auto& v : vertices) cpuPositions_.push_back(v.position);
  cpuIndices_ = indices;
  // Transfer source: tangent_frame = quaternion packs a copy (renderers/techniques/tbn.cpp).
  vertices_ = storageBuffer(ctx, vertices, VK_BUFFER_USAGE_VERTEX_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT);
  indices_ = storageBuffer(ctx, indices, VK_BUFFER_USAGE_INDEX_BUFFER_BIT);
  drawBuffer_ = storageBuffer(ctx, drawData, 0);
  // glTF's optional streams: one element per vertex when a mesh has them.
  std::vector<shaders::VertexAttributes> attributes;
  if (features_.vertexColors || features_.uv1) {
    attributes.reserve(vertices.size());
    for (const auto& m : scene.meshes) {
      for (size_t i = 0; i < m.vertices.size(); ++i) {
        shaders::VertexAttributes a = {};
        packColor(i < m.colors.size() ? m.colors[i] : glm::vec4(1.0f), a.color);
        const glm::vec2 uv1 = i < m.uv1.size() ? m.uv1[i] : m.vertices[i].uv;
        a.uv1[0] = uv1.x;
        a.uv1[1] = uv1.y;
        attributes.push_back(a);
      }
    }
  }
  attributes_ = storageBuffer(ctx, attributes, VK_BUFFER_USAGE_VERTEX_BUFFER_BIT);
}

void GpuScene::uploadTextures(gpu::Context& ctx, const scenes::Scene& scene) {
  // Per-texture images with mips, and a 1x1 dummy per kind.
  for (const auto& t : scene.textures) {
    VkFormat format = t.srgb ? VK_FORMAT_R8G8B8A8_SRGB : VK_FORMAT_R8G8B8A8_UNORM;
    textures_.push_back(createMipImage(ctx, t.width, t.height, mipLevels(t.width, t.height), 1, format,
                                       VK_IMAGE_VIEW_TYPE_2D));
    uploadWithMips(ctx, textures_.back(), t.rgba8);
    if (!t.mips.empty()) uploadExplicitMips(ctx, textures_.back(), 0, t.mips);
  }
  for (uint32_t k = 0; k < kKinds; ++k) {
    dummies_[k] = createMipImage(ctx, 1, 1, 1, 1, kindFormat(k), VK_IMAGE_VIEW_TYPE_2D);
    uploadWithMips(ctx, dummies_[k], kDummyTexels[k]);
    mapBytesPerKind_[k] = dummies_[k].allocationBytes;
  }
}

void GpuScene::uploadMaterials(gpu::Context& ctx, const scenes::Scene& scene, MaterialTables& tables) {
  // Which textures each kind uses, and the layered image per kind (layer 0: the dummy).
  std::vector<scenes::Material>& materials = tables.materials;
  materials = scene.materials;
  if (materials.empty()) materials.emplace_back();
  std::vector<shaders::Material>& materialData = tables.materialData;
  auto& layersOf = tables.layersOf;
  for (uint32_t k = 0; k < kKinds; ++k) layersOf[k].push_back(-1);
  std::vector<bool> counted(scene.textures.size(), false);
  textureKinds_.assign(scene.textures.size(), -1);
  VkSamplerCreateInfo& defaults = tables.defaults;
  defaults.magFilter = VK_FILTER_LINEAR;
  defaults.minFilter = VK_FILTER_LINEAR;
  defaults.mipmapMode = VK_SAMPLER_MIPMAP_MODE_LINEAR;
  defaults.addressModeU = defaults.addressModeV = defaults.addressModeW =
      VK_SAMPLER_ADDRESS_MODE_REPEAT;  // glTF's default sampler; the procedural maps repeat
  defaults.maxLod = VK_LOD_CLAMP_NONE;
  VK_CHECK(vkCreateSampler(ctx.device, &defaults, nullptr, &sampler_));
  ctx.log->sampler(sampler_, defaults);
  emissiveDummy_ = createMipImage(ctx, 1, 1, 1, 1, VK_FORMAT_R8G8B8A8_SRGB, VK_IMAGE_VIEW_TYPE_2D);
  uploadWithMips(ctx, emissiveDummy_, kDummyTexels[0]);  // white: the emissive factor alone
  std::vector<shaders::MaterialExtra>& extras = tables.extras;
  std::vector<int32_t>& emissiveLayers = tables.emissiveLayers;
  for (const auto& m : materials) {
    std::array<VkImageView, kKinds> views{};
    std::array<VkSampler, kKinds> samplers{};
    shaders::Material md = {};
    md.baseColor = m.baseColor;
    md.roughnessFactor = m.roughness;
    shaders::MaterialExtra extra = {};
    extra.emissive = glm::vec4(m.emissiveFactor, 0.0f);
    extra.flags = (m.alphaMode == scenes::AlphaMode::Mask ? shaders::kMaterialAlphaMask : 0u) |
                  (m.alphaMode == scenes::AlphaMode::Blend ? shaders::kMaterialAlphaBlend : 0u);
    extra.alphaCutoff = m.alphaCutoff;
    for (uint32_t k = 0; k < kKinds; ++k) {
      putTransform(extra, k, m.transform[k]);
      if (m.texCoord[k] == 1) extra.texCoords |= 1u << k;
    }
    int32_t e = m.emissive() ? m.emissiveMap : -1;
    if (e >= int32_t(scene.textures.size())) e = -1;
    putTransform(extra, shaders::kMapEmissive, m.emissiveTransform);
    if (m.emissiveTexCoord == 1) extra.texCoords |= 1u << shaders::kMapEmissive;
    emissiveViews_.push_back(e < 0 ? emissiveDummy_.view : textures_[size_t(e)].view);
    emissiveSamplers_.push_back(e < 0 ? sampler_ : samplerFor(scene.textures[size_t(e)].sampler));
    if (e >= 0) {
      const scenes::Sampler& es = scene.textures[size_t(e)].sampler;
      extra.wraps |= wrapBits(es) << (4 * shaders::kMapEmissive);
      wrapEmulation_ = wrapEmulation_ || es.wrapU != scenes::Wrap::Repeat || es.wrapV != scenes::Wrap::Repeat;
      auto it = std::find(emissiveLayers.begin(), emissiveLayers.end(), e);
      if (it == emissiveLayers.end()) it = emissiveLayers.insert(emissiveLayers.end(), e);
      extra.emissiveMap = uint32_t(it - emissiveLayers.begin());
      if (!counted[size_t(e)]) {
        counted[size_t(e)] = true;
        textureKinds_[size_t(e)] = int32_t(shaders::kMapEmissive);
        emissiveBytes_ += textures_[size_t(e)].allocationBytes;
      }
    }
    for (uint32_t k = 0; k < kKinds; ++k) {
      int32_t t = m.maps[k];
      if (t >= int32_t(scene.textures.size())) t = -1;
      views[k] = t < 0 ? dummies_[k].view : textures_[size_t(t)].view;
      samplers[k] = t < 0 ? sampler_ : samplerFor(scene.textures[size_t(t)].sampler);
      if (t >= 0) {
        const scenes::Sampler& ts = scene.textures[size_t(t)].sampler;
        extra.wraps |= wrapBits(ts) << (4 * k);
        wrapEmulation_ = wrapEmulation_ || ts.wrapU != scenes::Wrap::Repeat || ts.wrapV != scenes::Wrap::Repeat;
      }
      auto& layers = layersOf[k];
      auto it = std::find(layers.begin(), layers.end(), t);
      if (it == layers.end()) it = layers.insert(layers.end(), t);
      md.maps[k] = uint32_t(it - layers.begin());
      if (t >= 0 && !counted[size_t(t)]) {
        counted[size_t(t)] = true;
        textureKinds_[size_t(t)] = int32_t(k);
        mapBytesPerKind_[k] += textures_[size_t(t)].allocationBytes;
      }
    }
    materialMapViews_.push_back(views);
    materialSamplers_.push_back(samplers);
    materialData.push_back(md);
    extras.push_back(extra);
  }
  materialBuffer_ = storageBuffer(ctx, materialData, 0);
  materialExtras_ = storageBuffer(ctx, extras, 0);
  if (features_.emissiveMaps) emissiveBytes_ += emissiveDummy_.allocationBytes;
}

void GpuScene::buildIndexedMaps(gpu::Context& ctx, const scenes::Scene& scene, const MaterialTables& tables) {
  const auto& [materials, materialData, extras, layersOf, emissiveLayers, defaults] = tables;
  // The descriptor-indexing layout: dummies at 0..4, texture t at 5 + t.
  if (kKinds + scene.textures.size() <= shaders::kMaxMaterialMaps) {
    std::vector<std::string> textureKind(scene.textures.size(), "material_maps.unused");
    std::vector<bool> named(scene.textures.size(), false);
    std::vector<shaders::Material> indexedData = materialData;
    std::vector<shaders::MaterialExtra> indexedExtras = extras;
    for (size_t m = 0; m < materials.size(); ++m) {
      // The emissive map: its texture's element, or the white diffuse dummy's (0).
      int32_t e = materials[m].emissive() ? materials[m].emissiveMap : -1;
      if (e >= int32_t(scene.textures.size())) e = -1;
      indexedExtras[m].emissiveMap = e < 0 ? 0u : uint32_t(kKinds + size_t(e));
      for (uint32_t k = 0; k < kKinds; ++k) {
        int32_t t = materials[m].maps[k];
        if (t >= int32_t(scene.textures.size())) t = -1;
        indexedData[m].maps[k] = t < 0 ? k : uint32_t(kKinds + size_t(t));
        if (t >= 0 && !named[size_t(t)]) {  // a texture counts under the first kind that uses it
          named[size_t(t)] = true;
          textureKind[size_t(t)] = std::string("material_maps.") + mapKindName(k);
        }
      }
      if (e >= 0 && !named[size_t(e)]) {
        named[size_t(e)] = true;
        textureKind[size_t(e)] = std::string("material_maps.") + mapKindName(shaders::kMapEmissive);
      }
    }
    for (uint32_t k = 0; k < kKinds; ++k) {
      indexedViews_.push_back(dummies_[k].view);
      indexedSamplers_.push_back(sampler_);
      indexedNames_.push_back(std::string("material_maps.") + mapKindName(k));
    }
    for (size_t t = 0; t < scene.textures.size(); ++t) {
      indexedViews_.push_back(textures_[t].view);
      indexedSamplers_.push_back(samplerFor(scene.textures[t].sampler));
      indexedNames_.push_back(textureKind[t]);
    }
    while (indexedViews_.size() < shaders::kMaxMaterialMaps) {
      indexedViews_.push_back(dummies_[0].view);
      indexedSamplers_.push_back(sampler_);
      indexedNames_.push_back(indexedNames_[0]);
    }
    indexedMaterialBuffer_ = storageBuffer(ctx, indexedData, 0);
    indexedMaterialExtras_ = storageBuffer(ctx, indexedExtras, 0);
  }
}

void GpuScene::uploadMapArrays(gpu::Context& ctx, const scenes::Scene& scene, const MaterialTables& tables) {
  const auto& [materials, materialData, extras, layersOf, emissiveLayers, defaults] = tables;
  for (uint32_t k = 0; k < kKinds; ++k) {
    uint32_t w = 1, h = 1;
    for (int32_t t : layersOf[k]) {
      if (t < 0) continue;
      w = std::max(w, scene.textures[size_t(t)].width);
      h = std::max(h, scene.textures[size_t(t)].height);
    }
    uint32_t layers = uint32_t(layersOf[k].size());
    mapArrays_[k] =
        createMipImage(ctx, w, h, mipLevels(w, h), layers, kindFormat(k), VK_IMAGE_VIEW_TYPE_2D_ARRAY);
    std::vector<uint8_t> texels;
    texels.reserve(size_t(w) * h * 4 * layers);
    for (int32_t t : layersOf[k]) {
      if (t < 0) {
        for (size_t i = 0; i < size_t(w) * h; ++i)
          texels.insert(texels.end(), kDummyTexels[k].begin(), kDummyTexels[k].end());
      } else {
        auto layer = resizeNearest(scene.textures[size_t(t)], w, h);
        texels.insert(texels.end(), layer.begin(), layer.end());
      }
    }
    uploadWithMips(ctx, mapArrays_[k], texels);
    // A layer keeps its texture's own levels where it was not resized.
    for (uint32_t layer = 0; layer < layers; ++layer) {
      const int32_t t = layersOf[k][layer];
      if (t < 0) continue;
      const scenes::Texture& texture = scene.textures[size_t(t)];
      if (!texture.mips.empty() && texture.width == w && texture.height == h) {
        uploadExplicitMips(ctx, mapArrays_[k], layer, texture.mips);
      }
    }
  }

  if (features_.emissiveMaps) {  // map arrays: the emissive maps' layered image, as each kind's
    uint32_t w = 1, h = 1;
    for (int32_t t : emissiveLayers) {
      if (t < 0) continue;
      w = std::max(w, scene.textures[size_t(t)].width);
      h = std::max(h, scene.textures[size_t(t)].height);
    }
    const uint32_t layers = uint32_t(emissiveLayers.size());
    emissiveArray_ = createMipImage(ctx, w, h, mipLevels(w, h), layers, VK_FORMAT_R8G8B8A8_SRGB,
                                    VK_IMAGE_VIEW_TYPE_2D_ARRAY);
    std::vector<uint8_t> texels;
    texels.reserve(size_t(w) * h * 4 * layers);
    for (int32_t t : emissiveLayers) {
      if (t < 0) {
        for (size_t i = 0; i < size_t(w) * h; ++i) texels.insert(texels.end(), kDummyTexels[0].begin(), kDummyTexels[0].end());
      } else {
        auto layer = resizeNearest(scene.textures[size_t(t)], w, h);
        texels.insert(texels.end(), layer.begin(), layer.end());
      }
    }
    uploadWithMips(ctx, emissiveArray_, texels);
  }
}

void GpuScene::uploadLightsAndSky(gpu::Context& ctx, const scenes::Scene& scene, const VkSamplerCreateInfo& defaults) {
  // Lights: Halton points inside the bounds, radius a third of the diagonal.
  std::vector<shaders::PointLight> lights(kSceneLights);
  glm::vec3 lo = scene.bounds.min, size = scene.bounds.extent();
  float radius = std::max(scene.bounds.diagonal() / 3.0f, 1.0f);
  for (uint32_t i = 0; i < kSceneLights; ++i) {
    glm::vec3 p = lo + size * glm::vec3(halton(i + 1, 2), halton(i + 1, 3), halton(i + 1, 5));
    lights[i].positionRadius = glm::vec4(p, radius);
    float hue = float(halton(i + 1, 7));
    glm::vec3 c = glm::vec3(0.6f + 0.4f * hue, 0.7f, 1.0f - 0.4f * hue);
    lights[i].color = glm::vec4(c * (radius * radius * 0.1f), 0.0f);
  }
  lightBuffer_ = storageBuffer(ctx, lights, 0);

  sky_ = createMipImage(ctx, kSkyFaceSize, kSkyFaceSize, 1, 6, VK_FORMAT_R8G8B8A8_UNORM,
                        VK_IMAGE_VIEW_TYPE_CUBE);
  uploadWithMips(ctx, sky_, skyTexels());

  VkSamplerCreateInfo info = defaults;
  info.addressModeU = info.addressModeV = info.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  VK_CHECK(vkCreateSampler(ctx.device, &info, nullptr, &skySampler_));
  ctx.log->sampler(skySampler_, info);
}

void GpuScene::destroy() {
  if (ctx_ == nullptr) return;
  const gpu::Context& ctx = *ctx_;
  vkDeviceWaitIdle(ctx.device);
  lod_.reset();  // its index buffer, before the context goes
  for (auto* b : {&vertices_, &indices_, &drawBuffer_, &materialBuffer_, &lightBuffer_, &indexedMaterialBuffer_,
                  &attributes_, &materialExtras_, &indexedMaterialExtras_})
    gpu::destroyBuffer(ctx, *b);
  for (auto& [key, sampler] : samplers_) vkDestroySampler(ctx.device, sampler, nullptr);
  samplers_.clear();
  destroyMipImage(ctx, emissiveDummy_);
  destroyMipImage(ctx, emissiveArray_);
  materialSamplers_.clear();
  indexedSamplers_.clear();
  indexedViews_.clear();
  indexedNames_.clear();
  emissiveViews_.clear();
  emissiveSamplers_.clear();
  emissiveBytes_ = 0;
  wrapEmulation_ = false;
  features_ = {};
  for (auto& t : textures_) destroyMipImage(ctx, t);
  textures_.clear();
  textureKinds_.clear();
  for (auto& t : dummies_) destroyMipImage(ctx, t);
  for (auto& t : mapArrays_) destroyMipImage(ctx, t);
  destroyMipImage(ctx, sky_);
  if (sampler_ != VK_NULL_HANDLE) vkDestroySampler(ctx.device, sampler_, nullptr);
  if (skySampler_ != VK_NULL_HANDLE) vkDestroySampler(ctx.device, skySampler_, nullptr);
  sampler_ = skySampler_ = VK_NULL_HANDLE;
  draws_.clear();
  cpuPositions_.clear();
  cpuIndices_.clear();
  materialMapViews_.clear();
  mapBytesPerKind_ = {};
  ctx_ = nullptr;
}

Result<const SceneLod*> GpuScene::lod() const {
  if (ctx_ == nullptr) return makeError("lod: the scene is not uploaded");
  if (!lod_) {
    auto built = SceneLod::build(*ctx_, *this);
    if (!built) return makeError(built.error());
    lod_ = std::shared_ptr<const SceneLod>(std::move(*built));
  }
  return lod_.get();
}

std::vector<ResourceInfo> GpuScene::bufferResources() const {
  auto buffer = [&](const char* name, const gpu::Buffer& b, uint32_t element, const char* usage) {
    ResourceInfo r;
    r.name = name;
    r.kind = ResourceKind::Buffer;
    r.elementBytes = element;
    r.allocationBytes = allocationOf(*ctx_, b);
    r.usage = usage;
    r.objects = {gpu::objectOf(b.buffer)};
    return r;
  };
  std::vector<ResourceInfo> out = {buffer("vertices", vertices_, sizeof(shaders::Vertex), "vertex|storage"),
                                   buffer("indices", indices_, sizeof(uint32_t), "index|storage"),
                                   buffer("draws", drawBuffer_, sizeof(shaders::DrawData), "storage"),
                                   buffer("materials", materialBuffer_, sizeof(shaders::Material), "storage"),
                                   buffer("lights", lightBuffer_, sizeof(shaders::PointLight), "storage")};
  // The descriptor-indexing path's materials (indexedMaterialBuffer()) count as "materials" too.
  if (indexedMaterialBuffer_.buffer != VK_NULL_HANDLE) out[3].objects.push_back(gpu::objectOf(indexedMaterialBuffer_.buffer));
  // glTF scenes only: listed where a shader define can read them.
  if (features_.vertexColors || features_.uv1)
    out.push_back(buffer("vertex_attributes", attributes_, sizeof(shaders::VertexAttributes), "vertex|storage"));
  if (usesMaterialExtras()) {
    out.push_back(buffer("material_extras", materialExtras_, sizeof(shaders::MaterialExtra), "storage"));
    if (indexedMaterialExtras_.buffer != VK_NULL_HANDLE)
      out.back().objects.push_back(gpu::objectOf(indexedMaterialExtras_.buffer));
  }
  return out;
}

static ResourceInfo imageResource(std::string name, VkFormat format, uint32_t w, uint32_t h, uint64_t bytes,
                                  std::vector<gpu::DebugObject> objects) {
  ResourceInfo r;
  r.objects = std::move(objects);
  r.name = std::move(name);
  r.kind = ResourceKind::Texture;
  r.format = format;
  r.formatName = format == VK_FORMAT_R8G8B8A8_SRGB ? "R8G8B8A8_SRGB" : "R8G8B8A8_UNORM";
  r.elementBytes = gpu::formatBytes(format);
  r.width = w;
  r.height = h;
  r.allocationBytes = bytes;
  r.usage = "sampled";
  return r;
}

ResourceInfo GpuScene::skyResource() const {
  return imageResource("sky", sky_.format, sky_.width, sky_.height, sky_.allocationBytes, {gpu::objectOf(sky_.image)});
}

std::vector<ResourceInfo> GpuScene::materialMapResources() const {
  // A kind's images: its dummy and every texture counted under it (the
  // first kind that uses it, as its bytes are).
  auto imagesOf = [&](uint32_t kind, const MipImage& dummy) {
    std::vector<gpu::DebugObject> objects = {gpu::objectOf(dummy.image)};
    for (size_t t = 0; t < textures_.size(); ++t) {
      if (t < textureKinds_.size() && textureKinds_[t] == int32_t(kind)) objects.push_back(gpu::objectOf(textures_[t].image));
    }
    return objects;
  };
  std::vector<ResourceInfo> out;
  for (uint32_t k = 0; k < kKinds; ++k) {
    out.push_back(imageResource(std::string("material_maps.") + mapKindName(k), kindFormat(k), 0, 0,
                                mapBytesPerKind_[k], imagesOf(k, dummies_[k])));
  }
  if (features_.emissiveMaps) {
    out.push_back(imageResource(std::string("material_maps.") + mapKindName(shaders::kMapEmissive),
                                VK_FORMAT_R8G8B8A8_SRGB, 0, 0, emissiveBytes_,
                                imagesOf(shaders::kMapEmissive, emissiveDummy_)));
  }
  return out;
}

std::vector<ResourceInfo> GpuScene::mapArrayResources() const {
  std::vector<ResourceInfo> out;
  for (uint32_t k = 0; k < kKinds; ++k) {
    const auto& a = mapArrays_[k];
    out.push_back(imageResource(std::string("material_maps.") + mapKindName(k), a.format, a.width, a.height,
                                a.allocationBytes, {gpu::objectOf(a.image)}));
  }
  if (features_.emissiveMaps) {
    const auto& a = emissiveArray_;
    out.push_back(imageResource(std::string("material_maps.") + mapKindName(shaders::kMapEmissive), a.format,
                                a.width, a.height, a.allocationBytes, {gpu::objectOf(a.image)}));
  }
  return out;
}

}  // namespace tally::renderers
