#version 460
#extension GL_GOOGLE_include_directive : require
// Sky: one cube-map sample per sky pixel, into the HDR target.
#include "common.h"

layout(early_fragment_tests) in;

layout(set = kSetMaterial, binding = kBindingSky) uniform samplerCube sky;

layout(location = 0) in vec4 inFarPoint;

layout(location = kOutColor) out vec4 outColor;  // RGBA16F HDR

void main() {
  vec3 direction = inFarPoint.xyz / inFarPoint.w - camera.position.xyz;
  outColor = vec4(texture(sky, direction).rgb, 1.0);
}
