#version 460
#extension GL_GOOGLE_include_directive : require
// Deferred renderer, G-buffer pass: samples the draw's five material maps and
// writes the surface to three targets; depth (D32_S8) carries the position.
// Every fragment that passes the early depth test pays the maps and the
// three writes, so overshading costs here rather than in lighting.frag.
#define TALLY_MATERIALS
#include "common.h"

layout(early_fragment_tests) in;

layout(set = kSetMaterial, binding = kMapDiffuse) uniform sampler2D diffuseMap;
layout(set = kSetMaterial, binding = kMapAmbient) uniform sampler2D ambientMap;
layout(set = kSetMaterial, binding = kMapSpecular) uniform sampler2D specularMap;
layout(set = kSetMaterial, binding = kMapRoughness) uniform sampler2D roughnessMap;
layout(set = kSetMaterial, binding = kMapNormal) uniform sampler2D normalMap;

layout(push_constant) uniform PushBlock { DrawPush push; };

// location 0 (world position) is not read: lighting.frag reconstructs it from depth.
layout(location = 1) in vec3 inNormal;
layout(location = 2) in vec4 inTangent;
layout(location = 3) in vec2 inUv;

layout(location = kOutNormal) out vec4 outNormal;      // RGBA16F
layout(location = kOutDiffuse) out vec4 outDiffuse;    // RGBA8
layout(location = kOutSpecular) out vec4 outSpecular;  // RGBA8

void main() {
  Surface s = surfaceFromMaps(texture(diffuseMap, inUv), texture(ambientMap, inUv),
                              texture(specularMap, inUv), texture(roughnessMap, inUv),
                              texture(normalMap, inUv), inNormal, inTangent,
                              materials[push.materialIndex].baseColor, materials[push.materialIndex].roughnessFactor);
  encodeGBuffer(s, outNormal, outDiffuse, outSpecular);
}
