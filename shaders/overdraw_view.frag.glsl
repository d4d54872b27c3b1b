#version 460
#extension GL_GOOGLE_include_directive : require
// Forward's overdraw view (output=overdraw|overshading, full screen after
// fullscreen.vert): one count texel per pixel becomes a heat ramp in the HDR
// target, which tonemap then maps as usual. 0 fragments: black (the skybox
// pass paints those pixels), 1: blue, 2: green, 4: yellow, 8: red, 16 and
// more: white; a log2 ramp, since counts span orders of magnitude in real scenes.
#include "shared.h"

layout(set = kSetPassInput, binding = kBindingCountTarget) uniform sampler2D countTarget;  // R32_SFLOAT

layout(location = kOutColor) out vec4 outColor;

void main() {
  float count = texelFetch(countTarget, ivec2(gl_FragCoord.xy), 0).r;
  vec3 heat = vec3(0.0);
  if (count > 0.0) {
    float t = clamp(log2(count) / 4.0, 0.0, 1.0);  // 1 -> 0, 16 -> 1
    heat = t < 0.25   ? mix(vec3(0.0, 0.0, 1.0), vec3(0.0, 1.0, 0.0), t / 0.25)
           : t < 0.5  ? mix(vec3(0.0, 1.0, 0.0), vec3(1.0, 1.0, 0.0), (t - 0.25) / 0.25)
           : t < 0.75 ? mix(vec3(1.0, 1.0, 0.0), vec3(1.0, 0.0, 0.0), (t - 0.5) / 0.25)
                      : mix(vec3(1.0, 0.0, 0.0), vec3(1.0, 1.0, 1.0), (t - 0.75) / 0.25);
    heat *= 4.0;  // tonemap's L / (1 + L) keeps the hues bright
  }
  outColor = vec4(heat, 1.0);
}
