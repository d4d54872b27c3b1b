#version 460
#extension GL_GOOGLE_include_directive : require
// Sky: a full-screen triangle at the far plane (depth 1). The pipeline masks
// it to sky pixels (stencil 0, or depth LESS_OR_EQUAL against a cleared 1.0).
#include "common.h"

layout(location = 0) out vec4 outFarPoint;  // homogeneous world point on the far plane

void main() {
  vec2 ndc = vec2((gl_VertexIndex << 1) & 2, gl_VertexIndex & 2) * 2.0 - 1.0;
  gl_Position = vec4(ndc, 1.0, 1.0);
  outFarPoint = camera.invViewProj * gl_Position;  // linear in screen: w is 1 at every vertex
}
