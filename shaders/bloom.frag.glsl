#version 460
#extension GL_GOOGLE_include_directive : require
// Bloom passes (full screen, after fullscreen.vert; docs/techniques.md,
// "Bloom"), one per define, all into an RGBA16F target at full resolution:
//   BLOOM_BRIGHT     the HDR colour's excess over BLOOM_THRESHOLD luminance
//                    (hue kept): 1 fetch per pixel
//   BLOOM_NAIVE      the 2D Gaussian: BLOOM_TAPS^2 fetches per pixel
//   BLOOM_DIRECTION  ivec2(1, 0) or ivec2(0, 1): one direction of the
//                    separable Gaussian, BLOOM_TAPS fetches per pixel, or with
//                    BLOOM_LINEAR BLOOM_TAPS linear-filtered taps at
//                    BLOOM_OFFSETS (between texel pairs, renderers/techniques/bloom.hpp)
// BLOOM_WEIGHTS (a float[BLOOM_TAPS] initialiser) holds the normalised
// weights. Texel fetches clamp to the edge; the linear taps use a
// clamp-to-edge sampler, which gives the same edge texels.
#include "shared.h"

layout(set = kSetPassInput, binding = kBindingBloomSource) uniform sampler2D source;  // RGBA16F

layout(location = kOutColor) out vec4 outColor;

#ifndef BLOOM_BRIGHT
const float kWeights[BLOOM_TAPS] = BLOOM_WEIGHTS;
const int kRadius = BLOOM_TAPS / 2;
#endif
#ifdef BLOOM_LINEAR
const float kOffsets[BLOOM_TAPS] = BLOOM_OFFSETS;
#endif

vec3 fetchClamped(ivec2 p, ivec2 size) { return texelFetch(source, clamp(p, ivec2(0), size - 1), 0).rgb; }

void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  ivec2 size = textureSize(source, 0);
#if defined(BLOOM_BRIGHT)
  vec3 hdr = texelFetch(source, p, 0).rgb;
  float luminance = dot(hdr, vec3(0.2126, 0.7152, 0.0722));
  vec3 bright = luminance > BLOOM_THRESHOLD ? hdr * ((luminance - BLOOM_THRESHOLD) / luminance) : vec3(0.0);
  outColor = vec4(bright, 1.0);
#elif defined(BLOOM_NAIVE)
  vec3 sum = vec3(0.0);
  for (int y = -kRadius; y <= kRadius; ++y) {
    for (int x = -kRadius; x <= kRadius; ++x) {
      sum += kWeights[x + kRadius] * kWeights[y + kRadius] * fetchClamped(p + ivec2(x, y), size);
    }
  }
  outColor = vec4(sum, 1.0);
#elif defined(BLOOM_LINEAR)
  vec3 sum = vec3(0.0);
  vec2 centre = vec2(p) + 0.5;
  for (int i = 0; i < BLOOM_TAPS; ++i) {
    vec2 at = centre + kOffsets[i] * vec2(BLOOM_DIRECTION);
    sum += kWeights[i] * textureLod(source, at / vec2(size), 0.0).rgb;
  }
  outColor = vec4(sum, 1.0);
#else
  vec3 sum = vec3(0.0);
  for (int i = -kRadius; i <= kRadius; ++i) {
    sum += kWeights[i + kRadius] * fetchClamped(p + i * BLOOM_DIRECTION, size);
  }
  outColor = vec4(sum, 1.0);
#endif
}
