// What the glTF loader's files share: the model tinygltf read and the scene
// built from it. gltf.cpp reads the file and runs the steps; the others
// convert: gltf_accessors.cpp reads accessors, gltf_materials.cpp materials,
// samplers and texture references, gltf_meshes.cpp the node graph and its
// primitives, gltf_textures.cpp decodes the images. It includes tinygltf, so
// only tally_scenes' own sources include it.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include <tiny_gltf.h>
#include <glm/glm.hpp>

#include "common/result.hpp"
#include "scenes/gltf.hpp"
#include "scenes/scene.hpp"

namespace tally::scenes::detail {

using tinygltf::Model;

std::string quote(const std::string& s);

// gltf_accessors.cpp: an accessor's elements, every range checked; `what`
// names the attribute in errors. Floats: `components` per element (normalized
// integers where glTF allows them).
Result<std::vector<float>> readFloats(const Model& model, int index, int components, bool allowNormalized,
                                      const std::string& what);
// Triangle indices, each below vertexCount.
Result<std::vector<uint32_t>> readIndices(const Model& model, int index, size_t vertexCount,
                                          const std::string& what);

// One texture of the scene: a glTF image in a colour space through a sampler.
struct ImageUse {
  int image;
  bool srgb;
  Sampler sampler;
  bool operator<(const ImageUse& o) const {
    return std::tie(image, srgb, sampler) < std::tie(o.image, o.srgb, o.sampler);
  }
};

// A primitive's attributes as read, before the node's transform.
struct PrimitiveData {
  int mode = 0;         // triangles, strip or fan
  size_t vertices = 0;  // POSITION's count
  std::vector<float> positions, normals, uv, tangents, uv1;  // empty where absent
  std::vector<float> colors;                                 // COLOR_0 as RGBA
  std::vector<uint32_t> indices;                             // as stored, before triangulation
};

struct Loader {
  const GltfOptions& options;
  Model model;
  Scene scene;
  std::map<ImageUse, int32_t> textureOf;  // -> index in scene.textures
  std::vector<ImageUse> uses;             // in scene.textures order
  int32_t defaultMaterial = -1;

  // gltf_materials.cpp
  // Texture slot for a glTF texture index (or -1).
  Result<int32_t> texture(int gltfTexture, bool srgb, const std::string& what);
  Result<bool> loadMaterials();

  // gltf_meshes.cpp
  std::string meshName(int meshIndex, size_t primitive) const;
  // Errors name the primitive by `what` ("mesh \"name\"").
  Result<PrimitiveData> readPrimitive(int meshIndex, size_t p, const std::string& what) const;
  Result<bool> addPrimitive(int meshIndex, size_t p, const glm::mat4& transform);
  Result<bool> addNode(int nodeIndex, const glm::mat4& parent, int depth);
  Result<bool> loadNodes();

  // gltf_textures.cpp
  std::string imageName(int image) const;
  // Decodes each used image once, on several threads, then downsizes.
  Result<bool> decodeTextures();
};

}  // namespace tally::scenes::detail
