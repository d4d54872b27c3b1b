#version 450
// An SSBO descriptor array indexed with constants; .length() is not a read.
layout(local_size_x = 32) in;

layout(std430, set = 1, binding = 2) buffer B {
  uint count;
  float x[];
} bufs[2];

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= uint(bufs[1].x.length())) {
    return;
  }
  bufs[0].x[i] = bufs[1].x[i] * 2.0;
}
