#version 460
#extension GL_GOOGLE_include_directive : require
// Test kernel (tests/renderers/techniques/tbn_test.cpp): decodes packed frames with the
// renderers' GLSL decoder, so the C++ encoder can be checked against it.
#include "tbn.h"

layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Packed { uint packed[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Decoded { vec4 decoded[]; };  // normal, tangent per word

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= uint(packed.length())) return;
  TangentFrame f = decodeTangentFrame(packed[i]);
  decoded[2u * i] = vec4(f.normal, 0.0);
  decoded[2u * i + 1u] = f.tangent;
}
