#version 460
#extension GL_GOOGLE_include_directive : require
// Deferred renderer, lighting+shading pass (full screen, after fullscreen.vert):
// one texel of each G-buffer target per covered pixel, world position from
// depth, Blinn-Phong over every light. The stencil test masks sky pixels out;
// early tests keep the counters' atomics from forcing late tests.
#define TALLY_LIGHTS
#include "common.h"

layout(early_fragment_tests) in;

layout(set = kSetPassInput, binding = kBindingDepthTarget) uniform sampler2D depthTarget;  // D32 depth aspect
layout(set = kSetPassInput, binding = kBindingNormalTarget) uniform sampler2D normalTarget;
layout(set = kSetPassInput, binding = kBindingDiffuseTarget) uniform sampler2D diffuseTarget;
layout(set = kSetPassInput, binding = kBindingSpecularTarget) uniform sampler2D specularTarget;

layout(location = kOutColor) out vec4 outColor;  // RGBA16F HDR

void main() {
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  float depth = texelFetch(depthTarget, pixel, 0).r;
  Surface s = decodeGBuffer(texelFetch(normalTarget, pixel, 0), texelFetch(diffuseTarget, pixel, 0),
                            texelFetch(specularTarget, pixel, 0));
  outColor = vec4(shade(s, worldFromDepth(gl_FragCoord.xy, depth)), 1.0);
}
