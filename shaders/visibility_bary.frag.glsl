#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_fragment_shader_barycentric : require
// Fat visibility buffer, pass 1, on devices with fragment-shader barycentrics
// (VK_KHR_fragment_shader_barycentric; not lavapipe): the rasteriser's
// perspective-correct barycentrics, no buffer reads. Same outputs as visibility.frag.
#include "shared.h"

layout(early_fragment_tests) in;

layout(push_constant) uniform PushBlock { DrawPush push; };

layout(location = 0) in vec2 inUv;

layout(location = kOutVisibility) out uvec2 outVisibility;        // R32G32_UINT: id, barycentrics
layout(location = kOutUvDerivatives) out uvec2 outUvDerivatives;  // R32G32_UINT: half2 dFdx, dFdy

void main() {
  // gl_BaryCoordEXT follows the triangle's vertex order, as the index buffer does.
  outVisibility = uvec2(packVisibilityId(push.drawIndex, uint(gl_PrimitiveID)), packUnorm2x16(gl_BaryCoordEXT.yz));
  outUvDerivatives = uvec2(packHalf2x16(dFdx(inUv)), packHalf2x16(dFdy(inUv)));
}
