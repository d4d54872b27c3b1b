#version 460
#extension GL_GOOGLE_include_directive : require
#include "alpha_test_stage.h"  // early tests, or the alpha test of MASK draws
// Lean visibility buffer (Burns & Hunt 2013), pass 1, after zprepass.vert:
// one 32-bit id per pixel plus depth; shading_lean.frag recomputes the rest.
#include "shared.h"


layout(push_constant) uniform PushBlock { DrawPush push; };

layout(location = kOutVisibility) out uint outId;  // R32_UINT

void main() {
  ALPHA_TEST(push.materialIndex);  // alphaMode MASK draws (alpha_test_stage.h)
  outId = packVisibilityId(push.drawIndex, uint(gl_PrimitiveID));
}
