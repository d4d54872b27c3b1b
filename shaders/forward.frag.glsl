#version 460
#extension GL_GOOGLE_include_directive : require
// Forward renderer: samples the draw's five material maps and shades with
// Blinn-Phong over every light, per fragment that passes the early depth test
// (so overshading in this pass costs maps and lights).
#define TALLY_LIGHTS
#define TALLY_MATERIALS
#ifdef TALLY_DENSITY
// output=density: the triangle's vertices by gl_PrimitiveID (density.h).
#define TALLY_DRAWS
#define TALLY_MESH
#ifdef TALLY_DENSITY_QUADS
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_quad : require
#endif
#endif
#include "common.h"
#ifdef TALLY_DENSITY
#include "density.h"
#endif

layout(early_fragment_tests) in;

// The current material's maps, bound per draw (a neutral 1x1 dummy where missing).
layout(set = kSetMaterial, binding = kMapDiffuse) uniform sampler2D diffuseMap;
layout(set = kSetMaterial, binding = kMapAmbient) uniform sampler2D ambientMap;
layout(set = kSetMaterial, binding = kMapSpecular) uniform sampler2D specularMap;
layout(set = kSetMaterial, binding = kMapRoughness) uniform sampler2D roughnessMap;
layout(set = kSetMaterial, binding = kMapNormal) uniform sampler2D normalMap;

layout(push_constant) uniform PushBlock { DrawPush push; };

layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec3 inNormal;
layout(location = 2) in vec4 inTangent;
layout(location = 3) in vec2 inUv;

layout(location = kOutColor) out vec4 outColor;  // RGBA16F HDR
#ifdef TALLY_COUNT_FRAGMENTS
// output=overdraw|overshading: 1 per fragment into the R32_SFLOAT count
// target. The pipeline blends src + dst x (1 - src alpha): alpha 0 adds, and
// outColor's alpha 1 replaces as without blending.
layout(location = kOutCount) out vec4 outCount;
#endif
#ifdef TALLY_DENSITY
// output=density: quad lanes (densityQuadLanes) into the R32_SFLOAT
// "density.lanes" target, additive as outCount.
layout(location = kOutCount + 1) out vec4 outLanes;
#endif

void main() {
#ifdef TALLY_DENSITY
#ifdef TALLY_DENSITY_QUADS
  outLanes = vec4(densityQuadLanes(), 0.0, 0.0, 0.0);
#else
  outLanes = vec4(0.0);  // no quad operations: frameExtras() estimates lanes on the CPU
#endif
#endif
  Surface s = surfaceFromMaps(texture(diffuseMap, inUv), texture(ambientMap, inUv),
                              texture(specularMap, inUv), texture(roughnessMap, inUv),
                              texture(normalMap, inUv), inNormal, inTangent,
                              materials[push.materialIndex].baseColor, materials[push.materialIndex].roughnessFactor);
#ifdef TALLY_DENSITY
  outColor = vec4(densityColor(densityClass(push.drawIndex, uint(gl_PrimitiveID)), shade(s, inPosition)), 1.0);
#else
  outColor = vec4(shade(s, inPosition), 1.0);
#endif
#ifdef TALLY_COUNT_FRAGMENTS
  outCount = vec4(1.0, 0.0, 0.0, 0.0);
#endif
}
