#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_nonuniform_qualifier : require
// Fat visibility buffer, shading pass (full screen, after fullscreen.vert):
// per covered pixel, the two visibility texels, the draw, 3 indices and 3
// vertices, the material's map indices, then the five maps with the stored uv
// derivatives and Blinn-Phong. Stencil masks sky pixels out. Map reads are
// bounded by covered pixels x 5 whatever the overshading of pass 1.
#define TALLY_LIGHTS
#define TALLY_DRAWS
#define TALLY_MATERIALS
#define TALLY_MESH
#include "common.h"
#include "visibility_encoding.h"

layout(early_fragment_tests) in;

layout(set = kSetPassInput, binding = kBindingVisibilityTarget) uniform usampler2D visibilityTarget;
layout(set = kSetPassInput, binding = kBindingUvDerivativeTarget) uniform usampler2D uvDerivativeTarget;

// Every map of the scene; the material is known only per pixel, so the index
// is non-uniform (shaderSampledImageArrayNonUniformIndexing: NVIDIA has it).
// lavapipe has no descriptor indexing at all (not even dynamically uniform
// indexing) and 32 samplers per stage: the renderer needs a fallback there,
// e.g. one sampler2DArray per map kind with the material as the layer.
// Material selection (RendererOptions::materialSelection), defined by the
// renderer; by default the per-pixel selection above. TALLY_SELECT_UNIFORM:
// the index without nonuniformEXT, as the founding study wrote it (undefined
// unless dynamically uniform: what the driver does is what is measured).
// TALLY_SELECT_FIRST_LANE: every lane takes the first active lane's index or
// layer, a model of a driver that scalarises the index.
#ifdef TALLY_SELECT_FIRST_LANE
#extension GL_KHR_shader_subgroup_ballot : require
#endif
#ifdef TALLY_MAP_ARRAYS
// Fallback without descriptor indexing (lavapipe), defined by the renderer:
// one sampler2DArray per map kind, Material::maps[k] is the layer. The
// selection stays per pixel and needs no non-uniform descriptor index.
layout(set = kSetMaterial, binding = kMapDiffuse) uniform sampler2DArray diffuseMaps;
layout(set = kSetMaterial, binding = kMapAmbient) uniform sampler2DArray ambientMaps;
layout(set = kSetMaterial, binding = kMapSpecular) uniform sampler2DArray specularMaps;
layout(set = kSetMaterial, binding = kMapRoughness) uniform sampler2DArray roughnessMaps;
layout(set = kSetMaterial, binding = kMapNormal) uniform sampler2DArray normalMaps;
#ifdef TALLY_SELECT_FIRST_LANE
#define SAMPLE_MAP(kindMaps, kind) textureGrad(kindMaps, vec3(a.uv, float(subgroupBroadcastFirst(maps[kind]))), dx, dy)
#else
#define SAMPLE_MAP(kindMaps, kind) textureGrad(kindMaps, vec3(a.uv, float(maps[kind])), dx, dy)
#endif
#else
layout(set = kSetMaterial, binding = kBindingMaterialMaps) uniform sampler2D materialMaps[kMaxMaterialMaps];
#if defined(TALLY_SELECT_FIRST_LANE)
#define SAMPLE_MAP(kindMaps, kind) textureGrad(materialMaps[subgroupBroadcastFirst(maps[kind])], a.uv, dx, dy)
#elif defined(TALLY_SELECT_UNIFORM)
#define SAMPLE_MAP(kindMaps, kind) textureGrad(materialMaps[maps[kind]], a.uv, dx, dy)
#else
#define SAMPLE_MAP(kindMaps, kind) textureGrad(materialMaps[nonuniformEXT(maps[kind])], a.uv, dx, dy)
#endif
#endif

layout(location = kOutColor) out vec4 outColor;  // RGBA16F HDR

void main() {
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  uvec4 visibility = texelFetch(visibilityTarget, pixel, 0);
  uvec4 uvDerivatives = texelFetch(uvDerivativeTarget, pixel, 0);
  uint drawId = visibilityDrawId(visibility.x);
  vec2 b12 = decodeBarycentrics(visibility);

  uvec3 v = fetchTriangle(draws[drawId].firstIndex, draws[drawId].vertexOffset,
                          visibilityTriangleId(visibility.x));
  Interpolated a = interpolateVertices(vertices[v.x], vertices[v.y], vertices[v.z],
                                       vec3(1.0 - b12.x - b12.y, b12), draws[drawId].model);
  uint material = draws[drawId].materialIndex;
  uint maps[kMapCount] = materials[material].maps;
  vec2 dx, dy;
  decodeUvDerivatives(uvDerivatives, dx, dy);

  Surface s = surfaceFromMaps(SAMPLE_MAP(diffuseMaps, kMapDiffuse),
                              SAMPLE_MAP(ambientMaps, kMapAmbient),
                              SAMPLE_MAP(specularMaps, kMapSpecular),
                              SAMPLE_MAP(roughnessMaps, kMapRoughness),
                              SAMPLE_MAP(normalMaps, kMapNormal),
                              a.normal, a.tangent, materials[material].baseColor,
                              materials[material].roughnessFactor);
  outColor = vec4(shade(s, a.position), 1.0);
}
