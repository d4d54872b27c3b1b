#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_fragment_shader_barycentric : require
#include "alpha_test_stage.h"  // early tests, or the alpha test of MASK draws
// Fat visibility buffer, pass 1, on devices with fragment-shader barycentrics
// (VK_KHR_fragment_shader_barycentric; not lavapipe): the rasteriser's
// perspective-correct barycentrics, no buffer reads. Same outputs as visibility.frag.
#include "shared.h"
#include "visibility_encoding.h"


layout(push_constant) uniform PushBlock { DrawPush push; };

layout(location = 0) in vec2 inUv;

layout(location = kOutVisibility) out VisibilityTexel outVisibility;           // id, barycentrics
layout(location = kOutUvDerivatives) out UvDerivativeTexel outUvDerivatives;  // dFdx(uv), dFdy(uv)

void main() {
  ALPHA_TEST(push.materialIndex);  // alphaMode MASK draws (alpha_test_stage.h)
  // gl_BaryCoordEXT follows the triangle's vertex order, as the index buffer does.
  outVisibility = encodeVisibility(packVisibilityId(push.drawIndex, uint(gl_PrimitiveID)), gl_BaryCoordEXT.yz);
  outUvDerivatives = encodeUvDerivatives(dFdx(inUv), dFdy(inUv));
}
