#version 460
#extension GL_GOOGLE_include_directive : require
#ifdef TALLY_ALPHA_TEST
#define TALLY_MATERIALS  // alpha_test.h reads the material
#endif
#extension GL_EXT_fragment_shader_barycentric : require
// Fat visibility buffer, pass 1, on devices with fragment-shader barycentrics
// (VK_KHR_fragment_shader_barycentric; not lavapipe): the rasteriser's
// perspective-correct barycentrics, no buffer reads. Same outputs as visibility.frag.
#include "shared.h"
#include "visibility_encoding.h"

#ifdef TALLY_ALPHA_TEST
// alphaMode MASK draws (alpha_test.h): the test decides coverage, so no early tests.
#include "common.h"
#include "alpha_test.h"
#else
layout(early_fragment_tests) in;
#endif

layout(push_constant) uniform PushBlock { DrawPush push; };

layout(location = 0) in vec2 inUv;

layout(location = kOutVisibility) out VisibilityTexel outVisibility;           // id, barycentrics
layout(location = kOutUvDerivatives) out UvDerivativeTexel outUvDerivatives;  // dFdx(uv), dFdy(uv)

void main() {
#ifdef TALLY_ALPHA_TEST
  alphaTest(push.materialIndex);
#endif
  // gl_BaryCoordEXT follows the triangle's vertex order, as the index buffer does.
  outVisibility = encodeVisibility(packVisibilityId(push.drawIndex, uint(gl_PrimitiveID)), gl_BaryCoordEXT.yz);
  outUvDerivatives = encodeUvDerivatives(dFdx(inUv), dFdy(inUv));
}
