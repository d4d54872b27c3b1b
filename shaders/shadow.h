// Shadow mapping (docs/techniques.md, "Shadow mapping"): the sun's term of
// shade() in common.h, only compiled with TALLY_SHADOWS (RendererBase adds it
// to every shader with shadows on). TALLY_SHADOW_PCF4X4 selects the 4-tap
// kernel; hard and pcf2x2 are one tap each and differ only by the compare
// sampler (nearest or linear) bound at kBindingShadowMap.
#ifndef TALLY_SHADERS_SHADOW_H
#define TALLY_SHADERS_SHADOW_H
#include "shadow_shared.h"

layout(std140, set = kSetFrame, binding = kBindingShadow) uniform ShadowBlock { Shadow shadow; };
layout(set = kSetFrame, binding = kBindingShadowMap) uniform sampler2DShadow shadowMap;

// Fraction of the sun that reaches `position` (world) with surface normal
// `normal`: every call makes the same taps (no early out), so the map's reads
// are taps x invocations. Bias: params.x texels of params.y metres, times
// 1 + tan(angle to the sun) (slope-scaled, tan capped at 4), in depth units.
float sunVisibility(vec3 position, vec3 normal) {
  vec4 clip = shadow.viewProj * vec4(position, 1.0);  // orthographic: w = 1
  vec2 uv = clip.xy * 0.5 + 0.5;
  float cosTheta = clamp(dot(normal, shadow.direction.xyz), 1e-3, 1.0);
  float tanTheta = min(sqrt(1.0 - cosTheta * cosTheta) / cosTheta, 4.0);
  float reference = clip.z - shadow.params.x * shadow.params.y * (1.0 + tanTheta) / shadow.params.z;
#ifdef TALLY_SHADOW_PCF4X4
  // Four linear (2x2) compare taps centred 1 texel either side: together the
  // 4x4 texels around the position.
  return 0.25 * (textureLodOffset(shadowMap, vec3(uv, reference), 0.0, ivec2(-1, -1)) +
                 textureLodOffset(shadowMap, vec3(uv, reference), 0.0, ivec2(1, -1)) +
                 textureLodOffset(shadowMap, vec3(uv, reference), 0.0, ivec2(-1, 1)) +
                 textureLodOffset(shadowMap, vec3(uv, reference), 0.0, ivec2(1, 1)));
#else
  return textureLod(shadowMap, vec3(uv, reference), 0.0);
#endif
}

// The sun's Blinn-Phong term, shadowed.
vec3 sunTerm(Surface s, vec3 position, vec3 v, float shininess) {
  float visibility = sunVisibility(position, s.normal);
  vec3 l = shadow.direction.xyz;
  float nDotL = dot(s.normal, l);
  if (nDotL <= 0.0) return vec3(0.0);
  float nDotH = max(dot(s.normal, normalize(l + v)), 0.0);
  return shadow.color.rgb * visibility * (s.diffuse * nDotL + s.specular * pow(nDotH, shininess));
}
#endif  // TALLY_SHADERS_SHADOW_H
