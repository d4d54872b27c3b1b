#version 460
#extension GL_GOOGLE_include_directive : require
// Deferred renderer, lighting+shading pass (full screen, after fullscreen.vert):
// one texel of each G-buffer target per covered pixel, world position from
// depth, Blinn-Phong over every light. The stencil test masks sky pixels out;
// early tests keep the counters' atomics from forcing late tests.
#define TALLY_LIGHTS
#include "common.h"

#ifdef TALLY_MSAA
// MSAA (RendererOptions::msaa = TALLY_MSAA samples, renderers/techniques/msaa.hpp): the
// targets are multisampled. Every sample's depth is fetched; a covered sample
// (depth < 1, the clear value is the far plane) has its three G-buffer texels
// fetched and is shaded (at the pixel centre's x, y with the sample's depth);
// the covered samples' mean is the pixel. No covered sample: discard, so the
// stencil REPLACE of the pass marks only geometry pixels (late tests: no
// early_fragment_tests here, or discarded pixels would be marked too).
layout(set = kSetPassInput, binding = kBindingDepthTarget) uniform sampler2DMS depthTarget;
layout(set = kSetPassInput, binding = kBindingNormalTarget) uniform sampler2DMS normalTarget;
layout(set = kSetPassInput, binding = kBindingDiffuseTarget) uniform sampler2DMS diffuseTarget;
layout(set = kSetPassInput, binding = kBindingSpecularTarget) uniform sampler2DMS specularTarget;

layout(location = kOutColor) out vec4 outColor;  // RGBA16F HDR

void main() {
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  vec3 sum = vec3(0.0);
  int covered = 0;
  for (int i = 0; i < TALLY_MSAA; ++i) {
    float depth = texelFetch(depthTarget, pixel, i).r;
    if (depth < 1.0) {
      Surface s = decodeGBuffer(texelFetch(normalTarget, pixel, i), texelFetch(diffuseTarget, pixel, i),
                                texelFetch(specularTarget, pixel, i));
      sum += shade(s, worldFromDepth(gl_FragCoord.xy, depth));
      ++covered;
    }
  }
  if (covered == 0) discard;
  outColor = vec4(sum / float(covered), 1.0);
}
#else
layout(early_fragment_tests) in;

layout(set = kSetPassInput, binding = kBindingDepthTarget) uniform sampler2D depthTarget;  // D32 depth aspect
layout(set = kSetPassInput, binding = kBindingNormalTarget) uniform sampler2D normalTarget;
layout(set = kSetPassInput, binding = kBindingDiffuseTarget) uniform sampler2D diffuseTarget;
layout(set = kSetPassInput, binding = kBindingSpecularTarget) uniform sampler2D specularTarget;
#ifdef TALLY_EMISSIVE
layout(set = kSetPassInput, binding = kBindingEmissiveTarget) uniform sampler2D emissiveTarget;  // RGBA16F
#endif

layout(location = kOutColor) out vec4 outColor;  // RGBA16F HDR

void main() {
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  float depth = texelFetch(depthTarget, pixel, 0).r;
  Surface s = decodeGBuffer(texelFetch(normalTarget, pixel, 0), texelFetch(diffuseTarget, pixel, 0),
                            texelFetch(specularTarget, pixel, 0));
  outColor = vec4(shade(s, worldFromDepth(gl_FragCoord.xy, depth)), 1.0);
#ifdef TALLY_EMISSIVE
  outColor.rgb += texelFetch(emissiveTarget, pixel, 0).rgb;  // glTF emission, stored by the G-buffer pass
#endif
}
#endif
