#version 460
#extension GL_GOOGLE_include_directive : require
// Shadow pass: position only, transformed by the sun's orthographic
// view-projection (shadow_shared.h) into the D32_SFLOAT "shadow_map". In
// instrumented runs zprepass.frag (empty) counts its fragments, which with
// early tests are its depth writes.
#define TALLY_DRAWS
#include "common.h"
#include "shadow_shared.h"

layout(std140, set = kSetFrame, binding = kBindingShadow) uniform ShadowBlock { Shadow shadow; };
layout(location = kAttribPosition) in vec3 inPosition;
layout(push_constant) uniform PushBlock { DrawPush push; };
#include "alpha_test_vert.h"

void main() {
  gl_Position = shadow.viewProj * (draws[push.drawIndex].model * vec4(inPosition, 1.0));
  passAlphaInputs();  // alphaMode MASK draws (alpha_test_vert.h)
}
