// The scene data model shared by the procedural scenes, the glTF loader, the
// camera search and (later) the GPU upload. Pure CPU data, no Vulkan.
//
// Conventions (the renderers must follow them, or the CPU sky estimate and the
// analytic scenes stop matching what is drawn):
// - Right-handed world, +Y up, metres; front faces wind counter-clockwise (glTF).
// - Camera: fovDeg is the VERTICAL field of view; the view basis is viewMatrix()
//   (+Y up, with a fallback when looking straight up or down).
// - UVs may leave [0, 1]: each texture's Sampler says how it wraps (glTF's
//   default, and the procedural maps', is repeat).
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
  // Optional per-vertex streams, parallel to `vertices` (empty: absent):
  // COLOR_0 as linear RGBA (multiplies the base colour; alpha 1 where the file
  // gives RGB), and TEXCOORD_1.
  std::vector<glm::vec4> colors;
  std::vector<glm::vec2> uv1;
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

// A texture's sampler (glTF samplers): wrap per axis and filters. The default
// is glTF's when a texture names no sampler: repeat, trilinear.
enum class Wrap : uint32_t { Repeat, MirroredRepeat, ClampToEdge };
enum class Filter : uint32_t { Nearest, Linear };
struct Sampler {
  Wrap wrapU = Wrap::Repeat;
  Wrap wrapV = Wrap::Repeat;
  Filter mag = Filter::Linear;
  Filter min = Filter::Linear;
  Filter mip = Filter::Linear;  // between mip levels
  bool mipmaps = true;          // false: level 0 only (glTF minFilter NEAREST or LINEAR)
  bool operator==(const Sampler&) const = default;
  auto operator<=>(const Sampler&) const = default;
};
const char* toString(Wrap wrap);  // "repeat", "mirrored_repeat", "clamp_to_edge"

// KHR_texture_transform of one texture reference: uv' = T(offset) R(rotation) S(scale) uv.
struct UvTransform {
  glm::vec2 offset{0.0f};
  float rotation = 0.0f;  // radians, counter-clockwise in uv space
  glm::vec2 scale{1.0f};
  bool identity() const { return offset == glm::vec2(0.0f) && rotation == 0.0f && scale == glm::vec2(1.0f); }
  // Columns: the 2x2 linear part, then the translation (as the shaders apply it).
  glm::mat3x2 matrix() const;
};

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
  // Per map (MapSlot order): the uv set it samples (0: TEXCOORD_0, 1:
  // TEXCOORD_1) and its KHR_texture_transform.
  std::array<uint32_t, kMapSlotCount> texCoord{0, 0, 0, 0, 0};
  std::array<UvTransform, kMapSlotCount> transform{};
  // glTF emissive: emissiveFactor times the emissive texture (sRGB; -1: none,
  // then the factor alone), added to the shaded colour.
  glm::vec3 emissiveFactor{0.0f};
  int32_t emissiveMap = -1;
  uint32_t emissiveTexCoord = 0;
  UvTransform emissiveTransform;

  int32_t map(MapSlot slot) const { return maps[static_cast<size_t>(slot)]; }
  bool emissive() const { return emissiveFactor != glm::vec3(0.0f); }
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
  Sampler sampler;  // how every use of this texture samples it
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
  // What the scene asks of a renderer beyond the founding study's opaque,
  // single-uv, single-sampler materials; each turns a shader feature on, so
  // a scene without it renders (and counts) exactly as before.
  struct Features {
    bool alphaMask = false;     // a drawn material with AlphaMode::Mask
    bool alphaBlend = false;    // ... with AlphaMode::Blend
    bool vertexColors = false;  // a mesh with COLOR_0
    bool uv1 = false;           // a map that samples TEXCOORD_1
    bool uvTransform = false;   // a map with a non-identity KHR_texture_transform
    bool emissive = false;      // a material with a non-zero emissive factor
    bool emissiveMaps = false;  // ... with an emissive texture
    bool singleSided = false;   // a drawn material that is not double-sided (back faces culled)
  };
  Features features() const;
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
