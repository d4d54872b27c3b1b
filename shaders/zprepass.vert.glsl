#version 460
#extension GL_GOOGLE_include_directive : require
// Depth pre-pass (no fragment shader) and the lean visibility pass
// (with visibility_lean.frag): position only. `invariant` and the same
// expression as mesh.vert.h give bit-identical depth for an EQUAL test later.
#define TALLY_DRAWS
#include "common.h"

layout(location = kAttribPosition) in vec3 inPosition;
layout(push_constant) uniform PushBlock { DrawPush push; };
#include "alpha_test_vert.h"

invariant gl_Position;

void main() {
  mat4 model = draws[push.drawIndex].model;
  vec4 world = model * vec4(inPosition, 1.0);
  gl_Position = camera.viewProj * world;
  passAlphaInputs();  // alphaMode MASK draws (alpha_test_vert.h)
}
