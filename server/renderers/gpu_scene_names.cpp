// GpuScene: the names counts per draw and per material are reported under,
// and which materials sample each element of the descriptor-indexing map
// array (the visibility buffers' shading passes split their material-map
// reads per material with it).
#include "renderers/gpu_scene.hpp"

#include "shared.h"

namespace tally::renderers {

void GpuScene::recordNames(const scenes::Scene& scene) {
  constexpr uint32_t kKinds = scenes::kMapSlotCount;
  meshNames_.clear();
  materialNames_.clear();
  indexedMapMaterials_.clear();
  for (size_t i = 0; i < scene.meshes.size(); ++i) {
    meshNames_.push_back(scene.meshes[i].name.empty() ? std::to_string(i) : scene.meshes[i].name);
  }
  for (size_t m = 0; m < scene.materials.size(); ++m) {
    materialNames_.push_back(scene.materials[m].name.empty() ? "material " + std::to_string(m)
                                                              : scene.materials[m].name);
  }
  if (materialNames_.empty()) materialNames_.push_back("material 0");  // the default every draw gets
  if (indexedViews_.empty()) return;  // more maps than the array holds: no descriptor-indexing path
  // The element each material samples, as buildIndexedMaps laid them out:
  // the kind's dummy (0..4) where it has no map, else 5 + its texture.
  indexedMapMaterials_.assign(indexedViews_.size(), {});
  const size_t textures = scene.textures.size();
  auto element = [&](int32_t texture, uint32_t dummy) {
    return texture < 0 || size_t(texture) >= textures ? dummy : uint32_t(kKinds + size_t(texture));
  };
  for (uint32_t m = 0; m < scene.materials.size(); ++m) {
    const scenes::Material& material = scene.materials[m];
    std::vector<uint32_t> sampled;
    for (uint32_t k = 0; k < kKinds; ++k) sampled.push_back(element(material.maps[k], k));
    // The emissive map: its texture's element, or the white diffuse dummy's.
    if (features_.emissiveMaps) sampled.push_back(element(material.emissive() ? material.emissiveMap : -1, 0));
    for (uint32_t e : sampled) {
      auto& users = indexedMapMaterials_[e];
      if (users.empty() || users.back() != m) users.push_back(m);
    }
  }
}

}  // namespace tally::renderers
