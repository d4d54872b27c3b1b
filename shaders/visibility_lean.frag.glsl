#version 460
#extension GL_GOOGLE_include_directive : require
#ifdef TALLY_ALPHA_TEST
#define TALLY_MATERIALS  // alpha_test.h reads the material
#endif
// Lean visibility buffer (Burns & Hunt 2013), pass 1, after zprepass.vert:
// one 32-bit id per pixel plus depth; shading_lean.frag recomputes the rest.
#include "shared.h"

#ifdef TALLY_ALPHA_TEST
// alphaMode MASK draws (alpha_test.h): the test decides coverage, so no early tests.
#include "common.h"
#include "alpha_test.h"
#else
layout(early_fragment_tests) in;
#endif

layout(push_constant) uniform PushBlock { DrawPush push; };

layout(location = kOutVisibility) out uint outId;  // R32_UINT

void main() {
#ifdef TALLY_ALPHA_TEST
  alphaTest(push.materialIndex);
#endif
  outId = packVisibilityId(push.drawIndex, uint(gl_PrimitiveID));
}
