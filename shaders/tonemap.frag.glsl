#version 460
#extension GL_GOOGLE_include_directive : require
// Tonemap (full screen, after fullscreen.vert): Reinhard on luminance, one HDR
// texel per pixel. Writes linear values: the LDR target is R8G8B8A8_SRGB, so
// the hardware encodes on store. No depth/stencil attachment.
#include "shared.h"
#include "tonemap.h"

layout(set = kSetPassInput, binding = kBindingHdrTarget) uniform sampler2D hdrTarget;  // RGBA16F
#ifdef BLOOM
// The blurred bright parts (bloom.frag.glsl), added before tonemapping: one
// more RGBA16F texel per pixel.
layout(set = kSetPassInput, binding = kBindingBloomTarget) uniform sampler2D bloomTarget;  // RGBA16F
#endif
layout(std140, set = kSetFrame, binding = kBindingLighting) uniform LightingBlock { Lighting lighting; };

layout(location = kOutColor) out vec4 outColor;

void main() {
  vec3 hdr = texelFetch(hdrTarget, ivec2(gl_FragCoord.xy), 0).rgb;
#ifdef BLOOM
  hdr += texelFetch(bloomTarget, ivec2(gl_FragCoord.xy), 0).rgb;
#endif
  outColor = vec4(tonemapReinhard(hdr, lighting.exposure), 1.0);
}
