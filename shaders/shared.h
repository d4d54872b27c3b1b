// Structs and limits shared by the GLSL shaders and the C++ renderers.
// GLSL:  #extension GL_GOOGLE_include_directive : require
//        #include "shared.h"
// C++:   #include "shared.h"  ->  namespace tally::shaders
// Write only what both languages parse: structs of vec4/mat4/uint/float and
// float arrays, TALLY_CONST constants, TALLY_FN functions.
#ifndef TALLY_SHADERS_SHARED_H
#define TALLY_SHADERS_SHARED_H

#ifdef __cplusplus
#include <cstddef>
#include <cstdint>
#include <glm/glm.hpp>
namespace tally::shaders {
using glm::mat4;
using glm::uvec2;
using glm::vec2;
using glm::vec4;
using uint = uint32_t;
#define TALLY_CONST(type, name, value) inline constexpr type name = value
#define TALLY_FN inline constexpr
#else
#define TALLY_CONST(type, name, value) const type name = value
#define TALLY_FN
#endif

// ---- Limits -----------------------------------------------------------------
TALLY_CONST(uint, kMaxLights, 400u);  // Blinn-Phong point lights, as in the founding study
TALLY_CONST(uint, kMapCount, 5u);     // material maps per material, as in the founding study
TALLY_CONST(uint, kMapDiffuse, 0u);   // Material::maps[] order
TALLY_CONST(uint, kMapAmbient, 1u);
TALLY_CONST(uint, kMapSpecular, 2u);
TALLY_CONST(uint, kMapRoughness, 3u);
TALLY_CONST(uint, kMapNormal, 4u);
// Textures in the shading passes' materialMaps[] array: Sponza has 69 plus the
// dummies; 128 is lavapipe's maxPerStageDescriptorSampledImages. Each dynamic
// index gets one counter slot per element, so this also sizes the counters.
TALLY_CONST(uint, kMaxMaterialMaps, 128u);
TALLY_CONST(float, kMaxShininess, 2048.0f);  // Blinn-Phong exponent cap: 2 / r^4 - 2 at roughness r ~= 0.18

// ---- Visibility-buffer id (fat R channel, lean R32_UINT) ----------------------
// id = drawId << kTriangleIdBits | triangleId (gl_PrimitiveID within the draw).
// Capacity: 512 draws of up to 8,388,607 triangles each (Sponza: 262,267
// triangles in all). The all-ones id (draw 511, triangle 8,388,607) is the
// clear value and never written, so such a triangle must not exist.
TALLY_CONST(uint, kTriangleIdBits, 23u);
TALLY_CONST(uint, kDrawIdBits, 9u);
TALLY_CONST(uint, kTriangleIdMask, (1u << kTriangleIdBits) - 1u);
TALLY_CONST(uint, kMaxDraws, 1u << kDrawIdBits);
TALLY_CONST(uint, kVisibilityClear, 0xffffffffu);

TALLY_FN uint packVisibilityId(uint drawId, uint triangleId) {
  return (drawId << kTriangleIdBits) | (triangleId & kTriangleIdMask);
}
TALLY_FN uint visibilityDrawId(uint id) { return id >> kTriangleIdBits; }
TALLY_FN uint visibilityTriangleId(uint id) { return id & kTriangleIdMask; }

// ---- Descriptor sets: 0..3 only ---------------------------------------------
// Set 7 is Tally's counter buffer (spirv::InstrumentOptions::set); lavapipe
// binds at most 8 sets, so shaders keep to 4 and leave 4..7 free.
TALLY_CONST(uint, kSetFrame, 0u);      // per frame: camera, lighting, lights
TALLY_CONST(uint, kSetMaterial, 1u);   // per draw: the material's maps; shading: all maps; sky cube
TALLY_CONST(uint, kSetGeometry, 2u);   // per scene: draws, materials, vertices, indices
TALLY_CONST(uint, kSetPassInput, 3u);  // per pass: render targets read by full-screen passes
TALLY_CONST(uint, kSetReservedCounters, 7u);  // never bound by a renderer

// Set 0
TALLY_CONST(uint, kBindingCamera, 0u);    // UBO Camera
TALLY_CONST(uint, kBindingLighting, 1u);  // UBO Lighting
TALLY_CONST(uint, kBindingLights, 2u);    // SSBO PointLight[kMaxLights]
// Set 1: forward / G-buffer bind the current material's five maps per draw
// (map kind k at binding k); the shading passes bind materialMaps[] at 0.
TALLY_CONST(uint, kBindingMaterialMaps, 0u);
TALLY_CONST(uint, kBindingSky, 0u);  // samplerCube, skybox pass
// Set 2
TALLY_CONST(uint, kBindingDraws, 0u);      // SSBO DrawData[]
TALLY_CONST(uint, kBindingMaterials, 1u);  // SSBO Material[]
TALLY_CONST(uint, kBindingVertices, 2u);   // SSBO Vertex[] (also the vertex buffer)
TALLY_CONST(uint, kBindingIndices, 3u);    // SSBO uint[] (also the index buffer, 32-bit)
// glTF scenes only (scenes::Scene::Features): read by shaders compiled with
// the matching TALLY_* feature define, never by the founding study's scenes.
TALLY_CONST(uint, kBindingVertexAttributes, 4u);  // SSBO VertexAttributes[] (also vertex buffer 1)
TALLY_CONST(uint, kBindingMaterialExtras, 5u);    // SSBO MaterialExtra[], parallel to Material[]
// Set 3, deferred lighting
TALLY_CONST(uint, kBindingDepthTarget, 0u);     // D32_S8, depth aspect view
TALLY_CONST(uint, kBindingNormalTarget, 1u);    // RGBA16F
TALLY_CONST(uint, kBindingDiffuseTarget, 2u);   // RGBA8
TALLY_CONST(uint, kBindingSpecularTarget, 3u);  // RGBA8
// RGBA16F "gbuffer.emissive", glTF emissive scenes, fragment lighting only
// (the compute variant's storage-image slot: emissive scenes refuse shading=compute).
TALLY_CONST(uint, kBindingEmissiveTarget, 4u);
// Set 3, visibility shading
TALLY_CONST(uint, kBindingVisibilityTarget, 0u);     // fat: R32G32_UINT, lean: R32_UINT
TALLY_CONST(uint, kBindingUvDerivativeTarget, 1u);   // fat only: R32G32_UINT
// Set 3, shading=compute (lighting.comp, shading*.comp): "hdr" as a storage image
TALLY_CONST(uint, kBindingHdrImage, 4u);  // RGBA16F, imageStore in layout GENERAL
// Set 3, tonemap
TALLY_CONST(uint, kBindingHdrTarget, 0u);  // RGBA16F
TALLY_CONST(uint, kBindingBloomTarget, 1u);  // RGBA16F, the blurred bloom (only with bloom on)
// Set 3, bloom passes: the RGBA16F target the bright pass reads (hdr) or a blur pass blurs
TALLY_CONST(uint, kBindingBloomSource, 0u);
// Set 3, forward's overdraw view
TALLY_CONST(uint, kBindingCountTarget, 0u);  // R32_SFLOAT fragment counts

// ---- Vertex inputs and fragment outputs --------------------------------------
TALLY_CONST(uint, kAttribPosition, 0u);  // R32G32B32_SFLOAT at Vertex::position
TALLY_CONST(uint, kAttribNormal, 1u);    // R32G32B32_SFLOAT
TALLY_CONST(uint, kAttribTangent, 2u);   // R32G32B32A32_SFLOAT
TALLY_CONST(uint, kAttribUv, 3u);        // R32G32_SFLOAT
TALLY_CONST(uint, kAttribColor, 4u);     // R16G16B16A16_UNORM, vertex buffer 1 (TALLY_VERTEX_COLORS)
TALLY_CONST(uint, kAttribUv1, 5u);       // R32G32_SFLOAT, vertex buffer 1 (TALLY_UV1)
// Set 1, per draw: the emissive map beside the five (TALLY_EMISSIVE_MAPS);
// map arrays: the emissive sampler2DArray.
TALLY_CONST(uint, kBindingEmissiveMap, 5u);
TALLY_CONST(uint, kMapEmissive, 5u);     // MaterialExtra::uvTransform and texCoords index of the emissive map
// MaterialExtra::flags
TALLY_CONST(uint, kMaterialAlphaMask, 1u);   // alphaMode MASK: discard below alphaCutoff
TALLY_CONST(uint, kMaterialAlphaBlend, 2u);  // alphaMode BLEND: drawn in the transparent pass
TALLY_CONST(uint, kOutColor, 0u);        // HDR RGBA16F (forward, lighting, shading, sky); LDR (tonemap)
TALLY_CONST(uint, kOutNormal, 0u);       // G-buffer RGBA16F
TALLY_CONST(uint, kOutDiffuse, 1u);      // G-buffer RGBA8
TALLY_CONST(uint, kOutSpecular, 2u);     // G-buffer RGBA8
TALLY_CONST(uint, kOutEmissive, 3u);     // G-buffer RGBA16F "gbuffer.emissive" (TALLY_EMISSIVE scenes only)
TALLY_CONST(uint, kOutVisibility, 0u);   // fat R32G32_UINT / lean R32_UINT
TALLY_CONST(uint, kOutUvDerivatives, 1u);  // fat R32G32_UINT
TALLY_CONST(uint, kOutCount, 1u);        // forward output=overdraw|overshading: R32_SFLOAT, additive

// ---- Structs ------------------------------------------------------------------
// Depth convention: [0, 1] with far = 1 (the sky's depth), positive-height
// viewport (the projection flips y), so NDC y grows with gl_FragCoord.y.
struct Camera {       // std140 UBO; 304 bytes
  mat4 view;
  mat4 proj;
  mat4 viewProj;
  mat4 invViewProj;   // reconstructs world position from (NDC xy, depth)
  vec4 position;      // xyz: eye in world space (m); w unused
  vec4 viewport;      // xy: size (pixels); zw: 1 / size
  vec4 depthRange;    // x: near, y: far (m); zw unused
};

struct Lighting {         // std140 UBO; 16 bytes
  uint lightCount;        // <= kMaxLights
  float ambient;          // ambient radiance, times diffuse x ambient map
  float exposure;         // tonemap scale applied before Reinhard
  uint reserved;
};

struct PointLight {     // std430; 32 bytes
  vec4 positionRadius;  // xyz: world position (m); w: radius of influence (m)
  vec4 color;           // rgb: radiance scale; a unused
};

// One vertex, tightly packed (float arrays: std430 stride 4, no vec3 padding),
// so the same buffer is the vertex buffer and the SSBO the visibility passes
// read. Offsets 0, 12, 24, 40; 48 bytes: the layout of scenes::Vertex.
struct Vertex {
  float position[3];  // object space (m)
  float normal[3];
  float tangent[4];   // xyz tangent, w: bitangent sign (glTF)
  float uv[2];
};

struct Material {          // std430; 48 bytes (vec4 first: std430 aligns the struct to 16)
  vec4 baseColor;           // multiplies the diffuse map (scenes::Material::baseColor)
  uint maps[kMapCount];     // materialMaps[] index per kind (scenes::MapSlot order); the 1x1 dummy's where missing
  float roughnessFactor;    // multiplies the roughness map (glTF roughnessFactor)
  float reserved[2];
};

// glTF's optional vertex streams, parallel to Vertex[]: COLOR_0 as RGBA16
// unorm (two uints: R | G << 16, B | A << 16; white where a mesh has none)
// and TEXCOORD_1 (TEXCOORD_0's values where a mesh has none).
struct VertexAttributes {  // std430; 16 bytes
  uint color[2];
  float uv1[2];
};

// What a glTF material adds to the founding study's Material, read only by
// shaders compiled with the feature's define.
struct MaterialExtra {     // std430; 240 bytes
  vec4 emissive;           // rgb: emissiveFactor (times KHR_materials_emissive_strength); a unused
  // KHR_texture_transform per map (kMapCount maps, then kMapEmissive):
  // uv' = (row 2k . (u, v, 1), row 2k+1 . (u, v, 1)); xyz used.
  vec4 uvTransform[12];
  uint emissiveMap;        // per-draw path: unused; indexed path: materialMaps[] index; map arrays: layer
  uint texCoords;          // bit k: map k samples TEXCOORD_1 (bit kMapEmissive: the emissive map)
  // Map arrays only (one repeat sampler per kind): each map's wrap, 4 bits per
  // map k at 4k: U in bits 0-1, V in bits 2-3 (0 repeat, 1 mirrored, 2 clamp).
  uint wraps;
  uint flags;              // kMaterialAlphaMask | kMaterialAlphaBlend
  float alphaCutoff;       // alphaMode MASK
  float reserved[3];
};

struct DrawData {    // std430; 80 bytes; indexed by DrawPush::drawIndex and the visibility draw id
  mat4 model;        // object -> world, uniform scale (normals use mat3(model))
  uint materialIndex;
  uint firstIndex;   // into the index buffer
  int vertexOffset;  // added to each index
  uint indexCount;
};

struct DrawPush {  // push constants; 8 bytes
  uint drawIndex;  // < kMaxDraws
  uint materialIndex;
};

#ifdef __cplusplus
static_assert(kTriangleIdBits + kDrawIdBits == 32, "visibility id is one 32-bit word");
static_assert(visibilityDrawId(packVisibilityId(kMaxDraws - 1, 5)) == kMaxDraws - 1);
static_assert(sizeof(Camera) == 304 && sizeof(Lighting) == 16 && sizeof(PointLight) == 32);
static_assert(sizeof(Vertex) == 48 && sizeof(Material) == 48 && sizeof(DrawData) == 80);
static_assert(sizeof(DrawPush) == 8);
static_assert(sizeof(VertexAttributes) == 16 && sizeof(MaterialExtra) == 240);
static_assert(offsetof(Vertex, normal) == 12 && offsetof(Vertex, tangent) == 24 && offsetof(Vertex, uv) == 40);
static_assert(offsetof(Material, maps) == 16 && offsetof(Material, roughnessFactor) == 36);
static_assert(offsetof(DrawData, materialIndex) == 64 && offsetof(DrawData, vertexOffset) == 72);
}  // namespace tally::shaders
#endif

#undef TALLY_CONST
#undef TALLY_FN
#endif  // TALLY_SHADERS_SHARED_H
