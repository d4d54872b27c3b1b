// Checks of a glTF file's JSON before anything is loaded (tinygltf reads
// every buffer and image whole): the extensions it requires or uses, the
// ranges of buffer views and accessors (with overflow-safe arithmetic), and
// what its node graph instances, against Tally's limits. A file that fails
// is refused in about the time it takes to parse its JSON, with no
// allocation beyond it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/result.hpp"

namespace tally::scenes {

// Limits on what a scene may draw per frame, checked before the geometry is
// built (each instance's vertices are transformed and stored, so these bound
// the loader's memory: 16 M vertices of 48 bytes are 768 MiB).
constexpr uint64_t kMaxMeshInstances = 65'536;      // primitive instances = draws
constexpr uint64_t kMaxTriangles = 16'777'216;      // triangles drawn per frame, all instances
constexpr uint64_t kMaxVertices = 16'777'216;       // vertices stored, all instances
constexpr uint32_t kMaxImageSide = 16'384;          // texels per side of an image
constexpr uint64_t kMaxImageTexels = 1ull << 28;    // texels of one image (1 GiB of RGBA8)

// Extensions whose meaning Tally draws (in part, as docs/scenes.md says).
bool isImplementedExtension(const std::string& name);

struct GltfPrecheck {
  // Notes for Scene::notes: extensions used but not implemented, and what of
  // them is ignored.
  std::vector<std::string> notes;
};

// `path` is a .gltf or .glb file. Errors name the element ("accessor 3:
// ...", "node 2: ...") but not the file: the caller prefixes it.
Result<GltfPrecheck> precheckGltf(const std::string& path);

}  // namespace tally::scenes
