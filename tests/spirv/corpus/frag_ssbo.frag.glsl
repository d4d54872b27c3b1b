#version 450
// Fragment SSBO: atomic counter (write only), indexed store, read of another member.
layout(std430, set = 1, binding = 3) buffer Fragments {
  uint count;
  uint capacity;
  vec4 colors[];
} fragments;

layout(location = 0) in vec4 inColor;
layout(location = 0) out vec4 outColor;

void main() {
  uint index = atomicAdd(fragments.count, 1u);
  if (index < fragments.capacity) {
    fragments.colors[index] = inColor;
  }
  outColor = inColor;
}
