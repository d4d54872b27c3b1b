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

layout(early_fragment_tests) in;

layout(set = kSetPassInput, binding = kBindingVisibilityTarget) uniform usampler2D visibilityTarget;
layout(set = kSetPassInput, binding = kBindingUvDerivativeTarget) uniform usampler2D uvDerivativeTarget;

// Every map of the scene; the material is known only per pixel, so the index
// is non-uniform (shaderSampledImageArrayNonUniformIndexing: NVIDIA has it).
// lavapipe has no descriptor indexing at all (not even dynamically uniform
// indexing) and 32 samplers per stage: the renderer needs a fallback there,
// e.g. one sampler2DArray per map kind with the material as the layer.
#ifdef TALLY_MAP_ARRAYS
// Fallback without descriptor indexing (lavapipe), defined by the renderer:
// one sampler2DArray per map kind, Material::maps[k] is the layer. The
// selection stays per pixel and needs no non-uniform descriptor index.
layout(set = kSetMaterial, binding = kMapDiffuse) uniform sampler2DArray diffuseMaps;
layout(set = kSetMaterial, binding = kMapAmbient) uniform sampler2DArray ambientMaps;
layout(set = kSetMaterial, binding = kMapSpecular) uniform sampler2DArray specularMaps;
layout(set = kSetMaterial, binding = kMapRoughness) uniform sampler2DArray roughnessMaps;
layout(set = kSetMaterial, binding = kMapNormal) uniform sampler2DArray normalMaps;
#define SAMPLE_MAP(kindMaps, kind) textureGrad(kindMaps, vec3(a.uv, float(maps[kind])), dx, dy)
#else
layout(set = kSetMaterial, binding = kBindingMaterialMaps) uniform sampler2D materialMaps[kMaxMaterialMaps];
#define SAMPLE_MAP(kindMaps, kind) textureGrad(materialMaps[nonuniformEXT(maps[kind])], a.uv, dx, dy)
#endif

layout(location = kOutColor) out vec4 outColor;  // RGBA16F HDR

void main() {
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  uvec2 visibility = texelFetch(visibilityTarget, pixel, 0).xy;
  uvec2 uvDerivatives = texelFetch(uvDerivativeTarget, pixel, 0).xy;
  uint drawId = visibilityDrawId(visibility.x);
  vec2 b12 = unpackUnorm2x16(visibility.y);

  uvec3 v = fetchTriangle(draws[drawId].firstIndex, draws[drawId].vertexOffset,
                          visibilityTriangleId(visibility.x));
  Interpolated a = interpolateVertices(vertices[v.x], vertices[v.y], vertices[v.z],
                                       vec3(1.0 - b12.x - b12.y, b12), draws[drawId].model);
  uint material = draws[drawId].materialIndex;
  uint maps[kMapCount] = materials[material].maps;
  vec2 dx = unpackHalf2x16(uvDerivatives.x), dy = unpackHalf2x16(uvDerivatives.y);

  Surface s = surfaceFromMaps(SAMPLE_MAP(diffuseMaps, kMapDiffuse),
                              SAMPLE_MAP(ambientMaps, kMapAmbient),
                              SAMPLE_MAP(specularMaps, kMapSpecular),
                              SAMPLE_MAP(roughnessMaps, kMapRoughness),
                              SAMPLE_MAP(normalMaps, kMapNormal),
                              a.normal, a.tangent, materials[material].baseColor,
                              materials[material].roughnessFactor);
  outColor = vec4(shade(s, a.position), 1.0);
}
