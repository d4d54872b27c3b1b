#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_nonuniform_qualifier : require
// Lean visibility buffer (Burns & Hunt 2013), shading pass (full screen):
// from the 32-bit id alone, fetch the triangle, project its three vertices
// again and derive the perspective-correct barycentrics at the pixel centre
// and their change across one pixel; uv derivatives follow from those.
// Same resources as shading.frag but one visibility target instead of two.
#define TALLY_LIGHTS
#define TALLY_DRAWS
#define TALLY_MATERIALS
#define TALLY_MESH
#include "common.h"

layout(early_fragment_tests) in;

layout(set = kSetPassInput, binding = kBindingVisibilityTarget) uniform usampler2D visibilityTarget;  // R32_UINT

// See shading.frag: non-uniform indexing, or map arrays (TALLY_MAP_ARRAYS).
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
  uint id = texelFetch(visibilityTarget, ivec2(gl_FragCoord.xy), 0).r;
  uint drawId = visibilityDrawId(id);
  mat4 model = draws[drawId].model;
  uvec3 v = fetchTriangle(draws[drawId].firstIndex, draws[drawId].vertexOffset, visibilityTriangleId(id));
  Vertex v0 = vertices[v.x], v1 = vertices[v.y], v2 = vertices[v.z];

  mat4 clipFromObject = camera.viewProj * model;
  Barycentrics b = barycentricsFromClip(clipFromObject * vec4(toVec3(v0.position), 1.0),
                                        clipFromObject * vec4(toVec3(v1.position), 1.0),
                                        clipFromObject * vec4(toVec3(v2.position), 1.0), gl_FragCoord.xy);
  Interpolated a = interpolateVertices(v0, v1, v2, b.lambda, model);
  mat3x2 uvs = mat3x2(uvOf(v0), uvOf(v1), uvOf(v2));
  vec2 dx = uvs * b.ddx, dy = uvs * b.ddy;

  uint material = draws[drawId].materialIndex;
  uint maps[kMapCount] = materials[material].maps;
  Surface s = surfaceFromMaps(SAMPLE_MAP(diffuseMaps, kMapDiffuse),
                              SAMPLE_MAP(ambientMaps, kMapAmbient),
                              SAMPLE_MAP(specularMaps, kMapSpecular),
                              SAMPLE_MAP(roughnessMaps, kMapRoughness),
                              SAMPLE_MAP(normalMaps, kMapNormal),
                              a.normal, a.tangent, materials[material].baseColor,
                              materials[material].roughnessFactor);
  outColor = vec4(shade(s, a.position), 1.0);
}
