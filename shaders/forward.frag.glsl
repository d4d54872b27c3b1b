#version 460
#extension GL_GOOGLE_include_directive : require
// Forward renderer: samples the draw's five material maps and shades with
// Blinn-Phong over every light, per fragment that passes the early depth test
// (so overshading in this pass costs maps and lights).
#define TALLY_LIGHTS
#define TALLY_MATERIALS
#include "common.h"

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

void main() {
  Surface s = surfaceFromMaps(texture(diffuseMap, inUv), texture(ambientMap, inUv),
                              texture(specularMap, inUv), texture(roughnessMap, inUv),
                              texture(normalMap, inUv), inNormal, inTangent,
                              materials[push.materialIndex].baseColor, materials[push.materialIndex].roughnessFactor);
  outColor = vec4(shade(s, inPosition), 1.0);
#ifdef TALLY_COUNT_FRAGMENTS
  outCount = vec4(1.0, 0.0, 0.0, 0.0);
#endif
}
