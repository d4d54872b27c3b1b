// The scene data model shared by the procedural scenes, the glTF loader, the
// camera search and (later) the GPU upload. Pure CPU data, no Vulkan.
//
// Conventions (the renderers must follow them, or the CPU sky estimate and the
// analytic scenes stop matching what is drawn):
// - Right-handed world, +Y up, metres; front faces wind counter-clockwise (glTF).
// - Camera: fovDeg is the VERTICAL field of view; the view basis is viewMatrix()
//   (+Y up, with a fallback when looking straight up or down).
// - UVs may leave [0, 1]: samplers repeat (as Sponza's and the procedural maps expect).
// - Material maps: Diffuse is sRGB; Ambient (occlusion in R), Specular,
//   Roughness (roughness in G, metalness in B, glTF order) and Normal
//   (tangent space, xyz * 0.5 + 0.5) are linear. Procedural grey maps repeat the
//   value in R, G and B so either reading works.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>

namespace tally::scenes {

struct Vertex {
  glm::vec3 position;
  glm::vec3 normal;
  glm::vec4 tangent;  // xyz unit, orthogonal to normal; w = +-1: bitangent = cross(normal, xyz) * w
  glm::vec2 uv;
};
// Uploaded as is: 48 bytes, no padding (the renderers' vertex layout relies on it).
static_assert(sizeof(Vertex) == 48, "Vertex must stay tightly packed");

struct Bounds {
  glm::vec3 min{std::numeric_limits<float>::max()};
  glm::vec3 max{std::numeric_limits<float>::lowest()};

  bool empty() const { return min.x > max.x; }
  void extend(const glm::vec3& p) {
    min = glm::min(min, p);
    max = glm::max(max, p);
  }
  void extend(const Bounds& b) {
    if (!b.empty()) {
      extend(b.min);
      extend(b.max);
    }
  }
  glm::vec3 center() const { return (min + max) * 0.5f; }
  glm::vec3 extent() const { return max - min; }
  float diagonal() const { return empty() ? 0.0f : glm::length(max - min); }
};

// One mesh is one draw with one material.
struct Mesh {
  std::vector<Vertex> vertices;
  std::vector<uint32_t> indices;  // triangle list
  uint32_t material = 0;          // index into Scene::materials
  Bounds bounds;
  std::string name;

  size_t triangleCount() const { return indices.size() / 3; }
};

// The founding study's five material maps, in binding order.
enum class MapSlot : uint32_t { Diffuse, Ambient, Specular, Roughness, Normal };
constexpr size_t kMapSlotCount = 5;
const char* toString(MapSlot slot);  // "diffuse", "ambient", ...

enum class AlphaMode : uint32_t { Opaque, Mask, Blend };

struct Material {
  std::string name;
  // Texture index per MapSlot, or -1: the renderer binds its shared 1x1 dummy.
  std::array<int32_t, kMapSlotCount> maps{-1, -1, -1, -1, -1};
  glm::vec4 baseColor{1.0f};  // multiplies the diffuse map (glTF baseColorFactor)
  float roughness = 1.0f;     // glTF roughnessFactor
  float metallic = 0.0f;      // glTF metallicFactor
  AlphaMode alphaMode = AlphaMode::Opaque;
  float alphaCutoff = 0.5f;  // for AlphaMode::Mask
  bool doubleSided = false;  // draw without back-face culling

  int32_t map(MapSlot slot) const { return maps[static_cast<size_t>(slot)]; }
};

// Level 0; the GPU side generates the mip chain unless `mips` gives it.
struct Texture {
  std::string name;
  uint32_t width = 0;
  uint32_t height = 0;
  bool srgb = false;
  std::vector<uint8_t> rgba8;  // width * height * 4 bytes, rows top to bottom
  // Levels 1, 2, ... down to 1x1 (each max(1, previous / 2) per side), RGBA8
  // as rgba8: a texture whose levels must differ from box-filtered ones
  // (the precision sweep sees the mip level in the image). Empty: generated.
  std::vector<std::vector<uint8_t>> mips;
};

struct Camera {
  glm::vec3 eye{0.0f};
  glm::vec3 target{0.0f, 0.0f, -1.0f};
  float fovDeg = 60.0f;       // vertical
  float skyFraction = -1.0f;  // fraction of primary rays that hit nothing, measured; -1 = unknown
  std::string label;
};

struct Scene {
  std::string name;
  std::vector<Mesh> meshes;
  std::vector<Material> materials;
  std::vector<Texture> textures;
  Bounds bounds;
  // Cameras the scene is built for (planes, sky: the head-on camera whose
  // counts are known analytically). Empty for atrium and glTF scenes.
  std::vector<Camera> fixedCameras;
  // The effective spec, defaults filled in: {"name":"planes","layers":8,...}.
  nlohmann::json params;
  // What a loader skipped or changed (e.g. line primitives in a glTF file).
  std::vector<std::string> notes;

  size_t triangleCount() const;
  size_t vertexCount() const;
};

// View matrix for a camera: glm::lookAt with +Y up; when the view direction is
// within ~0.5 degrees of vertical, up becomes -Z (looking up) or +Z (looking
// down) so the basis stays defined.
glm::mat4 viewMatrix(const Camera& camera);

// Recomputes mesh.bounds from its vertices, and scene.bounds from the meshes.
void updateBounds(Mesh& mesh);
void updateBounds(Scene& scene);

// Per-vertex tangents from positions, normals and UVs: per-triangle tangent and
// bitangent accumulated (area-weighted), Gram-Schmidt against the normal,
// handedness in w. Vertices whose UVs are degenerate get any unit tangent
// orthogonal to the normal (w = 1). Normals must be unit length.
void computeTangents(Mesh& mesh);

// FNV-1a over every mesh's vertex and index bytes and every texture's texels:
// equal hashes mean identical data (used to check determinism).
uint64_t contentHash(const Scene& scene);

nlohmann::json toJson(const Camera& camera);

}  // namespace tally::scenes
