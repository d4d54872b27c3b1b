#version 460
#extension GL_GOOGLE_include_directive : require
// Fat visibility buffer, pass 1: position and uv only (uv for its screen
// derivatives). Same transform and `invariant` as mesh.vert.h.
#define TALLY_DRAWS
#include "common.h"

layout(location = kAttribPosition) in vec3 inPosition;
layout(location = kAttribUv) in vec2 inUv;
layout(push_constant) uniform PushBlock { DrawPush push; };
#define TALLY_HAS_UV_INPUT
#include "alpha_test_vert.h"

layout(location = 0) out vec2 outUv;

invariant gl_Position;

void main() {
  mat4 model = draws[push.drawIndex].model;
  vec4 world = model * vec4(inPosition, 1.0);
  gl_Position = camera.viewProj * world;
  outUv = inUv;
  passAlphaInputs();  // alphaMode MASK draws (alpha_test_vert.h)
}
