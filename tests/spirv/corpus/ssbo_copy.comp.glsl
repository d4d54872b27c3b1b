#version 450
// Compute: read one SSBO, write another, UBO parameters, bounds from .length() (not counted).
layout(local_size_x = 64) in;

layout(std430, set = 0, binding = 0) readonly buffer Src {
  float src[];
};
layout(std430, set = 0, binding = 1) writeonly buffer Dst {
  float dst[];
};
layout(set = 1, binding = 0) uniform Params {
  float scale;
  float bias;
} params;

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= uint(src.length())) {
    return;
  }
  dst[i] = src[i] * params.scale + params.bias;
}
