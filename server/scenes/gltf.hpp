// glTF 2.0 loading (tinygltf): the Crytek Sponza and users' own scenes.
#pragma once

#include <cstdint>
#include <string>

#include "common/result.hpp"
#include "scenes/scene.hpp"

namespace tally::scenes {

struct GltfOptions {
  // 0 keeps textures as stored; otherwise each is halved (2x2 box filter, in
  // its stored encoding) until neither side exceeds this. Keeps lavapipe tests
  // fast; measurements on real GPUs should use full-size textures.
  uint32_t maxTextureSize = 0;
  // Threads decoding images (the bulk of loading Sponza); 0 = one per core.
  unsigned threads = 0;
  // Geometry only: images are not decoded (textures keep their names and
  // samplers, with no texels). For CPU work on the triangles (the BVH).
  bool geometryOnly = false;
};

// Loads a .gltf (with its .bin and images) or .glb file:
// - every triangle primitive of every mesh instance in the default scene,
//   node transforms applied (strips and fans become lists; points and lines
//   are skipped with a note in Scene::notes); one Mesh per primitive instance;
// - materials: baseColorTexture -> Diffuse (sRGB), occlusionTexture -> Ambient,
//   KHR_materials_specular's specularColorTexture (else specularTexture) ->
//   Specular, metallicRoughnessTexture -> Roughness, normalTexture -> Normal;
//   absent maps are -1 (the shared 1x1 dummy). A primitive without a material
//   gets an appended "default" material;
// - textures: only those materials use, one per (image, colour space) pair,
//   decoded to RGBA8 by stb_image (16-bit images are reduced to 8 bits);
// - tangents: the file's when present (re-orthogonalised after the
//   transform), else derived from UVs (computeTangents); missing normals are
//   derived from the faces.
// Errors name the file and the problem: missing file, not glTF, invalid JSON,
// missing buffers or images, out-of-range or unsupported accessors and index
// types, extensions that change geometry or images (Draco, meshopt,
// quantization, KTX2/WebP).
Result<Scene> loadGltf(const std::string& path, const GltfOptions& options = {});

}  // namespace tally::scenes
