#version 460
#extension GL_GOOGLE_include_directive : require
// Lean visibility buffer (Burns & Hunt 2013), pass 1, after zprepass.vert:
// one 32-bit id per pixel plus depth; shading_lean.frag recomputes the rest.
#include "shared.h"

layout(early_fragment_tests) in;

layout(push_constant) uniform PushBlock { DrawPush push; };

layout(location = kOutVisibility) out uint outId;  // R32_UINT

void main() {
  outId = packVisibilityId(push.drawIndex, uint(gl_PrimitiveID));
}
