// Alpha test of alphaMode MASK for the passes that otherwise read no
// material (the depth pre-pass, the visibility passes, the shadow pass):
// with TALLY_ALPHA_TEST their vertex stage passes the uvs and colour
// (alpha_test_vert.h) and the fragment stage discards where the diffuse
// map's alpha times the base colour's (and the vertex colour's) is below
// the cutoff, as forward.frag and gbuffer.frag do. Without the define: nothing.
#ifndef TALLY_SHADERS_ALPHA_TEST_H
#define TALLY_SHADERS_ALPHA_TEST_H
#ifdef TALLY_ALPHA_TEST
#include "draw_uv.h"

layout(location = 8) in vec2 alphaUv0;
#ifdef TALLY_UV1
layout(location = 9) in vec2 alphaUv1;
#endif
#ifdef TALLY_VERTEX_COLORS
layout(location = 10) in vec4 alphaColor;
#endif
layout(set = kSetMaterial, binding = kMapDiffuse) uniform sampler2D alphaDiffuseMap;

void alphaTest(uint material) {
#ifdef TALLY_UV1
  UvFrame f = uvFrame(alphaUv0, alphaUv1);
#else
  UvFrame f = uvFrame(alphaUv0, alphaUv0);
#endif
  float alpha = SAMPLE_DRAW_MAP(alphaDiffuseMap, material, kMapDiffuse, f).a * materials[material].baseColor.a;
#ifdef TALLY_VERTEX_COLORS
  alpha *= alphaColor.a;
#endif
  if (alpha < materialExtras[material].alphaCutoff) discard;
}

#endif  // TALLY_ALPHA_TEST
#endif  // TALLY_SHADERS_ALPHA_TEST_H
